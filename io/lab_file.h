// The lab file (YAML), read and written: the robot and its controller or encoder box, the
// instruments and the stations they stand on, the tolerances of a capture session.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "calibration/model.h"
#include "instruments/device.h"
#include "robots/robot_codec.h"
#include "instruments/transport.h"
#include "reduction/network.h"

namespace armsig::io {

// A TCP address, checked where it is read (the lab file's `tcp:`, --tcp) and kept whole.
struct HostPort {
  std::string host;
  unsigned short port = 0;
  std::string Text() const;  // HOST:PORT
};

// The protocol an instrument speaks (the lab file's `protocol:`).
enum class InstrumentProtocol {
  kGeoCom,  // Leica GeoCOM (serial or TCP)
  kGsi,     // Leica GSI online (serial or TCP)
  kEmScon,  // a laser tracker's emScon server: binary packets over TCP, always distances
};
const char* NameOf(InstrumentProtocol protocol);  // geocom | gsi | emscon
std::optional<InstrumentProtocol> InstrumentProtocolNamed(const std::string& name);

struct InstrumentConfig {
  std::string station;  // station id (matches the stations file / orientation)
  InstrumentProtocol protocol = InstrumentProtocol::kGeoCom;
  std::string port;              // serial path, or empty with tcp
  std::optional<HostPort> tcp;   // or the instrument's address
  // Where it is reached, as a person names it: the address or the serial path.
  std::string Where() const { return tcp ? tcp->Text() : port; }
  unsigned baud = 19200;
  bool crc = false;
  bool distance = false;  // measure distances (laser tracker / total station)
  // A-priori sigmas; a laser tracker's readings carry their own, which take their place.
  double sigma_hz_arcsec = 0.5, sigma_v_arcsec = 0.5, sigma_distance_mm = 0.5;
  int measurement_time_ms = 500;  // emscon: the stationary measurement averages this long
};

// The protocol a robot controller speaks (the lab file's controller `protocol:`).
enum class ControllerProtocol {
  kValII,       // val: a Unimation VAL II monitor on a serial port
  kKawasakiAs,  // as: a Kawasaki AS monitor on a serial port
  kCounter,     // counter: an encoder counter box, one serial port per joint
  kUr,          // the network controllers (NetworkControllerProtocols)
  kAbb,
  kKuka,
};
const char* NameOf(ControllerProtocol protocol);  // val | as | counter | ur | abb | kuka
std::optional<ControllerProtocol> ControllerProtocolNamed(const std::string& name);

struct ControllerConfig {
  ControllerProtocol protocol = ControllerProtocol::kValII;
  std::string port;
  unsigned baud = 9600;
  bool can_move = false;                   // armsig commands the moves (else the operator does)
  std::vector<std::string> counter_ports;  // counter: one per joint
  robots::EncoderCalibration encoders;
  // A controller on the network (NetworkControllerProtocols): its address and every port
  // its protocol names, the defaults filled in (ur: rtde_port 30004, primary_port 30001,
  // secondary_port 30002, dashboard_port 29999).
  std::string host;
  std::map<std::string, unsigned short> ports;
  // `credentials: FILE` (resolved against the lab file's folder) for a protocol that logs in;
  // empty: the environment (io/credentials.h). Never the secret itself.
  std::string credentials_path;
  // The protocol's own settings beyond ports and credentials (NetworkControllerProtocol::
  // settings), as written.
  std::map<std::string, std::string> settings;

