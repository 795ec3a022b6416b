// Standard output checked to the last byte. Every command prints through std::cout, and
// Main puts this stream buffer under it: it writes with write(2), keeps the first error
// with its errno and how many bytes had reached the output, stops writing after it (a
// hole in the middle of a CSV would be worse than an end cut short), and keeps what could
// not be written (up to kKeptBytes) so that the message can repeat a lost summary line.
// Finish() flushes, closes the descriptor (a file system that reports a full disk only
// at close, NFS, is caught too) and says what went wrong, naming the output.
#pragma once

#include <cstddef>
#include <optional>
#include <streambuf>
#include <string>
#include <vector>

namespace armsig::app {

class CheckedStdout final : public std::streambuf {
 public:
  // What could not be written is kept up to this many bytes, for the message.
  static constexpr std::size_t kKeptBytes = 4096;

  explicit CheckedStdout(int fd);
  ~CheckedStdout() override;
  CheckedStdout(const CheckedStdout&) = delete;
  CheckedStdout& operator=(const CheckedStdout&) = delete;

  struct Failure {
    std::string reason;     // strerror of the failed write or close
    std::size_t written;    // bytes that reached the output
    std::size_t lost;       // bytes that did not
    std::string lost_text;  // the first kKeptBytes of them
  };
  // Writes what is buffered, then closes the descriptor and puts /dev/null in its place
  // (nothing later can write into a descriptor the process opens next). nullopt when
  // every byte was written.
  std::optional<Failure> Finish();
  bool failed() const { return failure_.has_value(); }

 protected:
  int_type overflow(int_type c) override;
  std::streamsize xsputn(const char* s, std::streamsize n) override;
  int sync() override;

 private:
  void Flush();
  void Lose(const char* s, std::size_t n);

  int fd_;
  bool line_buffered_;
  std::string buffer_;
  std::size_t written_ = 0;
  std::optional<Failure> failure_;
};

// The message for a failed standard output: "standard output: write failed (No space left
// on device) after 1234 of 1290 bytes: the output is incomplete", then what the command did:
// "The command only reads: nothing was stored or changed", or, for a command that stores or
// wrote files (`written`: io::CommittedFiles()), that its work stays done and the summary it
// could not print (when that is short).
std::string DescribeStdoutFailure(const CheckedStdout::Failure& failure, bool only_reads,
                                  int command_exit_code,
                                  const std::vector<std::string>& written = {});

}  // namespace armsig::app
