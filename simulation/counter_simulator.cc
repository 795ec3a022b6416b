#include "simulation/counter_simulator.h"

#include <cctype>

namespace armsig::simulation {

CounterSimulator::CounterSimulator(VirtualLab& lab, int joint,
                                   robots::EncoderCalibration calibration,
                                   std::string link_path, SimulatorOptions options)
    : LineSimulator(std::move(link_path), options),
      lab_(lab),
      joint_(joint),
      calibration_(std::move(calibration)) {}

std::optional<LineSimulator::Response> CounterSimulator::Handle(const std::string& line,
                                                                const FaultSpec& fault) {
  robots::CounterReading error;
  error.kind = 'e';
  const std::string error_reply = robots::FormatCounterReply(error);
  if (fault.fault == Fault::kErrorCode) return Response{error_reply, std::chrono::milliseconds(2)};
  const auto q = robots::ParseCounterRequest(line);
  if (!q || q->kind == 'S')
    return Response{error_reply, std::chrono::milliseconds(2)};  // no streaming
  robots::CounterReading r;
  r.kind = static_cast<char>(std::tolower(static_cast<unsigned char>(q->kind)));
  r.reg = q->reg;
  if (fault.fault == Fault::kOtherReply) {
    r.reg = 0x14;  // the version register
    r.value = 1;
  } else if (q->kind == 'R' && q->reg == 0x0E) {
    const Eigen::VectorXd counts = calibration_.ToCounts(lab_.Joints());
    r.value = static_cast<int64_t>(counts(joint_));
    if (fault.fault == Fault::kOutOfRange) r.value = 2147483647;  // the counter's limit
  }
  return Response{robots::FormatCounterReply(r), std::chrono::milliseconds(2)};
}

std::string CounterSimulator::FloodLine(const std::string&, int64_t k) {
  // Replies for another register (the stream-interval register), never the count.
  robots::CounterReading r;
  r.reg = 0x0C;
  r.value = k % 1000;
  return robots::FormatCounterReply(r);
}

}  // namespace armsig::simulation
