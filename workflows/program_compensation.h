// armsig compensate --program: a robot program read (URScript .script, KUKA .src with its
// .dat, ABB .mod / .modx), its targets compensated with a stored parameter set
// (programs/compensation.h), the program written again with only those numbers changed, a
// report per target on stdout and as JSON. The files at the edge; the work in programs/.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calibration/validity.h"
#include "db/database.h"
#include "programs/compensation.h"
#include "programs/program.h"
#include "programs/volume.h"
#include "workflows/signature.h"

namespace armsig::workflows {

struct ProgramCompensationOptions {
  std::string robot;
  std::optional<int> set;     // --set N (default: the active set)
  std::string program_path;   // --program
  std::string out_path;       // --out
  bool allow_outside = false;
  // KUKA: the robot's $config.dat (TOOL_DATA, BASE_DATA). UR: the controller's own
  // kinematics (KinematicsInfo's dh_theta, dh_a, dh_d, dh_alpha as YAML).
  std::string config_dat, controller_kinematics;
};

struct ProgramCompensationRun {
  programs::Program program;
  programs::ControllerModel controller;
  programs::ProgramCompensation result;
  int version = 0;                     // the parameter set used
  bool orientation_measured = false;   // the set was fitted to measured orientations
  // The set's model's tool mounting: with kFitted each target says its lever from the
  // calibration point to the TCP and what an unknown flange turn costs there.
  calibration::ToolMounting tool_mounting = calibration::ToolMounting::kFitted;
  std::string volume;                  // where the validated volume came from ("" none)
  calibration::SetValidity validity;   // the set's support and held-out σ (empty: not stored)
  std::vector<std::string> written;    // the files written (none when refused)
};

// The language of a program from its file name (.script, .src, .mod, .modx; any case);
// InputError naming --program otherwise.
programs::Language LanguageOfProgram(const std::string& path);

// Where the set `active` was validated: its joint arcs and the volume of the points its
// sessions measured (robot frame); nullopt for a set without sessions. `description` gets
// what it is made of ("the joint arcs stored with the set; the points of session 1: …").
std::optional<programs::ValidatedVolume> ValidatedVolumeOf(db::Database& database,
                                                           const ActiveSignature& active,
                                                           std::string* description = nullptr);

// Reads, parses, compensates and (unless refused) writes OUT and, for KRL, OUT's .dat.
// Throws InputError for what cannot be read or parsed, OutputError when a file cannot be
// written (then neither file of a KRL pair is changed).
ProgramCompensationRun CompensateProgramFiles(db::Database& database,
                                              const ProgramCompensationOptions& options);

// The per-target table for people (mm and degrees).
std::string FormatProgramCompensation(const ProgramCompensationRun& run);
// {"program","language","robot","set","controller","orientation","written","volume",
//  "sigma_inside_mm","sigma_outside_mm",
//  "targets":[{"line","file","name","kind","correction_mm","correction_rad","status","why",
//  "motions","residual_mm","inside_support","support","sigma_mm","map","nominal_joints_rad",
//  "compensated_joints_rad"}…],
//  "not_evaluated":[{"file","line","why"}…], "notes":[…]}
nlohmann::json ProgramCompensationJson(const ProgramCompensationRun& run, const std::string& robot);

}  // namespace armsig::workflows
