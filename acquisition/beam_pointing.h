// Where a laser tracker points its beam before it measures a configuration: at the target
// position the robot model predicts for the configuration's joints (the nominal model, or
// the robot's active arm signature once it has one), mapped into the lab frame through the
// robot base. The base is the lab file's `robot: base:` when given; otherwise it is unknown
// at the start of a set-up, and the first configurations are measured where the tracker
// finds the reflector (FindReflector around the beam, else the operator points the beam
// at it). From 3 measured points not on one line on, the base is the rigid best fit
// (Umeyama, no scale) of the model's positions to the measured ones, refitted after every
// new point; it then replaces a base the lab file gave, which is only as good as whoever
// measured it.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "calibration/model.h"

namespace armsig::acquisition {

class TargetPredictor {
 public:
  struct Options {
    int min_points = 3;  // measured points before the base is fitted
    // How far the points must spread across their best line (√(σ₂² / N) of the centred
    // model positions), mm: three points almost on a line leave the rotation about it free.
    double min_spread_mm = 10.0;
  };

  // `params`: the model's parameters (zeros: nominal). `lab_base`: world from robot base as
  // the lab file gives it, if it does.
  TargetPredictor(const calibration::RobotModel& model, Eigen::VectorXd params,
                  std::optional<Eigen::Isometry3d> lab_base, Options options);
  TargetPredictor(const calibration::RobotModel& model, Eigen::VectorXd params,
                  std::optional<Eigen::Isometry3d> lab_base)
      : TargetPredictor(model, std::move(params), lab_base, Options{}) {}
  TargetPredictor(calibration::RobotModel&&, Eigen::VectorXd,
                  std::optional<Eigen::Isometry3d>) = delete;  // the model is referenced

  // A measured target (lab frame) at these joints; refits the base when it can.
  void Add(const Eigen::VectorXd& joints_rad, const Eigen::Vector3d& target_in_world);
  // The predicted target in the lab frame, when there is a base.
  std::optional<Eigen::Vector3d> Predict(const Eigen::VectorXd& joints_rad);

  int points() const { return static_cast<int>(measured_.size()); }
  bool fitted() const { return fitted_.has_value(); }
  const std::optional<Eigen::Isometry3d>& base() const { return base_; }
  // RMS distance of the measured points from the fitted model positions, mm.
  std::optional<double> fit_rms_mm() const { return fit_rms_mm_; }
  // Whether the measured points follow the robot: nullopt when they do, or when there are
  // too few to tell (no fitted base yet); otherwise what is wrong, for the operator. Two
  // findings: the measured points stay in one place while the model's spread over the work
  // volume (the reflector is not on the robot, or an instrument aims at a fixed point);
  // the best rigid base leaves more than `max_fit_rms_mm` (an uncalibrated robot misses by
  // millimetres: centimetres are a wrong tool offset, model, joint zero or unit).
  std::optional<std::string> FollowProblem(double max_fit_rms_mm) const;
  // "the lab file's base", "base fitted to 7 measured points (rms 0.84 mm)", "no base yet
  // (2 of 3 points measured)".
  std::string Describe() const;

 private:
  void Refit();

  const calibration::RobotModel& model_;
  Eigen::VectorXd params_;
  std::optional<Eigen::Isometry3d> lab_base_;
  Options options_;
  calibration::Kinematics kinematics_;
  std::vector<Eigen::Vector3d> model_positions_, measured_;  // robot base frame, lab frame
  std::optional<Eigen::Isometry3d> fitted_, base_;
  std::optional<double> fit_rms_mm_;
};

}  // namespace armsig::acquisition
