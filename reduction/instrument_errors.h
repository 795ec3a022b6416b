// Theodolite axis errors from two-face readings: collimation c (line of sight not
// perpendicular to the trunnion axis), trunnion-axis tilt i (not perpendicular to the
// standing axis) and vertical index error ζ. Model (V the true zenith angle):
//   face I:  Hz_I  = Hz + c / sin V + i · cot V            V_I  = V + ζ
//   face II: Hz_II = Hz + 200 gon − c / sin V − i · cot V  V_II = 400 gon − V + ζ
// Half the face difference isolates c / sin V + i · cot V and ζ; averaging faces
// cancels them; single-face readings are corrected with the estimated values.
#pragma once

#include <span>

#include "core/types.h"

namespace armsig::reduction {

inline constexpr double kMaxTwoFaceDisagreementRad = 1e-2;  // 0.64 gon, 2063"

struct InstrumentErrors {
  double collimation_rad = 0.0;
  double trunnion_rad = 0.0;
  double index_rad = 0.0;
  double sigma_collimation_rad = 0.0, sigma_trunnion_rad = 0.0, sigma_index_rad = 0.0;
  int pairs = 0;
  // Separating i from c needs pairs at different zenith angles (cot V must vary).
  bool trunnion_determined = false;
};

// The reading an instrument with `errors` shows for the true face-I direction `truth`,
// in face `face` (1 or 2). Used by simulators and tests.
AngleReading ApplyInstrumentErrors(const AngleReading& truth, int face,
                                   const InstrumentErrors& errors);

// The true face-I reading from an observed reading (any face).
AngleReading CorrectReading(const AngleReading& observed, const InstrumentErrors& errors);

struct TwoFacePair {
  AngleReading face1, face2;
};

// Least-squares estimate from pairs of the same target in both faces. sigma_*: a-priori
// sigma of one reading (for the reported precisions).
InstrumentErrors EstimateInstrumentErrors(std::span<const TwoFacePair> pairs, double sigma_hz_rad,
                                          double sigma_v_rad);

}  // namespace armsig::reduction

#include <map>
#include <string>
#include <vector>

#include "reduction/network.h"

namespace armsig::reduction {

// For every station with readings of the same point in both faces: estimate its axis
// errors and correct all its readings (to face I). Stations without pairs are left as
// they are. Returns the estimates by station id.
// A pair is one direction read in both faces only when the two readings agree within
// kMaxTwoFaceDisagreementRad (Hz − 200 gon and 400 gon − V; real axis errors are a few
// tens of arc seconds) and neither lies at the zenith or nadir (where Hz says nothing):
// other pairs are blunders or different directions and are not used, so that one bad
// reading cannot become an "instrument error" applied to every reading of its station.
std::map<std::string, InstrumentErrors> ReduceTwoFace(std::vector<Observation>& observations,
                                                      const InstrumentDefaults& defaults);

}  // namespace armsig::reduction
