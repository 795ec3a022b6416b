// Output files appear whole or not at all: written to a temporary file in the
// same directory, flushed, then renamed over the target.
#pragma once

#include <string>
#include <string_view>

namespace armsig::io {

// Throws std::runtime_error naming the path when it cannot be written.
void WriteFileAtomically(const std::string& path, std::string_view content);
// Checks, before any work is stored, that `path` can be written later: its folder
// exists and is writable, and the path is not a folder. Throws InputError naming the
// option (e.g. "--json") and the path.
void CheckOutputFile(const std::string& path, const std::string& option);
// The same for a folder that will receive files: it exists and is writable, or it can be
// created (its parent exists and is writable).
void CheckOutputDirectory(const std::string& path, const std::string& option);

// Reads a whole file; throws InputError naming the path when it cannot.
std::string ReadWholeFile(const std::string& path);

}  // namespace armsig::io
