// Angle observations CSV (point, station, hz, v with units, optional distance and face).
#include "fuzz/fuzz_support.h"
#include "io/network_files.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace armsig;
  const std::string path = fuzz::InputFile(fuzz::Text(data, size), "-observations.csv");
  fuzz::ExpectOnlyInputErrors("observations", [&] { (void)io::ReadObservationsCsv(path); });
  fuzz::ExpectOnlyInputErrors("control", [&] { (void)io::ReadControlCsv(path); });
  return 0;
}
