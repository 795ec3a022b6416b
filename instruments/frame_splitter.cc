#include "instruments/frame_splitter.h"

namespace armsig::instruments {

void FrameSplitter::Append(std::string_view bytes) {
  // Drop the consumed prefix once it is at least half the buffer: amortised linear.
  if (start_ > 0 && start_ >= buffer_.size() / 2) {
    buffer_.erase(0, start_);
    start_ = 0;
  }
  buffer_.append(bytes.data(), bytes.size());
}

void FrameSplitter::Clear() {
  buffer_.clear();
  start_ = 0;
}

FrameSplitter::Status FrameSplitter::Next(std::string& frame, int32_t* bad_size) {
  // The size field alone decides: a read can end inside a header.
  const size_t field = static_cast<size_t>(format_.size_bytes);
  const size_t at = start_ + static_cast<size_t>(format_.size_offset);
  if (buffered() < static_cast<size_t>(format_.size_offset) + field) return Status::kNeedMore;
  uint32_t raw = 0;
  for (size_t k = 0; k < field; ++k) {
    const auto byte = static_cast<uint8_t>(buffer_[at + (format_.big_endian ? k : field - 1 - k)]);
    raw = (raw << 8) | byte;
  }
  // A 4-byte field is signed (int32); a 2-byte one unsigned (uint16).
  const int64_t size =
      (field == 4 ? static_cast<int64_t>(static_cast<int32_t>(raw)) : raw) + format_.size_adds;
  if (size < format_.min_bytes || size > format_.max_bytes) {
    if (bad_size) *bad_size = static_cast<int32_t>(size);
    Clear();
    return Status::kBadSize;
  }
  if (buffered() < static_cast<size_t>(size)) return Status::kNeedMore;
  frame.assign(buffer_, start_, static_cast<size_t>(size));
  start_ += static_cast<size_t>(size);
  if (start_ == buffer_.size()) Clear();
  return Status::kFrame;
}

}  // namespace armsig::instruments
