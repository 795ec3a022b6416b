#include "io/credentials.h"

#include <fmt/format.h>
#include <sys/stat.h>
#include <yaml-cpp/yaml.h>

#include <cstdlib>

#include "core/error.h"
#include "core/text.h"
#include "io/atomic_file.h"

namespace armsig::io {

namespace {

constexpr FileLimit kCredentialsLimit{std::size_t{64} << 10, "a credentials file"};  // 64 KiB

// One of the file's two texts; a refusal names the key and where, never the value.
std::string Field(const YAML::Node& root, const char* key, const std::string& path) {
  const YAML::Node node = root[key];
  if (!node || !node.IsScalar() || node.Scalar().empty()) {
    const auto mark = node ? node.Mark() : root.Mark();
    throw InputError({path, mark.line + 1, mark.column + 1, key},
                     std::string("expected '") + key + ": TEXT' (a non-empty text)");
  }
  for (const unsigned char ch : node.Scalar()) {
    if (ch < ' ' || ch == 0x7f) {
      throw InputError({path, node.Mark().line + 1, node.Mark().column + 1, key},
                       std::string("the ") + key + " holds a control character");
    }
  }
  return node.Scalar();
}

}  // namespace

Credentials ReadCredentialsFile(const std::string& path) {
  struct stat info {};
  if (::stat(path.c_str(), &info) == 0 && (info.st_mode & (S_IRWXG | S_IRWXO)) != 0) {
    throw InputError({path, 0, 0, "credentials"},
                     fmt::format("the credentials file can be read by others (mode {:04o}); "
                                 "make it its owner's alone: chmod 600 {}",
                                 info.st_mode & 07777, Quoted(path)));
  }
  const std::string text = ReadWholeFile(path, kCredentialsLimit);
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    // yaml-cpp's message may quote the text: only where it is said.
    throw InputError({path, e.mark.line + 1, e.mark.column + 1, ""},
                     "not a YAML mapping {user: NAME, password: SECRET}");
  }
  if (!root.IsMap()) {
    throw InputError({path, 0, 0, ""}, "expected a mapping {user: NAME, password: SECRET}");
  }
  for (auto it = root.begin(); it != root.end(); ++it) {
    const std::string key = it->first.IsScalar() ? it->first.Scalar() : std::string();
    if (key != "user" && key != "password") {
      throw InputError({path, it->first.Mark().line + 1, it->first.Mark().column + 1, ""},
                       "unknown key " + Quoted(key) + " (expected user and password)");
    }
  }
  Credentials c(Field(root, "user", path), Field(root, "password", path));
  c.set_from(path);
  return c;
}

std::optional<Credentials> LoadCredentials(const ControllerConfig& controller) {
  if (!controller.credentials_path.empty()) return ReadCredentialsFile(controller.credentials_path);
  const char* user = std::getenv(kUserVariable);
  const char* password = std::getenv(kPasswordVariable);
  const bool has_user = user && *user, has_password = password && *password;
  if (!has_user && !has_password) return std::nullopt;
  if (has_user != has_password) {
    throw InputError({has_user ? kPasswordVariable : kUserVariable, 0, 0, ""},
                     fmt::format("{} is set but {} is not: give both (or `credentials: FILE` in "
                                 "the lab file)",
                                 has_user ? kUserVariable : kPasswordVariable,
                                 has_user ? kPasswordVariable : kUserVariable));
  }
  return Credentials(user, password);
}

}  // namespace armsig::io
