// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
// The harness: mapping round trip, events, pushes, VSA beside MuJoCo.
#include <cmath>
#include <limits>
#include <string>

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
    } else {
      EXPECT_GT(e.flight(hopper::kYd), 0.0);
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
  sim.AddPush(Push{0.1, -20.0, 0.1});
  sim.AddPush(Push{0.3, 25.0, 0.05});
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
  ContactPhaseSettings s;
  s.takeoff_force = -1.0;
  try {
    ContactPhaseDetector detector(s);
    ADD_FAILURE() << "a negative takeoff force was accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("takeoff_force = -1"), std::string::npos) << e.what();
  }
  s = ContactPhaseSettings();
  s.min_phase_time = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(ContactPhaseDetector{s}, InvalidArgument);
}

TEST(HopperSimTest, DetectorFollowsTheCollisionPassAndTheLastSolvedForce) {
  // Touchdown fires at the step whose collision pass first has the foot in the floor (before any
  // contact force is solved), takeoff at the first step after the solved vertical force fell
  // below the threshold, and nothing fires within min_phase_time of the previous event.
  HopperSim sim(ModelPath("hopper.xml"));
  V14 x0 = V14::Zero();
  x0 << 0, 0.75, 0, 0, 0.7, 50, 2000, 0, -0.5, 0, 0, 0, 0, 0;  // foot 5 cm up, falling
  sim.SetFlightState(x0);
  const Eigen::Vector4d u(0, 0, 50, 2000);
  const HopperMapping& map = sim.mapping();
  double first_contact = -1;
  while (sim.events().empty() && sim.time() < 0.5) {
    mj_forward(sim.model(), sim.data());  // the collision pass of the current state
    if (first_contact < 0 && FootTouchesFloor(map, sim.data(), 0.0)) first_contact = sim.time();
    sim.Step(u);
  }
  ASSERT_EQ(sim.events().size(), 1u);
  EXPECT_EQ(sim.events()[0].type, ContactEvent::Type::kTouchdown);
  EXPECT_DOUBLE_EQ(sim.events()[0].time, first_contact);
  EXPECT_LT(HopperModel::FootHeight(sim.events()[0].flight), 1e-3);
  // The detector alone: no change within min_phase_time of the event, whatever mjData says.
  ContactPhaseDetector detector;
  detector.Reset(hopper::kFlight, sim.time());
  EXPECT_EQ(detector.Update(map, sim.data()), ContactChange::kNone);  // foot on the floor
  mjData* d = sim.data();
  const double t = d->time;
  d->time = t + detector.settings().min_phase_time;
  EXPECT_EQ(detector.Update(map, d), ContactChange::kTouchdown);
  EXPECT_EQ(detector.mode(), hopper::kStance);
  d->time = t + 3 * detector.settings().min_phase_time;
  const double force = d->qfrc_constraint[map.dof_z];
  d->qfrc_constraint[map.dof_z] = 0.4;  // below 0.5 N
  EXPECT_EQ(detector.Update(map, d), ContactChange::kTakeoff);
  d->qfrc_constraint[map.dof_z] = force;
  d->time = t;
}

}  // namespace
}  // namespace ddoc
