#include "simulation/rws_simulator.h"

// clang-format off
#include <utility>  // first: Boost 1.74 Asio uses std::exchange without including it (C++20)
#include <boost/asio.hpp>
// clang-format on
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <boost/asio/ssl.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <cmath>
#include <future>
#include <limits>
#include <map>
#include <numbers>
#include <random>

#include "core/text.h"
#include "simulation/rws_programs.h"
#include "simulation/rws_sessions.h"
#include "simulation/tls_certificate.h"
#include "simulation/virtual_arm.h"

namespace armsig::simulation {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace bhttp = boost::beast::http;
namespace ssl = boost::asio::ssl;
namespace rws = robots::rws;
using tcp = asio::ip::tcp;
using SteadyClock = std::chrono::steady_clock;

namespace {

constexpr double kRadPerDeg = std::numbers::pi / 180.0;
constexpr int64_t kEventOutsideReach = 50050;  // "Position outside reach"

double AsFloat(double v) { return static_cast<double>(static_cast<float>(v)); }


std::string Upper(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

struct Reply {
  enum class Action { kAnswer, kClose, kSilence, kGarbage, kTruncate } action = Action::kAnswer;
  bhttp::response<bhttp::string_body> response;
};

class Connection {
 public:
  virtual ~Connection() = default;
  virtual void Close() = 0;
};

}  // namespace

struct RwsSimulator::Impl {
  Impl(RwsSimulator& owner_, VirtualLab& lab_, RwsSimulatorOptions options, std::string host_,
       unsigned short port_)
      : owner(owner_),
        lab(lab_),
        o(std::move(options)),
        host(std::move(host_)),
        requested_port(port_),
        ssl_context(ssl::context::tls_server),
        tick(io) {
    if (o.robotware.empty()) {
      o.robotware = o.version == rws::Version::kRws1 ? "6.15.03.00" : "7.16.0.0";
    }
    if (!o.module_text.empty()) {
      module = ParseRapidModule(o.module_text, "the simulator's module");
      for (const RapidData& d : module->data) values[Upper(d.name)] = CanonicalValue(d, d.initial);
    }
    Eigen::VectorXd home(6);
    for (int i = 0; i < 6; ++i) home(i) = o.start_deg[static_cast<size_t>(i)] * kRadPerDeg;
    arm = std::make_unique<VirtualArm>(lab, clock, home);
    rapid_programs = std::make_unique<RwsPrograms>(
        o.task, programs::NominalController(lab.model(), programs::ControllerKind::kAbb, "nominal " + o.model), module);
    running = o.running && module.has_value();
  }

  // ---- RAPID data ----

  double Num(const char* name) const { return rws::ParseRapidNum(values.at(Upper(name))); }
  void SetNum(const char* name, double value) {
    values[Upper(name)] = rws::FormatRapidNum(AsFloat(value));
  }
  bool HasContract() const {
    return module && module->Find("armsig_cmd") && module->Find("armsig_done") &&
           module->Find("armsig_target") && module->Find("armsig_joints");
  }

  // ---- The task (armsig_serve of the module) ----

  Eigen::VectorXd JointsDeg() { return arm->Now().q / kRadPerDeg; }

  // CJointT after WaitRob \ZeroSpeed: where the arm stands, as RAPID nums.
  void Record() {
    const VirtualArm::State st = arm->Now();
    if (st.moving) {  // WaitRob \ZeroSpeed: recorded once it stands
      record_pending = true;
      return;
    }
    std::vector<double> q(6);
    for (int i = 0; i < 6; ++i) q[static_cast<size_t>(i)] = AsFloat(st.q(i) / kRadPerDeg);
    values["ARMSIG_JOINTS"] = rws::FormatRapidArray(q, 15);
    record_pending = false;
  }

  // A joint move at `speed_percent` of the axes' speeds: the leading joint (the largest turn)
  // at the speed and acceleration that keep every axis within its own maximum; {a, v}.
  std::pair<double, double> Profile(const Eigen::VectorXd& from, const Eigen::VectorXd& to,
                                    double speed_percent) const {
    const Eigen::VectorXd turn = (to - from).cwiseAbs();
    const double lead = turn.maxCoeff();
    if (!(lead > 0)) return {1.0, 1.0};  // no turn: any
    double v = std::numeric_limits<double>::infinity(), a = v;
    for (int i = 0; i < 6; ++i) {
      if (turn(i) <= 0) continue;
      const double vi = o.max_speed_deg_s[static_cast<size_t>(i)] * kRadPerDeg * speed_percent / 100.0;
      v = std::min(v, vi * lead / turn(i));
      a = std::min(a, vi / o.accel_time_s * lead / turn(i));
    }
    return {a, v};
  }

