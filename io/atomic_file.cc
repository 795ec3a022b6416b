#include "io/atomic_file.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "core/error.h"

namespace armsig::io {

namespace {

// The process's umask without changing it (umask(2) can only set it, which would race with
// other threads creating files): Linux reports it in /proc/self/status.
mode_t CurrentUmask() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("Umask:", 0) == 0)
      return static_cast<mode_t>(std::stoul(line.substr(6), nullptr, 8));
  }
  return 022;
}

}  // namespace

namespace {

constexpr char kTmpInfix[] = ".tmp.";
constexpr std::size_t kTmpSuffixLength = 6;  // mkostemp's XXXXXX

std::string FolderOf(const std::string& path) {
  const std::string folder = std::filesystem::path(path).parent_path().string();
  return folder.empty() ? std::string(".") : folder;
}

[[noreturn]] void ThrowOutputError(const std::string& path, const std::string& what, int error) {
  throw OutputError(path + ": " + what + " (" + std::strerror(error) + "); " + path +
                    " was not changed");
}

// Whether the file at `name` in `dir` is still the one open as `fd`.
bool SameFile(int dir, const char* name, int fd) {
  struct stat by_name {
  }, open{};
  return ::fstatat(dir, name, &by_name, AT_SYMLINK_NOFOLLOW) == 0 && ::fstat(fd, &open) == 0 &&
         by_name.st_dev == open.st_dev && by_name.st_ino == open.st_ino;
}

}  // namespace

int RemoveStaleTemporaries(const std::string& path) {
  const std::string folder = FolderOf(path);
  const std::string prefix = std::filesystem::path(path).filename().string() + kTmpInfix;
  const int dir = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir < 0) return 0;
  int removed = 0;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(folder, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.size() != prefix.size() + kTmpSuffixLength || name.rfind(prefix, 0) != 0) continue;
    struct stat st {};
    if (::fstatat(dir, name.c_str(), &st, AT_SYMLINK_NOFOLLOW) != 0 || !S_ISREG(st.st_mode) ||
        st.st_uid != ::geteuid()) {
      continue;  // not a file of ours: left alone
    }
    const int fd =
        ::openat(dir, name.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd < 0) continue;
    // Locked: its writer lives (and removes or renames it). Unlocked: its writer died.
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0 && SameFile(dir, name.c_str(), fd) &&
        ::unlinkat(dir, name.c_str(), 0) == 0) {
      ++removed;
    }
    ::close(fd);
  }
  ::close(dir);
  return removed;
}

PreparedFile::PreparedFile(std::string path) : path_(std::move(path)) {
  RemoveStaleTemporaries(path_);
  // The temporary file gets a name nobody can guess and is created with O_EXCL (mkostemp),
  // so a symlink or file planted in the folder is never followed or overwritten: a job
  // running as root cannot be made to write anywhere but `path`.
  for (;;) {
    tmp_ = path_ + kTmpInfix + std::string(kTmpSuffixLength, 'X');
    fd_ = ::mkostemp(tmp_.data(), O_CLOEXEC);
    if (fd_ < 0) ThrowOutputError(path_, "cannot write", errno);
    // Locked while this writer lives; a cleaner that took it between mkostemp and flock has
    // removed it: made again.
    if (::flock(fd_, LOCK_EX) == 0 && SameFile(AT_FDCWD, tmp_.c_str(), fd_)) break;
    ::close(fd_);
  }
  // mkostemp creates the file 0600; an output file is readable like any other (umask'ed
  // 0644 as open(2) would have made it).
  const mode_t mask = CurrentUmask();
  if (::fchmod(fd_, 0644 & ~mask) != 0) Fail("cannot set the file mode");
}

PreparedFile::PreparedFile(std::string path, std::string_view content)
    : PreparedFile(std::move(path)) {
  buffer_ = content;
  Ready();
}

PreparedFile::PreparedFile(PreparedFile&& other) noexcept
    : path_(std::move(other.path_)),
      tmp_(std::move(other.tmp_)),
      buffer_(std::move(other.buffer_)),
      fd_(other.fd_),
      ready_(other.ready_) {
  other.fd_ = -1;
}

PreparedFile::~PreparedFile() {
  if (fd_ < 0) return;
  ::unlink(tmp_.c_str());
  ::close(fd_);
}

void PreparedFile::Fail(const std::string& what) {
  const int error = errno;
  ::unlink(tmp_.c_str());
  ::close(fd_);
  fd_ = -1;
  ThrowOutputError(path_, what, error);
}

void PreparedFile::Write(std::string_view text) {
  if (ready_) throw std::logic_error(path_ + ": written after it was made ready");
  buffer_.append(text);
  if (buffer_.size() >= (std::size_t{1} << 20)) WriteBuffer();
}

void PreparedFile::WriteBuffer() {
  if (fd_ < 0) throw std::logic_error(path_ + ": written after a failure");
  std::size_t written = 0;
  while (written < buffer_.size()) {
    const ssize_t n = ::write(fd_, buffer_.data() + written, buffer_.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      Fail("write failed");
    }
    written += static_cast<std::size_t>(n);
  }
  buffer_.clear();
}

