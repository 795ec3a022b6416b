// Output files appear whole or not at all: written to a temporary file in the
// same directory, flushed, then renamed over the target.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace armsig::io {

// An output file made ready before what it reports is stored, and put in place after: it is
// written to a temporary file beside the target (`TARGET.tmp.XXXXXX`, mkostemp: O_EXCL and a
// name nobody can guess, so nothing planted there is followed or overwritten), whole
// (`PreparedFile(path, content)`) or piece by piece (`Write`, 1 MiB buffered: a file larger
// than the memory one would give it); Ready() flushes it to disk, Commit() (ready first)
// renames it over the target and flushes the folder. Destroyed without Commit(), the
// temporary file is removed. The temporary file is locked (flock) while its writer lives:
// one left by a process that died before it could remove it (kill -9, a power cut) is
// unlocked, and the next writer of the same target removes it. Throws OutputError
// (core/error.h) naming the target and the system's reason ("No space left on device"); the
// target is then as it was. What is at the path decides: nothing or a regular file is
// replaced as above; a FIFO or a character device (/dev/null, /dev/stdout, a pipe) is written
// through, as a shell's redirection would; a symbolic link, a folder, a socket or a block
// device is refused (OutputError; CheckOutputFile refuses them before any work).
class PreparedFile {
 public:
  explicit PreparedFile(std::string path);
  PreparedFile(std::string path, std::string_view content);
  ~PreparedFile();
  PreparedFile(PreparedFile&& other) noexcept;
  PreparedFile& operator=(PreparedFile&&) = delete;
  PreparedFile(const PreparedFile&) = delete;
  PreparedFile& operator=(const PreparedFile&) = delete;

  void Write(std::string_view text);
  void Ready();
  void Commit();
  const std::string& path() const { return path_; }

 private:
  void WriteBuffer();
  [[noreturn]] void Fail(const std::string& what);

  std::string path_;
  std::string tmp_;
  std::string buffer_;
  int fd_ = -1;
  bool ready_ = false;
  bool stream_ = false;  // a FIFO or a character device at the path: written through
  int live_slot_ = -1;  // in the table RemoveLiveTemporaries reads (-1: not in it)
};

// Removes the temporary file of every PreparedFile alive in this process. Async-signal-safe:
// for a signal handler that ends the process at once (_exit), so that what a stopped command
// was writing leaves nothing behind.
void RemoveLiveTemporaries() noexcept;

// PreparedFile(path, content).Commit(). Throws OutputError naming the path.
void WriteFileAtomically(const std::string& path, std::string_view content);

// The files this process has committed (PreparedFile::Commit), in order: what a command that
// changes nothing in the store did write, for the message when its standard output fails.
std::vector<std::string> CommittedFiles();

// Removes the temporary files of `path` (`PATH.tmp.XXXXXX`, this user's) that no living
// writer holds: what a killed writer left. Returns how many were removed.
int RemoveStaleTemporaries(const std::string& path);
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
inline constexpr FileLimit kProgramFileLimit{std::size_t{64} << 20, "a robot program"};  // 64 MiB

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
