// The lab file (robot, instruments, stations, tolerances, recalibration gates). Paths
// inside it are resolved but nothing is opened beyond files.
#include "acquisition/lab.h"
#include "fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace armsig;
  const std::string text(fuzz::Text(data, size));
  fuzz::ExpectOnlyInputErrors("lab yaml", [&] { (void)io::ParseLab(text, "fuzz-lab.yaml"); });
  fuzz::ExpectOnlyInputErrors("lab settings",
                              [&] { (void)io::ParseLabSettings(text, "fuzz-lab.yaml"); });
  return 0;
}
