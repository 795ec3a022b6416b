// An exclusive advisory lock on a file beside the database (flock): one holder at a
// time across processes. The OS releases it when the process ends, however it ends.
#pragma once

#include <string>

namespace armsig::io {

class FileLock {
 public:
  // Waits up to `wait_s` seconds for the lock; throws std::runtime_error naming the
  // path when it cannot be created or another holder keeps it longer.
  FileLock(const std::string& path, int wait_s);
  ~FileLock();
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;

 private:
  int fd_ = -1;
};

}  // namespace armsig::io
