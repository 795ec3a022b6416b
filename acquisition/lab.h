// The devices a lab file names, opened: its instruments (GeoCOM, GSI Online, emScon) and its
// robot controller or encoder box, with the lab's retry policy. The file itself is read and
// written by io/lab_file.h.
#pragma once

#include <memory>
#include <vector>

#include "instruments/device.h"
#include "io/lab_file.h"

namespace armsig::acquisition {

// Opens the devices the configuration names. The one-device forms serve `armsig
// instrument`: a malformed HOST:PORT is an InputError naming it.
std::unique_ptr<instruments::DistanceInstrument> OpenInstrument(
    const io::InstrumentConfig& config, const instruments::RetryPolicy& policy);
std::unique_ptr<instruments::RobotController> OpenController(
    const io::ControllerConfig& config, const instruments::RetryPolicy& policy);
std::vector<std::unique_ptr<instruments::DistanceInstrument>> OpenInstruments(
    const io::LabConfig& lab);
std::unique_ptr<instruments::RobotController> OpenController(const io::LabConfig& lab);

}  // namespace armsig::acquisition
