#include "reduction/instrument_errors.h"

#include <gtest/gtest.h>

#include <random>

#include "core/units.h"

namespace armsig::reduction {

TEST(InstrumentErrors, TwoFaceDataRecoverPlantedAxisErrors) {
  InstrumentErrors planted;
  planted.collimation_rad = 15.0 * kRadPerArcsec;
  planted.trunnion_rad = 25.0 * kRadPerArcsec;
  planted.index_rad = -10.0 * kRadPerArcsec;
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.5 * kRadPerArcsec);
  std::uniform_real_distribution<double> hz(0, 2 * kPi),
      v(ToRad(60, AngleUnit::kGon), ToRad(140, AngleUnit::kGon));
  std::vector<TwoFacePair> pairs;
  for (int k = 0; k < 40; ++k) {
    const AngleReading truth{hz(rng), v(rng), 1};
    AngleReading f1 = ApplyInstrumentErrors(truth, 1, planted);
    AngleReading f2 = ApplyInstrumentErrors(truth, 2, planted);
    f1.hz_rad += noise(rng);
    f1.v_rad += noise(rng);
    f2.hz_rad += noise(rng);
    f2.v_rad += noise(rng);
    pairs.push_back({f1, f2});
  }
  const auto e = EstimateInstrumentErrors(pairs, 0.5 * kRadPerArcsec, 0.5 * kRadPerArcsec);
  ASSERT_TRUE(e.trunnion_determined);
  EXPECT_NEAR(e.collimation_rad, planted.collimation_rad, 4 * e.sigma_collimation_rad);
  EXPECT_NEAR(e.trunnion_rad, planted.trunnion_rad, 4 * e.sigma_trunnion_rad);
  EXPECT_NEAR(e.index_rad, planted.index_rad, 4 * e.sigma_index_rad);
  EXPECT_LT(e.sigma_collimation_rad, 1.0 * kRadPerArcsec);
}

TEST(InstrumentErrors, CorrectionUndoesTheErrorsInBothFaces) {
  InstrumentErrors e;
  e.collimation_rad = 20 * kRadPerArcsec;
  e.trunnion_rad = -30 * kRadPerArcsec;
  e.index_rad = 12 * kRadPerArcsec;
  const AngleReading truth{1.1, ToRad(70, AngleUnit::kGon), 1};
  for (int face : {1, 2}) {
    const AngleReading back = CorrectReading(ApplyInstrumentErrors(truth, face, e), e);
    EXPECT_NEAR(WrapPi(back.hz_rad - truth.hz_rad), 0.0, 1e-9) << face;  // second-order terms
    EXPECT_NEAR(back.v_rad, truth.v_rad, 1e-12) << face;
    EXPECT_EQ(back.face, 1);
  }
}

TEST(InstrumentErrors, HorizontalSightsCannotSeparateTheTrunnionError) {
  std::vector<TwoFacePair> pairs;
  InstrumentErrors planted;
  planted.collimation_rad = 10 * kRadPerArcsec;
  for (int k = 0; k < 10; ++k) {
    const AngleReading truth{0.3 * k, ToRad(100.0 + 0.01 * k, AngleUnit::kGon), 1};
    pairs.push_back(
        {ApplyInstrumentErrors(truth, 1, planted), ApplyInstrumentErrors(truth, 2, planted)});
  }
  const auto e = EstimateInstrumentErrors(pairs, kRadPerArcsec, kRadPerArcsec);
  EXPECT_FALSE(e.trunnion_determined);
  EXPECT_NEAR(e.collimation_rad, planted.collimation_rad, 1e-9);
}

