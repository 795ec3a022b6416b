#include "reduction/instrument_errors.h"

#include <Eigen/Dense>
#include <cmath>

#include "core/units.h"
#include "reduction/observation.h"

namespace armsig::reduction {

namespace {
// c / sin V + i · cot V: the horizontal effect of collimation and trunnion errors.
double HorizontalEffect(double v, const InstrumentErrors& e) {
  return e.collimation_rad / std::sin(v) + e.trunnion_rad * std::cos(v) / std::sin(v);
}
}  // namespace

AngleReading ApplyInstrumentErrors(const AngleReading& truth, int face,
                                   const InstrumentErrors& errors) {
  const double effect = HorizontalEffect(truth.v_rad, errors);
  if (face == 1) {
    return {WrapTwoPi(truth.hz_rad + effect), truth.v_rad + errors.index_rad, 1};
  }
  return {WrapTwoPi(truth.hz_rad + kPi - effect), 2.0 * kPi - truth.v_rad + errors.index_rad, 2};
}

AngleReading CorrectReading(const AngleReading& observed, const InstrumentErrors& errors) {
  if (observed.face == 2) {
    const double v = 2.0 * kPi - (observed.v_rad - errors.index_rad);
    return {WrapTwoPi(observed.hz_rad - kPi + HorizontalEffect(v, errors)), v, 1};
  }
  const double v = observed.v_rad - errors.index_rad;
  return {WrapTwoPi(observed.hz_rad - HorizontalEffect(v, errors)), v, 1};
}

InstrumentErrors EstimateInstrumentErrors(std::span<const TwoFacePair> pairs, double sigma_hz_rad,
                                          double sigma_v_rad) {
  InstrumentErrors e;
  const int n = static_cast<int>(pairs.size());
  e.pairs = n;
  if (n == 0) return e;
  // Index: (V_I + V_II − 400 gon) / 2 per pair, averaged.
  double index_sum = 0.0;
  Eigen::MatrixXd a(n, 2);
  Eigen::VectorXd b(n);
  for (int k = 0; k < n; ++k) {
    const auto& p = pairs[k];
    index_sum += 0.5 * (p.face1.v_rad + p.face2.v_rad - 2.0 * kPi);
    const double v = 0.5 * (p.face1.v_rad + (2.0 * kPi - p.face2.v_rad));  // index cancels
    a(k, 0) = 1.0 / std::sin(v);
    a(k, 1) = std::cos(v) / std::sin(v);
    b(k) = 0.5 * WrapPi(p.face1.hz_rad - (p.face2.hz_rad - kPi));
  }
  e.index_rad = index_sum / n;
  e.sigma_index_rad = sigma_v_rad / std::sqrt(2.0 * n);  // each half-sum has σ/√2
  // Trunnion error is separable only if cot V varies across the pairs.
  double min_cot = a(0, 1), max_cot = a(0, 1);
  for (int k = 1; k < n; ++k) {
    min_cot = std::min(min_cot, a(k, 1));
    max_cot = std::max(max_cot, a(k, 1));
  }
  e.trunnion_determined = n >= 2 && (max_cot - min_cot) > 0.05;  // ≈ 3 gon of spread in V
  const double s = sigma_hz_rad / std::sqrt(2.0);                // σ of half a face difference
  if (e.trunnion_determined) {
    const Eigen::Matrix2d normal = a.transpose() * a;
    const Eigen::Vector2d x = normal.ldlt().solve(a.transpose() * b);
    const Eigen::Matrix2d q = normal.inverse();
    e.collimation_rad = x(0);
    e.trunnion_rad = x(1);
    e.sigma_collimation_rad = s * std::sqrt(q(0, 0));
    e.sigma_trunnion_rad = s * std::sqrt(q(1, 1));
  } else {
    const Eigen::VectorXd col = a.col(0);
    e.collimation_rad = col.dot(b) / col.squaredNorm();
    e.sigma_collimation_rad = s / col.norm();
  }
  return e;
}

}  // namespace armsig::reduction

namespace armsig::reduction {

std::map<std::string, InstrumentErrors> ReduceTwoFace(std::vector<Observation>& observations,
                                                      const InstrumentDefaults& defaults) {
  // (station, point) → first face-I and face-II reading.
  std::map<std::pair<std::string, std::string>, std::pair<int, int>> faces;
  for (size_t k = 0; k < observations.size(); ++k) {
    const auto& o = observations[k];
    auto& slot = faces[{o.station, o.point}];
    if (slot.first == 0 && slot.second == 0) slot = {-1, -1};
    if (o.reading.face == 1 && slot.first < 0) slot.first = static_cast<int>(k);
    if (o.reading.face == 2 && slot.second < 0) slot.second = static_cast<int>(k);
  }
  std::map<std::string, std::vector<TwoFacePair>> pairs;
  std::map<std::string, EffectiveSigmas> sigmas;
  for (const auto& [key, slot] : faces) {
    if (slot.first < 0 || slot.second < 0) continue;
    const auto& o1 = observations[slot.first];
    const AngleReading& face1 = o1.reading;
    const AngleReading& face2 = observations[slot.second].reading;
    const bool agree =
        std::abs(WrapPi(face1.hz_rad - (face2.hz_rad - kPi))) <= 2 * kMaxTwoFaceDisagreementRad &&
        std::abs(face1.v_rad + face2.v_rad - 2.0 * kPi) <= 2 * kMaxTwoFaceDisagreementRad;
    if (!agree || NearPole(face1.v_rad) || NearPole(face2.v_rad)) continue;
    pairs[key.first].push_back({face1, face2});
    sigmas[key.first] = SigmasOf(o1, nullptr, defaults);
  }
  std::map<std::string, InstrumentErrors> out;
  for (const auto& [station, list] : pairs) {
    out[station] = EstimateInstrumentErrors(list, sigmas[station].hz_rad, sigmas[station].v_rad);
  }
  for (auto& o : observations) {
    if (auto it = out.find(o.station); it != out.end())
      o.reading = CorrectReading(o.reading, it->second);
  }
  return out;
}

}  // namespace armsig::reduction
