// KUKA KRL programs: a .src and the .dat beside it, after KUKA's "KUKA System Software 8.x
// — Operating and Programming Instructions for System Integrators" (KSS 8.3–8.7; the
// syntax of KRL, its inline forms and their data lists) and "Expert Programming" (KSS 5.x
// and 8.x). The whole language is read — ";" comments with ;FOLD … ;ENDFOLD (the inline
// forms' folds), "&" header lines, strings, DEF / DEFFCT / DEFDAT blocks with IF / FOR /
// WHILE / LOOP / REPEAT / SWITCH / SPLINE, declarations (DECL, GLOBAL, CONST, arrays),
// aggregates {X 1, …} — and its motion targets found:
//
//   PTP / LIN / CIRC (and SPTP / SLIN / SCIRC / SPL) with a target that is
//     an E6POS / POS / FRAME aggregate {X, Y, Z, A, B, C [, S, T]} (mm, deg: Rz(A)·Ry(B)·Rx(C)),
//       TCP in the base in use
//     an E6AXIS / AXIS aggregate {A1 … A6} (deg)
//     a variable holding one of them, declared in the .dat (an inline form's XP1) or the
//     .src with one value
//   the tool and base in use at each motion, followed in file order from $TOOL = … /
//   $BASE = …, BAS(#TOOL, n) / BAS(#BASE, n), an inline form's FDAT (TOOL_NO, BASE_NO,
//   applied by BAS(#PTP_PARAMS | #CP_PARAMS | #FRAMES …)) and a motion's WITH $TOOL = …;
//   TOOL_DATA[n] and BASE_DATA[n] from the robot's $config.dat when it is given. BASE 0 and
//   $WORLD are the robot's base: the robot stands at $ROBROOT = $WORLD.
//
// Named, never guessed: relative motions (PTP_REL …), a partial aggregate ({X 10}: the rest
// comes from the robot's position at run time), $POS_ACT and other system variables, the
// geometric operator (A:B), a variable given a value in more than one place, a parameter.
#pragma once

#include <map>
#include <optional>

#include "programs/program.h"

namespace armsig::programs {

// The frames a KRL program names by number: TOOL_DATA[n] and BASE_DATA[n] of the robot's
// $config.dat (KRC:\R1\System\$config.dat), mm.
struct KrlControllerData {
  std::map<int, Eigen::Isometry3d> tools, bases;
  std::string source;  // the file they came from
};

// Reads TOOL_DATA[n] = {X …} and BASE_DATA[n] = {X …} of a $config.dat (KRL data-list syntax).
KrlControllerData ParseKrlConfigDat(const ProgramFile& config_dat);

// The .src (files[0]) and its .dat (files[1], when given). Throws InputError (file, line,
// column) for what is not KRL: a string or aggregate that never ends, blocks that do not
// close (DEF without END, IF without ENDIF, …).
Program ParseKrl(ProgramFile src, std::optional<ProgramFile> dat,
                 const KrlControllerData* controller = nullptr);

}  // namespace armsig::programs
