#include "app/checked_stdout.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "core/text.h"

namespace armsig::app {

namespace {

constexpr std::size_t kBufferBytes = std::size_t{1} << 16;

}  // namespace

CheckedStdout::CheckedStdout(int fd) : fd_(fd), line_buffered_(::isatty(fd) == 1) {
  buffer_.reserve(kBufferBytes);
}

CheckedStdout::~CheckedStdout() { Flush(); }

void CheckedStdout::Lose(const char* s, std::size_t n) {
  failure_->lost += n;
  const std::size_t room = kKeptBytes - std::min(kKeptBytes, failure_->lost_text.size());
  failure_->lost_text.append(s, std::min(n, room));
}

void CheckedStdout::Flush() {
  std::size_t done = 0;
  while (!failure_ && done < buffer_.size()) {
    const ssize_t n = ::write(fd_, buffer_.data() + done, buffer_.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      failure_ = Failure{n < 0 ? std::strerror(errno) : "nothing written", written_, 0, {}};
      break;
    }
    done += static_cast<std::size_t>(n);
    written_ += static_cast<std::size_t>(n);
  }
  if (failure_ && done < buffer_.size()) Lose(buffer_.data() + done, buffer_.size() - done);
  buffer_.clear();
}

CheckedStdout::int_type CheckedStdout::overflow(int_type c) {
  if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
  const char ch = traits_type::to_char_type(c);
  xsputn(&ch, 1);
  return c;
}

std::streamsize CheckedStdout::xsputn(const char* s, std::streamsize n) {
  const auto size = static_cast<std::size_t>(n);
  if (failure_) {
    // Nothing more is written after a failure: what follows is kept for the message.
    Lose(s, size);
    return n;
  }
  buffer_.append(s, size);
  const bool line_done = line_buffered_ && std::memchr(s, '\n', size) != nullptr;
  if (buffer_.size() >= kBufferBytes || line_done) Flush();
  return n;
}

int CheckedStdout::sync() {
  Flush();
  return 0;  // a failure is kept and reported by Finish(), not by the stream's state
}

std::optional<CheckedStdout::Failure> CheckedStdout::Finish() {
  Flush();
  // close(2) reports what a network file system only learns when the file is closed.
  // EBADF: standard output was closed from the start; an error only if something was
  // printed (then the write above has failed already).
  if (::close(fd_) != 0 && errno != EBADF && errno != EINTR && !failure_) {
    failure_ = Failure{std::strerror(errno), written_, 0, {}};
  }
  const int null = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
  if (null >= 0 && null != fd_) {
    ::dup2(null, fd_);
    ::close(null);
  }
  return failure_;
}

std::string DescribeStdoutFailure(const CheckedStdout::Failure& failure, bool only_reads,
                                  int command_exit_code, const std::vector<std::string>& written) {
  std::string text = fmt::format("standard output: write failed ({})", failure.reason);
  if (failure.lost > 0) {
    text += fmt::format(" after {} of {} bytes: the output is incomplete", failure.written,
                        failure.written + failure.lost);
  }
  if (only_reads && written.empty()) {
    return text +
           ". The command only reads: nothing was stored or changed; run it again where "
           "the output has room";
  }
  if (only_reads) {
    // `iso9283 plan --out`, `import gsi --out`, …: the store unchanged, the files whole.
    std::string files;
    constexpr size_t kNamed = 3;  // a report's dozen figures: the first three and a count
    for (size_t k = 0; k < written.size() && k < kNamed; ++k)
      files += (k ? ", " : "") + Printable(written[k]);
    if (written.size() > kNamed) files += fmt::format(" and {} more files", written.size() - kNamed);
    text += fmt::format(
        ". The command changed nothing in the store and wrote {} whole (exit code {} but for "
        "this)",
        files, command_exit_code);
  } else {
    text += fmt::format(
        ". The command did its work (exit code {} but for this), and that stays done",
        command_exit_code);
  }
  // A short summary ("session 12: 40 poses … stored in lab.db") says what was done; a long
  // output (a table) is not repeated.
  const auto lines = std::count(failure.lost_text.begin(), failure.lost_text.end(), '\n');
  if (failure.lost > 0 && failure.lost <= 1000 && lines <= 8) {
    text += "; what it could not print:";
    std::string_view rest = failure.lost_text;
    while (!rest.empty()) {
      const std::size_t end = rest.find('\n');
      text += "\n" + Printable(rest.substr(0, end));  // the log indents it
      if (end == std::string_view::npos) break;
      rest.remove_prefix(end + 1);
    }
  }
  return text;
}

}  // namespace armsig::app
