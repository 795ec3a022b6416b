// Commands printed for the user to run ("resume with: …", "register it: …"). A hint must
// work as printed, from any directory: it always names the database by its absolute
// path, and every word is quoted for a POSIX shell when it needs to be.
#pragma once

#include "db/database.h"

#include <initializer_list>
#include <string>
#include <vector>

namespace armsig::workflows {

// The path made absolute and normal (unchanged if that fails).
std::string AbsolutePath(const std::string& path);
// `word` as one word of a POSIX shell command line ('…' quoting when needed).
std::string ShellWord(const std::string& word);

// "armsig --db /abs/lab.db WORD…": every word quoted as needed. Words that name files
// should be passed through AbsolutePath first.
std::string Hint(const std::string& db_path, std::initializer_list<std::string> words);
std::string Hint(const std::string& db_path, const std::vector<std::string>& words);

// "no robot 'pumaa' in the database (did you mean 'puma'?)" when a registered robot's name
// is a likely typo of it, else "no robot 'NAME' in the database (register it: armsig --db …
// robot add NAME --model MODEL.yaml; armsig --db … robot list shows the robots)":
// MODEL.yaml is the one word to replace.
std::string UnknownRobotMessage(db::Database& database, const std::string& robot);

}  // namespace armsig::workflows
