// ABB RAPID modules (.mod, .modx, and the same text in a .sys), after ABB's "Technical
// reference manual — RAPID Instructions, Functions and Data types" (RobotWare 6.x and 7.x)
// and "RAPID overview": the whole language is read — "!" comments, strings, the %%% header,
// MODULE / PROC / FUNC / TRAP / RECORD blocks with IF / FOR / WHILE / TEST, data
// declarations (LOCAL / TASK, CONST / PERS / VAR, arrays {n}), statements that continue over
// lines up to their ";", optional arguments (\WObj:=…) — and its motion targets found:
//
//   MoveJ / MoveL / MoveC (and their DO / Sync / AO / GO forms, TriggJ / TriggL / TriggC)
//     with a robtarget [[x,y,z],[q1,q2,q3,q4],[cf1,cf4,cf6,cfx],[eax…]] (mm; the TCP of the
//     tool in the work object, quaternion w x y z, the configuration), and MoveAbsJ with a
//     jointtarget [[rax_1…rax_6],[eax…]] (deg); each a literal, a data declaration with one
//     value (CONST, PERS, VAR) or an element of an array declared with its values;
//   the tool (a tooldata of the module or tool0) and the work object (\WObj:=, a wobjdata of
//   the module, else wobj0): the TCP is the tool's tframe, the target's frame the work
//   object's uframe · oframe in the world, which is the robot's base.
//
// Named, never guessed: Offs(…), RelTool(…), CRobT(…) and other computed targets, data given a
// value in more than one place or changed component by component, a routine's parameter, a
// tool or work object declared in another module, a stationary tool (robhold FALSE) or a
// work object the robot holds or a mechanical unit moves.
#pragma once

#include "programs/program.h"

namespace armsig::programs {

// Throws InputError (file, line, column) for what is not RAPID: a string that never ends, a
// block that does not close (MODULE without ENDMODULE, PROC without ENDPROC, IF … THEN
// without ENDIF, …).
Program ParseRapid(ProgramFile module);

}  // namespace armsig::programs
