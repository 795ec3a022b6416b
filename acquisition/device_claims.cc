#include "acquisition/device_claims.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <stdexcept>

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
  return (std::filesystem::temp_directory_path() / "armsig-devices").string();
}

DeviceClaims ClaimDevices(const LabConfig& lab, const std::string& what,
                          const std::string& lock_dir) {
  std::vector<std::string> devices;
  for (const auto& i : lab.instruments)
    devices.push_back(i.tcp.empty() ? SerialName(i.port) : TcpName(i.tcp));
  const auto& c = lab.controller;
  if (c.protocol == "counter") {
    for (const auto& p : c.counter_ports) devices.push_back(SerialName(p));
  } else if (!c.port.empty()) {
    devices.push_back(SerialName(c.port));
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

  std::error_code ec;
  if (std::filesystem::create_directories(lock_dir, ec))
    ::chmod(lock_dir.c_str(), 01777);  // shared by every user's captures, like /run/lock
  DeviceClaims claims;
  for (const auto& device : devices) {
    const std::string path = (std::filesystem::path(lock_dir) / FileNameOf(device)).string();
    int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
    if (fd < 0) fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);  // another user's
    if (fd < 0) {
      throw std::runtime_error(fmt::format("{}: cannot create the claim of {} (is {} writable?)",
                                           path, device, lock_dir));
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      char holder[512] = {};
      const ssize_t n = ::pread(fd, holder, sizeof holder - 1, 0);
      ::close(fd);
      std::string who = n > 0 ? std::string(holder, static_cast<size_t>(n)) : std::string();
      while (!who.empty() && (who.back() == '\n' || who.back() == ' ')) who.pop_back();
      throw std::runtime_error(fmt::format(
          "{} ({}) is in use by another armsig process{}: one capture drives a device at a "
          "time; wait for it to end or stop it (its session resumes later)",
          device.substr(device.find(' ') + 1), lab.source,
          who.empty() ? std::string() : " (" + who + ")"));
    }
    // Who holds it, for whoever finds it taken (best effort: a read-only claim stays blank).
    const std::string me =
        fmt::format("pid {} on {}: {}\n", static_cast<long>(::getpid()), HostName(), what);
    if (::ftruncate(fd, 0) == 0) {
      [[maybe_unused]] const ssize_t w = ::pwrite(fd, me.data(), me.size(), 0);
    }
    claims.fds_.push_back(fd);
    claims.devices_.push_back(device);
  }
  return claims;
}

}  // namespace armsig::acquisition
