#include "acquisition/device_claims.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <pwd.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <climits>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>

#include "core/text.h"

namespace armsig::acquisition {

namespace {

// A device's name in a file name: [A-Za-z0-9._-] as they are, every other byte as %XX.
std::string FileNameOf(const std::string& device) {
  std::string out;
  for (const unsigned char c : device) {
    if (std::isalnum(c) || c == '.' || c == '_' || c == '-')
      out += static_cast<char>(c);
    else
      out += fmt::format("%{:02X}", c);
  }
  return out + ".lock";
}

// One name per physical device: a serial port by its canonical path (a symlink such as
// /dev/serial/by-id/… and the node it points to are one port), a TCP instrument by its
// host (lower case) and port.
std::string SerialName(const std::string& port) {
  std::error_code ec;
  const auto canonical = std::filesystem::weakly_canonical(port, ec);
  return "serial " + (ec ? port : canonical.string());
}

std::string TcpName(std::string host_port) {
  std::transform(host_port.begin(), host_port.end(), host_port.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return "tcp " + host_port;
}

std::string HostName() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "?";
  return name;
}

std::string UserName(uid_t uid) {
  if (const passwd* pw = ::getpwuid(uid)) return pw->pw_name;
  return "uid " + std::to_string(uid);
}

[[noreturn]] void RefuseFolder(const std::string& dir, const std::string& why) {
  throw std::runtime_error(fmt::format(
      "device claims: {}: {}; refused (another user could remove or redirect the claims: give "
      "$ARMSIG_DEVICE_LOCK_DIR a folder of your own, mode 0700, or a shared one of root's, mode "
      "1777)",
      Printable(dir), why));
}

// Owned by this user or root, and writable by nobody else unless sticky (where nobody
// removes or renames another's file).
std::optional<std::string> UnsafeFolder(const struct stat& st) {
  if (st.st_uid != ::geteuid() && st.st_uid != 0)
    return fmt::format("owned by another user ({})", UserName(st.st_uid));
  if ((st.st_mode & (S_IWGRP | S_IWOTH)) != 0 && (st.st_mode & S_ISVTX) == 0) {
    return fmt::format("writable by {} without the sticky bit (mode {:04o})",
                       (st.st_mode & S_IWOTH) != 0 ? "every user" : "its group",
                       st.st_mode & 07777);
  }
  return std::nullopt;
}

// The folder made by root and shared by every user's captures.
constexpr char kSharedFolder[] = "/run/armsig";

}  // namespace

DeviceClaims::DeviceClaims(DeviceClaims&& other) noexcept
    : fds_(std::move(other.fds_)), devices_(std::move(other.devices_)) {
  other.fds_.clear();
}

DeviceClaims& DeviceClaims::operator=(DeviceClaims&& other) noexcept {
  if (this != &other) {
    for (const int fd : fds_) ::close(fd);
    fds_ = std::move(other.fds_);
    devices_ = std::move(other.devices_);
    other.fds_.clear();
  }
  return *this;
}

DeviceClaims::~DeviceClaims() {
  for (const int fd : fds_) ::close(fd);  // closing the file releases its flock
}

std::string DeviceLockDir() {
  if (const char* dir = std::getenv("ARMSIG_DEVICE_LOCK_DIR"); dir && *dir) return dir;
  struct stat st {};
  // Root makes the shared folder; a user uses it when it is there for them (the package
  // makes it at boot, 1777).
  if (::geteuid() == 0 || (::lstat(kSharedFolder, &st) == 0 && S_ISDIR(st.st_mode) &&
                           ::access(kSharedFolder, W_OK) == 0))
    return kSharedFolder;
  if (const char* runtime = std::getenv("XDG_RUNTIME_DIR");
      runtime && *runtime && ::stat(runtime, &st) == 0 && S_ISDIR(st.st_mode) &&
      st.st_uid == ::geteuid()) {
    return std::string(runtime) + "/armsig-devices";
  }
  return (std::filesystem::temp_directory_path() /
          ("armsig-devices-" + std::to_string(::geteuid())))
      .string();
}

int OpenClaimFolder(const std::string& dir) {
  const bool shared = dir == kSharedFolder;
  if (::mkdir(dir.c_str(), shared ? 01777 : 0700) == 0) {
    ::chmod(dir.c_str(), shared ? 01777 : 0700);  // mkdir's mode is umask'ed
  } else if (errno != EEXIST) {
    RefuseFolder(dir, fmt::format("cannot be made ({})", std::strerror(errno)));
  }
  // O_NOFOLLOW: a symbolic link in its place (planted in a shared folder) is not followed.
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) {
    struct stat st {};
    if (::lstat(dir.c_str(), &st) == 0 && S_ISLNK(st.st_mode))
      RefuseFolder(dir, "is a symbolic link, not a folder");
    RefuseFolder(dir, fmt::format("cannot be opened as a folder ({})", std::strerror(errno)));
  }
  struct stat st {};
  std::optional<std::string> why;
  if (::fstat(fd, &st) != 0) why = std::string("cannot be examined: ") + std::strerror(errno);
  if (!why) why = UnsafeFolder(st);
  // The folders above it: one another user could write into could swap this one.
  char resolved[PATH_MAX];
  if (!why && ::realpath(dir.c_str(), resolved) != nullptr) {
    for (auto up = std::filesystem::path(resolved).parent_path();; up = up.parent_path()) {
      struct stat above {};
      if (::stat(up.c_str(), &above) == 0) {
        if (auto unsafe = UnsafeFolder(above)) {
          why = fmt::format("lies in {}, which is {}", up.string(), *unsafe);
          break;
        }
      }
      if (up == up.root_path() || up.empty()) break;
    }
  }
  if (why) {
    ::close(fd);
    RefuseFolder(dir, *why);
  }
  return fd;
}

