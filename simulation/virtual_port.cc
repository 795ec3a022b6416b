#include "simulation/virtual_port.h"

#include <fcntl.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace armsig::simulation {

VirtualPort::VirtualPort(std::string link_path) : link_path_(std::move(link_path)) { Create(); }

VirtualPort::~VirtualPort() { Disappear(); }

void VirtualPort::Create() {
  int master = -1, slave = -1;
  char name[256] = {};
  if (::openpty(&master, &slave, name, nullptr, nullptr) != 0) {
    throw std::runtime_error(std::string("openpty failed: ") + std::strerror(errno));
  }
  termios tio{};
  ::tcgetattr(slave, &tio);
  ::cfmakeraw(&tio);
  ::tcsetattr(slave, TCSANOW, &tio);
  ::fcntl(master, F_SETFD, FD_CLOEXEC);
  ::fcntl(slave, F_SETFD, FD_CLOEXEC);
  ::unlink(link_path_.c_str());
  if (::symlink(name, link_path_.c_str()) != 0) {
    ::close(master);
    ::close(slave);
    throw std::runtime_error("cannot create " + link_path_ + ": " + std::strerror(errno));
  }
  master_ = master;
  slave_keepalive_ = slave;
}

void VirtualPort::Disappear() {
  if (master_ < 0) return;
  ::unlink(link_path_.c_str());
  ::close(slave_keepalive_);
  ::close(master_);
  master_ = -1;
  slave_keepalive_ = -1;
}

void VirtualPort::Reappear() {
  if (master_ >= 0) return;
  Create();
}

}  // namespace armsig::simulation