  // Whether a target is within the working ranges; if not, the motion planner stops the
  // program (event 50050) and the arm does not move.
  bool WithinReach(const Eigen::VectorXd& target_deg) {
    for (int i = 0; i < 6; ++i) {
      const auto [lo, hi] = o.limits_deg[static_cast<size_t>(i)];
      if (target_deg(i) >= lo && target_deg(i) <= hi) continue;
      running = false;
      events.push_back(fmt::format("{} Position outside reach: {} joint {} at {:.2f}°", kEventOutsideReach,
                                   o.mechunit, i + 1, target_deg(i)));
      return false;
    }
    return true;
  }

  // MoveAbsJ of armsig_serve at `speed_percent` (Profile).
  void StartMove(const Eigen::VectorXd& target_deg, double speed_percent) {
    const Eigen::VectorXd to = target_deg * kRadPerDeg;
    const auto [a, v] = Profile(arm->Now().q, to, speed_percent);
    if (armed_stop) {
      arm->ProtectiveStopDuringNextMove(armed_fraction);
      stop_kind = *armed_stop;
      armed_stop.reset();
    }
    target_deg_ = target_deg;
    if (arm->MoveJ(to, a, v)) {
      phase = Phase::kMoving;
    } else {
      running = false;  // the arm is stopped or not powered: the program cannot go on
    }
  }

  // The program stops: a move running brakes along its path (continuing finishes it).
  void StopTask() {
    if (phase == Phase::kMoving) {
      arm->ProtectiveStop();
      arm->ClearProtectiveStop();  // braking goes on; no stop of the cell
      phase = Phase::kInterrupted;
    }
    running = false;
  }

  // A stop of the cell: the arm brakes, the motors go off, the program stops.
  void StopBy(RwsSimulator::CellStop kind) {
    if (kind == RwsSimulator::CellStop::kProgramStop) return StopTask();
    if (kind == RwsSimulator::CellStop::kEmergencyStop) {
      arm->EmergencyStop();
      ctrl = rws::ControllerState::kEmergencyStop;
    } else {
      arm->ProtectiveStop();
      ctrl = rws::ControllerState::kGuardStop;
    }
    if (phase == Phase::kMoving) phase = Phase::kInterrupted;
    running = false;
  }

  // The routine the program pointer was set to runs instead of armsig_serve; its moves at
  // the axes' full speed (the program's speed data are not followed: the arm stands at each
  // fine point before the next step, which is what the landings depend on).
  void AdvanceProgram() {
    if (!running) return;
    const auto status = rapid_programs->Tick(*arm, [&](const Eigen::VectorXd& q) {
      if (WithinReach(q / kRadPerDeg)) {
        const auto [a, v] = Profile(arm->Now().q, q, 100.0);
        arm->MoveJ(q, a, v);
      }
    });
    if (status != ProgramPlayer::Status::kRunning) running = false;  // its end, or a stop
  }

  void Advance() {
    if (rapid_programs->Armed()) return AdvanceProgram();
    if (!HasContract()) return;
    VirtualArm::State st = arm->Now();
    if (phase == Phase::kMoving && st.stop != VirtualArm::Stop::kNone) {
      // A stop planned for this move (StopDuringNextMove) happened: the cell reacts.
      const RwsSimulator::CellStop kind = stop_kind;
      stop_kind = RwsSimulator::CellStop::kGuardStop;
      if (kind == RwsSimulator::CellStop::kProgramStop) arm->ClearProtectiveStop();
      StopBy(kind);
      if (kind == RwsSimulator::CellStop::kProgramStop) phase = Phase::kInterrupted;
    }
    if (record_pending && !st.moving) Record();
    if (!running) return;
    for (int guard = 0; guard < 4; ++guard) {
      st = arm->Now();
      if (phase == Phase::kMoving) {
        if (st.moving) return;
        phase = Phase::kWaiting;
        ++moves;
        Record();
        SetNum("armsig_done", request);
        continue;
      }
      if (phase == Phase::kInterrupted) {  // continued after a stop: finish the move
        StartMove(target_deg_, Num("armsig_speed"));
        if (!running) return;
        continue;
      }
      if (Num("armsig_cmd") == Num("armsig_done")) return;
      request = Num("armsig_cmd");
      SetNum("armsig_error", 0);
      const double speed = Num("armsig_speed");
      if (!(speed >= 1 && speed <= 100)) {
        SetNum("armsig_error", 1);
        Record();
        SetNum("armsig_done", request);
        continue;
      }
      const rws::JointTarget t = rws::ParseRapidJointTarget(values.at("ARMSIG_TARGET"));
      Eigen::VectorXd target(6);
      for (int i = 0; i < 6; ++i) target(i) = t.robax_deg[static_cast<size_t>(i)];
      if (!WithinReach(target)) return;
      StartMove(target, speed);
      if (!running) return;
    }
  }