void PreparedFile::Ready() {
  if (ready_) return;
  WriteBuffer();
  if (::fsync(fd_) != 0) Fail("write failed (flushing to disk)");
  ready_ = true;
}

void PreparedFile::Commit() {
  if (fd_ < 0) throw std::logic_error(path_ + ": committed twice");
  Ready();
  // Renamed while still open and locked (a cleaner never takes a finished file); closed after.
  if (::rename(tmp_.c_str(), path_.c_str()) != 0) Fail("cannot rename into place");
  const int close_result = ::close(fd_);
  const int close_error = errno;
  fd_ = -1;
  // The rename itself survives a power cut once the folder is flushed.
  const int dir = ::open(FolderOf(path_).c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir >= 0) {
    ::fsync(dir);
    ::close(dir);
  }
  if (close_result != 0 && close_error != EINTR) {
    throw OutputError(path_ + ": write failed (" + std::strerror(close_error) + ")");
  }
}

void WriteFileAtomically(const std::string& path, std::string_view content) {
  PreparedFile(path, content).Commit();
}

namespace {

void CheckWritableFolder(const std::string& folder, const std::string& path,
                         const std::string& option) {
  std::error_code error;
  if (!std::filesystem::is_directory(folder, error)) {
    throw InputError({option, 0, 0, ""}, "cannot write " + path + ": folder " + folder +
                                             " does not exist (nothing was stored)");
  }
  if (::access(folder.c_str(), W_OK) != 0) {
    throw InputError({option, 0, 0, ""}, "cannot write " + path + ": folder " + folder +
                                             " is not writable (nothing was stored)");
  }
}

}  // namespace

void CheckOutputFile(const std::string& path, const std::string& option) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) {
    throw InputError({option, 0, 0, ""},
                     path + " is a folder; expected a file name (nothing was stored)");
  }
  CheckWritableFolder(FolderOf(path), path, option);
}

void CheckOutputDirectory(const std::string& path, const std::string& option) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) {
    CheckWritableFolder(path, path, option);
    return;
  }
  if (std::filesystem::exists(path, error)) {
    throw InputError({option, 0, 0, ""}, path + " exists and is not a folder (nothing was stored)");
  }
  CheckWritableFolder(FolderOf(path), path, option);
}

namespace {

const char* KindOf(mode_t mode) {
  if (S_ISDIR(mode)) return "a folder";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

std::string Size(std::size_t bytes) {
  return bytes >= (std::size_t{1} << 20) ? std::to_string(bytes >> 20) + " MiB"
                                         : std::to_string(bytes) + " bytes";
}

}  // namespace

InputFile::InputFile(const std::string& path, FileLimit limit) : path_(path), limit_(limit) {
  // O_NONBLOCK: opening a FIFO for reading would otherwise wait for a writer; it is refused
  // below before anything is read. O_NOCTTY: a terminal never becomes the controlling one.
  fd_ = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
  if (fd_ < 0) {
    throw InputError({path, 0, 0, ""},
                     std::string("cannot open file for reading (") + std::strerror(errno) + ")");
  }
  struct stat st {};
  if (::fstat(fd_, &st) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd_);
    throw InputError({path, 0, 0, ""}, "cannot read file (" + why + ")");
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd_);
    throw InputError({path, 0, 0, ""}, std::string("is ") + KindOf(st.st_mode) +
                                           ", not a regular file: expected " + limit.format +
                                           " (nothing was read)");
  }
  size_ = static_cast<std::size_t>(st.st_size);
  if (size_ > limit.max_bytes) {
    ::close(fd_);
    throw InputError({path, 0, 0, ""}, "is larger than " + std::string(limit.format) +
                                           " armsig reads (at most " + Size(limit.max_bytes) + ")");
  }
}

InputFile::~InputFile() { ::close(fd_); }

std::size_t InputFile::Read(char* buffer, std::size_t size) {
  for (;;) {
    const ssize_t n = ::read(fd_, buffer, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw InputError({path_, 0, 0, ""},
                       std::string("cannot read file (") + std::strerror(errno) + ")");
    }
    read_ += static_cast<std::size_t>(n);
    if (read_ > limit_.max_bytes) {  // it grew while read
      throw InputError({path_, 0, 0, ""}, "is larger than " + std::string(limit_.format) +
                                              " armsig reads (at most " + Size(limit_.max_bytes) +
                                              ")");
    }
    return static_cast<std::size_t>(n);
  }
}

std::string ReadWholeFile(const std::string& path, FileLimit limit) {
  InputFile file(path, limit);
  std::string out;
  out.reserve(file.size());
  char buffer[1 << 16];
  while (const std::size_t n = file.Read(buffer, sizeof buffer)) out.append(buffer, n);
  return out;
}

}  // namespace armsig::io
