// FNV-1a, 64 bits: a stable fingerprint of bytes, the same in every build and on every
// machine (a digest of measured poses, a lock file's name cut to the system's limit).
#pragma once

#include <cstdint>
#include <string_view>

namespace armsig::core {

inline constexpr uint64_t kFnv1a64Offset = 0xcbf29ce484222325ULL;

// `hash` carried on over `bytes` (start from kFnv1a64Offset).
inline uint64_t Fnv1a64(std::string_view bytes, uint64_t hash = kFnv1a64Offset) {
  for (unsigned char c : bytes) {
    hash ^= c;
    hash *= 0x100000001b3ULL;
  }
  return hash;
}

}  // namespace armsig::core
