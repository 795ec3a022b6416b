// Internal to acquisition/ (session.cc): one instrument's reading in a capture and what
// it becomes: the observation the capture reduces, the row it stores, the instrument's row.
#pragma once

#include <optional>

#include "db/observations.h"
#include "instruments/device.h"
#include "io/lab_file.h"
#include "reduction/observation.h"

namespace armsig::acquisition {

struct StationReading {
  instruments::Reading reading;
  int instrument = 0;
  int round = 0;  // which round of readings (repeat or face) it came from
};

// The instrument stated usable sigmas (positive and finite) with the reading.
bool UsableSigmas(const std::optional<instruments::ReadingSigmas>& s);

// A reading of the capture's target as an observation: with the sigmas the instrument
// stated with it (a laser tracker), else its configured ones.
reduction::Observation TargetObservation(const StationReading& r, const io::InstrumentConfig& c);

// A reading as stored: the observation with the instrument's own record of it (when its
// answer arrived, its warning, its return code, the air at it) and the instrument's id.
db::ObservationRow StoredReading(const StationReading& r, const io::InstrumentConfig& c,
                                 int64_t pose, int64_t instrument_id);

// An instrument as the instruments table records it: named by its model and serial number
// when it gave them (the same instrument on another port or station is the same row), else
// by its protocol and port.
db::InstrumentRow InstrumentRowOf(const io::InstrumentConfig& c,
                                  const instruments::DeviceInfo& who);

}  // namespace armsig::acquisition