namespace {

// The process that holds a lock on the file open as `fd`, from the kernel's lock table
// (/proc/locks: "1: FLOCK  ADVISORY  WRITE 4711 08:01:123456 0 EOF"); 0 when none is found.
pid_t LiveHolder(int fd) {
  struct stat st {};
  if (::fstat(fd, &st) != 0) return 0;
  const std::string id = fmt::format("{:02x}:{:02x}:{}", major(st.st_dev), minor(st.st_dev),
                                     static_cast<unsigned long>(st.st_ino));
  std::ifstream locks("/proc/locks");
  std::string line;
  while (std::getline(locks, line)) {
    std::istringstream fields(line);
    std::string number, kind, advisory, access, pid, file;
    fields >> number >> kind;
    if (kind == "->") continue;  // a waiter, not the holder
    fields >> advisory >> access >> pid >> file;
    if (file == id) return static_cast<pid_t>(std::atol(pid.c_str()));
  }
  return 0;
}

struct Holder {
  std::string who;
  bool armsig = false;  // the note in the claim is the live holder's own
};

// "pid 4711 on cell3 (lab): armsig capture --lab …", or the live holder when the note in the
// file is not its (a foreign process's lock, a note left by an earlier holder).
Holder HolderOf(int fd) {
  char text[512] = {};
  const ssize_t n = ::pread(fd, text, sizeof text - 1, 0);
  std::string note = n > 0 ? std::string(text, static_cast<size_t>(n)) : std::string();
  while (!note.empty() && (note.back() == '\n' || note.back() == ' ')) note.pop_back();
  long noted_pid = 0;
  std::sscanf(note.c_str(), "pid %ld", &noted_pid);
  const pid_t live = LiveHolder(fd);
  if (live > 0 && live == noted_pid) return {Printable(note), true};
  if (live > 0) {
    struct stat proc {};
    std::string who = fmt::format("pid {}", static_cast<long>(live));
    std::ifstream comm(fmt::format("/proc/{}/comm", static_cast<long>(live)));
    std::string name;
    if (std::getline(comm, name) && !name.empty()) who += " (" + Printable(name) + ")";
    if (::stat(fmt::format("/proc/{}", static_cast<long>(live)).c_str(), &proc) == 0) {
      who += proc.st_uid == ::geteuid()
                 ? std::string(" of this user")
                 : fmt::format(" of another user, {}", UserName(proc.st_uid));
    }
    return {who + (note.empty() ? std::string() : "; the note in the claim is an earlier holder's"),
            false};
  }
  // No lock table: the note's pid, when that process still lives.
  if (noted_pid > 0 && (::kill(static_cast<pid_t>(noted_pid), 0) == 0 || errno == EPERM))
    return {Printable(note), true};
  return {"a process that could not be identified", false};
}

}  // namespace

