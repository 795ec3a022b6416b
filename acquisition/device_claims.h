// One capture per device: before a session opens its instruments and its robot controller,
// it claims each of them by an exclusive lock (flock) on a file named after the device in
// a folder of claims (DeviceLockDir, checked so that no other user can remove or redirect
// the claims). A second capture on the same lab
// (or another lab file naming the same port or tracker) is refused before it sends a
// byte, naming the device and who holds it; the OS releases the claim when the process
// ends, however it ends (kill -9, a crash), so a stale claim cannot block the next shift.
// Two machines driving one TCP instrument are not covered: the instrument itself serves one
// client (an emScon server is one tracker's).
#pragma once

#include <string>
#include <vector>

#include "acquisition/lab.h"

namespace armsig::acquisition {

class DeviceClaims {
 public:
  DeviceClaims() = default;
  DeviceClaims(DeviceClaims&&) noexcept;
  DeviceClaims& operator=(DeviceClaims&&) noexcept;
  DeviceClaims(const DeviceClaims&) = delete;
  DeviceClaims& operator=(const DeviceClaims&) = delete;
  ~DeviceClaims();

  // The devices held, as named in the lock files ("serial /dev/ttyUSB0", "tcp 10.0.0.5:700").
  const std::vector<std::string>& devices() const { return devices_; }

 private:
  friend DeviceClaims ClaimDevices(const io::LabConfig&, const std::string&, const std::string&);
  std::vector<int> fds_;
  std::vector<std::string> devices_;
};

// The folder of the claim files: $ARMSIG_DEVICE_LOCK_DIR when set; else /run/armsig, made
// by root with mode 1777 (sticky, shared like /run/lock: every user's captures see root's
// claims, nobody removes another's file) and used by other users when it is there; else
// $XDG_RUNTIME_DIR/armsig-devices (the user's own, 0700), else armsig-devices-UID in the
// system's temporary folder (0700).
std::string DeviceLockDir();

// Opens the folder of the claim files, making it when missing (1777 for /run/armsig,
// otherwise 0700), and checks it before anything is written there: a folder itself, not a
// symbolic link to one; owned by this user or root; writable by nobody else unless sticky;
// every folder above it likewise (owned by this user or root, not writable by others
// unless sticky). Returns the open folder's descriptor (claims are made through it, so the
// folder cannot be swapped after the check). Throws std::runtime_error naming the folder and
// what is wrong.
int OpenClaimFolder(const std::string& dir);

// Claims every instrument and the controller of `lab` (what: "capture session 12 (lab.yaml)"
// is written into each claim for whoever finds it taken). Throws std::runtime_error naming
// the device, the lab file and the live holder (its pid, checked against the kernel's lock
// table, and its user when that is not this one) when one is taken; nothing stays claimed
// then. A claim file that is a symbolic link or not a regular file is refused.
DeviceClaims ClaimDevices(const io::LabConfig& lab, const std::string& what,
                          const std::string& lock_dir = DeviceLockDir());

}  // namespace armsig::acquisition
