#include "iso9283/iso9283_report.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <numeric>

#include "acquisition/lab.h"
#include "acquisition/plan.h"
#include "calibration/residual_map.h"
#include "core/error.h"
#include "core/text.h"
#include "db/calibrations.h"
#include "db/report_queries.h"
#include "db/robots.h"
#include "db/sessions.h"
#include "iso9283/iso9283_csv.h"
#include "io/model_yaml.h"
#include "workflows/hint.h"
#include "iso9283/iso9283_page.h"
#include "iso9283/iso9283_path_report.h"
#include "report/report.h"
#include "workflows/signature.h"

namespace armsig::iso9283 {

namespace iso = calibration::iso9283;

std::optional<Iso9283Frame> SignatureFrame(const calibration::RobotModel& model,
                                           const workflows::ActiveSignature& signature,
                                           const std::vector<MeasuredPose>& poses, size_t most,
                                           size_t* used) {
  const size_t stride = std::max<size_t>(1, poses.size() / std::max<size_t>(1, most));
  std::vector<Eigen::VectorXd> joints;
  std::vector<Eigen::Vector3d> measured, predicted;
  for (size_t i = 0; i < poses.size(); i += stride) {
    joints.push_back(poses[i].joints_rad);
    measured.push_back(poses[i].target_in_world);
  }
  if (used) *used = joints.size();
  for (const auto& p : calibration::PredictPositions(model, Eigen::Isometry3d::Identity(),
                                                     signature.signature.params,
                                                     signature.signature.map.get(), joints))
    predicted.push_back(p.position_mm);
  const auto fit = iso::AlignRigidly(measured, predicted);
  if (!fit) return std::nullopt;
  Iso9283Frame frame;
  frame.method = "arm signature";
  frame.commanded_from_attained = fit->commanded_from_attained;
  frame.fit = fit;
  return frame;
}

std::optional<Iso9283Frame> LabBaseFrame(const std::string& lab_yaml, int64_t session,
                                         const std::string& db_path) {
  const auto settings = io::StoredLabSettings(lab_yaml, session, db_path);
  if (!settings || !settings->robot_base) return std::nullopt;
  Iso9283Frame frame;
  frame.method = "lab base";
  frame.commanded_from_attained = settings->robot_base->inverse();
  frame.detail = "the robot's base as the session's lab file gives it (robot: base:)";
  return frame;
}

std::optional<Iso9283Label> ParseIso9283Label(const std::string& label) {
  // P<digit>-<cycle>[-<approach>]
  if (label.size() < 4 || label[0] != 'P' || label[1] < '1' || label[1] > '9' || label[2] != '-')
    return std::nullopt;
  Iso9283Label l;
  l.point = label.substr(0, 2);
  const size_t dash = label.find('-', 3);
  const std::string_view cycle =
      std::string_view(label).substr(3, dash == std::string::npos ? std::string::npos : dash - 3);
  const auto [end, ec] = std::from_chars(cycle.data(), cycle.data() + cycle.size(), l.cycle);
  if (ec != std::errc() || end != cycle.data() + cycle.size() || l.cycle < 1) return std::nullopt;
  if (dash != std::string::npos) {
    l.approach = label.substr(dash + 1);
    if (l.approach.empty() || l.approach.find('-') != std::string::npos)
      return std::nullopt;  // "-via"
  }
  return l;
}

namespace {

// One session's test poses, in its measuring frame.
struct SessionTest {
  int64_t id = 0;
  db::SessionRow row;
  std::string started_at;
  std::vector<MeasuredPose> poses;  // every measured configuration
  std::vector<Eigen::Matrix3d> covariances;
  std::vector<iso::PointData> points;                // sorted by name
  std::vector<std::vector<Eigen::VectorXd>> joints;  // per point, per sample
  std::vector<std::string> notes;
};

struct Commanded {
  std::string point, approach;
  int cycle = 0;
  Eigen::Vector3d target_mm = Eigen::Vector3d::Zero();
};

SessionTest LoadTest(db::Database& db, int64_t session, const std::string& robot,
                     const calibration::RobotModel& model,
                     const std::map<std::string, Commanded>* plan_file,
                     const std::map<std::string, Eigen::Vector3d>* targets_by_point) {
  SessionTest t;
  t.id = session;
  const auto row = db::LoadSession(db, session);
  if (!row) throw InputError({db.path(), 0, 0, "--session"}, fmt::format("no session {}", session));
  if (row->robot != robot) {
    throw InputError({db.path(), 0, 0, "--session"},
                     fmt::format("session {} is of robot {}, not {}", session,
                                 workflows::ShellWord(row->robot), workflows::ShellWord(robot)));
  }
  t.row = *row;
  for (const auto& s : db::LoadReportSessions(db, {session})) t.started_at = s.started_at;
  t.poses = db::LoadSessionPoses(db, session, &t.covariances);
  std::map<std::string, acquisition::PlannedConfiguration> planned;
  if (!row->plan_json.empty()) {
    for (auto& c : acquisition::PlanFromJson(row->plan_json,
                                              {db.path(), "sessions", session, "plan_json"}))
      planned[c.label] = c;
  }
  calibration::Kinematics kin(model);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model.num_parameters());
  std::map<std::string, size_t> index;
  int other = 0, nominal_targets = 0;
  std::map<std::string, int> approaches;
  for (const auto& pose : t.poses) {
    Commanded c;
    if (plan_file) {
      const auto it = plan_file->find(pose.id);
      if (it == plan_file->end() || it->second.point.empty()) {
        ++other;
        continue;
      }
      c = it->second;
    } else {
      const auto label = ParseIso9283Label(pose.id);
      if (!label) {
        ++other;
        continue;
      }
      c.point = label->point;
      c.cycle = label->cycle;
      c.approach = label->approach;
      const auto p = planned.find(pose.id);
      if (p != planned.end() && p->second.target_mm) {
        c.target_mm = *p->second.target_mm;
      } else if (targets_by_point && targets_by_point->count(c.point)) {
        c.target_mm = targets_by_point->at(c.point);
      } else {
        // No target kept: the nominal model's position of the joints the plan commanded.
        const Eigen::VectorXd& q = p != planned.end() ? p->second.joints_rad : pose.joints_rad;
        c.target_mm = kin.Position(Eigen::Isometry3d::Identity(), zero, q.data());
        ++nominal_targets;
      }
    }
    auto [it, fresh] = index.emplace(c.point, t.points.size());
    if (fresh) {
      t.points.push_back({c.point, c.target_mm, std::nullopt, {}});
      t.joints.emplace_back();
    } else if ((t.points[it->second].commanded_mm - c.target_mm).norm() > 1e-6) {
      throw InputError({db.path(), 0, 0, "--session"},
                       fmt::format("session {}: configuration {} commands {} elsewhere than its "
                                   "earlier cycles ({:.6f} mm apart)",
                                   session, pose.id, c.point,
                                   (t.points[it->second].commanded_mm - c.target_mm).norm()));
    }
    int approach = 0;
    if (!c.approach.empty())
      approach =
          approaches.emplace(c.approach, static_cast<int>(approaches.size()) + 1).first->second;
    t.points[it->second].samples.push_back({c.cycle, approach, pose.target_in_world, std::nullopt});
    t.joints[it->second].push_back(pose.joints_rad);
  }
  if (t.points.empty()) {
    throw InputError({db.path(), 0, 0, "--session"},
                     fmt::format("session {} holds no ISO 9283 test poses (labels P1-01 … as "
                                 "`iso9283 plan` writes them, or a --commanded plan naming them)",
                                 session));
  }
  // P1…P5 in order, whatever order the cycles visited them in.
  std::vector<size_t> order(t.points.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t b) { return t.points[a].name < t.points[b].name; });
  std::vector<iso::PointData> points;
  std::vector<std::vector<Eigen::VectorXd>> joints;
  for (size_t i : order) {
    points.push_back(std::move(t.points[i]));
    joints.push_back(std::move(t.joints[i]));
  }
  t.points = std::move(points);
  t.joints = std::move(joints);
  if (other > 0) {
    t.notes.push_back(
        fmt::format("{} measured configurations are no test poses (via points of "
                    "the multi-directional test, or others): left out",
                    other));
  }
  if (nominal_targets > 0) {
    t.notes.push_back(fmt::format(
        "{} test poses had no stored target: commanded = the nominal model's position of the "
        "planned joints (right for a nominal plan; give --commanded PLAN.csv otherwise)",
        nominal_targets));
  }
  return t;
}

