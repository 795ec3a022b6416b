// A lab database with rows in every table a reading command shows (robots, sessions, poses,
// points, observations, station set-ups, one not levelled, parameter sets with drift
// decisions, activations, jobs with results), made the way a lab makes it: simulated
// sessions stored as a capture stores them, then armsig's own commands (import
// observations, reduce, recalibrate twice, schedule, worker). Made once per test program
// and copied for each test (MakeLabDatabase is slow, about ten seconds).
#pragma once

#include <string>

namespace armsig::testing {

struct LabDatabase {
  std::string path;                             // the copy: lab.db in the caller's folder
  std::string joints_csv;                       // a predict input for robot puma
  std::string targets_csv;                      // a compensate input for robot puma
  std::string poses_csv;                        // a calibrate input for the PUMA model
  std::string stations_yaml, observations_csv;  // the imported session's files
  std::string model_yaml;                       // models/puma760.yaml
  int64_t simulated_session = 0;                // a session of poses and reduced points
  int64_t observed_session = 0;                 // the imported session (stations, observations)
};

// Copies the lab database (made at the first call) into `folder` as lab.db, with the input
// files beside it.
LabDatabase CopyLabDatabase(const std::string& folder);

}  // namespace armsig::testing
