// ABB RAPID modules (programs/rapid.h).
#include "fuzz/fuzz_support.h"
#include "fuzz/program_fuzz_support.h"
#include "programs/rapid.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace armsig;
  fuzz::ExpectOnlyInputErrors("rapid", [&] {
    const auto program = programs::ParseRapid({"fuzz.mod", std::string(fuzz::Text(data, size))});
    fuzz::CheckProgramRoundTrip("rapid", program, [](const std::vector<programs::ProgramFile>& files) {
      return programs::ParseRapid(files[0]);
    });
  });
  return 0;
}
