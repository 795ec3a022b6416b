// Output files appear whole or not at all: written to a temporary file in the
// same directory, flushed, then renamed over the target.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace armsig::io {

// Throws std::runtime_error naming the path when it cannot be written.
void WriteFileAtomically(const std::string& path, std::string_view content);

// The same for an output written piece by piece (a file larger than the memory one would
// give it): Write appends (1 MiB buffered), Commit makes the file appear whole; a writer
// destroyed without Commit leaves nothing behind.
class AtomicFileWriter {
 public:
  explicit AtomicFileWriter(std::string path);  // throws std::runtime_error
  ~AtomicFileWriter();
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;
  void Write(std::string_view text);
  void Commit();

 private:
  void Flush();
  [[noreturn]] void Fail(const std::string& what);

  std::string path_, tmp_, buffer_;
  int fd_ = -1;
  bool committed_ = false;
};
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
// A CSV file read one record at a time (io::CsvReader: memory for one record, whatever the
// file's size): a bound only against a file that never stops growing.
inline constexpr FileLimit kCsvStreamLimit{std::size_t{64} << 30, "a streamed CSV file"};  // 64 GiB
inline constexpr FileLimit kGsiFileLimit{std::size_t{64} << 20, "a GSI file"};    // 64 MiB

// Reads a whole input file: every reader of a file armsig is given goes through here.
// Throws InputError naming the path when it cannot be opened, is not a regular file (a
// folder, a FIFO that would block, /dev/zero or /dev/urandom that never end, a socket or a
// terminal: never read from) or holds more than the format's limit.
std::string ReadWholeFile(const std::string& path, FileLimit limit);

// An input file opened as ReadWholeFile opens it (the same refusals), read piece by piece.
class InputFile {
 public:
  InputFile(const std::string& path, FileLimit limit);
  ~InputFile();
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;
  // Up to `size` bytes into `buffer`; 0 at the end of the file. Throws InputError when the
  // file cannot be read or grows past its limit.
  std::size_t Read(char* buffer, std::size_t size);
  std::size_t size() const { return size_; }  // when it was opened
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  FileLimit limit_;
  int fd_ = -1;
  std::size_t size_ = 0, read_ = 0;
};

}  // namespace armsig::io
