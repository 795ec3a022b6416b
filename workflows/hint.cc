#include "workflows/hint.h"

#include <fmt/format.h>

#include <filesystem>

#include "core/text.h"
#include "db/postgres_connection.h"
#include "db/robots.h"

namespace armsig::workflows {

std::string AbsolutePath(const std::string& path) {
  std::error_code ec;
  const auto absolute = std::filesystem::absolute(path, ec);
  return ec ? path : absolute.lexically_normal().string();
}

std::string ShellWord(const std::string& word) {
  if (!word.empty() &&
      word.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789"
                             "_-./:=@%+,") == std::string::npos) {
    return word;
  }
  if (Printable(word) != word) {
    // A control character or a byte that is not UTF-8: bash's $'…', every such byte as
    // \xHH, so that the printed command is one inert line that still pastes as the word.
    std::string out = "$'";
    for (const unsigned char c : word) {
      if (c == '\'' || c == '\\') {
        out += '\\';
        out += static_cast<char>(c);
      } else if (c < 0x20 || c >= 0x7f) {
        out += fmt::format("\\x{:02x}", c);
      } else {
        out += static_cast<char>(c);
      }
    }
    return out + "'";
  }
  std::string out = "'";
  for (char c : word) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string Hint(const std::string& db_path, std::initializer_list<std::string> words) {
  return Hint(db_path, std::vector<std::string>(words));
}

std::string Hint(const std::string& db_path, const std::vector<std::string>& words) {
  // A server's store as its URI (without a password), a file as an absolute path.
  const std::string store =
      db::IsPostgresAddress(db_path) ? db::RedactedAddress(db_path) : AbsolutePath(db_path);
  std::string out = "armsig --db " + ShellWord(store);
  for (const auto& w : words) out += " " + ShellWord(w);
  return out;
}

std::string UnknownRobotMessage(db::Database& database, const std::string& robot) {
  const std::string& db_path = database.path();
  std::vector<std::string> names;
  for (const auto& r : db::ListRobots(database)) names.push_back(r.name);
  if (const auto nearest = NearestKey(robot, names)) {
    return "no robot " + ShellWord(robot) + " in the database (did you mean " +
           ShellWord(*nearest) + "? a new robot is registered with " +
           Hint(db_path, {"robot", "add", robot, "--model", "MODEL.yaml"}) + ")";
  }
  return "no robot " + ShellWord(robot) + " in the database (register it: " +
         Hint(db_path, {"robot", "add", robot, "--model", "MODEL.yaml"}) + "; " +
         Hint(db_path, {"robot", "list"}) + " shows the robots)";
}

}  // namespace armsig::workflows
