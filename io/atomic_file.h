// Output files appear whole or not at all: written to a temporary file in the
// same directory, flushed, then renamed over the target.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace armsig::io {

// Throws std::runtime_error naming the path when it cannot be written.
void WriteFileAtomically(const std::string& path, std::string_view content);
// Checks, before any work is stored, that `path` can be written later: its folder
// exists and is writable, and the path is not a folder. Throws InputError naming the
// option (e.g. "--json") and the path.
void CheckOutputFile(const std::string& path, const std::string& option);
// The same for a folder that will receive files: it exists and is writable, or it can be
// created (its parent exists and is writable).
void CheckOutputDirectory(const std::string& path, const std::string& option);

// The most armsig reads of one input file, per format: far beyond any real file of the
// format (a robot model is a few kB, a stations file a few hundred, an observations CSV of a
// million readings 60 MB), far below what would exhaust the memory.
struct FileLimit {
  std::size_t max_bytes;
  const char* format;  // "a YAML file", for the message
};
inline constexpr FileLimit kYamlFileLimit{std::size_t{16} << 20, "a YAML file"};  // 16 MiB
inline constexpr FileLimit kCsvFileLimit{std::size_t{256} << 20, "a CSV file"};   // 256 MiB
inline constexpr FileLimit kGsiFileLimit{std::size_t{64} << 20, "a GSI file"};    // 64 MiB

// Reads a whole input file: every reader of a file armsig is given goes through here.
// Throws InputError naming the path when it cannot be opened, is not a regular file (a
// folder, a FIFO that would block, /dev/zero or /dev/urandom that never end, a socket or a
// terminal: never read from) or holds more than the format's limit.
std::string ReadWholeFile(const std::string& path, FileLimit limit);

}  // namespace armsig::io