DeviceClaims ClaimDevices(const io::LabConfig& lab, const std::string& what,
                          const std::string& lock_dir) {
  std::vector<std::string> devices;
  for (const auto& i : lab.instruments)
    devices.push_back(i.tcp ? TcpName(i.tcp->Text()) : SerialName(i.port));
  const auto& c = lab.controller;
  if (c.protocol == io::ControllerProtocol::kCounter) {
    for (const auto& p : c.counter_ports) devices.push_back(SerialName(p));
  } else if (!c.port.empty()) {
    devices.push_back(SerialName(c.port));
  } else if (!c.host.empty()) {
    // A controller on the network: one claim for every port it is reached on (a lab file
    // naming another of its interfaces still meets the claim of the port it shares).
    for (const auto& [key, port] : c.ports) devices.push_back(TcpName(c.host + ":" + std::to_string(port)));
  }
  std::set<std::string> seen;
  for (const auto& d : devices) {
    if (!seen.insert(d).second) {
      throw std::runtime_error(fmt::format(
          "{}: {} is named twice in the lab file: one device serves one instrument or the "
          "controller",
          lab.source, d.substr(d.find(' ') + 1)));
    }
  }

  const int dir = OpenClaimFolder(lock_dir);
  struct DirCloser {
    int fd;
    ~DirCloser() { ::close(fd); }
  } dir_closer{dir};
  DeviceClaims claims;
  for (const auto& device : devices) {
    const std::string name = FileNameOf(device);
    const std::string path = (std::filesystem::path(lock_dir) / name).string();
    int fd = -1;
    for (;;) {
      // O_NOFOLLOW: a symbolic link planted under the claim's name is not followed (a root
      // capture would write its note into the file it names); O_NONBLOCK: a FIFO there does
      // not block the open.
      constexpr int kFlags = O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK | O_NOCTTY;
      fd = ::openat(dir, name.c_str(), O_RDWR | O_CREAT | kFlags, 0644);
      if (fd < 0 && errno == EACCES) fd = ::openat(dir, name.c_str(), O_RDONLY | kFlags);
      if (fd < 0) {
        throw std::runtime_error(fmt::format("{}: cannot open the claim of {} ({}{})",
                                             Printable(path), device, std::strerror(errno),
                                             errno == ELOOP ? ": a symbolic link, refused" : ""));
      }
      struct stat st {};
      if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        ::close(fd);
        throw std::runtime_error(fmt::format("{}: the claim of {} is not a regular file; refused",
                                             Printable(path), device));
      }
      if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
        const Holder holder = HolderOf(fd);
        ::close(fd);
        throw std::runtime_error(fmt::format(
            "{} ({}) is in use by another {}process ({}): one capture drives a device at a "
            "time; wait for it to end or stop it (its session resumes later)",
            device.substr(device.find(' ') + 1), lab.source, holder.armsig ? "armsig " : "",
            holder.who));
      }
      // Still the file of that name (its owner may have removed it meanwhile): else again.
      struct stat by_name {};
      if (::fstatat(dir, name.c_str(), &by_name, AT_SYMLINK_NOFOLLOW) == 0 &&
          by_name.st_dev == st.st_dev && by_name.st_ino == st.st_ino)
        break;
      ::close(fd);
    }
    // Who holds it, for whoever finds it taken (a claim file of another user's, opened
    // read-only, keeps its note: the refusal then names the live holder from the kernel).
    const std::string me = fmt::format("pid {} on {} ({}): {}\n", static_cast<long>(::getpid()),
                                       HostName(), UserName(::geteuid()), what);
    if (::ftruncate(fd, 0) == 0) {
      [[maybe_unused]] const ssize_t w = ::pwrite(fd, me.data(), me.size(), 0);
    }
    claims.fds_.push_back(fd);
    claims.devices_.push_back(device);
  }
  return claims;
}

}  // namespace armsig::acquisition