// The robot's frame for a session: the signature located on its measured configurations,
// else the lab file's base.
Iso9283Frame FrameOf(const SessionTest& t, const calibration::RobotModel& model,
                     const workflows::ActiveSignature* signature, const std::string& db_path) {
  if (signature) {
    auto frame = SignatureFrame(model, *signature, t.poses);
    if (!frame) {
      throw InputError(
          {db_path, 0, 0, "--session"},
          fmt::format("session {}: its measured configurations cannot locate the robot "
                      "(fewer than three, or on one line); use --align",
                      t.id));
    }
    frame->detail = fmt::format(
        "the robot's base located by arm signature version {} on the session's {} measured "
        "configurations (rms {:.4f} mm of its positions against them), independently of the "
        "commanded positions",
        signature->signature.version, t.poses.size(), frame->fit->rms_mm);
    return *frame;
  }
  if (auto frame = LabBaseFrame(t.row.lab_yaml, t.id, db_path)) return *frame;
  throw InputError(
      {db_path, 0, 0, "--session"},
      fmt::format("session {}: the robot's frame is not known (the robot has no arm signature and "
                  "the lab file gives no robot: base:): measure the base, or use --align (a rigid "
                  "best fit of the barycentres onto the commanded positions, reported)",
                  t.id));
}

