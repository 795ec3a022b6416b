// Leica GSI-8/16: data files (codec and `import gsi`) and online replies.
#include <sstream>

#include "fuzz/fuzz_support.h"
#include "instruments/gsi_codec.h"
#include "io/gsi_import.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace armsig;
  const std::string_view text = fuzz::Text(data, size);
  fuzz::ExpectOnlyInputErrors("gsi codec", [&] {
    const auto file = instruments::gsi::ParseFile(text);
    for (const auto& block : file.blocks) {
      for (const auto& word : block.words) {
        (void)instruments::gsi::AngleRad(word);
        (void)instruments::gsi::LengthMm(word);
        (void)instruments::gsi::Identifier(word);
        (void)instruments::gsi::BlockNumber(word);
      }
    }
    std::istringstream lines{std::string(text)};
    for (std::string line; std::getline(lines, line);) {
      (void)instruments::gsi::ParseOnlineReply(line);
      (void)instruments::gsi::ParseOnlineRequest(line);
    }
  });
  // `import gsi` on the text itself: no file written per input (ImportGsi only adds the read).
  fuzz::ExpectOnlyInputErrors("import gsi",
                              [&] { (void)io::ParseGsiImport(text, "fuzz.gsi", "S1"); });
  return 0;
}
