// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/hopper/nominal_gait.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace ddoc {
namespace {

// The expected gait scale of the design notes (docs/hopper.md, the nominal gait; own simulation of
// the stance model, M = 10 kg, k = 2000 N/m).
void ExpectInDesignRange(const NominalGait& g) {
  EXPECT_GE(g.stance_time, 0.25);
  EXPECT_LE(g.stance_time, 0.33);
  EXPECT_GE(g.period, 0.45);
  EXPECT_LE(g.period, 0.70);
  EXPECT_GE(g.apex, 0.75);
  EXPECT_LE(g.apex, 0.90);
  EXPECT_GE(g.forward_speed, 0.0);
  EXPECT_LE(g.forward_speed, 1.5);
}

TEST(NominalGaitTest, ForwardGaitIsPeriodicAndInRange) {
  NominalGaitSettings s;
  s.forward_speed = 0.5;
  const NominalGait g = FindNominalGait(HopperParams(), s);
  ASSERT_TRUE(g.hop.ok);
  EXPECT_LT(g.periodicity, 1e-10);
  EXPECT_LT(g.max_abs_residual, 1e-6);
  ExpectInDesignRange(g);
  EXPECT_NEAR(g.forward_speed, 0.5, 1e-12);
  EXPECT_GT(g.step_length, 0.1);
  // The hop starts on the ground with the leg at rest length, inside the input bounds.
  EXPECT_NEAR(HopperModel::FootHeight(g.x0), 0.0, 1e-12);
  EXPECT_TRUE((g.u0.array() >= hopper::InputLowerBound().array()).all());
  EXPECT_TRUE((g.u0.array() <= hopper::InputUpperBound().array()).all());
  EXPECT_NEAR(g.T0(1), g.period, 1e-12);
}

// NominalGaitAt rebuilds FindNominalGait's gait from its search variables bit for bit (the law
// cache stores them instead of searching again), with and without the issue 44 terms.
TEST(NominalGaitTest, TheSearchVariablesRebuildTheGaitExactly) {
  NominalGaitSettings s;
  s.forward_speed = 0.5;
  HopperParams damped;
  damped.M = 12.0;
  damped.b_leg = 2.0;
  damped.slope = -0.02;
  for (const HopperParams& p : {HopperParams(), damped}) {
    const NominalGait g = FindNominalGait(p, s);
    const NominalGait at = NominalGaitAt(p, s, g.search);
    EXPECT_TRUE(at.search == g.search);
    EXPECT_TRUE(at.x0 == g.x0);
    EXPECT_TRUE(at.u0 == g.u0);
    EXPECT_TRUE(at.T0 == g.T0);
    EXPECT_EQ(at.periodicity, g.periodicity);
    EXPECT_EQ(at.energy_loss, g.energy_loss);
    EXPECT_EQ(at.step_length, g.step_length);
    // Other variables give another gait (the variables are what it is built from).
    Eigen::Matrix<double, 6, 1> other = g.search;
    other(2) += 1e-3;
    EXPECT_FALSE(NominalGaitAt(p, s, other).x0 == g.x0);
  }
  Eigen::Matrix<double, 6, 1> bad = Eigen::Matrix<double, 6, 1>::Zero();
  bad(1) = std::nan("");
  EXPECT_THROW(NominalGaitAt(HopperParams(), s, bad), InvalidArgument);
}

TEST(NominalGaitTest, HeavyRobotStillHops) {
  HopperParams p;
  p.M = 12.0;
  p.c_d = 0.01;
  NominalGaitSettings s;
  s.forward_speed = 0.3;
  s.k0_leg = 2350.0;
  const NominalGait g = FindNominalGait(p, s);
  ASSERT_TRUE(g.hop.ok);
  // With drag a constant input cannot be exactly periodic; the residual is small but nonzero.
  EXPECT_LT(g.max_abs_residual, 0.05);
  EXPECT_GT(g.stance_time, 0.2);
  // Hopping in place with drag: the free search would collapse to yd0 -> 0 (no hop); the
  // fallback holds the requested apex.
  s.forward_speed = 0.0;
  const NominalGait g0 = FindNominalGait(p, s);
  EXPECT_NEAR(g0.apex, 0.8, 0.01);
  ExpectInDesignRange(g0);
  EXPECT_LT(g0.max_abs_residual, 1e-3);
}

TEST(NominalGaitTest, ASpeedWithoutAPeriodicGaitIsAnError) {
  // On the 10 kg drag-free model the search reaches I1 ~ 1e-19 up to 2.6 m/s and ends near 0.05
  // from 2.7 m/s on (a 2.7 m/s "gait" is not a hop of the model: its controller would be nonsense).
  NominalGaitSettings s;
  s.forward_speed = 2.6;
  EXPECT_LT(FindNominalGait(HopperParams(), s).periodicity, 1e-12);
  s.forward_speed = 2.7;
  try {
    FindNominalGait(HopperParams(), s);
    ADD_FAILURE() << "no error at 2.7 m/s";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("FindNominalGait: no periodic gait at 2.7 m/s"),
              std::string::npos)
        << e.what();
  }
  // Drag leaves a residual far below the bound: 12 kg, c_d 0.05 at 1.5 m/s.
  HopperParams p;
  p.M = 12.0;
  p.c_d = 0.05;
  s.forward_speed = 1.5;
  const NominalGait g = FindNominalGait(p, s);
  EXPECT_GT(g.periodicity, 1e-6);
  EXPECT_LT(g.periodicity, 1e-3);
}

TEST(NominalGaitTest, RejectsBadSettings) {
  NominalGaitSettings s;
  s.k0_leg = 100.0;
  EXPECT_THROW(FindNominalGait(HopperParams(), s), InvalidArgument);
  s = NominalGaitSettings();
  s.apex_height = 0.5;
  EXPECT_THROW(FindNominalGait(HopperParams(), s), InvalidArgument);
}

}  // namespace
}  // namespace ddoc
