// The declarations of a RAPID module, read from its text (ABB, "Technical reference manual -
// RAPID Overview" and "RAPID Instructions, Functions and Data types": a module is MODULE name
// … ENDMODULE; its data are [LOCAL] PERS | VAR | CONST type name[{dim}] [:= value];
// comments run from ! to the end of the line; routines are PROC / FUNC / TRAP … END…).
// Enough to know what a module such as controllers/abb/ArmsigServer.mod declares: the
// virtual controller (simulation/rws_simulator.h) takes its RAPID data from it, and a test
// checks the driver's symbol names against it.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace armsig::simulation {

struct RapidData {
  std::string storage;  // PERS, VAR or CONST
  std::string type;     // num, dnum, jointtarget …
  std::string name;
  int elements = 0;     // 0: a scalar; N: an array {N}
  std::string initial;  // the value text after :=, "" when none
  int line = 0;
};

struct RapidModule {
  std::string name;
  std::vector<RapidData> data;       // module-level declarations, in order
  std::vector<std::string> routines;  // PROC, FUNC and TRAP names
  const RapidData* Find(std::string_view name) const;  // case-insensitive, as RAPID
};

// A datum's value text as the controller keeps it: num components as single-precision floats
// (9 significant digits), dnum with 15; robots::rws::DecodeError for text that is not a
// value of its type, or a type the virtual controller does not keep.
std::string CanonicalValue(const RapidData& datum, const std::string& text);

// Throws InputError (`source`, line) for text that is not a module this reader knows.
RapidModule ParseRapidModule(std::string_view text, const std::string& source);

// The module shipped with armsig (controllers/abb/ArmsigServer.mod), as it was when armsig
// was built.
std::string_view ShippedAbbModule();

}  // namespace armsig::simulation
