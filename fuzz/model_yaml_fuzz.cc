// Robot model YAML (DH rows, tool, limits, h-terms).
#include "fuzz/fuzz_support.h"
#include "io/model_yaml.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace armsig;
  fuzz::ExpectOnlyInputErrors("model yaml", [&] {
    (void)io::ParseRobotModel(std::string(fuzz::Text(data, size)), "fuzz-model.yaml");
  });
  return 0;
}
