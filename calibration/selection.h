// Selection of well-spread configurations by an observability criterion on the
// identification Jacobian: D-optimality (max log det of the scaled information
// matrix), greedy forward selection followed by exchange passes (Wynn/Fedorov).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "calibration/model.h"
#include "core/stop_token.h"

namespace armsig::calibration {

struct SelectionOptions {
  int count = 80;           // configurations to keep
  int exchange_passes = 2;  // 0 = greedy only; none when keeping more than half
  // Regularisation of the start (scaled units): keeps the greedy step well defined
  // before the selected set reaches full rank.
  double ridge = 1e-6;
  core::StopToken stop;  // looked at before every step: a request throws core::Stopped
  void Check(int candidates) const;
};

struct SelectionResult {
  std::vector<int> selected;      // indices into the candidates, ascending
  double log_det = 0.0;           // log det(JᵀJ) of the selected set, scaled columns
  double condition_number = 0.0;  // of the selected scaled Jacobian
  double o1 = 0.0;                // Borm & Menq O1: (σ1…σL)^(1/L) / √m
  int exchanges = 0;              // swaps made by the exchange passes
};

// Observability figures of a set of configurations (same scaling as the selection).
struct Observability {
  double log_det = 0.0, condition_number = 0.0, o1 = 0.0;
};

// `parameters`: the identifiable subset to make observable (indices of the model).
// `frames`: the measurement frame of every candidate (MeasuredPose::frame), or empty for
// one frame. With several, the criterion includes the six base unknowns of every frame but
// the latest (as calibration::Estimate fits them), so each frame keeps the configurations
// that place it (at least three) along with those that make the parameters observable.
SelectionResult SelectConfigurations(const RobotModel& model,
                                     const std::vector<Eigen::VectorXd>& candidates_rad,
                                     const std::vector<int>& parameters,
                                     const SelectionOptions& options,
                                     const std::vector<int64_t>& frames = {});

Observability MeasureObservability(const RobotModel& model,
                                   const std::vector<Eigen::VectorXd>& configurations_rad,
                                   const std::vector<int>& parameters,
                                   const Eigen::VectorXd& column_scale);

// Column scale used by the selection: RMS norm of each parameter's column over the set.
Eigen::VectorXd ColumnScale(const RobotModel& model,
                            const std::vector<Eigen::VectorXd>& configurations_rad,
                            const std::vector<int>& parameters);

}  // namespace armsig::calibration
