// KUKA KRL programs (programs/krl.h): the input up to its first form feed is the .src, the
// rest its .dat; the whole input read as a $config.dat too.
#include "fuzz/fuzz_support.h"
#include "fuzz/program_fuzz_support.h"
#include "programs/krl.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace armsig;
  const std::string text(fuzz::Text(data, size));
  const std::size_t split = text.find('\f');
  programs::ProgramFile src{"fuzz.src", text.substr(0, split)};
  std::optional<programs::ProgramFile> dat;
  if (split != std::string::npos) dat = programs::ProgramFile{"fuzz.dat", text.substr(split + 1)};
  fuzz::ExpectOnlyInputErrors("krl $config.dat", [&] { (void)programs::ParseKrlConfigDat({"$config.dat", text}); });
  fuzz::ExpectOnlyInputErrors("krl", [&] {
    const auto program = programs::ParseKrl(src, dat);
    fuzz::CheckProgramRoundTrip("krl", program, [](const std::vector<programs::ProgramFile>& files) {
      return programs::ParseKrl(files[0], files.size() > 1 ? std::optional(files[1]) : std::nullopt);
    });
  });
  return 0;
}
