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

void WriteFileAtomically(const std::string& path, std::string_view content) {
  // The temporary file gets a name nobody can guess and is created with O_EXCL (mkostemp),
  // so a symlink or file planted in the folder is never followed or overwritten: a job
  // running as root cannot be made to write anywhere but `path`.
  std::string tmp = path + ".tmp.XXXXXX";
  const int fd = ::mkostemp(tmp.data(), O_CLOEXEC);
  if (fd < 0) {
    throw std::runtime_error(path + ": cannot write (" + std::strerror(errno) + ")");
  }
  auto fail = [&](const std::string& what) {
    const std::string reason = std::strerror(errno);
    ::close(fd);
    ::unlink(tmp.c_str());
    throw std::runtime_error(path + ": " + what + " (" + reason + ")");
  };
  // mkostemp creates the file 0600; an output file is readable like any other (umask'ed
  // 0644 as open(2) would have made it).
  const mode_t mask = CurrentUmask();
  if (::fchmod(fd, 0644 & ~mask) != 0) fail("cannot set the file mode");
  size_t written = 0;
  while (written < content.size()) {
    const ssize_t n = ::write(fd, content.data() + written, content.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("write failed");
    }
    written += static_cast<size_t>(n);
  }
  if (::fsync(fd) != 0) fail("cannot flush to disk");
  if (::close(fd) != 0) {
    const std::string reason = std::strerror(errno);
    ::unlink(tmp.c_str());
    throw std::runtime_error(path + ": write failed (" + reason + ")");
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    ::unlink(tmp.c_str());
    throw std::runtime_error(path + ": cannot rename into place (" + reason + ")");
  }
  // The rename itself survives a power cut once the folder is flushed.
  const std::string folder = std::filesystem::path(path).parent_path().string();
  const int dir = ::open(folder.empty() ? "." : folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir >= 0) {
    ::fsync(dir);
    ::close(dir);
  }
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

std::string ReadWholeFile(const std::string& path, FileLimit limit) {
  // O_NONBLOCK: opening a FIFO for reading would otherwise wait for a writer; it is refused
  // below before anything is read. O_NOCTTY: a terminal never becomes the controlling one.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
  if (fd < 0) {
    throw InputError({path, 0, 0, ""},
                     std::string("cannot open file for reading (") + std::strerror(errno) + ")");
  }
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    throw InputError({path, 0, 0, ""},
                     std::string("cannot read file (") + std::strerror(errno) + ")");
  }
  if (!S_ISREG(st.st_mode)) {
    throw InputError({path, 0, 0, ""}, std::string("is ") + KindOf(st.st_mode) +
                                           ", not a regular file: expected " + limit.format +
                                           " (nothing was read)");
  }
  const auto too_big = [&] {
    return InputError({path, 0, 0, ""}, "is larger than " + std::string(limit.format) +
                                            " armsig reads (at most " + Size(limit.max_bytes) +
                                            ")");
  };
  if (static_cast<std::size_t>(st.st_size) > limit.max_bytes) throw too_big();
  std::string out;
  out.reserve(static_cast<std::size_t>(st.st_size));
  char buffer[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw InputError({path, 0, 0, ""},
                       std::string("cannot read file (") + std::strerror(errno) + ")");
    }
    if (n == 0) break;
    if (out.size() + static_cast<std::size_t>(n) > limit.max_bytes) throw too_big();  // it grew
    out.append(buffer, static_cast<std::size_t>(n));
  }
  return out;
}

}  // namespace armsig::io