Iso9283Evaluation Evaluate(SessionTest& t, const calibration::RobotModel& model,
                           const workflows::ActiveSignature* signature, bool align,
                           const std::string& db_path) {
  Iso9283Evaluation e;
  if (align) {
    e = EvaluateIso9283(t.points, true);
  } else {
    const Iso9283Frame frame = FrameOf(t, model, signature, db_path);
    std::vector<iso::PointData> points = t.points;
    for (auto& p : points) iso::TransformSamples(p, frame.commanded_from_attained);
    e = EvaluateIso9283(std::move(points), false, frame);
  }
  e.notes.insert(e.notes.end(), t.notes.begin(), t.notes.end());
  return e;
}

// AP predicted by the signature for each point's attained joints (robot frame).
std::vector<Eigen::Vector3d> PredictedAp(const SessionTest& t, const calibration::RobotModel& model,
                                         const workflows::ActiveSignature& signature) {
  std::vector<Eigen::Vector3d> out;
  for (size_t i = 0; i < t.points.size(); ++i) {
    const auto positions = calibration::PredictPositions(
        model, Eigen::Isometry3d::Identity(), signature.signature.params,
        signature.signature.map.get(), t.joints[i]);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const auto& p : positions) sum += p.position_mm;
    out.push_back(sum / static_cast<double>(positions.size()) - t.points[i].commanded_mm);
  }
  return out;
}

std::string Conditions(db::Database& db, const SessionTest& t, Iso9283PageInput& page,
                       nlohmann::json& json) {
  const auto temperatures = db::PoseTemperatures(db, {t.id});
  std::vector<double> c;
  for (const auto& [pose, value] : temperatures) c.push_back(value);
  if (!c.empty()) {
    double sum = 0.0;
    for (double v : c) sum += v;
    const auto [lo, hi] = std::minmax_element(c.begin(), c.end());
    page.temperature = fmt::format("{:.2f} °C ({:.2f} to {:.2f}) at the instrument, over {} poses",
                                   sum / c.size(), *lo, *hi, c.size());
    json["temperature_c"] = {{"mean", sum / c.size()}, {"min", *lo}, {"max", *hi}};
  }
  nlohmann::json instruments = nlohmann::json::array();
  for (const auto& i : report::LoadReportSources(db, std::vector<int64_t>{t.id}).instruments) {
    page.instruments.push_back(i.name + ": " + i.description);
    instruments.push_back(page.instruments.back());
  }
  json["instruments"] = instruments;
  double precision = 0.0;
  int counted = 0;
  for (const auto& cov : t.covariances) {
    if (!cov.allFinite()) continue;
    precision += 0.921 * std::sqrt(cov.trace());  // mean length of a 3-D normal error
    ++counted;
  }
  if (counted > 0) {
    page.point_precision = fmt::format(
        "{:.4f} mm: the mean 3-D error of a measured point by its own covariance ({} points)",
        precision / counted, counted);
    json["point_precision_mm"] = precision / counted;
  }
  return page.temperature;
}

