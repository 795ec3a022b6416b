#include "io/atomic_file.h"

#include <fcntl.h>
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

AtomicFileWriter::AtomicFileWriter(std::string path)
    : path_(std::move(path)), tmp_(path_ + ".tmp.XXXXXX") {
  // The temporary file gets a name nobody can guess and is created with O_EXCL (mkostemp),
  // so a symlink or file planted in the folder is never followed or overwritten: a job
  // running as root cannot be made to write anywhere but `path`.
  fd_ = ::mkostemp(tmp_.data(), O_CLOEXEC);
  if (fd_ < 0) {
    throw std::runtime_error(path_ + ": cannot write (" + std::strerror(errno) + ")");
  }
  // mkostemp creates the file 0600; an output file is readable like any other (umask'ed
  // 0644 as open(2) would have made it).
  const mode_t mask = CurrentUmask();
  if (::fchmod(fd_, 0644 & ~mask) != 0) Fail("cannot set the file mode");
}

AtomicFileWriter::~AtomicFileWriter() {
  if (fd_ >= 0) ::close(fd_);
  if (!committed_) ::unlink(tmp_.c_str());
}

void AtomicFileWriter::Fail(const std::string& what) {
  const std::string reason = std::strerror(errno);
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  ::unlink(tmp_.c_str());
  throw std::runtime_error(path_ + ": " + what + " (" + reason + ")");
}

void AtomicFileWriter::Write(std::string_view text) {
  buffer_.append(text);
  if (buffer_.size() >= (std::size_t{1} << 20)) Flush();
}

void AtomicFileWriter::Flush() {
  if (fd_ < 0) throw std::runtime_error(path_ + ": written after a failure");
  size_t written = 0;
  while (written < buffer_.size()) {
    const ssize_t n = ::write(fd_, buffer_.data() + written, buffer_.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      Fail("write failed");
    }
    written += static_cast<size_t>(n);
  }
  buffer_.clear();
}

void AtomicFileWriter::Commit() {
  Flush();
  if (::fsync(fd_) != 0) Fail("cannot flush to disk");
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) {
    const std::string reason = std::strerror(errno);
    ::unlink(tmp_.c_str());
    throw std::runtime_error(path_ + ": write failed (" + reason + ")");
  }
  if (::rename(tmp_.c_str(), path_.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    ::unlink(tmp_.c_str());
    throw std::runtime_error(path_ + ": cannot rename into place (" + reason + ")");
  }
  committed_ = true;
  // The rename itself survives a power cut once the folder is flushed.
  const std::string folder = std::filesystem::path(path_).parent_path().string();
  const int dir = ::open(folder.empty() ? "." : folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir >= 0) {
    ::fsync(dir);
    ::close(dir);
  }
}

void WriteFileAtomically(const std::string& path, std::string_view content) {
  AtomicFileWriter out(path);
  out.Write(content);
  out.Commit();
}

namespace {

std::string ParentOf(const std::string& path) {
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  return parent.empty() ? std::string(".") : parent.string();
}

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
  CheckWritableFolder(ParentOf(path), path, option);
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
  CheckWritableFolder(ParentOf(path), path, option);
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
