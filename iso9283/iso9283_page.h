// The ISO 9283 certificate page: one self-contained HTML file (figures drawn with OpenCV,
// embedded as PNG, no JavaScript, the A4 print stylesheet of report/figures.h): the test
// cube, the five points' scatter, the figures table, the conditions, and with an arm
// signature the figures it predicts, the figures attained with compensation and its
// held-out validation over the work volume.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "calibration/iso9283_cube.h"
#include "iso9283/iso9283.h"

namespace armsig::iso9283 {

// One measured test (a session) on the page.
struct Iso9283PageTest {
  std::string title;  // "Nominal program (session 4)"
  int64_t session = 0;
  std::string started_at;
  const Iso9283Evaluation* figures = nullptr;
  // With a signature: the AP it predicts for this session's joints (per point of
  // `figures`, robot frame); empty without one.
  std::vector<Eigen::Vector3d> predicted_ap_mm;
};

struct Iso9283PageSignature {
  int version = 0;
  std::string params_spec;
  int validation_poses = 0;
  double validation_mean_mm = NAN, validation_max_mm = NAN;
};

struct Iso9283PageInput {
  std::string generated_at;  // "" = now
  std::string armsig_version;
  std::string robot, model;
  std::optional<calibration::iso9283::TestCube> cube;  // from the commanded P1…P5
  Iso9283PageTest test;                                // the test (nominal program)
  std::optional<Iso9283PageTest> compensated;          // the same test with compensation
  std::optional<Iso9283PageSignature> signature;
  // Conditions, as stated or measured.
  std::optional<double> load_kg, speed_percent;
  std::string temperature;  // "20.7 °C (20.6–20.9) at the tracker", "" = not measured
  std::vector<std::string> instruments;  // one line each, with its stated uncertainty
  std::string point_precision;           // "mean 3-D σ of a measured point 0.018 mm"
  // Judged against stated limits (--limit): the decisive test's verdict (the compensated
  // one when there is one), and each test's checks.
  std::optional<Iso9283Verdict> verdict, compensated_verdict;
};

// Writes DIR/index.html and its PNGs; returns the HTML path. Throws on I/O failure.
std::string WriteIso9283Page(const std::string& dir, const Iso9283PageInput& input);

// The cube behind ISO test points named P1…P5 (P1 its centre, |P2 − P4| = 0.8 √3 · edge),
// when they are there and fit one (the other points within 1 µm per metre of edge);
// nullopt otherwise (data from elsewhere with other names).
std::optional<calibration::iso9283::TestCube> CubeOfTestPoints(const Iso9283Evaluation& e);

}  // namespace armsig::iso9283
