// armsig demo: the whole chain on a virtual lab. A PUMA 760 with hidden true errors (the
// paper's Table 3, h1…h4 included), three theodolites speaking GeoCOM and a
// Kawasaki-AS-style controller on pseudo-terminals, all through the real drivers: the
// stations are oriented from mutual pointings and a scale bar, the configurations are
// captured into the database, reduced, and the best-spread ones calibrated with the
// paper's three parameter sets, validated on the others. `--robot ur10`: a UR10 with hidden
// geometric and joint-angle errors, its virtual controller on loopback TCP (RTDE, primary
// and secondary interfaces, dashboard) and a laser tracker (demo/demo_robots.h).
#pragma once

#include <atomic>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "acquisition/session.h"
#include "calibration/model.h"
#include "reduction/orientation.h"
#include "workflows/calibration_run.h"

namespace armsig::demo {

struct DemoOptions {
  std::string db_path;
  // "theodolites" (three GeoCOM theodolites on pseudo-terminals, oriented by mutual
  // pointings and a scale bar) or "tracker" (one virtual laser tracker speaking emScon on
  // loopback TCP; its frame is the lab frame, so no orientation). A resumed session keeps
  // the instruments it was captured with.
  std::string instrument;  // empty: theodolites for a new demo
  std::string json_path;     // --json: written at the end (checked by the command line)
  int configurations = 200;  // captured
  int select = 0;            // fitted (D-optimal), the rest validate; 0 = 40 % (80 of 200)
  // The virtual robot (demo/demo_robots.h): puma (the default), ur10; a resumed
  // session keeps its own.
  std::string robot;
  // Multiplies every simulated latency and move time; unset: the robot's own (PUMA 0.25,
  // UR10 0.02: its moves take the real arm's time).
  std::optional<double> time_scale;
  // The virtual robot's own repeatability (mm per axis): every move lands this far off at
  // random, apart from the instruments' noise (simulation::VirtualLab::SetRepeatability).
  double repeatability_mm = 0.0;
  // The virtual lab's noise and plan. Unset: 1985 plus the demo sessions already in the
  // database, so a first demo repeats the README's figures and every further run on one
  // database measures anew (the same data night after night is no lab's).
  std::optional<unsigned> seed;
  // Continue this stopped demo session (its stored plan; `configurations` is ignored):
  // capture what is missing, then reduce and calibrate.
  int64_t resume_session = 0;
  // Serve the virtual lab instead of running the chain: its devices stay up in this
  // folder (pseudo-terminals, the tracker's TCP port) with the lab file, stations file and
  // model a technician would write (a tracker lab's `robot: base:` as if measured by hand,
  // 3 mm and 1 mrad off, so the beam is pointed from the first configuration), until
  // `serve_seconds` pass (0: until stopped). Nothing is captured and no database is opened:
  // `armsig capture --lab DIR/lab.yaml` drives it by hand.
  std::string serve_dir;
  double serve_seconds = 0.0;
  // Changes planted in the virtual robot's truth (`--change joint2_zero=0.02deg`,
  // ParsePlantedChanges), to rehearse what the nightly job does when a robot changes.
  std::vector<std::string> changes;
  // Another day's set-up (`--setup N`): the instruments set up anew at their N-th place (0:
  // the first day's), so the robot's base lies elsewhere in their frame (the lab's); the
  // robot and its errors stay, the noise is drawn anew. To use a set fitted on one day's
  // set-up on another's, as a lab does.
  int setup = 0;
  // --on-the-move (ur10): the UR sweeps well-spread waypoints without stopping while the
  // tracker measures continuously on a clock `clock_offset_ms` and `clock_drift_ppm` off the
  // controller's (unset: drawn from the seed); the clock is estimated from the data, the
  // paired points calibrated (the D-optimal selection on the swept stream), validated on the
  // sweep's held-out segments; `waypoints` well-spread configurations are swept through.
  bool on_the_move = false;
  int waypoints = 60;
  std::optional<double> clock_offset_ms, clock_drift_ppm;
  // Ctrl-C: stop at the next safe point (between configurations, between stages).
  const std::atomic<bool>* stop = nullptr;
};

// The change of every parameter that `changes` plant: each NAME=VALUE, NAME a parameter of
// the model (gamma2, a3, h1, …) or jointN_zero (= gammaN) or linkN_length (link N, from
// joint N to joint N+1, longer along its nominal direction), VALUE a number with its unit:
// mm or um for a length, deg, mrad, urad or rad for an angle. InputError naming --change
// and what was expected otherwise.
Eigen::VectorXd ParsePlantedChanges(const calibration::RobotModel& model,
                                    const std::vector<std::string>& changes);

// How few configurations the demo's calibration can use, from the model: the fit needs
// more equations (3 per configuration) than the model has identifiable parameters
// (all 43 candidates, rank on configurations spread over the joint limits), and the
// validation set is at least as large as that smallest fit.
struct DemoLimits {
  int identifiable = 0;        // identifiable parameters of the built-in PUMA 760
  int min_fit = 0;             // identifiable / 3 + 1
  int min_validation = 0;      // = min_fit
  int min_configurations = 0;  // min_fit + min_validation
};
DemoLimits DemoLimitsOf(const calibration::RobotModel& model, unsigned seed);

// The configurations to fit for `configurations` captured ones: `select`, or 40 % when 0,
// within [min_fit, configurations − min_validation]. Throws InputError (naming
// --configurations or --select and the limit) when that range is empty or `select` is
// outside it.
int DemoSelectCount(int configurations, int select, const DemoLimits& limits);

struct DemoObserver {
  std::function<void(const std::string&)> say;  // the narrative, one block at a time
  std::function<void(const acquisition::Progress&)> progress;
};

struct DemoResult {
  int64_t session = 0;     // 0 when stopped before the session was created
  bool completed = false;  // false when stopped before the end (the session is paused)
  double seconds = 0.0;
  nlohmann::json json;      // the --json document (also written to json_path)
  std::string resume_hint;  // when stopped after the session was created
};

// The narrative's parts that carry figures, each line at most 100 columns.
// Step 1 for theodolites: the readings, σ0, degrees of freedom, blunders removed, and each
// station's position and azimuth with their sigmas.
std::string DemoOrientationText(const reduction::OrientationProblem& setup,
                                const reduction::OrientationResult& oriented);
// Step 2: the configurations captured (those left out named), their timing, the miss
// distance (theodolites) or how the beam was pointed (a tracker).
std::string DemoCaptureText(const acquisition::CaptureSummary& captured, bool tracker);
// The closing table: nominal and each stage's fit and validation mean (max), against the
// paper's when `paper` (the PUMA), and the measurement noise floor.
std::string DemoProgressionText(const std::vector<workflows::CalibrationRun>& runs, double noise_floor_mm,
                                bool paper = true);

// Checks the options (DemoSelectCount) before anything is created. The virtual lab lives
// in a private directory under $TMPDIR (armsig-demo-XXXXXX, holding its owner's pid),
// removed on every way out but a hard kill; the next demo removes those whose owner is
// gone.
DemoResult RunDemo(const DemoOptions& options, const DemoObserver& observer);

}  // namespace armsig::demo
