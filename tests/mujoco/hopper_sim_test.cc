// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
// The harness: mapping round trip, events, pushes, VSA beside MuJoCo.
#include <cmath>

#include <gtest/gtest.h>

#include "ddoc/hopper/nominal_gait.h"
#include "ddoc/mujoco/hopper_sim.h"
#include "model_files.h"

namespace ddoc {
namespace {

using testing::ModelPath;
using V14 = Eigen::Matrix<double, 14, 1>;
using V10 = Eigen::Matrix<double, 10, 1>;

TEST(HopperSimTest, StateMappingRoundTrips) {
  HopperSim sim(ModelPath("hopper.xml"));
  V14 x;
  x << 0.4, 1.1, -0.3, 0.2, 0.69, 77, 2100, 0.5, -0.7, 1.3, -0.4, 0.2, 5, -30;
  sim.SetFlightState(x, 0.25);
  EXPECT_TRUE(sim.Flight().isApprox(x, 1e-14));
  EXPECT_EQ(sim.mode(), hopper::kFlight);
  EXPECT_DOUBLE_EQ(sim.time(), 0.25);
  V10 xs;
  xs << 0.2, -0.1, 0.66, 80, 2000, -0.9, 0.3, -0.5, 0, 0;
  sim.SetStanceState(xs, 1.5);
  EXPECT_TRUE(sim.Stance().isApprox(xs, 1e-14));
  EXPECT_EQ(sim.mode(), hopper::kStance);
  EXPECT_NEAR(sim.Foot()(0), 1.5, 1e-14);
  EXPECT_NEAR(sim.Foot()(1), 0.0, 1e-14);
  EXPECT_EQ(sim.State().size(), 10);
}

TEST(HopperSimTest, EventsAlternateWithStatesBeforeAndAfter) {
  const std::string path = ModelPath("hopper.xml");
  NominalGaitSettings gs;
  gs.forward_speed = 0.5;
  const NominalGait g = FindNominalGait(LoadHopperParamsFromMjcf(path), gs);
  HopperSim sim(path);
  sim.SetFlightState(g.x0);
  while (sim.events().size() < 4 && sim.time() < 3.0) sim.Step(g.u0);
  ASSERT_GE(sim.events().size(), 4u);
  for (size_t i = 0; i < 4; ++i) {
    const ContactEvent& e = sim.events()[i];
    EXPECT_EQ(e.type, i % 2 == 0 ? ContactEvent::Type::kTouchdown : ContactEvent::Type::kTakeoff);
    if (i > 0) EXPECT_GT(e.time, sim.events()[i - 1].time + 0.1);
    if (e.type == ContactEvent::Type::kTouchdown) {
      // Before: foot within one step of travel of the floor, descending; after: leg compressing.
      EXPECT_LT(std::abs(HopperModel::FootHeight(e.flight)), 2e-3);
      EXPECT_LT(e.flight(hopper::kYd), 0.0);
      EXPECT_LT(e.stance(hopper::kSRd), 0.0);
      EXPECT_GT(e.normal_force, 1.0);
    } else {
      EXPECT_GT(e.flight(hopper::kYd), 0.0);
      EXPECT_LT(e.normal_force, 0.1);
      // Takeoff happens where the leg force is ~0: r ~ r0 + F0/k_leg.
      EXPECT_NEAR(e.stance(hopper::kSR), 0.7, 3e-3);
    }
  }
}

TEST(HopperSimTest, PushChangesMomentumByItsImpulse) {
  const std::string path = ModelPath("hopper.xml");
  const HopperParams p = LoadHopperParamsFromMjcf(path);
  HopperSim sim(path);
  V14 x0 = V14::Zero();
  x0 << 0, 20.0, 0, 0, 0.7, 50, 2000, 0, 0, 0, 0, 0, 0, 0;
  sim.SetFlightState(x0);
  sim.AddPush(Push{-20.0, 0.1, 0.1});
  sim.AddPush(Push{25.0, 0.3, 0.05});
  const Eigen::Vector4d u(0, 0, 50, 2000);
  while (sim.time() < 0.5 - 1e-9) sim.Step(u);
  const double expected = (-20.0 * 0.1 + 25.0 * 0.05) / p.M;
  EXPECT_NEAR(sim.Flight()(hopper::kXd), expected, 1e-3 * std::abs(expected));
  EXPECT_EQ(sim.PushForce(0.15), -20.0);
  EXPECT_EQ(sim.PushForce(0.25), 0.0);
}

TEST(HopperSimTest, VsaStatesAdvanceBesideMujoco) {
  HopperSim sim(ModelPath("hopper.xml"));
  V14 x0 = V14::Zero();
  x0 << 0, 5.0, 0, 0, 0.7, 10, 1780, 0, 0, 0, 0, 0, 0, 0;
  sim.SetFlightState(x0);
  const Eigen::Vector4d u(0, 0, 150, 2350);
  Vsa ref(20.0, VsaState{10, 1780, 0, 0});
  for (int i = 0; i < 400; ++i) {
    sim.Step(u);
    ref.Advance(sim.timestep(), 150, 2350);
  }
  EXPECT_DOUBLE_EQ(sim.Flight()(hopper::kKhip), ref.state().k_hip);
  EXPECT_DOUBLE_EQ(sim.Flight()(hopper::kKlegd), ref.state().kd_leg);
  EXPECT_GT(ref.state().k_hip, 100.0);
}

TEST(HopperSimTest, DetectorRejectsBadSettings) {
  ContactDetectorSettings s;
  s.takeoff_force = 2.0;  // above the touchdown threshold: no hysteresis
  EXPECT_THROW(ContactPhaseDetector{s}, InvalidArgument);
}

}  // namespace
}  // namespace ddoc