// A path test (ISO 9283 clause 8), and the same paths compensated: their figures, text, JSON
// and page.
Iso9283ReportResult PathReport(db::Database& db, const Iso9283ReportOptions& o,
                               const calibration::RobotModel& model,
                               const workflows::ActiveSignature* signature) {
  const auto refuse = [&](const char* option, const char* why) {
    throw InputError({option, 0, 0, ""},
                     fmt::format("session {} is an ISO 9283 path test: {}", o.session, why));
  };
  if (o.align) refuse("--align", "its frame is the robot's (an arm signature or the lab's base)");
  if (o.limits.any()) refuse("--limit", "--limit judges the pose test's AP, RP, AD and RD");
  if (!o.commanded_csv.empty()) refuse("--commanded", "its commanded path is its stored plan");
  const auto check_robot = [&](int64_t session) {
    const auto row = db::LoadSession(db, session);
    if (!row) throw InputError({db.path(), 0, 0, "--session"}, fmt::format("no session {}", session));
    if (row->robot != o.robot) {
      throw InputError({db.path(), 0, 0, "--session"},
                       fmt::format("session {} is of robot {}, not {}", session,
                                   workflows::ShellWord(row->robot), workflows::ShellWord(o.robot)));
    }
  };
  check_robot(o.session);
  const Iso9283PathEvaluation test = EvaluateIso9283PathSession(db, o.session, model, signature);
  std::optional<Iso9283PathEvaluation> after;
  if (o.compensated_session > 0) {
    check_robot(o.compensated_session);
    if (!IsIso9283PathSession(db, o.compensated_session)) {
      throw InputError({"--compensated-session", 0, 0, ""},
                       fmt::format("session {} is no path test, session {} is",
                                   o.compensated_session, o.session));
    }
    after = EvaluateIso9283PathSession(db, o.compensated_session, model, signature);
  }
  Iso9283ReportResult result;
  result.json = Iso9283PathJson(test);
  result.json["robot"] = o.robot;
  if (after) result.json["compensated"] = Iso9283PathJson(*after);
  result.text = fmt::format("ISO 9283 path test of robot {}, session {} ({} tracker records)\n",
                            o.robot, o.session, test.records);
  result.text += FormatIso9283PathFigures(test);
  if (after) {
    result.text += fmt::format("\nwith compensation, session {}:\n", o.compensated_session);
    result.text += FormatIso9283PathFigures(*after);
  }
  if (!o.out_dir.empty()) {
    Iso9283PathPageInput page;
    page.generated_at = o.generated_at;
    page.armsig_version = ARMSIG_VERSION;
    page.robot = o.robot;
    page.model = model.name;
    page.test = &test;
    page.compensated = after ? &*after : nullptr;
    for (const auto& i : report::LoadReportSources(db, std::vector<int64_t>{o.session}).instruments)
      page.instruments.push_back(i.name + ": " + i.description);
    result.html_path = WriteIso9283PathPage(o.out_dir, page);
    result.text += "report: " + result.html_path + "\n";
  }
  return result;
}

}  // namespace

