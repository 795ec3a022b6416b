// Stations YAML (orient's output, triangulate's and the lab file's input).
#include "fuzz/fuzz_support.h"
#include "io/network_files.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace armsig;
  fuzz::ExpectOnlyInputErrors("stations yaml", [&] {
    (void)io::ParseStationsYaml(std::string(fuzz::Text(data, size)), "fuzz-stations.yaml");
  });
  return 0;
}
