// Leica GSI-8 / GSI-16 word codec and GSI Online messages (pure: text ⇄ values, no I/O).
// A word: WI (3, '.'-padded), two auxiliary characters, unit digit, sign, data (8 or 16
// characters), a blank. GSI-16 blocks start with '*'. Blocks end with CR LF or CR alone.
// Every layout has a parser and a formatter: ParseWord ⇄ FormatWord, ParseFile ⇄
// FormatFile, AngleRad ⇄ AngleWord, LengthMm ⇄ LengthWord, Identifier ⇄ TextWord,
// ParseOnlineRequest ⇄ FormatOnlineRequest, ParseOnlineReply ⇄ FormatOnlineReply.
// Parse failures are values (nullopt and `why`: the position or field and what was
// expected); formatting a value that does not fit its word throws std::out_of_range.
#pragma once

#include <cstddef>
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
  int column = 0;  // 1-based position in its line (for messages; 0 when not from a file)
  bool operator==(const Word&) const = default;
};

struct Block {
  bool gsi16 = false;
  std::vector<Word> words;
  int line = 0;  // 1-based line of the block in the file
  bool operator==(const Block&) const = default;
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
// Blocks as lines ending in CR LF; a GSI-16 block starts with '*'.
std::string FormatFile(const std::vector<Block>& blocks);
std::string FormatBlock(const Block& block);  // without the line end

std::optional<Word> ParseWord(std::string_view text, bool gsi16, std::string* why = nullptr);
// The 16 (GSI-8) or 24 (GSI-16) characters of the word, its trailing blank included.
// Throws std::invalid_argument when the word's fields do not have their layout's widths.
std::string FormatWord(const Word& word);

// Values. Angles: units 2 gon, 3 decimal degrees, 4 DDDMMSSs, 5 mil → rad.
// Lengths: units 0 (1 mm), 1 (1/1000 ft), 6 (0.1 mm), 7 (1/10000 ft), 8 (0.01 mm) → mm.
std::optional<double> AngleRad(const Word& word, std::string* why = nullptr);
std::optional<double> LengthMm(const Word& word, std::string* why = nullptr);
// Point or code id of WI 11/41 (leading zeros stripped).
std::string Identifier(const Word& word);
// Block number carried by WI 11/41 in positions 3–6, or nullopt.
std::optional<int> BlockNumber(const Word& word);

// Value → word, rounded to the unit's last digit; the sign is the value's. Throws
// std::invalid_argument for a unit that is not an angle (length) unit and
// std::out_of_range when the value needs more digits than the word has.
Word AngleWord(int wi, double rad, bool gsi16, char unit = '2');
Word LengthWord(int wi, double mm, bool gsi16, char unit = '0');
// An identifier word (right-aligned, zero-filled; WI 11/41 carry block number 0001).
Word TextWord(int wi, std::string_view text, bool gsi16);

// --- GSI Online (TPS100…1100): one command per line, no transaction ids ------------

// The longest GSI Online reply line a driver accepts: a reply is one word ('*' and 24
// characters for GSI-16), "?" or "@E<code>"; 256 leaves room for a whole block.
inline constexpr size_t kMaxOnlineLineBytes = 256;

struct OnlineRequest {
  enum class Kind { kGet, kSet };
  Kind kind = Kind::kGet;
  char mode = 'I';  // GET/<mode>/WI<wi>: I instantly, M measure first, C continuous
  int wi = 0;
  int param = 0, value = 0;  // SET/<param>/<value>, e.g. SET/137/1 = GSI-16
  bool operator==(const OnlineRequest&) const = default;
};
std::string FormatOnlineRequest(const OnlineRequest& request);  // ends with CR LF
std::optional<OnlineRequest> ParseOnlineRequest(std::string_view line, std::string* why = nullptr);

struct OnlineReply {
  enum class Kind { kWord, kAck, kWarning, kError };  // word, "?", "@W<code>", "@E<code>"
  Kind kind = Kind::kWord;
  Word word;     // kWord (a GSI-16 word is sent with a leading '*')
  int code = 0;  // kWarning, kError
  bool operator==(const OnlineReply&) const = default;
};
std::string FormatOnlineReply(const OnlineReply& reply);  // ends with CR LF
// One reply line (terminator stripped). nullopt and `why` for anything else (noise).
std::optional<OnlineReply> ParseOnlineReply(std::string_view line, std::string* why = nullptr);
// "@E139" / "@W427" / "?" / the word, for messages.
std::string Describe(const OnlineReply& reply);

}  // namespace armsig::instruments::gsi
