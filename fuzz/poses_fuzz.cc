// The poses CSV (pose, q1_deg…q6_deg, x_mm, y_mm, z_mm; docs/reference/file-formats.md).
#include "fuzz/fuzz_support.h"
#include "io/poses_csv.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace armsig;
  const std::string path = fuzz::InputFile(fuzz::Text(data, size), "-poses.csv");
  fuzz::ExpectOnlyInputErrors("poses", [&] { (void)io::ReadPosesCsv(path, 6); });
  return 0;
}
