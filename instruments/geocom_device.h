// A Leica GeoCOM instrument (TPS1100/1200, TS/TM30, TDRA6000 …) over a line transport.
// One request in flight; every reply's transaction id is checked, stale replies and
// noise are discarded, busy codes and timeouts retried, a lost port reopened.
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

  // One RPC with the full retry policy. Returns the reply (rc may be a warning).
  geocom::Reply Call(int rpc, const std::vector<std::string>& params);

  struct Statistics {
    int requests = 0, retries = 0, stale_replies = 0, noise_lines = 0, crc_errors = 0,
        reconnects = 0, busy = 0;
  };
  const Statistics& statistics() const { return stats_; }

 private:
  int NextTransactionId();
  Reading ToReading(const geocom::Reply& reply, int hz_index, int v_index, int distance_index,
                    int face_index);

  std::unique_ptr<LineTransport> transport_;
  RetryPolicy policy_;
  bool use_crc_;
  int trid_ = 0;
  Statistics stats_;
};

}  // namespace armsig::instruments