  // Why execution cannot start (motors off, a routine that cannot run), or nullopt: started.
  std::optional<std::string> StartTaskWhy(bool from_main) {
    if (ctrl != rws::ControllerState::kMotorsOn) return "the motors are off";
    if (rapid_programs->Armed()) {
      if (auto why = rapid_programs->Start(arm->Now().q)) return why;
      running = true;
      return std::nullopt;
    }
    if (!StartTask(from_main)) return "no program in the task";
    return std::nullopt;
  }

  bool StartTask(bool from_main) {
    if (ctrl != rws::ControllerState::kMotorsOn || !module) return false;
    if (from_main && HasContract()) {
      if (phase == Phase::kInterrupted) phase = Phase::kWaiting;  // the move is dropped
      SetNum("armsig_done", Num("armsig_cmd"));
      SetNum("armsig_error", 0);
      Record();
    }
    running = true;
    return true;
  }

  // ---- Answers ----

  rws::Representation RepresentationFor(const bhttp::request<bhttp::string_body>& req,
                                        const std::string& query, bool& acceptable) const {
    acceptable = true;
    if (o.version == rws::Version::kRws1) {
      for (const auto& [n, v] : rws::ParseForm(query)) {
        if (n == "json" && v == "1") return rws::Representation::kJson1;
      }
      return rws::Representation::kXhtml;
    }
    const auto it = req.find(bhttp::field::accept);
    const std::string accept = it == req.end() ? "" : std::string(it->value());
    if (accept.find("hal+json") != std::string::npos) return rws::Representation::kHalJson;
    if (accept.find("xhtml+xml") != std::string::npos) return rws::Representation::kXhtml;
    acceptable = false;
    return rws::Representation::kHalJson;
  }

  static rws::Resource Li(std::string type, std::string title,
                          std::vector<std::pair<std::string, std::string>> fields) {
    rws::Resource r;
    r.type = std::move(type);
    r.title = std::move(title);
    r.fields = std::move(fields);
    return r;
  }

  static rws::Document Error(int64_t code, std::string message) {
    rws::Document d;
    d.status = rws::Status{code, std::move(message)};
    return d;
  }

  // One authenticated request: its method, path (no query), query and form pairs, raw body.
  using Pairs = std::vector<std::pair<std::string, std::string>>;
  struct Call {
    std::string method, path;
    Pairs query, form;
    std::string body, session;
    bool get() const { return method == "GET"; }
    bool post() const { return method == "POST"; }
    std::string Param(const char* name, bool in_form = false) const {
      for (const auto& [n, v] : in_form ? form : query)
        if (n == name) return v;
      return "";
    }
  };
  using Answer = std::pair<unsigned, rws::Document>;

  // The controller's identity and states: read-only resources.
  std::optional<Answer> RouteTable(const Call& c) {
    if (!c.get()) return std::nullopt;
    const bool v1 = o.version == rws::Version::kRws1;
    rws::Document d;
    if (c.path == "/ctrl/identity") {
      d.resources.push_back(Li("ctrl-identity-info", "identity",
                               {{"ctrl-name", o.controller_name},
                                {"ctrl-type", "Virtual Controller"},
                                {"ctrl-id", o.controller_id}}));
    } else if (c.path == "/rw/system") {
      d.resources.push_back(Li("sys-system-li", "system",
                               {{"name", o.controller_name},
                                {"rwversion", o.robotware},
                                {"sysid", "{7E16B1D3-0000-4A2B-9C3D-000000000001}"},
                                {"rwversionname", o.robotware}}));
    } else if (c.path == "/rw/system/robottype") {
      d.resources.push_back(Li("sys-robottype", "1", {{"robot-type", o.model}}));
    } else if (c.path == "/rw/cfg/moc/ROBOT_SERIAL_NUMBER/instances") {
      rws::Resource inst = Li("cfg-dt-instance-li", "rob_1", {});
      inst.children.push_back(Li("cfg-ia-t-li", "name", {{"value", "rob_1"}}));
      inst.children.push_back(Li("cfg-ia-t-li", "robot_serial_number_high_part", {{"value", o.serial_high}}));
      inst.children.push_back(Li("cfg-ia-t-li", "robot_serial_number_low_part", {{"value", o.serial_low}}));
      d.resources.push_back(std::move(inst));
    } else if (c.path == (v1 ? "/rw/panel/ctrlstate" : "/rw/panel/ctrl-state")) {
      d.resources.push_back(Li("pnl-ctrlstate", "ctrlstate", {{"ctrlstate", rws::Text(ctrl)}}));
    } else if (c.path == "/rw/panel/opmode") {
      d.resources.push_back(Li("pnl-opmode", "opmode", {{"opmode", rws::Text(mode)}}));
    } else if (c.path == "/rw/rapid/execution") {
      d.resources.push_back(Li("rap-execution", "execution",
                               {{"ctrlexecstate", running ? "running" : "stopped"},
                                {"cycle", rapid_programs->Armed() ? "once" : "forever"}}));
    } else if (c.path == "/rw/motionsystem/mechunits/" + o.mechunit + "/jointtarget") {
      const Eigen::VectorXd q = JointsDeg();
      rws::Resource r = Li("ms-jointtarget", o.mechunit, {});
      for (int i = 0; i < 6; ++i) r.fields.emplace_back("rax_" + std::to_string(i + 1), fmt::format("{:.2f}", q(i)));
      for (const char* e : {"eax_a", "eax_b", "eax_c", "eax_d", "eax_e", "eax_f"}) r.fields.emplace_back(e, "9E+09");
      d.resources.push_back(std::move(r));
    } else if (c.path == "/logout") {
      users.Logout(c.session);
      if (mastership == c.session) mastership.reset();
    } else {
      return std::nullopt;
    }
    return Answer{200, d};
  }

