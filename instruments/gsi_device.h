// A GSI Online theodolite (TPS100…1100, Wild T2000 class) over a line transport.
#pragma once

#include <memory>

#include "instruments/device.h"
#include "instruments/gsi_codec.h"
#include "instruments/transport.h"

namespace armsig::instruments {

// GET/M/WI21 triggers a measurement and returns Hz, GET/I/WI22 the V of the same
// measurement, GET/M/WI31 a distance. No transaction ids: each reply's word index must
// be the one asked for (other words are skipped, against the deadline), and after a
// timeout the line is drained before the next request. The requests of one device call
// share its deadline (RetryPolicy::timeout); a reply line is at most
// gsi::kMaxOnlineLineBytes. Angles and distances outside what an instrument can report
// are refused (ReadingRangeError).
class GsiOnlineDevice : public DistanceInstrument {
 public:
  GsiOnlineDevice(std::unique_ptr<LineTransport> transport, RetryPolicy policy = {});
  const std::string& name() const override { return transport_->name(); }
  DeviceInfo Identify() override;
  Reading MeasureAngles() override;
  Reading MeasureDistanceAndAngles() override;
  int Face() override;               // from V (> 200 gon = face II)
  void ChangeFace() override;        // not in GSI Online: InstrumentError
  bool CompensatorOn() override;     // not in GSI Online: InstrumentError
  gsi::Word Get(char mode, int wi);  // GET/<mode>/WI<wi> with retries
  gsi::Word Get(char mode, int wi, Deadline deadline);
  void SetInterrupt(const std::atomic<bool>* flag) override { transport_->SetInterrupt(flag); }

 private:
  std::unique_ptr<LineTransport> transport_;
  RetryPolicy policy_;
};

}  // namespace armsig::instruments
