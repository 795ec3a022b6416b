// The emScon TPI codec against byte sequences written out by hand from the public layout
// (ES_C_API_Def.h, pack(4), little-endian; instruments/EMSCON.md §3 and the worked
// examples of §6), never produced by our own encoder: each vector is annotated with its
// fields at their offsets. Decoding them must give the values; encoding the values must
// give the same bytes. Then framing: several packets in one read, packets split across
// reads, a status packet between a command's reply and its result, truncated packets and
// size fields out of bounds.
#include "instruments/emscon_codec.h"

#include <gtest/gtest.h>

#include <cctype>
#include <chrono>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "test_support.h"

namespace armsig::instruments::emscon {
namespace {

using ::armsig::testing::Hex;

template <typename T>
T DecodeAs(const std::string& frame) {
  const DecodedPacket d = DecodePacket(frame);
  EXPECT_FALSE(d.error) << d.why;
  EXPECT_TRUE(d.packet);
  EXPECT_TRUE(d.packet && std::holds_alternative<T>(*d.packet));
  return d.packet && std::holds_alternative<T>(*d.packet) ? std::get<T>(*d.packet) : T{};
}

// --- Hand-written vectors (EMSCON.md §6 and more) --------------------------------------

// V1: GetSystemStatus, a bare BasicCommandCT: size 12, type 0 (command), command 1.
const std::string kGetSystemStatus = Hex("0C 00 00 00  00 00 00 00  01 00 00 00");

// V3: SetUnits(mm = 1, degree = 1, Celsius = 0, hPa = 1, RH = 0): 32 bytes.
const std::string kSetUnitsDegrees =
    Hex("20 00 00 00  00 00 00 00  05 00 00 00"  // size 32, type 0, command 5
        "01 00 00 00  01 00 00 00  00 00 00 00"  // 12 length unit, 16 angle unit, 20 temperature
        "01 00 00 00  00 00 00 00");             // 24 pressure unit, 28 humidity unit

// armsig's own: mm = 1, radian = 0, Celsius = 0, mbar = 0, RH = 0.
const std::string kSetUnitsArmsig =
    Hex("20 00 00 00  00 00 00 00  05 00 00 00"
        "01 00 00 00  00 00 00 00  00 00 00 00"
        "00 00 00 00  00 00 00 00");

// SetCoordinateSystemType(SCW = 6): size 16, command 26 = 0x1A.
const std::string kSetScw = Hex("10 00 00 00  00 00 00 00  1A 00 00 00  06 00 00 00");
// SetMeasurementMode(stationary = 0): command 24 = 0x18.
const std::string kSetStationary = Hex("10 00 00 00  00 00 00 00  18 00 00 00  00 00 00 00");
// V9: SetStationaryModeParams(lMeasTime 1000 ms = 0x3E8, bUseADM 0): 20 bytes, command 28.
const std::string kStationaryParams =
    Hex("14 00 00 00  00 00 00 00  1C 00 00 00  E8 03 00 00  00 00 00 00");
// SetReflector(2): command 40 = 0x28.
const std::string kSetReflector2 = Hex("10 00 00 00  00 00 00 00  28 00 00 00  02 00 00 00");
// StartMeasurement: a bare command, 49 = 0x31.
const std::string kStartMeasurement = Hex("0C 00 00 00  00 00 00 00  31 00 00 00");
// GoPosition(0.5, 1.5, 2000.0, bUseADM 1): 40 bytes, command 55 = 0x37; 0.5 = 0x3FE0…,
// 1.5 = 0x3FF8…, 2000 = 0x409F4000….
const std::string kGoPosition =
    Hex("28 00 00 00  00 00 00 00  37 00 00 00"
        "00 00 00 00 00 00 E0 3F"  // 12 dVal1 0.5
        "00 00 00 00 00 00 F8 3F"  // 20 dVal2 1.5
        "00 00 00 00 00 40 9F 40"  // 28 dVal3 2000.0
        "01 00 00 00");            // 36 bUseADM
// FindReflector(5000.0 = 0x40B3880000000000): 20 bytes, command 63 = 0x3F.
const std::string kFindReflector =
    Hex("14 00 00 00  00 00 00 00  3F 00 00 00  00 00 00 00 00 88 B3 40");
// SetSystemSettings: weather 2, transformation 0, orientation 0, keep last position 1,
// unsolicited 1, position stream 0, try mode 0, nivel 1, camera 0: 48 bytes, command 47.
const std::string kSetSettings =
    Hex("30 00 00 00  00 00 00 00  2F 00 00 00"
        "02 00 00 00  00 00 00 00  00 00 00 00  01 00 00 00  01 00 00 00"
        "00 00 00 00  00 00 00 00  01 00 00 00  00 00 00 00");
// GetLongSystemParameter(5002 = 0x138A): 16 bytes, command 121 = 0x79.
const std::string kGetInclination = Hex("10 00 00 00  00 00 00 00  79 00 00 00  8A 13 00 00");

// V2: Initialize reply AllOK (BasicCommandRT): size 16, type 0, command 7, status 0.
const std::string kInitializeOk = Hex("10 00 00 00  00 00 00 00  07 00 00 00  00 00 00 00");
// V4: ErrorResponseT: type 1, command 49, status 37 (NoDistanceSet).
const std::string kBeamBroken = Hex("10 00 00 00  01 00 00 00  31 00 00 00  25 00 00 00");
// V5: SystemStatusChangeT: type 8, value 27 (MeasStatus_Ready).
const std::string kReady = Hex("0C 00 00 00  08 00 00 00  1B 00 00 00");
// V6: GetSystemStatusRT, 56 bytes.
const std::string kSystemStatus = Hex(
    "38 00 00 00  00 00 00 00  01 00 00 00  00 00 00 00"  // size 56, command 1, status 0
    "00 00 00 00  05 00 00 00  03 00 00 00  02 00 00 00"  // last result 0, TPS 5, laser 3, ADM 2
    "03 00 00 00  06 00 00 00  D2 04 00 00  00 00 00 00"  // version 3.6.1234, weather 0
    "00 00 00 00  42 F8 05 00");                          // flags 0, serial 391234
// V7: SingleMeasResultT, 156 bytes (0x9C).
const std::string kSingleMeasResult =
    Hex("9C 00 00 00  02 00 00 00"                          // size 156, type 2
        "00 00 00 00  00 00 00 00  00 00 00 00"             // 8 status, 12 mode, 16 try mode
        "00 00 00 00 00 4A 93 40"                           // 20 dVal1 1234.5
        "00 00 00 00 00 48 6F C0"                           // 28 dVal2 -250.25
        "00 00 00 00 00 00 C0 3F"                           // 36 dVal3 0.125
        "00 00 00 00 00 00 80 3F  00 00 00 00 00 00 90 3F"  // 44, 52 dStd1 2^-7, dStd2 2^-6
        "00 00 00 00 00 00 A0 3F  00 00 00 00 00 00 B0 3F"  // 60 dStd3 2^-5, 68 total 2^-4
        "00 00 00 00 00 00 00 00  00 00 00 00 00 00 00 00"  // 76, 84 pointing errors
        "00 00 00 00 00 00 00 00"                           // 92 pointing error 3
        "00 00 00 00 00 00 80 3F  00 00 00 00 00 00 90 3F"  // 100, 108 a-priori std 1, 2
        "00 00 00 00 00 00 A0 3F  00 00 00 00 00 00 B0 3F"  // 116 std 3, 124 total
        "00 00 00 00 00 80 34 40"                           // 132 temperature 20.5
        "00 00 00 00 00 AA 8F 40"                           // 140 pressure 1013.25
        "00 00 00 00 00 80 46 40");                         // 148 humidity 45.0
// SingleMeasResult2T, 204 bytes (0xCC), type 9: the same values, dCovar12 0.5 at 76,
// temperature at 180, pressure at 188, humidity at 196, all else zero.
const std::string kSingleMeasResult2 =
    Hex("CC 00 00 00  09 00 00 00  00 00 00 00  00 00 00 00  00 00 00 00"
        "00 00 00 00 00 4A 93 40  00 00 00 00 00 48 6F C0  00 00 00 00 00 00 C0 3F"  // 20..43
        "00 00 00 00 00 00 80 3F  00 00 00 00 00 00 90 3F  00 00 00 00 00 00 A0 3F"  // 44..67
        "00 00 00 00 00 00 B0 3F"                                                    // 68 total
        "00 00 00 00 00 00 E0 3F  00 00 00 00 00 00 00 00  00 00 00 00 00 00 00 00"  // 76 covars
        "00 00 00 00 00 00 00 00  00 00 00 00 00 00 00 00  00 00 00 00 00 00 00 00"  // 100 pointing
        "00 00 00 00 00 00 00 00  00 00 00 00 00 00 00 00  00 00 00 00 00 00 00 00"  // 124 a priori
        "00 00 00 00 00 00 00 00"                                                    // 148 total
        "00 00 00 00 00 00 00 00  00 00 00 00 00 00 00 00  00 00 00 00 00 00 00 00"  // 156 covars
        "00 00 00 00 00 80 34 40  00 00 00 00 00 AA 8F 40  00 00 00 00 00 80 46 40");
// GetEnvironmentParamsRT, 40 bytes: command 21, T 20.5, p 1013.25, RH 45.0.
const std::string kEnvironment =
    Hex("28 00 00 00  00 00 00 00  15 00 00 00  00 00 00 00"
        "00 00 00 00 00 80 34 40  00 00 00 00 00 AA 8F 40  00 00 00 00 00 80 46 40");
// GetReflectorsRT, 100 bytes: total 2, id 3, target type 5 (RRR15), surface offset 0.0,
// name "RRR 1.5in" in UTF-16LE, zero-terminated inside 32 code units.
const std::string kReflector =
    Hex("64 00 00 00  00 00 00 00  2A 00 00 00  00 00 00 00"
        "02 00 00 00  03 00 00 00  05 00 00 00  00 00 00 00 00 00 00 00"  // 16 total, 20 id,
                                                                          // 24 type, 28 offset
        "52 00 52 00 52 00 20 00 31 00 2E 00 35 00 69 00 6E 00"           // 36 "RRR 1.5in"
        "00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00"    // 9 + 23 = 32
        "00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00");  // code units
// GetSystemSettingsRT, 52 bytes: weather 2, transformation 1, orientation 1, keep 0,
// unsolicited 0, stream 1, try 0, nivel 1, camera 0.
const std::string kSettings =
    Hex("34 00 00 00  00 00 00 00  30 00 00 00  00 00 00 00"
        "02 00 00 00  01 00 00 00  01 00 00 00  00 00 00 00  00 00 00 00"
        "01 00 00 00  00 00 00 00  01 00 00 00  00 00 00 00");
// GetFace reply: face 2.
const std::string kFace2 = Hex("14 00 00 00  00 00 00 00  62 00 00 00  00 00 00 00  02 00 00 00");
// GetLongSystemParameter reply: parameter 5002, value 2.
const std::string kInclination =
    Hex("18 00 00 00  00 00 00 00  79 00 00 00  00 00 00 00  8A 13 00 00  02 00 00 00");
// ReflectorPosResultT, 36 bytes, type 7: status 0, (1.0, 1.5, 2000.0).
const std::string kReflectorPosition =
    Hex("24 00 00 00  07 00 00 00  00 00 00 00"
        "00 00 00 00 00 00 F0 3F  00 00 00 00 00 00 F8 3F  00 00 00 00 00 40 9F 40");

}  // namespace

TEST(EmsconCodec, CommandsEncodeToTheHandWrittenBytes) {
  EXPECT_EQ(EncodeRequest(GetSystemStatus{}), kGetSystemStatus);
  EXPECT_EQ(EncodeRequest(
                SetUnits{{length_unit::kMillimeter, angle_unit::kDegree, temperature_unit::kCelsius,
                          pressure_unit::kHPascal, humidity_unit::kRelativeHumidity}}),
            kSetUnitsDegrees);
  EXPECT_EQ(EncodeRequest(SetUnits{}), kSetUnitsArmsig);  // the defaults are armsig's units
  EXPECT_EQ(EncodeRequest(SetCoordinateSystemType{coordinate_system::kSCW}), kSetScw);
  EXPECT_EQ(EncodeRequest(SetMeasurementMode{meas_mode::kStationary}), kSetStationary);
  EXPECT_EQ(EncodeRequest(SetStationaryModeParams{1000, false}), kStationaryParams);
  EXPECT_EQ(EncodeRequest(SetReflector{2}), kSetReflector2);
  EXPECT_EQ(EncodeRequest(StartMeasurement{}), kStartMeasurement);
  EXPECT_EQ(EncodeRequest(GoPosition{0.5, 1.5, 2000.0, true}), kGoPosition);
  EXPECT_EQ(EncodeRequest(FindReflector{5000.0}), kFindReflector);
  SystemSettings s;
  s.weather_monitor_status = 2;
  s.keep_last_position = true;
  s.send_unsolicited_messages = true;
  s.has_nivel = true;
  EXPECT_EQ(EncodeRequest(SetSystemSettings{s}), kSetSettings);
  EXPECT_EQ(EncodeRequest(GetLongSystemParameter{system_parameter::kInclinationSensorState}),
            kGetInclination);
  EXPECT_EQ(EncodeRequest(Initialize{}), Hex("0C 00 00 00 00 00 00 00 07 00 00 00"));
}

TEST(EmsconCodec, CommandsDecodeFromTheHandWrittenBytes) {
  const auto decode = [](const std::string& bytes) {
    const DecodedRequest d = DecodeRequest(bytes);
    EXPECT_FALSE(d.error) << d.why;
    return d.request.value_or(Request{Initialize{}});
  };
  EXPECT_EQ(decode(kGetSystemStatus), Request{GetSystemStatus{}});
  EXPECT_EQ(decode(kSetUnitsDegrees), (Request{SetUnits{{1, 1, 0, 1, 0}}}));
  EXPECT_EQ(decode(kSetScw), Request{SetCoordinateSystemType{6}});
  EXPECT_EQ(decode(kStationaryParams), (Request{SetStationaryModeParams{1000, false}}));
  EXPECT_EQ(decode(kGoPosition), (Request{GoPosition{0.5, 1.5, 2000.0, true}}));
  EXPECT_EQ(decode(kFindReflector), Request{FindReflector{5000.0}});
  const auto settings = std::get<SetSystemSettings>(decode(kSetSettings)).settings;
  EXPECT_EQ(settings.weather_monitor_status, 2);
  EXPECT_FALSE(settings.apply_transformation);
  EXPECT_TRUE(settings.keep_last_position);
  EXPECT_TRUE(settings.send_unsolicited_messages);
  EXPECT_TRUE(settings.has_nivel);
  EXPECT_FALSE(settings.has_video_camera);
  // A known command with the wrong size, and a command this codec does not model.
  const DecodedRequest short_units =
      DecodeRequest(kSetUnitsDegrees.substr(0, 28).replace(0, 1, "\x1C"));
  EXPECT_EQ(short_units.error, DecodeError::kBadLength) << short_units.why;
  const DecodedRequest park = DecodeRequest(Hex("0C 00 00 00 00 00 00 00 0A 00 00 00"));
  EXPECT_EQ(park.error, DecodeError::kUnknownType);
  EXPECT_EQ(park.command, 10);  // a server can still answer it NotImplemented
}

TEST(EmsconCodec, RepliesDecodeFromTheHandWrittenBytesAndEncodeBack) {
  const auto ok = DecodeAs<CommandAnswer>(kInitializeOk);
  EXPECT_EQ(ok.command, 7);
  EXPECT_EQ(ok.status, status::kAllOk);
  EXPECT_EQ(EncodePacket(ok), kInitializeOk);

  const auto st = DecodeAs<CommandAnswer>(kSystemStatus);
  ASSERT_TRUE(std::holds_alternative<SystemStatus>(st.data));
  const auto& s = std::get<SystemStatus>(st.data);
  EXPECT_EQ(s.tracker_processor_status, tracker_processor_status::kInitialized);
  EXPECT_EQ(s.laser_status, 3);
  EXPECT_EQ(s.adm_status, 2);
  EXPECT_EQ(s.version_major, 3);
  EXPECT_EQ(s.version_minor, 6);
  EXPECT_EQ(s.version_build, 1234);
  EXPECT_EQ(s.serial, 391234);
  EXPECT_EQ(EncodePacket(st), kSystemStatus);

  const auto env = DecodeAs<CommandAnswer>(kEnvironment);
  const auto& e = std::get<EnvironmentParams>(env.data);
  EXPECT_EQ(e.temperature, 20.5);
  EXPECT_EQ(e.pressure, 1013.25);
  EXPECT_EQ(e.humidity, 45.0);
  EXPECT_EQ(EncodePacket(env), kEnvironment);

  const auto refl = DecodeAs<CommandAnswer>(kReflector);
  const auto& r = std::get<ReflectorInfo>(refl.data);
  EXPECT_EQ(r.total, 2);
  EXPECT_EQ(r.id, 3);
  EXPECT_EQ(r.target_type, 5);
  EXPECT_EQ(r.name, "RRR 1.5in");
  EXPECT_EQ(EncodePacket(refl), kReflector);

  const auto set = DecodeAs<CommandAnswer>(kSettings);
  const auto& ss = std::get<SystemSettings>(set.data);
  EXPECT_TRUE(ss.apply_transformation);
  EXPECT_TRUE(ss.apply_station_orientation);
  EXPECT_FALSE(ss.send_unsolicited_messages);
  EXPECT_TRUE(ss.send_reflector_position);
  EXPECT_EQ(EncodePacket(set), kSettings);

  const auto face = DecodeAs<CommandAnswer>(kFace2);
  EXPECT_EQ(std::get<Int32Value>(face.data).value, 2);
  EXPECT_EQ(EncodePacket(face), kFace2);
  const auto incl = DecodeAs<CommandAnswer>(kInclination);
  EXPECT_EQ(std::get<LongParameter>(incl.data), (LongParameter{5002, 2}));
  EXPECT_EQ(EncodePacket(incl), kInclination);
}

TEST(EmsconCodec, ErrorStatusChangeAndPositionPacketsFromTheHandWrittenBytes) {
  const auto err = DecodeAs<ErrorResponse>(kBeamBroken);
  EXPECT_EQ(err.command, StartMeasurement::kCommand);
  EXPECT_EQ(err.status, status::kNoDistanceSet);
  EXPECT_EQ(EncodePacket(err), kBeamBroken);
  const auto ready = DecodeAs<StatusChange>(kReady);
  EXPECT_EQ(ready.change, status_change::kMeasStatusReady);
  EXPECT_EQ(EncodePacket(ready), kReady);
  const auto pos = DecodeAs<ReflectorPosition>(kReflectorPosition);
  EXPECT_EQ(pos.value, (std::array<double, 3>{1.0, 1.5, 2000.0}));
  EXPECT_EQ(EncodePacket(pos), kReflectorPosition);
}

TEST(EmsconCodec, SingleMeasResultFieldsAtTheirPacked4Offsets) {
  ASSERT_EQ(kSingleMeasResult.size(), 156u);  // 160 with natural alignment: wrong
  const auto m = DecodeAs<MeasResult>(kSingleMeasResult);
  EXPECT_FALSE(m.extended);
  EXPECT_EQ(m.status, 0);
  EXPECT_EQ(m.value, (std::array<double, 3>{1234.5, -250.25, 0.125}));
  EXPECT_EQ(m.std_dev, (std::array<double, 3>{0.0078125, 0.015625, 0.03125}));
  EXPECT_EQ(m.std_total, 0.0625);
  EXPECT_EQ(m.apriori_std, (std::array<double, 3>{0.0078125, 0.015625, 0.03125}));
  EXPECT_EQ(m.apriori_std_total, 0.0625);
  EXPECT_EQ(m.temperature, 20.5);
  EXPECT_EQ(m.pressure, 1013.25);
  EXPECT_EQ(m.humidity, 45.0);
  EXPECT_EQ(EncodePacket(m), kSingleMeasResult);

  const auto m2 = DecodeAs<MeasResult>(kSingleMeasResult2);
  EXPECT_TRUE(m2.extended);
  EXPECT_EQ(m2.value, m.value);
  EXPECT_EQ(m2.std_dev, m.std_dev);
  EXPECT_EQ(m2.covariance, (std::array<double, 3>{0.5, 0.0, 0.0}));
  EXPECT_EQ(m2.temperature, 20.5);
  EXPECT_EQ(m2.pressure, 1013.25);
  EXPECT_EQ(m2.humidity, 45.0);
  EXPECT_EQ(EncodePacket(m2), kSingleMeasResult2);
}

// SetContinuousTimeModeParams(lTimeSeparation 50 ms, lNumberOfPoints 0, bUseRegion 0,
// regionType 0): 28 bytes, command 30 = 0x1E; StopMeasurement: 12 bytes, command 52 = 0x34.
const std::string kContinuousTime50 =
    Hex("1C 00 00 00  00 00 00 00  1E 00 00 00"   // size 28, type 0, command 30
        "32 00 00 00  00 00 00 00  00 00 00 00"   // 12 separation 50, 16 points 0, 20 region off
        "00 00 00 00");                           // 24 region type
const std::string kStopMeasurement = Hex("0C 00 00 00  00 00 00 00  34 00 00 00");

// MultiMeasResultT (type 3) with two MeasValueT records: 48 + 2 × 36 = 120 bytes.
const std::string kMultiMeasResult =
    Hex("78 00 00 00  03 00 00 00  00 00 00 00"  // size 120, type 3, status 0
        "02 00 00 00  01 00 00 00  00 00 00 00"  // 12 records 2, 16 mode ContinuousTime, 20 try 0
        "00 00 00 00 00 80 34 40"                // 24 temperature 20.5
        "00 00 00 00 00 AA 8F 40"                // 32 pressure 1013.25
        "00 00 00 00 00 80 46 40"                // 40 humidity 45
        // record 1 at 48: status 0, lTime1 100 s, lTime2 250000 µs, 1.5, 0.25, 2000
        "00 00 00 00  64 00 00 00  90 D0 03 00"
        "00 00 00 00 00 00 F8 3F  00 00 00 00 00 00 D0 3F  00 00 00 00 00 40 9F 40"
        // record 2 at 84: status 3 (PrismError), lTime1 100, lTime2 300000, -0.5, 3, 2000
        "03 00 00 00  64 00 00 00  E0 93 04 00"
        "00 00 00 00 00 00 E0 BF  00 00 00 00 00 00 08 40  00 00 00 00 00 40 9F 40");

TEST(EmsconCodec, ContinuousCommandsAndMultiMeasResultFromTheHandWrittenBytes) {
  EXPECT_EQ(EncodeRequest(SetContinuousTimeModeParams{50, 0, false, region_type::kSphere}),
            kContinuousTime50);
  EXPECT_EQ(EncodeRequest(StopMeasurement{}), kStopMeasurement);
  const DecodedRequest r = DecodeRequest(kContinuousTime50);
  ASSERT_TRUE(r.request);
  EXPECT_EQ(std::get<SetContinuousTimeModeParams>(*r.request).time_separation_ms, 50);
  ASSERT_EQ(kMultiMeasResult.size(), 120u);
  const auto m = DecodeAs<MultiMeasResult>(kMultiMeasResult);
  EXPECT_EQ(m.meas_mode, meas_mode::kContinuousTime);
  EXPECT_EQ(m.temperature, 20.5);
  EXPECT_EQ(m.pressure, 1013.25);
  EXPECT_EQ(m.humidity, 45.0);
  ASSERT_EQ(m.records.size(), 2u);
  EXPECT_EQ(m.records[0].value, (std::array<double, 3>{1.5, 0.25, 2000.0}));
  EXPECT_EQ(m.records[1].status, continuous_status::kPrismError);
  EXPECT_DOUBLE_EQ(TimeOf(m.records[0]), 100.25);
  EXPECT_DOUBLE_EQ(TimeOf(m.records[1]), 100.3);
  EXPECT_EQ(EncodePacket(m), kMultiMeasResult);
  // A time stamp set and read back, to the microsecond; a record count that disagrees with the
  // size is a typed error.
  MeasRecord rec;
  SetTime(rec, 86399.9999996);
  EXPECT_EQ(rec.time1, 86400);
  EXPECT_EQ(rec.time2, 0);
  std::string wrong = kMultiMeasResult;
  wrong[12] = 3;
  EXPECT_EQ(DecodePacket(wrong).error, DecodeError::kBadLength);
}

// Values the tables do not know are kept as numbers and named by them.
TEST(EmsconCodec, UnknownStatusValuesAreKeptRawAndNamedByNumber) {
  const auto err = DecodeAs<ErrorResponse>(Hex("10 00 00 00 01 00 00 00 40 00 00 00 D1 5D 00 00"));
  EXPECT_EQ(err.command, 64);
  EXPECT_EQ(err.status, 24017);  // a CallTransformation range status, outside the enum
  EXPECT_EQ(StatusName(24017), "ES_RS 24017");
  EXPECT_EQ(StatusName(1), "ES_RS_ServerBusy");
  EXPECT_EQ(StatusName(10004), "ES_RS_MeasurementStatusNotReady");
  EXPECT_EQ(CommandName(49), "StartMeasurement");
  EXPECT_EQ(CommandName(777), "command 777");
  EXPECT_EQ(StatusChangeName(27), "MeasStatus_Ready");
  EXPECT_EQ(StatusChangeName(4711), "status change 4711");
  // A failed reply keeps its status and carries no payload, whatever its length.
  const auto failed =
      DecodeAs<CommandAnswer>(Hex("10 00 00 00 00 00 00 00 01 00 00 00 27 00 00 00"));
  EXPECT_EQ(failed.command, 1);
  EXPECT_EQ(failed.status, 39);  // TrackerNotInitialized
  EXPECT_TRUE(std::holds_alternative<std::monostate>(failed.data));
  // A reply to a command without a modelled layout keeps its id and status.
  const auto park =
      DecodeAs<CommandAnswer>(Hex("14 00 00 00 00 00 00 00 0A 00 00 00 00 00 00 00 FF FF FF FF"));
  EXPECT_EQ(park.command, 10);
}

TEST(EmsconCodec, TruncatedBadSizeUnknownTypeAndBadLengthAreTypedErrors) {
  EXPECT_EQ(DecodePacket(Hex("0C 00 00")).error, DecodeError::kTruncated);
  EXPECT_EQ(DecodePacket(kSingleMeasResult.substr(0, 100)).error, DecodeError::kTruncated);
  // Size fields below 12 and above 64 KiB.
  EXPECT_EQ(DecodePacket(Hex("08 00 00 00 08 00 00 00")).error, DecodeError::kBadSize);
  EXPECT_EQ(DecodePacket(Hex("01 00 01 00 08 00 00 00 1B 00 00 00")).error, DecodeError::kBadSize);
  EXPECT_EQ(DecodePacket(Hex("F4 FF FF FF 08 00 00 00 1B 00 00 00")).error, DecodeError::kBadSize);
  // A frame with more bytes than its size says.
  EXPECT_EQ(DecodePacket(kReady + "x").error, DecodeError::kBadSize);
  // Type 4711.
  const auto unknown = DecodePacket(Hex("0C 00 00 00 67 12 00 00 1B 00 00 00"));
  EXPECT_EQ(unknown.error, DecodeError::kUnknownType);
  EXPECT_EQ(unknown.type, 4711);
  // A status change of 16 bytes, a result of 152, a GetSystemStatus reply of 16 with AllOK.
  EXPECT_EQ(DecodePacket(Hex("10 00 00 00 08 00 00 00 1B 00 00 00 00 00 00 00")).error,
            DecodeError::kBadLength);
  std::string short_result = kSingleMeasResult.substr(0, 152);
  short_result[0] = static_cast<char>(152);
  EXPECT_EQ(DecodePacket(short_result).error, DecodeError::kBadLength);
  EXPECT_EQ(DecodePacket(Hex("10 00 00 00 00 00 00 00 01 00 00 00 00 00 00 00")).error,
            DecodeError::kBadLength);
}

// --- Framing --------------------------------------------------------------------------

TEST(FrameSplitter, SeveralPacketsInOneReadComeOutWhole) {
  FrameSplitter s;
  s.Append(kReady + kInitializeOk + kSingleMeasResult);
  std::string frame;
  ASSERT_EQ(s.Next(frame), FrameSplitter::Status::kFrame);
  EXPECT_EQ(frame, kReady);
  ASSERT_EQ(s.Next(frame), FrameSplitter::Status::kFrame);
  EXPECT_EQ(frame, kInitializeOk);
  ASSERT_EQ(s.Next(frame), FrameSplitter::Status::kFrame);
  EXPECT_EQ(frame, kSingleMeasResult);
  EXPECT_EQ(s.Next(frame), FrameSplitter::Status::kNeedMore);
  EXPECT_EQ(s.buffered(), 0u);
}

TEST(FrameSplitter, APacketSplitAcrossReadsAtEveryByteComesOutWhole) {
  // Every split point, including inside the 4-byte size field and inside the header.
  const std::string stream = kStartMeasurement + kSingleMeasResult;
  for (size_t cut = 1; cut < stream.size(); ++cut) {
    FrameSplitter s;
    std::string frame;
    s.Append(stream.substr(0, cut));
    std::vector<std::string> frames;
    while (s.Next(frame) == FrameSplitter::Status::kFrame) frames.push_back(frame);
    s.Append(stream.substr(cut));
    while (s.Next(frame) == FrameSplitter::Status::kFrame) frames.push_back(frame);
    ASSERT_EQ(frames.size(), 2u) << "cut at " << cut;
    EXPECT_EQ(frames[0], kStartMeasurement);
    EXPECT_EQ(frames[1], kSingleMeasResult);
  }
  // One byte per read.
  FrameSplitter s;
  std::string frame;
  int frames = 0;
  for (char c : kSingleMeasResult2) {
    s.Append(std::string_view(&c, 1));
    while (s.Next(frame) == FrameSplitter::Status::kFrame) ++frames;
  }
  EXPECT_EQ(frames, 1);
  EXPECT_EQ(frame, kSingleMeasResult2);
}

// What a tracker sends after StartMeasurement when its status changes meanwhile: the
// reply, a status packet, the result, another status packet, in arbitrary reads.
TEST(FrameSplitter, StatusPacketsBetweenTheReplyAndTheResult) {
  const std::string accepted = Hex("10 00 00 00  00 00 00 00  31 00 00 00  00 00 00 00");
  const std::string busy = Hex("0C 00 00 00  08 00 00 00  1A 00 00 00");  // MeasStatus_Busy
  const std::string stream = busy + accepted + busy + kSingleMeasResult + kReady;
  FrameSplitter s;
  std::vector<Packet> packets;
  std::string frame;
  for (size_t at = 0; at < stream.size(); at += 7) {  // reads of 7 bytes
    s.Append(std::string_view(stream).substr(at, 7));
    while (s.Next(frame) == FrameSplitter::Status::kFrame) {
      const auto d = DecodePacket(frame);
      ASSERT_FALSE(d.error) << d.why;
      packets.push_back(*d.packet);
    }
  }
  ASSERT_EQ(packets.size(), 5u);
  EXPECT_EQ(std::get<StatusChange>(packets[0]).change, status_change::kMeasStatusBusy);
  EXPECT_EQ(std::get<CommandAnswer>(packets[1]).command, StartMeasurement::kCommand);
  EXPECT_EQ(std::get<StatusChange>(packets[2]).change, status_change::kMeasStatusBusy);
  EXPECT_EQ(std::get<MeasResult>(packets[3]).value[0], 1234.5);
  EXPECT_EQ(std::get<StatusChange>(packets[4]).change, status_change::kMeasStatusReady);
}

TEST(FrameSplitter, SizeFieldsOutOfBoundsLoseTheFramingAndDropTheBuffer) {
  for (const std::string& head : {Hex("0B 00 00 00"), Hex("00 00 00 00"), Hex("FF FF FF FF"),
                                  Hex("01 00 01 00")}) {  // 11, 0, -1, 65537
    FrameSplitter s;
    s.Append(head + kReady + kReady);
    std::string frame;
    int32_t bad = 0;
    EXPECT_EQ(s.Next(frame, &bad), FrameSplitter::Status::kBadSize);
    EXPECT_EQ(s.buffered(), 0u);  // nothing after a lost framing can be trusted
    EXPECT_TRUE(bad < kMinPacketBytes || bad > kMaxPacketBytes) << bad;
    s.Append(kReady);  // a clean stream afterwards is read again
    EXPECT_EQ(s.Next(frame), FrameSplitter::Status::kFrame);
    EXPECT_EQ(frame, kReady);
  }
  // The largest packet allowed waits for its bytes; one byte more is out of frame.
  FrameSplitter s;
  s.Append(Hex("00 00 01 00 00 00 00 00"));  // 65536
  std::string frame;
  EXPECT_EQ(s.Next(frame), FrameSplitter::Status::kNeedMore);
}

TEST(FrameSplitter, AFloodOfSmallPacketsCostsLinearTime) {
  FrameSplitter s;
  std::string chunk;
  for (int i = 0; i < 340; ++i) chunk += kReady;  // 4080 bytes
  std::string frame;
  size_t frames = 0;
  const auto start = std::chrono::steady_clock::now();
  for (int round = 0; round < 2000; ++round) {  // 8 MB
    s.Append(chunk.substr(0, 4000));
    s.Append(chunk.substr(4000));
    while (s.Next(frame) == FrameSplitter::Status::kFrame) ++frames;
  }
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(frames, 340u * 2000u);
  EXPECT_LT(ms, 2000.0);  // quadratic erasing would take minutes
}

// --- Units and conventions ------------------------------------------------------------

TEST(EmsconCodec, UnitFactors) {
  EXPECT_EQ(*MillimetresPer(length_unit::kMeter), 1000.0);
  EXPECT_EQ(*MillimetresPer(length_unit::kInch), 25.4);
  EXPECT_FALSE(MillimetresPer(6));
  EXPECT_DOUBLE_EQ(*RadiansPer(angle_unit::kGon) * 400.0, 2.0 * std::numbers::pi);
  EXPECT_DOUBLE_EQ(*ToCelsius(68.0, temperature_unit::kFahrenheit), 20.0);
  EXPECT_DOUBLE_EQ(*FromCelsius(20.0, temperature_unit::kFahrenheit), 68.0);
  EXPECT_NEAR(*ToHectopascal(760.0, pressure_unit::kMmHg), 1013.25, 1e-3);  // 1 atm
  EXPECT_NEAR(*ToHectopascal(29.9213, pressure_unit::kInHg), 1013.25, 1e-2);
  EXPECT_NEAR(*FromHectopascal(1013.25, pressure_unit::kPsi), 14.6959, 1e-4);
  EXPECT_FALSE(ToHectopascal(1.0, 7));
}

// The theodolite frame (docs/reference/conventions.md): Hz clockwise from +y seen from
// above (Hz = 100 gon along +x),
// V the zenith angle.
TEST(EmsconCodec, SphericalMappingFollowsTheTheodoliteFrame) {
  const double pi = std::numbers::pi;
  const Eigen::Vector3d east = PointFromSpherical({pi / 2, pi / 2, 1000.0});
  EXPECT_NEAR(east.x(), 1000.0, 1e-9);
  EXPECT_NEAR(east.y(), 0.0, 1e-9);
  EXPECT_NEAR(east.z(), 0.0, 1e-9);
  const Eigen::Vector3d up = PointFromSpherical({1.0, 0.0, 2.0});
  EXPECT_NEAR(up.z(), 2.0, 1e-12);
  const Spherical s = SphericalFromPoint({-1000.0, 0.0, 1000.0});  // west, 45° up
  EXPECT_NEAR(s.hz_rad, 3 * pi / 2, 1e-12);
  EXPECT_NEAR(s.v_rad, pi / 4, 1e-12);
  EXPECT_NEAR(s.distance_mm, std::sqrt(2.0) * 1000.0, 1e-9);
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(1234.5, -250.25, 0.125),
                                   Eigen::Vector3d(-3000, -4000, -500), Eigen::Vector3d(0, 1, 0)}) {
    const Spherical q = SphericalFromPoint(p);
    EXPECT_GE(q.hz_rad, 0.0);
    EXPECT_LT(q.hz_rad, 2 * pi);
    EXPECT_LT((PointFromSpherical(q) - p).norm(), 1e-9);
  }
}

}  // namespace armsig::instruments::emscon