  // RAPID execution start and stop, and mastership over RAPID (RWS 1.0: the rapid domain,
  // or all; RWS 2.0: edit).
  std::optional<Answer> RouteExecution(const Call& c) {
    if (!c.post()) return std::nullopt;
    const bool v1 = o.version == rws::Version::kRws1;
    const bool action_path = v1 && c.path == "/rw/rapid/execution";
    if (action_path ? c.Param("action") == "start" : c.path == "/rw/rapid/execution/start") {
      if (mode != rws::OperationMode::kAuto)
        return Answer{400, Error(rws::code::kWrongState, "execution start refused: not in AUTO")};
      if (auto why = StartTaskWhy(false))
        return Answer{400, Error(rws::code::kWrongState, "execution start refused: " + *why)};
      return Answer{204, {}};
    }
    if (action_path ? c.Param("action") == "stop" : c.path == "/rw/rapid/execution/stop") {
      StopTask();
      return Answer{204, {}};
    }
    std::string action;
    if (v1 && (c.path == "/rw/mastership/rapid" || c.path == "/rw/mastership")) action = c.Param("action");
    if (!v1 && c.path == "/rw/mastership/edit/request") action = "request";
    if (!v1 && c.path == "/rw/mastership/edit/release") action = "release";
    if (action == "request") {
      if (mastership && *mastership != c.session)
        return Answer{403, Error(rws::code::kHeldBySomeoneElse, "Requested resource is held by someone else")};
      mastership = c.session;
      return Answer{204, {}};
    }
    if (action == "release") {
      if (mastership == c.session) mastership.reset();
      return Answer{204, {}};
    }
    return std::nullopt;
  }

  // A RAPID symbol of the resident module: read, or written with mastership in AUTO.
  std::optional<Answer> RouteSymbol(const Call& c) {
    const bool v1 = o.version == rws::Version::kRws1;
    const std::string prefix = v1 ? "/rw/rapid/symbol/data/RAPID/" : "/rw/rapid/symbol/RAPID/";
    if (c.path.rfind(prefix, 0) != 0) return std::nullopt;
    std::string rest = c.path.substr(prefix.size());
    if (!v1) {
      if (rest.size() < 5 || rest.substr(rest.size() - 5) != "/data")
        return Answer{404, Error(rws::code::kNotFound, "Resource not found")};
      rest.resize(rest.size() - 5);
    }
    const std::string wanted_prefix = o.task + "/" + (module ? module->name : "") + "/";
    const RapidData* datum = nullptr;
    if (module && Upper(rest.substr(0, wanted_prefix.size())) == Upper(wanted_prefix))
      datum = module->Find(rest.substr(wanted_prefix.size()));
    if (!datum)
      return Answer{v1 ? 400u : 404u, Error(v1 ? rws::code::kNotFound : rws::code::kSymbolNotFound, "Symbol not found")};
    if (c.get()) {
      rws::Document d;
      d.resources.push_back(Li("rap-data", "RAPID/" + o.task + "/" + module->name + "/" + datum->name,
                               {{"value", values.at(Upper(datum->name))}}));
      return Answer{200, d};
    }
    const bool set = v1 ? (c.post() && c.Param("action") == "set") : c.post();
    if (!set) return Answer{400, Error(rws::code::kNotFound, "unknown action")};
    if (mode != rws::OperationMode::kAuto)
      return Answer{403, Error(rws::code::kRejected, "Rejected: RMMP needed in manual mode")};
    if (mastership && *mastership != c.session)
      return Answer{403, Error(rws::code::kHeldBySomeoneElse, "Requested resource is held by someone else")};
    if (!v1 && mastership != c.session)
      return Answer{403, Error(rws::code::kNoMastership, "The user does not have required mastership")};
    if (datum->storage == "CONST") return Answer{400, Error(rws::code::kRejected, "a constant cannot be written")};
    try {
      values[Upper(datum->name)] = CanonicalValue(*datum, c.Param("value", true));
    } catch (const rws::DecodeError& e) {
      return Answer{400, Error(0, std::string("value not valid for ") + datum->type + ": " + e.what())};
    }
    Advance();
    return Answer{204, {}};
  }

