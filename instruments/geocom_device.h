// A Leica GeoCOM instrument (TPS1100/1200, TS/TM30, TDRA6000 …) over a line transport.
// One request in flight; every reply's transaction id is checked, stale replies and
// noise are discarded, busy codes and timeouts retried, a lost port reopened, all by the
// call's deadline (RetryPolicy::timeout). Lines are at most geocom::kMaxLineBytes; with
// CRCs a reply without one is refused. Angles and distances outside what an instrument
// can report are refused (ReadingRangeError).
#pragma once

#include <memory>

#include "instruments/device.h"
#include "instruments/geocom_codec.h"
#include "instruments/transport.h"

namespace armsig::instruments {

class GeoComDevice : public DistanceInstrument {
 public:
  GeoComDevice(std::unique_ptr<LineTransport> transport, RetryPolicy policy = {},
               bool use_crc = false);

  const std::string& name() const override { return transport_->name(); }
  DeviceInfo Identify() override;
  Reading MeasureAngles() override;             // TMC_GetAngle1 (complete, with face)
  Reading MeasureAnglesSimple();                // TMC_GetAngle5
  Reading MeasureDistanceAndAngles() override;  // TMC_DoMeasure + TMC_GetSimpleMea
  int Face() override;
  void ChangeFace() override;
  bool CompensatorOn() override;
  void FineAdjust(double search_hz_rad, double search_v_rad);
  void PositionTo(double hz_rad, double v_rad, bool atr);

  // One RPC with the full retry policy, by now + policy.timeout or by `deadline`.
  // Returns the reply (rc may be a warning); throws InstrumentError.
  geocom::Reply Call(int rpc, const std::vector<std::string>& params);
  geocom::Reply Call(int rpc, const std::vector<std::string>& params, Deadline deadline);

  void SetInterrupt(const std::atomic<bool>* flag) override { transport_->SetInterrupt(flag); }

  struct Statistics {
    int requests = 0, retries = 0, stale_replies = 0, noise_lines = 0, crc_errors = 0,
        reconnects = 0, busy = 0, long_lines = 0;
  };
  const Statistics& statistics() const { return stats_; }

 private:
  int NextTransactionId();
  Deadline CallDeadline() const { return Clock::now() + policy_.timeout; }
  // A return code without data (not ok, not a warning with data): InstrumentError.
  void ThrowIfNoData(const geocom::Reply& reply) const;
  // A reading stamped now, with the reply's return code and its note.
  Reading StartReading(const geocom::Reply& reply) const;

  std::unique_ptr<LineTransport> transport_;
  RetryPolicy policy_;
  bool use_crc_;
  int trid_ = 0;
  Statistics stats_;
};

}  // namespace armsig::instruments
