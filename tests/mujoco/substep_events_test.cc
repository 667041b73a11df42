// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// ContactPhaseSettings::substep_events: the touchdown and takeoff instants located inside the
// 0.5 ms physics step, against cases with a known answer.
#include <algorithm>
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "ddoc/mujoco/contact_phase.h"
#include "ddoc/mujoco/hopper_sim.h"
#include "model_files.h"

namespace ddoc {
namespace {

using testing::ModelPath;
using V14 = Eigen::Matrix<double, 14, 1>;
using V10 = Eigen::Matrix<double, 10, 1>;

constexpr double kSubstepTolerance = 5e-5;  // s: a tenth of the 0.5 ms step

void ZeroActuation(const mjModel* m, mjData* d) {
  for (int i = 0; i < m->nu; ++i) d->ctrl[i] = 0.0;
  for (int i = 0; i < 6 * m->nbody; ++i) d->xfrc_applied[i] = 0.0;
}

struct Drop {
  double event_time = 0.0;  // the detector's event_time()
  double step_time = 0.0;   // d->time of the Update that found the touchdown
  double exact = 0.0;       // the analytic instant
};

// The robot, rigid and unactuated, falls from foot-centre height `height` (above the floor's
// foot-centre surface at x = foot_x) with vertical velocity v0. MuJoCo's semi-implicit Euler step
// (v += h a, then q += h v) puts the positions of the steps exactly on the free fall
// y(t) = y0 + (v0 - g h / 2) t - g t^2 / 2 (the continuous fall from y0 with v0 - g h / 2): the
// analytic touchdown is where this parabola meets the floor, along its normal
// (-sin alpha, cos alpha): cos alpha (y_f(t)) - sin alpha foot_x = 0.
Drop DropOnce(HopperSim* sim, double height, double v0, bool substep) {
  const mjModel* m = sim->model();
  mjData* d = sim->data();
  const HopperMapping& map = sim->mapping();
  const double g = -m->opt.gravity[2], h = m->opt.timestep, r = 0.69, foot_x = 0.1;
  const double alpha = map.floor_slope;
  const double y_foot0 = foot_x * std::tan(alpha) + height;  // foot centre at t = 0
  V14 x = V14::Zero();
  x << foot_x, y_foot0 + r, 0, 0, r, 50, 2000, 0, v0, 0, 0, 0, 0, 0;  // leg vertical, at rest
  sim->SetFlightState(x, 0.0);
  ZeroActuation(m, d);
  ContactPhaseSettings settings;
  settings.substep_events = substep;
  ContactPhaseDetector detector(settings);
  detector.Reset(hopper::kFlight, -1.0);
  Drop drop;
  for (int k = 0; k < 4000; ++k) {
    mj_step1(m, d);
    if (detector.Update(map, d) == ContactChange::kTouchdown) {
      drop.event_time = detector.event_time();
      drop.step_time = d->time;
      break;
    }
    mj_step2(m, d);
  }
  // cos(alpha) (y_foot0 + b t - g t^2 / 2) = sin(alpha) foot_x, i.e. a + b t - g t^2 / 2 = 0.
  const double a = y_foot0 - foot_x * std::tan(alpha), b = v0 - 0.5 * g * h;
  drop.exact = (b + std::sqrt(b * b + 2.0 * g * a)) / g;
  return drop;
}

TEST(SubstepEventsTest, TouchdownOfAFreeFallOnAFlatAndASlopedFloor) {
  for (const char* file : {"hopper.xml", "hopper_slope_down.xml"}) {
    SCOPED_TRACE(file);
    HopperSim sim(ModelPath(file));
    double worst_substep = 0.0, worst_step = 0.0;
    for (int i = 0; i < 12; ++i) {
      // Heights and speeds that put the touchdown at different places inside a step.
      const double height = 0.02 + 0.0137 * i, v0 = -0.1 * (i % 4);
      const Drop on = DropOnce(&sim, height, v0, true);
      const Drop off = DropOnce(&sim, height, v0, false);
      ASSERT_GT(on.step_time, 0.0) << "no touchdown from height " << height;
      EXPECT_NEAR(on.event_time, on.exact, kSubstepTolerance)
          << "height " << height << " v0 " << v0 << ": step time " << on.step_time;
      // The step-time detection: the first step at or after the instant; off is the old one.
      EXPECT_GE(on.step_time, on.exact);
      EXPECT_LT(on.step_time, on.exact + sim.timestep() + 1e-12);
      EXPECT_EQ(off.event_time, off.step_time);
      EXPECT_EQ(off.step_time, on.step_time);
      worst_substep = std::max(worst_substep, std::abs(on.event_time - on.exact));
      worst_step = std::max(worst_step, on.step_time - on.exact);
    }
    // The cases span the step: the step time is off by most of one; the estimate is not.
    EXPECT_GT(worst_step, 0.3 * sim.timestep());
    EXPECT_LT(worst_substep, 1e-6);
  }
}

struct Lift {
  double event_time = 0.0, step_time = 0.0, exact = 0.0;
};

// The robot stands on the floor, leg vertical, its leg motor carrying the body's weight; an
// upward force on the foot grows at `rate` (N/s) from t = 0. The floor's vertical force is then
// N0 - rate t (the foot stays put while it is pressed down), so it falls below takeoff_force at
// t = (N0 - takeoff_force) / rate, N0 the force before the ramp (the robot's weight).
Lift LiftOnce(HopperSim* sim, double rate, bool substep) {
  const mjModel* m = sim->model();
  mjData* d = sim->data();
  const HopperMapping& map = sim->mapping();
  const double g = -m->opt.gravity[2];
  V10 x = V10::Zero();
  x << 0, 0, 0.69, 50, 2000, 0, 0, 0, 0, 0;
  sim->SetStanceState(x, 0.0, -0.2);
  ZeroActuation(m, d);
  const double upper = m->body_mass[map.body_torso] + m->body_mass[map.body_leg];
  d->ctrl[map.act_leg] = upper * g;  // the leg carries the body: nothing moves
  while (d->time < -1e-9) mj_step(m, d);  // settle for 0.2 s
  const double n0 = d->qfrc_constraint[map.dof_z];
  ContactPhaseSettings settings;
  settings.substep_events = substep;
  ContactPhaseDetector detector(settings);
  detector.Reset(hopper::kStance, -1.0);
  Lift lift;
  const int foot_z = 6 * map.body_foot + 2;
  for (int k = 0; k < 4000; ++k) {
    mj_step1(m, d);
    if (detector.Update(map, d) == ContactChange::kTakeoff) {
      lift.event_time = detector.event_time();
      lift.step_time = d->time;
      break;
    }
    d->xfrc_applied[foot_z] = rate * std::max(0.0, d->time);  // solved from this state
    mj_step2(m, d);
  }
  lift.exact = (n0 - settings.takeoff_force) / rate;
  return lift;
}

TEST(SubstepEventsTest, TakeoffWhereTheFloorForceFallsBelowTheThreshold) {
  HopperSim sim(ModelPath("hopper.xml"));
  const double total = sim.model()->body_mass[sim.mapping().body_torso] +
                       sim.model()->body_mass[sim.mapping().body_leg] +
                       sim.model()->body_mass[sim.mapping().body_foot];
  double worst_substep = 0.0, worst_step = 0.0;
  for (int i = 0; i < 8; ++i) {
    const double rate = 1500.0 + 61.0 * i;  // N/s: the crossing at different places in a step
    const Lift on = LiftOnce(&sim, rate, true);
    const Lift off = LiftOnce(&sim, rate, false);
    ASSERT_GT(on.step_time, 0.0) << "no takeoff at rate " << rate;
    EXPECT_NEAR(on.exact * rate + 0.5, total * 9.81, 0.01 * total * 9.81);  // N0: the weight
    EXPECT_NEAR(on.event_time, on.exact, kSubstepTolerance)
        << "rate " << rate << ": step time " << on.step_time;
    // The step-time detection comes one to two steps late (the force it reads is a step old).
    EXPECT_GT(on.step_time, on.exact + sim.timestep() - 1e-9);
    EXPECT_LE(on.step_time, on.exact + 2 * sim.timestep() + 1e-9);
    EXPECT_EQ(off.event_time, off.step_time);
    worst_substep = std::max(worst_substep, std::abs(on.event_time - on.exact));
    worst_step = std::max(worst_step, on.step_time - on.exact);
  }
  EXPECT_GT(worst_step, 1.3 * sim.timestep());
}

}  // namespace
}  // namespace ddoc
