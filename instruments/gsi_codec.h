// Leica GSI-8 / GSI-16 word codec (pure). A word: WI (3, '.'-padded), two auxiliary
// characters, unit digit, sign, data (8 or 16 characters), a blank. GSI-16 blocks start
// with '*'. Blocks end with CR LF or CR alone.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace armsig::instruments::gsi {

struct Word {
  int wi = 0;       // word index: 11, 21, 22, 31, 531, …
  std::string aux;  // positions 4–5 (or 3–6 for WI 11/41: the block number)
  char unit = '.';  // position 6
  char sign = '+';
  std::string data;  // 8 or 16 characters
  bool gsi16 = false;
  int column = 0;  // 1-based position in its line (for messages)
};

struct Block {
  bool gsi16 = false;
  std::vector<Word> words;
  int line = 0;  // 1-based line of the block in the file
};

struct DecodeError {
  int line = 0, column = 0;
  std::string message;
};

// Parses a whole file; blocks are separated by CR LF, LF or CR. Returns the blocks, or
// the first error (line, column, what was expected).
struct FileResult {
  std::vector<Block> blocks;
  std::optional<DecodeError> error;
};
FileResult ParseFile(std::string_view text);
std::optional<Word> ParseWord(std::string_view text, bool gsi16, std::string* why = nullptr);

// Values. Angles: units 2 gon, 3 decimal degrees, 4 DDDMMSSs, 5 mil → rad.
// Lengths: units 0 (1 mm), 1 (1/1000 ft), 6 (0.1 mm), 7 (1/10000 ft), 8 (0.01 mm) → mm.
std::optional<double> AngleRad(const Word& word, std::string* why = nullptr);
std::optional<double> LengthMm(const Word& word, std::string* why = nullptr);
// Point or code id of WI 11/41 (leading zeros stripped).
std::string Identifier(const Word& word);
// Block number carried by WI 11/41 in positions 3–6, or nullopt.
std::optional<int> BlockNumber(const Word& word);

// Encoders for the simulator (GSI Online replies).
std::string EncodeAngleWord(int wi, double rad, bool gsi16, char unit = '2');
std::string EncodeLengthWord(int wi, double mm, bool gsi16, char unit = '0');
std::string EncodeTextWord(int wi, std::string_view text, bool gsi16);

}  // namespace armsig::instruments::gsi
