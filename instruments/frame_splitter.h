// Splits a byte stream into binary packets by the size field at each packet's start (the
// whole packet's length, header included): Leica emScon TPI (int32, little-endian), Universal
// Robots RTDE (uint16, big-endian) and the UR primary/secondary interfaces (int32,
// big-endian); or by a size field further in that counts only the bytes after itself (a KUKA
// variable server: a uint16 tag, then the uint16 length of the rest). Several packets in one read and a packet split across reads both come out
// whole. Each byte is copied once and a consumed prefix is dropped in amortised linear time,
// so a flood costs linear time. Pure: no I/O.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace armsig::instruments {

class FrameSplitter {
 public:
  struct Format {
    int size_bytes = 4;       // 2 or 4
    bool big_endian = false;  // network order (UR) or little-endian (emScon)
    int64_t min_bytes = 0;    // the smallest and largest packet the protocol has
    int64_t max_bytes = 65536;
    int size_offset = 0;      // where the size field starts in the packet
    int size_adds = 0;        // bytes of the packet its size field does not count
  };
  enum class Status {
    kFrame,     // `frame` holds the next whole packet
    kNeedMore,  // no whole packet yet
    kBadSize,   // a packet size outside [min_bytes, max_bytes]: the stream has lost its
                // framing; everything buffered was dropped (`bad_size`: the packet size the
                // field announced, size_adds included)
  };
  explicit FrameSplitter(Format format) : format_(format) {}
  void Append(std::string_view bytes);
  Status Next(std::string& frame, int32_t* bad_size = nullptr);
  size_t buffered() const { return buffer_.size() - start_; }
  void Clear();
  const Format& format() const { return format_; }

 private:
  Format format_;
  std::string buffer_;
  size_t start_ = 0;  // bytes of buffer_ already handed out
};

}  // namespace armsig::instruments
