// The PUMA 760 of models/puma760.yaml, the UR10 of models/ur10.yaml, the KR 16-2 of
// models/kr16_2.yaml and the IRB 4600 of models/irb4600.yaml, built into the program so `armsig demo` and `armsig instrument
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

// The KUKA KR 16-2 of models/kr16_2.yaml: `armsig demo --robot kuka`'s nominal model.
inline constexpr const char* kKr16Yaml =
    R"yaml(# KUKA KR 16-2 (KR C4), nominal geometry (mm) from ROS-Industrial's kuka_experimental
# (kuka_kr16_support/urdf/kr16_2_macro.xacro, commit 0849a26: A1 at 675 mm, A2 260 mm out,
# upper arm 680 mm, forearm 670 mm with a 35 mm offset, flange 158 mm beyond the wrist), in
# KUKA's own joint convention, so that the model's joint angles are the controller's A1 … A6
# as $AXIS_ACT shows them, in degrees:
#
# - zero: the upper arm and the forearm stretched forward horizontally (the usual home
#   {A1 0, A2 -90, A3 90, A4 0, A5 0, A6 0} has the upper arm vertical, the forearm forward);
# - signs: A1 turns clockwise seen from above (about −z of $ROBROOT), A2, A3 and A5 about
#   +y (positive lowers the arm), A4 and A6 about −x at zero.
#
# Standard DH cannot give KUKA's A3 zero without a joint offset (its common normal with A4
# is vertical while the forearm points forward), and armsig's model has no offsets: the link
# transforms N2 … N6 are given whole instead. Each joint frame has z along its axis: joint 1's
# frame is $ROBROOT turned half a turn about x (its z points down), so `base` (N1, fitted by
# `auto`) maps that frame, and gravity in it is +z. The tool is a reflector (SMR) on the flange
# axis 100 mm beyond the flange; change tool_mm for yours (the flange centre is [0, 0, -158]).
# tests/calibration/kuka_model_test.cc checks this file against the URDF's chain.
name: kr16_2
base: auto
links:                # N2..N6, 4x4 row-major
  - [[1,0,0,260],[0,0,-1,0],[0,1,0,-675],[0,0,0,1]]
  - [[1,0,0,680],[0,1,0,0],[0,0,1,0],[0,0,0,1]]
  - [[0,0,-1,670],[-1,0,0,35],[0,1,0,0],[0,0,0,1]]
  - [[0,-1,0,0],[0,0,1,0],[-1,0,0,0],[0,0,0,1]]
  - [[0,0,-1,0],[-1,0,0,0],[0,1,0,0],[0,0,0,1]]
tool_mm: [0, 0, -258]
gravity: [0, 0, 1]    # in joint 1's frame, whose z points down
# KUKA's data sheet ranges (the URDF's limits): $SOFTN_END / $SOFTP_END are within them.
joint_limits_deg: [[-185, 185], [-155, 35], [-130, 154], [-350, 350], [-130, 130], [-350, 350]]
# Gravity bends the upper arm and the forearm: with KUKA's zero the moments on A2 and A3 go
# with cos A2 and cos(A2 + A3), as on the UR10 and the PUMA.
nongeometric:
  - {name: h1, joint: 2, basis: cos, of: [2, 3]}
  - {name: h2, joint: 2, basis: cos, of: [2]}
  - {name: h3, joint: 3, basis: cos, of: [2, 3]}
  - {name: h4, joint: 4, basis: cos, of: [2, 3, 4]}
generated_terms: [compliance, harmonics]
)yaml";

}  // namespace armsig::io
