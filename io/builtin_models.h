// The PUMA 760 of models/puma760.yaml, built into the program so `armsig demo` and
// `armsig instrument simulate` run anywhere (tests check it matches the file).
#pragma once

namespace armsig::io {

inline constexpr const char* kPuma760Yaml =
    R"yaml(# Unimation PUMA 760, after Chen & Chao, "Positioning Error Analysis for Robot
# Manipulators with All Rotary Joints": nominal link transforms N2…N6 (mm), null
# configuration with links 2 and 3 stretched horizontally (upper arm 650 mm,
# forearm 550 mm), target on the joint-6 axis at the flange (paper eq. 16).
name: puma760
base: auto            # N1: rigid best fit of the nominal positions to the measurements
links:                # N2..N6, 4x4 row-major
  - [[1,0,0,0],[0,0,-1,164],[0,1,0,0],[0,0,0,1]]
  - [[1,0,0,650],[0,1,0,0],[0,0,1,50],[0,0,0,1]]
  - [[0,0,1,550],[0,1,0,0],[-1,0,0,0],[0,0,0,1]]
  - [[0,0,-1,0],[0,1,0,0],[1,0,0,50],[0,0,0,1]]
  - [[0,0,1,125],[0,1,0,0],[-1,0,0,0],[0,0,0,1]]
tool_mm: [0, 0, 0]    # x̄, nominal target point in the last link frame
nongeometric:         # paper eq. (6)-(7): joint 2 and 3 twist under gravity, joint 3 backlash
  - {name: h1, joint: 2, basis: cos, of: [2, 3]}
  - {name: h2, joint: 2, basis: cos, of: [2]}
  - {name: h3, joint: 3, basis: cos, of: [2, 3]}
  - {name: h4, joint: 3, basis: sign_cos, of: [2, 3]}
)yaml";

}  // namespace armsig::io
