// URScript programs (programs/urscript.h).
#include "fuzz/fuzz_support.h"
#include "fuzz/program_fuzz_support.h"
#include "programs/urscript.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace armsig;
  fuzz::ExpectOnlyInputErrors("urscript", [&] {
    const auto program = programs::ParseUrScript({"fuzz.script", std::string(fuzz::Text(data, size))});
    fuzz::CheckProgramRoundTrip("urscript", program, [](const std::vector<programs::ProgramFile>& files) {
      return programs::ParseUrScript(files[0]);
    });
  });
  return 0;
}