TEST(InstrumentErrors, ReduceTwoFaceCorrectsEveryReadingOfTheStation) {
  InstrumentErrors planted;
  planted.collimation_rad = 18 * kRadPerArcsec;
  planted.trunnion_rad = 22 * kRadPerArcsec;
  planted.index_rad = 9 * kRadPerArcsec;
  std::vector<Observation> obs;
  std::vector<AngleReading> truth;
  for (int k = 0; k < 12; ++k) {
    const AngleReading t{0.5 * k, ToRad(65.0 + 6.0 * k, AngleUnit::kGon), 1};
    truth.push_back(t);
    for (int face : {1, 2}) {
      Observation o;
      o.station = "T1";
      o.point = "P" + std::to_string(k);
      o.reading = ApplyInstrumentErrors(t, face, planted);
      obs.push_back(o);
    }
  }
  const auto errors = ReduceTwoFace(obs, InstrumentDefaults{});
  ASSERT_EQ(errors.count("T1"), 1u);
  EXPECT_EQ(errors.at("T1").pairs, 12);
  for (size_t k = 0; k < obs.size(); ++k) {
    EXPECT_EQ(obs[k].reading.face, 1);
    EXPECT_NEAR(WrapPi(obs[k].reading.hz_rad - truth[k / 2].hz_rad), 0.0, 1e-8);
    EXPECT_NEAR(obs[k].reading.v_rad, truth[k / 2].v_rad, 1e-10);
  }
}

// A reading at the nadir (V = 200 gon, which converts to π plus an ulp) was taken
// for face II and paired with the face-I reading of the same point: a "collimation" of
// 18 gon and an "index" of 81 gon were then applied to every reading of the station, and
// orient failed ("network is singular").
TEST(InstrumentErrors, TheNadirIsFaceOne) {
  EXPECT_EQ(FaceOfZenithAngle(ToRad(200.0, AngleUnit::kGon)), 1);
  EXPECT_EQ(FaceOfZenithAngle(ToRad(180.0, AngleUnit::kDeg)), 1);
  EXPECT_EQ(FaceOfZenithAngle(ToRad(200.0001, AngleUnit::kGon)), 2);
  EXPECT_EQ(FaceOfZenithAngle(ToRad(399.9, AngleUnit::kGon)), 2);
}

TEST(InstrumentErrors, PairsThatDoNotReadOneDirectionAreNotUsed) {
  InstrumentErrors planted;
  planted.collimation_rad = 18 * kRadPerArcsec;
  planted.index_rad = 9 * kRadPerArcsec;
  std::vector<Observation> obs;
  for (int k = 0; k < 4; ++k) {
    const AngleReading t{0.5 * k, ToRad(70.0 + 10.0 * k, AngleUnit::kGon), 1};
    for (int face : {1, 2}) {
      Observation o;
      o.station = "T1";
      o.point = "P" + std::to_string(k);
      o.reading = ApplyInstrumentErrors(t, face, planted);
      obs.push_back(o);
    }
  }
  // P9: face I at V = 38 gon, and a "face II" that is another direction (a blunder);
  // P8: a face-II reading at the pole (Hz says nothing there).
  auto add = [&](const char* point, AngleReading reading) {
    Observation o;
    o.station = "T1";
    o.point = point;
    o.reading = reading;
    obs.push_back(o);
  };
  add("P9", {ToRad(238.0, AngleUnit::kGon), ToRad(38.0, AngleUnit::kGon), 1});
  add("P9", {0.0, ToRad(200.5, AngleUnit::kGon), 2});
  add("P8", {1.0, ToRad(60.0, AngleUnit::kGon), 1});
  add("P8", {1.0 + kPi, 2.0 * kPi, 2});
  const auto errors = ReduceTwoFace(obs, InstrumentDefaults{});
  ASSERT_EQ(errors.count("T1"), 1u);
  EXPECT_EQ(errors.at("T1").pairs, 4);
  EXPECT_NEAR(errors.at("T1").collimation_rad, planted.collimation_rad, 1e-9);
  EXPECT_NEAR(errors.at("T1").index_rad, planted.index_rad, 1e-9);
}

}  // namespace armsig::reduction
