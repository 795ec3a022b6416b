// Leica GSI files to angle observations (`armsig import gsi`, docs/reference/file-formats.md):
// word 11 point, 21 Hz, 22 V, 31 slope distance, every unit the format defines.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "reduction/network.h"

namespace armsig::io {

struct GsiImport {
  std::vector<reduction::Observation> observations;
  int blocks = 0;
  int skipped_blocks = 0;  // blocks without Hz and V (coordinates, codes, levelling)
};

// Throws InputError naming the file, line and column of a malformed word, a point number
// that is no name, a circle reading or a distance outside core/plausibility.h's rules (the
// same the observations CSV and the drivers apply; a distance of 0 is GSI's "none").
GsiImport ImportGsi(const std::string& path, const std::string& station);
// The same on text already read; `source` names it in messages.
GsiImport ParseGsiImport(std::string_view text, const std::string& source,
                         const std::string& station);

// The angle observations CSV (the interface reference, docs/reference/file-formats.md), with
// the sigma columns when a reading carries its own.
std::string FormatObservationsCsv(const std::vector<reduction::Observation>& observations);

}  // namespace armsig::io
