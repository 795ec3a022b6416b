// The CSV reader every table goes through: dialect detection, quoting, numbers and angle
// columns with units.
#include "fuzz/fuzz_support.h"
#include "io/csv.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace armsig;
  fuzz::ExpectOnlyInputErrors("csv", [&] {
    const io::CsvTable table = io::ParseCsv(fuzz::Text(data, size), "fuzz.csv");
    for (const auto& base : {"hz", "v", "q1"}) {
      if (const auto column = table.FindAngleColumn(base)) {
        for (const auto& row : table.rows()) (void)table.AngleRad(row, *column);
      }
    }
    for (const auto& row : table.rows()) {
      for (int c = 0; c < static_cast<int>(table.header().size()); ++c) {
        (void)table.OptionalNumber(row, c);
      }
    }
  });
  return 0;
}