  // The program side: files, modules, the program pointer (simulation/rws_programs.h).
  std::optional<Answer> RoutePrograms(const Call& c) {
    RwsPrograms::Request r;
    r.method = c.method;
    r.path = c.path;
    r.body = c.body;
    r.query = c.query;
    r.form = c.form;
    r.v1 = o.version == rws::Version::kRws1;
    r.mastership = mastership == c.session;
    r.automatic = mode == rws::OperationMode::kAuto;
    r.running = running;
    auto a = rapid_programs->Route(r);
    if (!a) return std::nullopt;
    return Answer{a->status, std::move(a->document)};
  }

  // The answer to an authenticated request: HTTP status and the document.
  Answer Route(const Call& c) {
    for (auto route : {&Impl::RouteTable, &Impl::RouteExecution, &Impl::RouteSymbol, &Impl::RoutePrograms}) {
      if (auto a = (this->*route)(c)) return std::move(*a);
    }
    return {404, Error(rws::code::kNotFound, "Resource not found")};
  }

  static std::string Service(const std::string& path) {
    const size_t a = path.find('/', 1);
    if (path.rfind("/rw/", 0) == 0) {
      const size_t b = path.find('/', 4);
      return path.substr(4, b == std::string::npos ? std::string::npos : b - 4);
    }
    return path.substr(1, a == std::string::npos ? std::string::npos : a - 1);
  }

  // The fault injected for this request, as the reply's action; true when the request ends
  // there (the answer is not computed).
  static bool Faulted(const FaultSpec& fault, Reply& reply) {
    switch (fault.fault) {
      case Fault::kVanish:
        reply.action = Reply::Action::kClose;
        return true;
      case Fault::kDropReply:
        reply.action = Reply::Action::kSilence;
        return true;
      case Fault::kNoiseBytes:
        reply.action = Reply::Action::kGarbage;
        return true;
      case Fault::kTruncateReply:
        reply.action = Reply::Action::kTruncate;
        return false;
      default:
        return false;
    }
  }

  // The query and, for a POST, the form body; an error answer when they cannot be read.
  std::optional<Answer> ReadParameters(const bhttp::request<bhttp::string_body>& req, const std::string& query,
                                       Call& c) const {
    try {
      c.query = rws::ParseForm(query);
      if (req.method() != bhttp::verb::post) return std::nullopt;
      const auto ct = req.find(bhttp::field::content_type);
      const std::string content_type = ct == req.end() ? "" : std::string(ct->value());
      if (o.version == rws::Version::kRws2 && !req.body().empty() && content_type.find(";v=2.0") == std::string::npos)
        return Answer{415, Error(0, "Unsupported media type: form bodies are application/x-www-form-urlencoded;v=2.0")};
      c.form = rws::ParseForm(req.body());
    } catch (const rws::DecodeError& e) {
      return Answer{400, Error(0, e.what())};
    }
    return std::nullopt;
  }

  Reply Handle(const bhttp::request<bhttp::string_body>& req) {
    std::lock_guard lock(mutex);
    Reply reply;
    const FaultSpec fault = faults.Next();
    log.push_back(std::string(req.method_string()) + " " + std::string(req.target()));
    if (log.size() > 10000) log.erase(log.begin());
    auto& res = reply.response;
    res.version(11);
    res.keep_alive(req.keep_alive());
    res.set(bhttp::field::server, "armsig virtual ABB controller");
    if (Faulted(fault, reply)) return reply;
    Advance();

    const std::string target(req.target());
    const size_t q = target.find('?');
    Call c;
    c.method = std::string(req.method_string());
    c.path = target.substr(0, q);
    c.body = req.body();
    const std::string query = q == std::string::npos ? "" : target.substr(q + 1);
    const std::string scheme = o.version == rws::Version::kRws1 ? "http" : "https";
    const std::string base = fmt::format("{}://{}:{}{}/", scheme, host, port, c.path);
    bool acceptable = true;
    rws::Representation representation = rws::Representation::kXhtml;
    try {
      representation = RepresentationFor(req, query, acceptable);
    } catch (const rws::DecodeError&) {
    }
    auto answer = [&](unsigned status, const rws::Document& doc) {
      res.result(status);
      if (status != 204 && (status >= 300 || !doc.resources.empty() || doc.status)) {
        res.set(bhttp::field::content_type, rws::MediaType(representation));
        res.body() = rws::Format(doc, representation, Service(c.path), base);
      }
      res.prepare_payload();
      return reply;
    };
    if (fault.fault == Fault::kErrorCode)
      return answer(500, Error(fault.code, "internal error (a fault injected by the test)"));
    const std::optional<std::string> session = users.Authenticate(req, res);
    if (!session) return answer(401, {});
    c.session = *session;
    if (!acceptable) return answer(406, Error(0, "Not Acceptable: ask for application/hal+json;v=2.0"));
    if (auto refused = ReadParameters(req, query, c)) return answer(refused->first, refused->second);
    const auto [status, doc] = Route(c);
    return answer(status, doc);
  }

