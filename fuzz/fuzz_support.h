// Shared by the libFuzzer targets: a reader may refuse an input only with InputError
// (what a user sees as exit 2, naming file, line and column); any other exception, a
// crash, a leak or undefined behaviour is a finding.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <string>
#include <string_view>

#include "core/error.h"

namespace armsig::fuzz {

inline std::string_view Text(const uint8_t* data, size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

// Runs `read`; returns quietly when it succeeds or refuses with InputError.
template <typename F>
void ExpectOnlyInputErrors(const char* target, F&& read) {
  try {
    read();
  } catch (const InputError&) {
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: a reader threw something else than InputError: %s\n", target,
                 e.what());
    std::abort();
  }
}

// For readers that take a path: the input in a per-process file under /dev/shm (or
// $TMPDIR), rewritten for each input.
inline std::string InputFile(std::string_view content, const char* suffix) {
  const char* dir = std::getenv("ARMSIG_FUZZ_DIR");
  const std::string path = std::string(dir ? dir : "/dev/shm") + "/armsig-fuzz-" +
                           std::to_string(::getpid()) + suffix;
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(content.data(), content.size());
  return path;
}

}  // namespace armsig::fuzz