  // The port called `key`, its default when the lab file did not give it.
  unsigned short Port(const std::string& key) const;
};

// A robot controller reached over the network, as the lab file names it:
// `{protocol: NAME, host: HOST, can_move: …, <port keys>: N, credentials: FILE, <settings>}`.
// Adding a controller is one entry here (its keys) and one in acquisition/lab.cc (its
// device); the lab file refuses every key its protocol does not name.
struct NetworkControllerProtocol {
  ControllerProtocol id;
  std::string name;         // the lab file's protocol: ur
  std::string description;  // "Universal Robots (CB3 from 3.4, e-Series)"
  std::vector<std::pair<std::string, unsigned short>> ports;  // optional keys, their defaults
  // The port `armsig instrument probe --tcp HOST:PORT` names (its key in `ports`).
  std::string tcp_port;
  bool credentials = false;            // takes `credentials: FILE`
  std::vector<std::string> settings;   // further optional keys (texts)
};
const std::vector<NetworkControllerProtocol>& NetworkControllerProtocols();
// nullptr for a protocol that is not a network controller's (val, as, counter).
const NetworkControllerProtocol* FindNetworkControllerProtocol(const std::string& name);
const NetworkControllerProtocol* FindNetworkControllerProtocol(ControllerProtocol protocol);

struct Tolerances {
  double max_miss_mm = 0.2;        // largest ray miss distance of an accepted point
  double max_repeat_mm = 0.05;     // agreement of repeated readings
  int readings = 1;                // readings per configuration (≥ 2 checks repeatability)
  int max_remeasure = 3;           // automatic re-measurements before giving up
  int settle_ms = 300;             // wait after a move
  int fault_retries = 2;           // session-level retries of a failing instrument
  int fault_retry_delay_ms = 500;  // wait before each retry (a port coming back, an operator)
  bool two_face = false;           // measure in both faces
  // Laser trackers, against the sigmas they state with each reading: a reading whose
  // largest one-sigma error exceeds max_sigma_mm is flagged (sigma_exceeded) and measured
  // again; repeated readings (readings ≥ 2) of one tracker that differ by more than
  // max_repeat_sigma of their combined sigma are flagged (repeat_exceeded) and measured
  // again.
  double max_sigma_mm = 0.05;
  double max_repeat_sigma = 4.0;
  // Do the measured points follow the robot? The best rigid robot base (fitted from the
  // third point on) may leave at most this rms, mm: an uncalibrated robot misses by
  // millimetres, a reflector that is not on the flange or a wrong tool offset by far more.
  // The session pauses, naming what it found.
  double max_base_fit_rms_mm = 25.0;
  // A controller armsig moves: the joints it reads back may differ from the commanded ones
  // by at most this (degrees) on any joint. More means the robot is not where the plan put
  // it (another program drives it, it stopped at a limit or a fence): a fault of the
  // configuration, retried, then the session pauses.
  double max_joint_error_deg = 0.1;
};

// The lab file's `recalibration:` block: gates of the nightly job. An absent key is
// nullopt (the job then takes its option, else its default).
struct RecalibrationSettings {
  std::optional<double> max_validation_mean_mm;
  std::optional<double> max_validation_max_mm;
  std::optional<double> tolerance_mm;
  std::optional<double> drift_sigma;
  std::optional<double> drift_mm;  // smallest change of predicted positions called drift
  // `window: {sessions: N, days: D}`: the sessions a nightly fit may use — the newest N
  // (0: no limit), started within the last D days (0: no limit).
  std::optional<int> window_sessions, window_days;
};

// What a lab text says, read without opening the files it names: works on the lab YAML a
// session stored in the database even when its model or stations file is gone. The whole
// text is checked (unknown keys refused everywhere), not only the parts returned.
struct LabSettings {
  std::string robot_model_path;  // resolved against the lab file's folder
  // `robot: base:` — world (lab frame) from robot base, when the lab knows it; laser
  // trackers point their beam through it until enough points are measured to fit it.
  std::optional<Eigen::Isometry3d> robot_base;
  ControllerConfig controller;
  std::vector<InstrumentConfig> instruments;
  std::string stations_path;                        // `stations: FILE` (resolved), else empty
  std::vector<reduction::Station> inline_stations;  // `stations: [...]`
  Tolerances tolerances;
  instruments::RetryPolicy policy;  // timeout from tolerances.timeout_ms
  std::optional<RecalibrationSettings> recalibration;
};

struct LabConfig {
  std::string source;  // file it came from
  std::string text;    // the YAML as read (stored with the session)
  std::string robot_model_path;
  std::string model_yaml;  // the robot model file's text (stored with the robot)
  calibration::RobotModel model;
  std::optional<Eigen::Isometry3d> robot_base;  // world from robot base (`robot: base:`)
  ControllerConfig controller;
  std::vector<InstrumentConfig> instruments;
  std::vector<reduction::Station> stations;  // oriented stations (from the stations file)
  Tolerances tolerances;
  instruments::RetryPolicy policy;
  std::optional<RecalibrationSettings> recalibration;
};

// Throws InputError with file, line and column: malformed YAML, a wrong shape, an unknown
// or misspelt key (naming the nearest valid one), a model or stations file that cannot be
// read. Stations (from a file or inline) go through io::ParseStationsList.
LabConfig LoadLab(const std::string& path);
LabConfig ParseLab(const std::string& text, const std::string& source);
// The same checks on the text alone; relative paths resolve against `source`'s folder.
LabSettings ParseLabSettings(const std::string& text, const std::string& source);
// The settings of the lab file a session was captured with (sessions.lab_yaml), the one
// reader of every command that uses them (reduce, recalibrate, the reports): nullopt for a
// session stored without one (imported poses); a stored text that no longer reads is an
// InputError naming the session and the database ("lab file stored with session 4 in
// lab.db:3:7: …").
std::optional<LabSettings> StoredLabSettings(const std::string& lab_yaml, int64_t session,
                                             const std::string& db_path);

// A lab file's text (YAML::Emitter) from its parts, as a technician would write it: the
// model and stations by file name, every instrument and the controller with the keys
// that differ from their defaults, the tolerances and the device timeout in full.
struct LabFile {
  std::string model_path, stations_path;
  ControllerConfig controller;
  std::optional<Eigen::Isometry3d> robot_base;  // `robot: base:` when given
  std::vector<InstrumentConfig> instruments;
  Tolerances tolerances;
  int timeout_ms = 3000;
};
std::string FormatLabYaml(const LabFile& lab);
// "HOST:PORT" with a port from 1 to 65535, else nullopt.
std::optional<HostPort> SplitHostPort(const std::string& text);
}  // namespace armsig::io