  // ---- Server ----

  template <typename Stream>
  class HttpConnection : public Connection,
                         public std::enable_shared_from_this<HttpConnection<Stream>> {
   public:
    HttpConnection(Impl& impl, Stream stream)
        : impl_(impl), stream_(std::move(stream)), timer_(impl.io) {}

    void Begin() {
      if constexpr (std::is_same_v<Stream, beast::tcp_stream>) {
        Read();
      } else {
        auto self = this->shared_from_this();
        stream_.async_handshake(ssl::stream_base::server,
                                [self](const boost::system::error_code& ec) {
                                  if (!ec) self->Read();
                                });
      }
    }

    void Close() override {
      boost::system::error_code ignored;
      beast::get_lowest_layer(stream_).socket().shutdown(tcp::socket::shutdown_both, ignored);
      beast::get_lowest_layer(stream_).close();
    }

   private:
    void Read() {
      parser_.emplace();
      parser_->body_limit(1024 * 1024);  // a module uploaded to $HOME
      auto self = this->shared_from_this();
      bhttp::async_read(stream_, buffer_, *parser_,
                        [self](const boost::system::error_code& ec, size_t) {
                          if (ec) return self->Close();
                          self->OnRequest(self->parser_->release());
                        });
    }

    void OnRequest(bhttp::request<bhttp::string_body> request) {
      ++impl_.owner.requests_;
      auto reply = std::make_shared<Reply>(impl_.Handle(request));
      if (reply->action == Reply::Action::kClose) return Close();
      if (reply->action == Reply::Action::kSilence) {  // no answer; the connection stays open
        impl_.silent.push_back(this->shared_from_this());
        return;
      }
      timer_.expires_after(
          impl_.clock.Wall(std::chrono::duration<double>(impl_.o.latency).count()));
      auto self = this->shared_from_this();
      timer_.async_wait([self, reply](const boost::system::error_code& ec) {
        if (ec) return;
        self->Write(reply);
      });
    }

    void Write(const std::shared_ptr<Reply>& reply) {
      auto self = this->shared_from_this();
      if (reply->action == Reply::Action::kGarbage ||
          reply->action == Reply::Action::kTruncate) {
        auto bytes = std::make_shared<std::string>();
        if (reply->action == Reply::Action::kGarbage) {
          *bytes = std::string("\x16\x03\x01 this is no HTTP \xff\xfe\r\n\r\n", 27);
        } else {
          std::ostringstream all;
          all << reply->response;
          *bytes = all.str().substr(0, all.str().size() / 2);
        }
        asio::async_write(stream_, asio::buffer(*bytes),
                          [self, bytes](const boost::system::error_code&, size_t) { self->Close(); });
        return;
      }
      bhttp::async_write(stream_, reply->response,
                         [self, reply](const boost::system::error_code& ec, size_t) {
                           if (ec || !reply->response.keep_alive()) return self->Close();
                           self->Read();
                         });
    }

    Impl& impl_;
    Stream stream_;
    asio::steady_timer timer_;
    beast::flat_buffer buffer_;
    std::optional<bhttp::request_parser<bhttp::string_body>> parser_;
  };

  void Listen() {
    acceptor = std::make_unique<tcp::acceptor>(io);
    acceptor->open(endpoint.protocol());
    acceptor->set_option(asio::socket_base::reuse_address(true));
    acceptor->bind(endpoint);
    acceptor->listen();
    endpoint = acceptor->local_endpoint();
    port = endpoint.port();
    Accept();
  }

  void Accept() {
    acceptor->async_accept([this](const boost::system::error_code& ec, tcp::socket socket) {
      if (ec) return;  // closed: the network was cut or the simulator stops
      {
        std::lock_guard lock(mutex);
        ++accepted;
      }
      std::erase_if(connections, [](const std::weak_ptr<Connection>& w) { return w.expired(); });
      if (o.version == rws::Version::kRws1) {
        auto c = std::make_shared<HttpConnection<beast::tcp_stream>>(
            *this, beast::tcp_stream(std::move(socket)));
        connections.push_back(c);
        c->Begin();
      } else {
        using Tls = ssl::stream<beast::tcp_stream>;
        auto c = std::make_shared<HttpConnection<Tls>>(
            *this, Tls(beast::tcp_stream(std::move(socket)), ssl_context));
        connections.push_back(c);
        c->Begin();
      }
      Accept();
    });
  }

  void Tick() {
    tick.expires_after(std::chrono::milliseconds(5));
    tick.async_wait([this](const boost::system::error_code& ec) {
      if (ec) return;
      {
        std::lock_guard lock(mutex);
        Advance();
      }
      Tick();
    });
  }

  // Runs `f` on the io thread and waits for it.
  template <typename F>
  void OnIoThread(F&& f) {
    std::promise<void> done;
    asio::post(io, [&] {
      f();
      done.set_value();
    });
    done.get_future().wait();
  }

