// One capture per device: before a session opens its instruments and its robot controller,
// it claims each of them by an exclusive lock (flock) on a file named after the device in
// a folder every armsig process on the machine shares. A second capture on the same lab
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
  friend DeviceClaims ClaimDevices(const LabConfig&, const std::string&, const std::string&);
  std::vector<int> fds_;
  std::vector<std::string> devices_;
};

// The folder of the claim files: $ARMSIG_DEVICE_LOCK_DIR, else armsig-devices in the
// system's temporary folder (created shared, sticky, like /run/lock).
std::string DeviceLockDir();

// Claims every instrument and the controller of `lab` (what: "capture session 12 (lab.yaml)"
// is written into each claim for whoever finds it taken). Throws std::runtime_error naming
// the device, the lab file and the holder (pid, host, what) when one is taken; nothing stays
// claimed then.
DeviceClaims ClaimDevices(const LabConfig& lab, const std::string& what,
                          const std::string& lock_dir = DeviceLockDir());

}  // namespace armsig::acquisition
