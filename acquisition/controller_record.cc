#include "acquisition/controller_record.h"

#include <fmt/format.h>

#include <cctype>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/text.h"
#include "db/store.h"

namespace armsig::acquisition {

db::ControllerRecord ControllerFacts::Record() const {
  db::ControllerRecord r;
  if (identity) {
    r.model = identity->model;
    r.serial = identity->serial;
    r.software = identity->software;
    r.kinematics_checksum = identity->kinematics_checksum;
  }
  if (kinematics) {
    r.kinematics_checksum = kinematics->checksum;
    r.kinematics_json = KinematicsJson(*kinematics);
  }
  return r;
}

std::string ControllerFacts::Describe() const {
  if (!identity) return "a controller that does not say who it is";
  const auto& i = *identity;
  std::string text = i.model.empty() ? std::string("a controller") : Printable(i.model);
  if (!i.serial.empty()) text += " serial " + Printable(i.serial);
  if (!i.software.empty()) text += ", " + Printable(i.software);
  const std::string& checksum = kinematics ? kinematics->checksum : i.kinematics_checksum;
  if (!checksum.empty()) text += " (kinematics " + Printable(checksum) + ")";
  return text;
}

ControllerFacts AskController(instruments::RobotController& controller) {
  ControllerFacts facts;
  facts.identity = controller.Identify();
  if (facts.identity) facts.kinematics = controller.Kinematics();
  return facts;
}

std::string KinematicsJson(const instruments::ControllerKinematics& k) {
  const nlohmann::json j = {{"checksum", k.checksum},
                            {"dh_theta_rad", k.dh_theta_rad},
                            {"dh_a_mm", k.dh_a_mm},
                            {"dh_d_mm", k.dh_d_mm},
                            {"dh_alpha_rad", k.dh_alpha_rad},
                            {"calibration_status", k.calibration_status},
                            {"calibration_state", k.calibration_state}};
  return JsonText(j);
}

instruments::ControllerKinematics KinematicsFromJson(const std::string& text,
                                                     const db::JsonCell& cell) {
  return db::ReadStoredJson(text, cell, [&](const nlohmann::json& j) {
    if (!j.is_object()) db::RefuseStoredJson(cell, "expected the controller's kinematics object");
    instruments::ControllerKinematics k;
    k.checksum = j.at("checksum").get<std::string>();
    k.dh_theta_rad = j.at("dh_theta_rad").get<std::vector<double>>();
    k.dh_a_mm = j.at("dh_a_mm").get<std::vector<double>>();
    k.dh_d_mm = j.at("dh_d_mm").get<std::vector<double>>();
    k.dh_alpha_rad = j.at("dh_alpha_rad").get<std::vector<double>>();
    k.calibration_status = j.at("calibration_status").get<int>();
    k.calibration_state = j.value("calibration_state", std::string());
    return k;
  });
}

namespace {

std::string Normalised(const std::string& name) {
  std::string out;
  for (const unsigned char c : name) {
    if (std::isalnum(c)) out += static_cast<char>(std::tolower(c));
  }
  return out;
}

std::string LeadingLetters(const std::string& text) {
  size_t n = 0;
  while (n < text.size() && std::isalpha(static_cast<unsigned char>(text[n]))) ++n;
  return text.substr(0, n);
}

}  // namespace

std::optional<bool> ModelFits(const std::string& controller_model, const std::string& model_name) {
  const std::string controller = Normalised(controller_model), model = Normalised(model_name);
  if (controller.empty() || model.empty()) return std::nullopt;
  if (LeadingLetters(controller).empty() || LeadingLetters(controller) != LeadingLetters(model))
    return std::nullopt;
  if (model.compare(0, controller.size(), controller) != 0) return false;
  return model.size() == controller.size() ||
         !std::isdigit(static_cast<unsigned char>(model[controller.size()]));
}

void CheckControllerFacts(db::Database& db, const io::LabConfig& lab, const std::string& robot,
                          int64_t session, const ControllerFacts& facts) {
  if (!facts.identity) return;
  const auto& id = *facts.identity;
  const SourceLocation where{lab.source, 0, 0, "robot.controller"};
  if (ModelFits(id.model, lab.model.name) == false) {
    throw InputError(where, fmt::format(
                                "the controller at {} answers model {}, the lab's robot model "
                                "is {} ({}): another arm, or the wrong model file; correct the "
                                "lab file's host or its robot model; nothing was stored",
                                Printable(lab.controller.host), Printable(id.model),
                                Printable(lab.model.name), lab.robot_model_path));
  }
  const auto robot_id = db::FindRobot(db, robot);
  if (robot_id) {
    if (const auto registered = db::RobotControllerRecord(db, *robot_id)) {
      const bool other_model = !registered->model.empty() && !id.model.empty() &&
                               Normalised(registered->model) != Normalised(id.model);
      const bool other_serial =
          !registered->serial.empty() && !id.serial.empty() && registered->serial != id.serial;
      if (other_model || other_serial) {
        throw InputError(
            where, fmt::format("robot {} is the arm of controller {} serial {} (as registered by "
                               "its first session); this controller answers {} serial {}: "
                               "another arm. Correct the lab file's host, or register this arm "
                               "under its own name (armsig robot add NAME --model FILE); nothing "
                               "was stored",
                               Quoted(robot), Printable(registered->model),
                               Printable(registered->serial), Printable(id.model),
                               Printable(id.serial)));
      }
    }
  }
  if (session <= 0) return;
  const auto stored = db::SessionController(db, session);
  if (!stored) return;
  const db::ControllerRecord now = facts.Record();
  if ((!stored->serial.empty() && stored->serial != now.serial) ||
      (!stored->model.empty() && Normalised(stored->model) != Normalised(now.model))) {
    throw InputError(where, fmt::format("session {} began on controller {} serial {}; this "
                                        "controller answers {} serial {}: another arm. Resume it "
                                        "on its own robot; nothing was stored",
                                        session, Printable(stored->model),
                                        Printable(stored->serial), Printable(now.model),
                                        Printable(now.serial)));
  }
  if (!stored->kinematics_checksum.empty() &&
      stored->kinematics_checksum != now.kinematics_checksum) {
    throw InputError(
        where, fmt::format("the controller's own calibration changed since session {} began "
                           "(KinematicsInfo checksum {} then, {} now): the arm may have been "
                           "repaired or recalibrated, and its configurations would mix two "
                           "robots. Start a new session; nothing was stored",
                           session, Printable(stored->kinematics_checksum),
                           Printable(now.kinematics_checksum)));
  }
}

std::string ControllerCalibrationChange(db::Database& db, int64_t robot_id) {
  const auto history = db::KinematicsHistory(db, robot_id);
  if (history.size() < 2) return "";
  const auto& before = history[history.size() - 2];
  const auto& newest = history.back();
  if (before.checksum == newest.checksum) return "";
  return fmt::format(
      "the controller's own calibration changed (KinematicsInfo checksum {} in session {}, {} in "
      "session {})",
      Printable(before.checksum), before.session, Printable(newest.checksum), newest.session);
}

}  // namespace armsig::acquisition