  RwsSimulator& owner;
  VirtualLab& lab;
  RwsSimulatorOptions o;
  std::string host;
  unsigned short requested_port;
  unsigned short port = 0;
  asio::io_context io;
  std::optional<asio::executor_work_guard<asio::io_context::executor_type>> work;
  std::thread thread;
  std::unique_ptr<tcp::acceptor> acceptor;
  tcp::endpoint endpoint;
  ssl::context ssl_context;
  asio::steady_timer tick;
  std::vector<std::weak_ptr<Connection>> connections;
  std::vector<std::shared_ptr<Connection>> silent;  // kept open without an answer

  mutable std::mutex mutex;  // everything below
  std::optional<RapidModule> module;
  std::map<std::string, std::string> values;  // upper-case name → value text
  rws::ControllerState ctrl = rws::ControllerState::kMotorsOn;
  rws::OperationMode mode = rws::OperationMode::kAuto;
  bool running = true;
  PhysicalClock clock{o.time_scale};
  std::unique_ptr<VirtualArm> arm;  // moved by the task's MoveAbsJ
  std::unique_ptr<RwsPrograms> rapid_programs;  // loaded modules, the program pointer
  enum class Phase { kWaiting, kMoving, kInterrupted } phase = Phase::kWaiting;
  double request = 0;
  Eigen::VectorXd target_deg_;  // of the move running or interrupted
  bool record_pending = false;  // armsig_record waits for zero speed
  int moves = 0, accepted = 0;
  RwsSessions users{o.version, o.user, o.password};
  std::optional<std::string> mastership;  // the session holding it; "elsewhere"
  std::optional<RwsSimulator::CellStop> armed_stop;  // for the next move
  RwsSimulator::CellStop stop_kind = RwsSimulator::CellStop::kGuardStop;  // of the planned stop
  double armed_fraction = 0.5;
  std::vector<std::string> events;
  std::vector<std::string> log;
  FaultQueue faults;
};

RwsSimulator::RwsSimulator(VirtualLab& lab, RwsSimulatorOptions options, std::string host,
                           unsigned short port)
    : impl_(std::make_unique<Impl>(*this, lab, std::move(options), std::move(host), port)) {}

RwsSimulator::~RwsSimulator() { Stop(); }

void RwsSimulator::Start() {
  Impl& m = *impl_;
  if (m.thread.joinable()) return;
  {
    std::lock_guard lock(m.mutex);
    m.Record();
  }
  if (m.o.version == rws::Version::kRws2) {
    const Certificate cert = MakeCertificate(m.host, "armsig virtual OmniCore");
    SSL_CTX_use_certificate(m.ssl_context.native_handle(), cert.x509.get());
    SSL_CTX_use_PrivateKey(m.ssl_context.native_handle(), cert.key.get());
    certificate_pem_ = cert.pem;
    fingerprint_ = cert.fingerprint;
  }
  try {
    m.endpoint = tcp::endpoint(asio::ip::make_address(m.host), m.requested_port);
    m.Listen();
  } catch (const boost::system::system_error& e) {
    throw std::runtime_error("the virtual ABB controller cannot listen on " + m.host + ":" +
                             std::to_string(m.requested_port) + ": " + e.what());
  }
  port_ = m.port;
  address_ = m.host + ":" + std::to_string(port_);
  m.Tick();
  m.work.emplace(m.io.get_executor());
  m.thread = std::thread([&m] { m.io.run(); });
}

void RwsSimulator::Stop() {
  Impl& m = *impl_;
  if (!m.thread.joinable()) return;
  m.OnIoThread([&m] {
    boost::system::error_code ignored;
    if (m.acceptor) m.acceptor->close(ignored);
    m.tick.cancel();
    for (auto& w : m.connections) {
      if (auto c = w.lock()) c->Close();
    }
    m.silent.clear();
  });
  m.work.reset();
  m.io.stop();
  m.thread.join();
}

void RwsSimulator::InjectOnce(FaultSpec fault) { impl_->faults.Once(fault); }
void RwsSimulator::InjectAlways(FaultSpec fault) { impl_->faults.Always(fault); }
void RwsSimulator::ClearFaults() { impl_->faults.Clear(); }

void RwsSimulator::GuardStop() {
  std::lock_guard lock(impl_->mutex);
  impl_->StopBy(CellStop::kGuardStop);
}

void RwsSimulator::EmergencyStop() {
  std::lock_guard lock(impl_->mutex);
  impl_->StopBy(CellStop::kEmergencyStop);
}

void RwsSimulator::StopDuringNextMove(CellStop stop, double fraction) {
  std::lock_guard lock(impl_->mutex);
  impl_->armed_stop = stop;
  impl_->armed_fraction = std::clamp(fraction, 0.0, 1.0);
}

void RwsSimulator::ResetStop() {
  std::lock_guard lock(impl_->mutex);
  using CS = rws::ControllerState;
  if (impl_->ctrl == CS::kGuardStop) {
    impl_->arm->ClearProtectiveStop();
    impl_->ctrl = CS::kMotorsOff;
  } else if (impl_->ctrl == CS::kEmergencyStop || impl_->ctrl == CS::kEmergencyStopReset) {
    impl_->arm->ReleaseEmergencyStop();
    impl_->ctrl = CS::kMotorsOff;
  }
}

void RwsSimulator::SetMotors(bool on) {
  std::lock_guard lock(impl_->mutex);
  if (on) {
    if (impl_->ctrl == rws::ControllerState::kMotorsOff && impl_->arm->PowerOn()) {
      impl_->ctrl = rws::ControllerState::kMotorsOn;
    }
  } else if (impl_->ctrl == rws::ControllerState::kMotorsOn) {
    impl_->StopTask();
    impl_->ctrl = rws::ControllerState::kMotorsOff;
  }
}

void RwsSimulator::SetMode(rws::OperationMode mode) {
  std::lock_guard lock(impl_->mutex);
  if (mode == impl_->mode) return;
  impl_->StopTask();  // turning the key stops the program and switches the motors off
  if (impl_->ctrl == rws::ControllerState::kMotorsOn) impl_->ctrl = rws::ControllerState::kMotorsOff;
  impl_->mode = mode;
}

bool RwsSimulator::StartProgram(bool from_main) {
  std::lock_guard lock(impl_->mutex);
  return impl_->StartTask(from_main);
}

void RwsSimulator::StopProgram() {
  std::lock_guard lock(impl_->mutex);
  impl_->StopTask();
}

void RwsSimulator::Recover() {
  ResetStop();
  SetMotors(true);
  StartProgram(false);
}

void RwsSimulator::CutNetwork() {
  Impl& m = *impl_;
  m.OnIoThread([&m] {
    boost::system::error_code ignored;
    if (m.acceptor) m.acceptor->close(ignored);
    for (auto& w : m.connections) {
      if (auto c = w.lock()) c->Close();
    }
    m.connections.clear();
    m.silent.clear();
  });
}

void RwsSimulator::RestoreNetwork() {
  Impl& m = *impl_;
  m.OnIoThread([&m] {
    if (m.acceptor && m.acceptor->is_open()) return;
    m.Listen();
  });
}

void RwsSimulator::RequestMoveElsewhere(const Eigen::VectorXd& joints_deg) {
  std::lock_guard lock(impl_->mutex);
  rws::JointTarget t;
  for (int i = 0; i < 6; ++i) t.robax_deg[static_cast<size_t>(i)] = joints_deg(i);
  impl_->values["ARMSIG_TARGET"] = rws::FormatRapidJointTarget(t);
  impl_->SetNum("armsig_cmd", impl_->Num("armsig_cmd") + 1);
  impl_->Advance();
}

void RwsSimulator::TurnBehindModule(int joint, double deg_per_s) {
  std::lock_guard lock(impl_->mutex);
  impl_->arm->Drift(joint, deg_per_s * kRadPerDeg);
}

void RwsSimulator::TurnAfterNextMove(int joint, double deg_per_s, double delay_s, double for_s) {
  std::lock_guard lock(impl_->mutex);
  impl_->arm->DriftAfterNextMove(joint, deg_per_s * kRadPerDeg, delay_s, for_s);
}

void RwsSimulator::HoldMastershipElsewhere(bool held) {
  std::lock_guard lock(impl_->mutex);
  if (held)
    impl_->mastership = "elsewhere";
  else if (impl_->mastership == "elsewhere")
    impl_->mastership.reset();
}

RwsSimulator::Snapshot RwsSimulator::snapshot() const {
  std::lock_guard lock(impl_->mutex);
  impl_->Advance();
  Snapshot s;
  s.controller = impl_->ctrl;
  s.mode = impl_->mode;
  s.running = impl_->running;
  const VirtualArm::State arm = impl_->arm->Now();
  s.moving = arm.moving;
  s.joints_deg = arm.q / kRadPerDeg;
  if (impl_->HasContract()) {
    s.cmd = impl_->Num("armsig_cmd");
    s.done = impl_->Num("armsig_done");
    s.error = impl_->Num("armsig_error");
  }
  s.moves = impl_->moves;
  s.logins = impl_->users.logins();
  s.refused_logins = impl_->users.refused_logins();
  s.connections = impl_->accepted;
  s.routines_run = impl_->rapid_programs->routines_run();
  s.program_pointer = impl_->rapid_programs->Pointer();
  return s;
}

std::string RwsSimulator::Symbol(const std::string& name) const {
  std::lock_guard lock(impl_->mutex);
  const auto it = impl_->values.find(Upper(name));
  return it == impl_->values.end() ? "" : it->second;
}

std::vector<std::string> RwsSimulator::request_log() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->log;
}

}  // namespace armsig::simulation
