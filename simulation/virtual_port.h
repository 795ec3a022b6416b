// A pseudo-terminal whose slave side is reachable at a stable path (a symlink), so a
// driver can open it like /dev/ttyUSB0, and so it can disappear and come back like an
// unplugged USB adapter.
#pragma once

#include <string>

namespace armsig::simulation {

class VirtualPort {
 public:
  // Creates the pty and the symlink `link_path` → /dev/pts/N.
  explicit VirtualPort(std::string link_path);
  ~VirtualPort();
  VirtualPort(const VirtualPort&) = delete;
  VirtualPort& operator=(const VirtualPort&) = delete;

  const std::string& path() const { return link_path_; }
  int master_fd() const { return master_; }  // -1 while gone
  bool present() const { return master_ >= 0; }

  // The port vanishes: master closed (the driver's reads fail), symlink removed.
  void Disappear();
  // A new pty appears at the same path.
  void Reappear();

 private:
  void Create();
  std::string link_path_;
  int master_ = -1;
  int slave_keepalive_ = -1;  // keeps the slave open so early writes are not lost
};

}  // namespace armsig::simulation
