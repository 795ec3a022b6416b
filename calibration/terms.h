// Physical non-geometric terms generated from the nominal model, beside the paper's
// h1…h4. Both families add to the true angle of
// one joint, like the paper's eq. (6)–(7), so they share its Jacobian (∂x/∂θ_joint · f),
// its identifiability analysis and its F-tests:
//
//  - compliance `k{i}_{j}` (rad): joint i yields to the gravity torque of a lumped unit
//    mass at the origin of joint j's frame (j = i+1 … n; j = n+1 is the target point),
//    computed on the nominal geometry at the encoder angles, gravity along the model's
//    `gravity_in_base` (base z up by default). One stiffness-like coefficient per mass:
//    Δθ_i = k_ij · τ_ij, τ counted in unit-mass metres (a pure number), so k_ij is the
//    deflection in rad under a unit mass one metre out. Motors sit at the joints, so
//    masses lumped at the joint origins are the usual first model of an arm's weight.
//  - transmission harmonics `e{i}_s1 e{i}_c1 e{i}_s2 e{i}_c2` (rad): sin/cos of joint i's
//    own encoder angle, first and second order (eccentric gears and encoders, the
//    twice-per-turn error of strain-wave gears).
//
// Terms that cannot move the target on this model are not generated: a joint whose axis
// passes through the target (UR10 joint 6 with its on-axis probe), a gravity torque that
// is identically zero (a vertical joint-1 axis, a mass on the joint's own axis), or a mass
// whose torque equals an earlier mass's for the same joint (exact duplicates). Every other
// dependency is left to the data's identifiability analysis.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "calibration/model.h"

namespace armsig::calibration {

// "compliance" | "harmonics" (the names model files and --params lists use).
std::optional<TermFamily> TermFamilyFromName(std::string_view name);
const char* TermFamilyName(TermFamily family);

// The family's terms for this model, in joint order (see the header comment).
std::vector<NongeometricTerm> GenerateTerms(const RobotModel& model, TermFamily family);

// The model with the families' terms appended after its own non-geometric terms. A family
// already present (e.g. read back from an exported model) is not added twice. Throws
// std::invalid_argument when a generated name is taken by a different term.
RobotModel WithGeneratedTerms(const RobotModel& model, const std::vector<TermFamily>& families);

// The generated families a --params list names ("geometric,compliance,h2" → compliance),
// so that a caller can add them (WithGeneratedTerms) before ParseParameterSpec.
std::vector<TermFamily> FamiliesNamedIn(const std::string& spec);

}  // namespace armsig::calibration
