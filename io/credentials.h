// A robot controller's login (KUKA, ABB): from the lab file's `credentials: FILE` or from
// the environment, never from the command line, and never printed — no message, log line
// or stored text carries the user's password (the lab text stores the file's name only).
//
// The file is YAML, `{user: NAME, password: SECRET}`, and must be readable by its owner
// alone (mode 0600 or 0400: a file others can read is refused, as ssh refuses a key).
// Without `credentials:` the environment gives them: ARMSIG_CONTROLLER_USER and
// ARMSIG_CONTROLLER_PASSWORD (both, or neither).
#pragma once

#include <optional>
#include <string>

#include "io/lab_file.h"

namespace armsig::io {

class Credentials {
 public:
  Credentials(std::string user, std::string password)
      : user_(std::move(user)), password_(std::move(password)) {}
  const std::string& user() const { return user_; }
  // The secret, for the one place that sends it (an HTTP digest, a login command).
  const std::string& password() const { return password_; }
  // What a message may say: "user NAME (password from FILE)".
  std::string Describe() const { return "user " + user_ + " (password from " + from_ + ")"; }
  void set_from(std::string from) { from_ = std::move(from); }

 private:
  std::string user_, password_;
  std::string from_ = "the environment";
};

// The credentials of the lab's controller: its `credentials:` file, else the environment;
// nullopt when neither gives any. Throws InputError naming the file (and line) or the
// variable — never the secret: an unreadable file or one others can read, a malformed one,
// one of the two variables without the other.
std::optional<Credentials> LoadCredentials(const ControllerConfig& controller);
// The same from a file alone (the `credentials:` key).
Credentials ReadCredentialsFile(const std::string& path);

inline constexpr const char* kUserVariable = "ARMSIG_CONTROLLER_USER";
inline constexpr const char* kPasswordVariable = "ARMSIG_CONTROLLER_PASSWORD";

}  // namespace armsig::io
