// URScript programs (.script), after Universal Robots' "The URScript Programming Language"
// (Script Manual, e-Series SW 5.11 and CB-series SW 3.15): the whole language is read —
// comments (#), strings, def / thread / sec blocks with if / elif / else / while / for /
// end, global and local variables, bracketed expressions across lines, PolyScope's "$ n"
// markers and PolyScope X's struct waypoints — and its motion targets found:
//
//   movej / movel / movep / movec / optimovej / optimovel with a target that is
//     p[x, y, z, rx, ry, rz]        a pose (m, rotation vector) of the TCP in the base frame
//     [q1, …, qn]                   joint positions (rad)
//     a variable holding one of them (global or local, assigned once), a struct waypoint's
//     field (Home.p, Home.q), or get_inverse_kin(pose, qnear=joints) (the pose, its
//     configuration from qnear)
//   set_tcp(p[…]) sets the TCP of the motions after it in the file (the flange before any).
//
// A target written any other way (pose_trans(…), a variable assigned twice or from a
// computation, a function's parameter) is named with its line and why, never guessed.
#pragma once

#include "programs/program.h"

namespace armsig::programs {

// Throws InputError (file, line, column) for what is not URScript at all: a string that
// never ends, a block never closed by `end`, an `end` without a block.
Program ParseUrScript(ProgramFile file);

}  // namespace armsig::programs
