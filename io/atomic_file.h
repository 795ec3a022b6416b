// Output files appear whole or not at all: written to a temporary file in the
// same directory, flushed, then renamed over the target.
#pragma once

#include <string>
#include <string_view>

namespace armsig::io {

// Throws std::runtime_error naming the path when it cannot be written.
void WriteFileAtomically(const std::string& path, std::string_view content);
// Reads a whole file; throws InputError naming the path when it cannot.
std::string ReadWholeFile(const std::string& path);

}  // namespace armsig::io
