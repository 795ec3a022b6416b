// The PUMA 760 of models/puma760.yaml, the UR10 of models/ur10.yaml and the IRB 4600 of
// models/irb4600.yaml, built into the program so `armsig demo` and `armsig instrument
// simulate` run anywhere (tests check they match the files).
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

// The UR10 of models/ur10.yaml: `armsig demo --robot ur10`'s nominal model.
inline constexpr const char* kUr10Yaml =
    R"yaml(# Universal Robots UR10 (CB-series), nominal DH from Universal Robots (mm, deg), in UR's
# joint-zero convention. The tool is the IPA T-Mac probe centre of the laser-tracker
# data set (../shared/data/ur10-ipa, series_*-Trafo_TM_F_init.txt): 109.0 mm along the
# flange axis (the file gives the flange in the probe frame; its inverse puts the probe
# at (0.00, 0.00, 109.00) mm in the flange frame).
name: ur10
base: auto
dh:                   # one row per joint: N(i+1) = Tz(d)·Tx(a)·Rx(alpha); last row folded into x̄
  - {d_mm: 127.3,   a_mm: 0,      alpha_deg: 90}
  - {d_mm: 0,       a_mm: -612.0, alpha_deg: 0}
  - {d_mm: 0,       a_mm: -572.3, alpha_deg: 0}
  - {d_mm: 163.941, a_mm: 0,      alpha_deg: 90}
  - {d_mm: 115.7,   a_mm: 0,      alpha_deg: -90}
  - {d_mm: 92.2,    a_mm: 0,      alpha_deg: 0}
tool_mm: [0, 0, 109.0]
joint_limits_deg: [[-360, 360], [-360, 360], [-360, 360], [-360, 360], [-360, 360], [-360, 360]]
# Gravity-induced joint deflection, the paper's eq. (6)-(7) idea on the UR10: at UR joint
# zero the upper arm and forearm are horizontal, so the gravity moments on joints 2 and 3
# go with cos q2 and cos(q2+q3). `--params auto` decides by F-test whether they matter.
nongeometric:
  - {name: h1, joint: 2, basis: cos, of: [2, 3]}
  - {name: h2, joint: 2, basis: cos, of: [2]}
  - {name: h3, joint: 3, basis: cos, of: [2, 3]}
  - {name: h4, joint: 4, basis: cos, of: [2, 3, 4]}
# Terms generated from the nominal geometry (issue 13), after h1…h4: joint compliance under
# the gravity torque of unit masses at the following joints' frames (k2_3 … k5_7, rad per
# unit-mass metre of torque; base z is up unless `gravity: [x, y, z]` says otherwise) and
# each joint's transmission harmonics (e1_s1 e1_c1 e1_s2 e1_c2 … e5_c2, rad). Terms that
# cannot move the probe are not generated (joint 1's vertical axis carries no gravity
# torque; joint 6 turns the probe about itself). `--params auto` keeps those that pass an
# F-test and lower the cross-validated error.
generated_terms: [compliance, harmonics]
)yaml";

// The IRB 4600-40/2.55 of models/irb4600.yaml: `armsig demo --robot abb`'s nominal model.
inline constexpr const char* kIrb4600Yaml =
    R"yaml(# ABB IRB 4600-40/2.55, nominal geometry (mm) in ABB's own joint zero: the upper arm upright,
# the forearm horizontal and forward, the flange facing forward (+x of the base) at
# (1580, 0, 1765) mm. Axis directions and the joint zero are the controller's, so the angles
# an IRC5 or OmniCore reports (jointtarget, degrees) are this model's joints. Dimensions from
# ABB's data sheet as ROS-Industrial's abb_irb4600_support gives them
# (urdf/irb4600_40_255_macro.xacro): base to axis 2 495 up and 175 forward, upper arm 1095,
# axis 3 to the wrist axis 175, forearm 1270, wrist to flange 135.
#
# In the standard DH form with joint offsets θ (A_i = Rz(q_i + θ_i)·Tz(d_i)·Tx(a_i)·Rx(α_i)):
#   joint  d_mm   a_mm   alpha_deg  theta_deg
#     1     495    175     -90          0
#     2       0   1095       0        -90     (the upper arm is upright at ABB's zero)
#     3       0    175     -90          0
#     4    1270      0      90          0
#     5       0      0     -90          0
#     6     135      0       0          0
# armsig's model has no joint offsets (docs/reference/conventions.md), so the rows are given
# as the link transforms they make: N(i+1) = Rz(θ_i)·Tz(d_i)·Tx(a_i)·Rx(α_i), and row 6 folded
# into the target point.
#
# The target point is a tracker reflector (SMR) in a nest 40 mm above the flange axis and
# 100 mm beyond the flange: (40, 0, 135 + 100) mm in the last link's frame (z along the
# flange axis, x upright at the joint zero). Off the axis, so that joint 6 moves it.
name: irb4600-40-2.55  # the controller calls it IRB 4600-40/2.55
base: auto
links:                # N2..N6, 4x4 row-major
  - [[1,0,0,175],[0,0,1,0],[0,-1,0,495],[0,0,0,1]]
  - [[0,1,0,0],[-1,0,0,-1095],[0,0,1,0],[0,0,0,1]]
  - [[1,0,0,175],[0,0,1,0],[0,-1,0,0],[0,0,0,1]]
  - [[1,0,0,0],[0,0,-1,0],[0,1,0,1270],[0,0,0,1]]
  - [[1,0,0,0],[0,0,1,0],[0,-1,0,0],[0,0,0,1]]
tool_mm: [40, 0, 235]
# Working ranges from the same data sheet (axis 2: +150/−90, axis 3: +75/−180 …).
joint_limits_deg: [[-180, 180], [-90, 150], [-180, 75], [-400, 400], [-125, 120], [-400, 400]]
# Joint compliance under gravity and each joint's transmission harmonics, generated from the
# nominal geometry (docs/explanation/residual-map.md); `--params auto` keeps what the data
# support.
generated_terms: [compliance, harmonics]
)yaml";

}  // namespace armsig::io