Iso9283ReportResult RunIso9283Report(db::Database& db, const Iso9283ReportOptions& o) {
  const auto robot_id = db::FindRobot(db, o.robot);
  if (!robot_id)
    throw InputError({db.path(), 0, 0, "--robot"}, workflows::UnknownRobotMessage(db, o.robot));
  const calibration::RobotModel model =
      io::ParseRobotModel(db::RobotModelYaml(db, *robot_id), "model of robot " + o.robot);
  std::optional<workflows::ActiveSignature> signature;
  std::optional<db::StoredCalibration> stored = db::ActiveCalibration(db, *robot_id);
  if (stored) signature = workflows::LoadActiveSignature(db, o.robot);
  if (IsIso9283PathSession(db, o.session))
    return PathReport(db, o, model, signature ? &*signature : nullptr);

  std::optional<std::map<std::string, Commanded>> plan_file;
  if (!o.commanded_csv.empty()) {
    plan_file.emplace();
    for (const auto& r : iso9283::ReadIso9283PlanCsv(o.commanded_csv, model.num_joints()))
      (*plan_file)[r.pose] = {r.point, r.approach, r.cycle, r.target_mm};
  }
  SessionTest test = LoadTest(db, o.session, o.robot, model,
                              plan_file ? &*plan_file : nullptr, nullptr);
  Iso9283ReportResult result;
  result.test = Evaluate(test, model, signature ? &*signature : nullptr, o.align, db.path());

  std::optional<SessionTest> after;
  if (o.compensated_session > 0) {
    std::map<std::string, Eigen::Vector3d> targets;
    for (const auto& p : test.points) targets[p.name] = p.commanded_mm;
    after = LoadTest(db, o.compensated_session, o.robot, model, nullptr, &targets);
    result.compensated =
        Evaluate(*after, model, signature ? &*signature : nullptr, o.align, db.path());
  }

  // The page and the JSON.
  Iso9283PageInput page;
  page.generated_at = o.generated_at;
  page.armsig_version = ARMSIG_VERSION;
  page.robot = o.robot;
  page.model = model.name;
  page.cube = CubeOfTestPoints(result.test);
  page.test = {"nominal program", o.session, test.started_at, &result.test, {}};
  page.load_kg = o.load_kg;
  page.speed_percent = o.speed_percent;
  result.json = Iso9283Json(result.test);
  result.json["robot"] = o.robot;
  result.json["session"] = o.session;
  nlohmann::json conditions;
  if (o.load_kg) conditions["load_kg"] = *o.load_kg;
  if (o.speed_percent) conditions["speed_percent"] = *o.speed_percent;
  Conditions(db, test, page, conditions);
  result.json["conditions"] = conditions;
  if (after) {
    page.compensated = Iso9283PageTest{
        "compensated program", o.compensated_session, after->started_at, &*result.compensated, {}};
    nlohmann::json c = Iso9283Json(*result.compensated);
    c["session"] = o.compensated_session;
    result.json["compensated"] = c;
  }
  if (o.limits.any()) {
    result.verdict = JudgeIso9283(result.test, o.limits);
    page.verdict = result.verdict;
    result.json["verdict"] = Iso9283VerdictJson(*result.verdict, o.limits);
    result.pass = result.verdict->pass;
    if (result.compensated) {
      result.compensated_verdict = JudgeIso9283(*result.compensated, o.limits);
      page.compensated_verdict = result.compensated_verdict;
      result.json["compensated"]["verdict"] =
          Iso9283VerdictJson(*result.compensated_verdict, o.limits);
      result.pass = result.compensated_verdict->pass;
    }
  }
  if (signature) {
    page.test.predicted_ap_mm = PredictedAp(test, model, *signature);
    page.signature =
        Iso9283PageSignature{stored->version, stored->params_spec, stored->poses_validation,
                             stored->validation_mean_mm, stored->validation_max_mm};
    nlohmann::json predicted = nlohmann::json::array();
    for (size_t i = 0; i < test.points.size(); ++i) {
      const Eigen::Vector3d& ap = page.test.predicted_ap_mm[i];
      predicted.push_back({{"point", test.points[i].name},
                           {"AP_mm", ap.norm()},
                           {"APx_mm", ap.x()},
                           {"APy_mm", ap.y()},
                           {"APz_mm", ap.z()}});
    }
    result.json["signature"] = {{"version", stored->version},
                                {"params", stored->params_spec},
                                {"validation_poses", stored->poses_validation},
                                {"validation_mean_mm", stored->validation_mean_mm},
                                {"validation_max_mm", stored->validation_max_mm},
                                {"predicted", predicted}};
  }

  // The text.
  std::string& text = result.text;
  text = fmt::format(
      "ISO 9283 test of robot {}, session {} ({} test poses of {} measured "
      "configurations)\n",
      o.robot, o.session,
      std::accumulate(result.test.points.begin(), result.test.points.end(), 0,
                      [](int s, const auto& f) { return s + f.n; }),
      test.poses.size());
  text += FormatIso9283Figures(result.test);
  if (result.compensated) {
    text += fmt::format("\nwith compensation, session {}:\n", o.compensated_session);
    text += FormatIso9283Figures(*result.compensated);
  }
  if (signature) {
    text += fmt::format("\narm signature version {} predicts AP", stored->version);
    for (size_t i = 0; i < test.points.size(); ++i) {
      text += fmt::format("{} {} {:.4f}", i ? "," : "", test.points[i].name,
                          page.test.predicted_ap_mm[i].norm());
    }
    text += fmt::format(
        " mm for the nominal program; its held-out validation: mean {:.4f} mm, max "
        "{:.4f} mm on {} configurations\n",
        stored->validation_mean_mm, stored->validation_max_mm, stored->poses_validation);
  }
  if (result.verdict) {
    text += "\nagainst the stated limits: " + result.verdict->summary + "\n";
    if (result.compensated_verdict) {
      text += "with compensation: " + result.compensated_verdict->summary + "\n";
    }
  }
  if (!o.out_dir.empty()) {
    result.html_path = WriteIso9283Page(o.out_dir, page);
    text += "report: " + result.html_path + "\n";
  }
  return result;
}

}  // namespace armsig::iso9283
