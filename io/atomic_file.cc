#include "io/atomic_file.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <climits>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
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

namespace {

const char* KindOf(mode_t mode) {
  if (S_ISDIR(mode)) return "a folder";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

// What is at an output path decides how it is written (docs/reference/robustness.md):
// nothing or a regular file is replaced whole (a temporary file renamed over it); a FIFO or a
// character device (/dev/null, /dev/stdout, a pipe a reader waits on) is written through, as a
// shell's redirection would, also through a symbolic link (/dev/stdout); a symbolic link to
// anything else is refused (replacing it would cut the link, following it would let a planted
// link choose which file a job running as root replaces); anything else (a folder, a socket,
// a block device) is refused.
enum class OutputTarget { kFile, kStream, kLink, kOther };

OutputTarget TargetAt(const std::string& path, struct stat* st) {
  if (::lstat(path.c_str(), st) != 0) return OutputTarget::kFile;  // nothing there yet
  if (S_ISREG(st->st_mode)) return OutputTarget::kFile;
  if (S_ISLNK(st->st_mode)) {
    // The process's own descriptors (/dev/stdout, /dev/fd/3): whatever the shell opened.
    const bool own = path == "/dev/stdout" || path == "/dev/stderr" ||
                     path.rfind("/dev/fd/", 0) == 0 || path.rfind("/proc/self/fd/", 0) == 0;
    struct stat to {};
    if (::stat(path.c_str(), &to) == 0 &&
        (own || S_ISFIFO(to.st_mode) || S_ISCHR(to.st_mode))) {
      *st = to;
      return OutputTarget::kStream;
    }
    return OutputTarget::kLink;
  }
  if (S_ISFIFO(st->st_mode) || S_ISCHR(st->st_mode)) return OutputTarget::kStream;
  return OutputTarget::kOther;
}

std::string LinkRefusal(const std::string& path) {
  std::error_code error;
  const auto to = std::filesystem::read_symlink(path, error);
  return path + " is a symbolic link" + (error ? "" : " to " + to.string()) +
         "; armsig replaces only a regular file whole: give the path of the file itself";
}

// The temporary files of the living writers, for RemoveLiveTemporaries in a signal handler:
// fixed storage and lock-free flags only (no allocation, no lock a handler could wait on).
constexpr int kLiveSlots = 64;
struct LiveTemporary {
  std::atomic<int> state{0};  // 0 free, 1 being filled, 2 holds a path
  char path[PATH_MAX];
};
LiveTemporary g_live[kLiveSlots];

int RegisterLive(const std::string& tmp) {
  if (tmp.size() >= PATH_MAX) return -1;
  for (int k = 0; k < kLiveSlots; ++k) {
    int expected = 0;
    if (!g_live[k].state.compare_exchange_strong(expected, 1)) continue;
    std::memcpy(g_live[k].path, tmp.c_str(), tmp.size() + 1);
    g_live[k].state.store(2);
    return k;
  }
  return -1;  // more writers than slots: the next writer of that target removes its file
}

void UnregisterLive(int& slot) {
  if (slot >= 0) g_live[slot].state.store(0);
  slot = -1;
}

}  // namespace

void RemoveLiveTemporaries() noexcept {
  for (auto& live : g_live) {
    if (live.state.load() == 2) ::unlink(live.path);
  }
}

PreparedFile::PreparedFile(std::string path) : path_(std::move(path)) {
  struct stat st {};
  switch (TargetAt(path_, &st)) {
    case OutputTarget::kFile:
      break;
    case OutputTarget::kStream:
      // Written through: no temporary file, no rename, nothing to flush to a disk.
      // O_APPEND: behind /dev/stdout may be a file the shell opened with >> (or > and empty).
      fd_ = ::open(path_.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC | O_NOCTTY);
      if (fd_ < 0) ThrowOutputError(path_, "cannot write", errno);
      stream_ = true;
      return;
    case OutputTarget::kLink:
      throw OutputError(LinkRefusal(path_));
    case OutputTarget::kOther:
      throw OutputError(path_ + " is " + KindOf(st.st_mode) + "; expected a file name");
  }
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
  live_slot_ = RegisterLive(tmp_);
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
      ready_(other.ready_),
      stream_(other.stream_),
      live_slot_(other.live_slot_) {
  other.fd_ = -1;
  other.live_slot_ = -1;
}

PreparedFile::~PreparedFile() {
  if (fd_ < 0) return;
  if (!stream_) ::unlink(tmp_.c_str());
  UnregisterLive(live_slot_);
  ::close(fd_);
}

void PreparedFile::Fail(const std::string& what) {
  const int error = errno;
  if (!stream_) ::unlink(tmp_.c_str());
  UnregisterLive(live_slot_);
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
  if (!stream_ && ::fsync(fd_) != 0) Fail("write failed (flushing to disk)");
  ready_ = true;
}

namespace {
std::mutex committed_mutex;
std::vector<std::string>& Committed() {
  static std::vector<std::string> files;
  return files;
}
void RecordCommitted(const std::string& path) {
  const std::lock_guard lock(committed_mutex);
  Committed().push_back(path);
}
}  // namespace

std::vector<std::string> CommittedFiles() {
  const std::lock_guard lock(committed_mutex);
  return Committed();
}

void PreparedFile::Commit() {
  if (fd_ < 0) throw std::logic_error(path_ + ": committed twice");
  Ready();
  if (stream_) {
    const int closed = ::close(fd_);
    fd_ = -1;
    if (closed != 0 && errno != EINTR) ThrowOutputError(path_, "write failed", errno);
    RecordCommitted(path_);
    return;
  }
  // Renamed while still open and locked (a cleaner never takes a finished file); closed after.
  if (::rename(tmp_.c_str(), path_.c_str()) != 0) Fail("cannot rename into place");
  UnregisterLive(live_slot_);
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
  RecordCommitted(path_);
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
  struct stat st {};
  switch (TargetAt(path, &st)) {
    case OutputTarget::kFile:
      break;
    case OutputTarget::kStream:  // written through: the device or FIFO must take writes
      if (::access(path.c_str(), W_OK) != 0) {
        throw InputError({option, 0, 0, ""}, path + ": cannot write (" + std::strerror(errno) +
                                                 "; nothing was stored)");
      }
      return;
    case OutputTarget::kLink:
      throw InputError({option, 0, 0, ""}, LinkRefusal(path) + " (nothing was stored)");
    case OutputTarget::kOther:
      throw InputError({option, 0, 0, ""}, path + " is " + KindOf(st.st_mode) +
                                               "; expected a file name (nothing was stored)");
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
