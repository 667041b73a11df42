// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The controller plugin on the MuJoCo hopper: creation errors, contact-phase switching, the state
// mapping it records, re-entry (mj_forward, finite differencing), bounds under bad states, and a
// short learning run.
#include "hopper_controller.h"

#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "ddoc/mujoco/hopper_sim.h"
#include "robot.h"

namespace ddoc::plugin {
namespace {

std::string ModelPath(const std::string& name) { return std::string(DDOC_MODELS_DIR) + "/" + name; }

void ExpectInputInBounds(const HopperController& c) {
  for (int i = 0; i < 4; ++i) {
    const double u = c.last_input()[i];
    ASSERT_TRUE(std::isfinite(u)) << "u[" << i << "] is not finite";
    EXPECT_GE(u, c.u_min()(i)) << "u[" << i << "]";
    EXPECT_LE(u, c.u_max()(i)) << "u[" << i << "]";
  }
}

TEST(HopperControllerTest, CreateFailsClearlyOnMisconfiguration) {
  MjModelPtr model = LoadMjcf(ModelPath("hopper.xml"));
  std::string error;
  // Create fails, and its error names what is wrong.
  auto rejected = [&](const ControllerConfig& config, const std::string& names) {
    EXPECT_EQ(HopperController::Create(model.get(), config, &error), nullptr) << names;
    EXPECT_NE(error.find(names), std::string::npos) << error;
  };
  EXPECT_EQ(HopperController::Create(nullptr, {}, &error), nullptr);
  EXPECT_NE(error.find("mjModel is null"), std::string::npos) << error;

  ControllerConfig reversed;
  reversed.durations.flight_min = 2.0;  // > flight_max = 1.5
  rejected(reversed, "duration");

  ControllerConfig bad_pitch;
  bad_pitch.pitch_experiment.scale = 1.5;
  rejected(bad_pitch, "pitch_experiment.scale = 1.5, expected in [0, 1]");
  bad_pitch.pitch_experiment.scale = 0.5;
  bad_pitch.pitch_experiment.from_hop = -1;
  rejected(bad_pitch, "pitch_experiment.from_hop = -1, expected >= 0");

  // One field of the default configuration set to `value`, and the error that names it.
  const auto field_rejected = [&](double ControllerConfig::*field, double value,
                                  const char* expected) {
    ControllerConfig bad;
    bad.*field = value;
    rejected(bad, expected);
  };
  field_rejected(&ControllerConfig::anchor_weight, 1.5, "anchor_weight = 1.5, expected in [0, 1]");
  field_rejected(&ControllerConfig::reference_filter, 0.0,
                 "reference_filter = 0, expected in (0, 1]");
  field_rejected(&ControllerConfig::overspeed_latch, -0.05,
                 "overspeed_latch = -0.05, expected finite and >= 0");
  // A latch needs the moving reference it latches: with the gait's state alone it is an error.
  field_rejected(&ControllerConfig::overspeed_latch, 0.05,
                 "overspeed_latch = 0.05, expected 0 unless the reference moves");
  field_rejected(&ControllerConfig::watch_max_mass, -1.0,
                 "watch_max_mass = -1, expected finite and >= 0");

  ControllerConfig bad_latency;
  bad_latency.offline_latency = 0.06;  // not below the shortest flight (0.05 s)
  rejected(bad_latency, "offline_latency = 0.06");

  for (double bad : {-1e-6, std::nan("")}) {
    ControllerConfig bad_model_latency;
    bad_model_latency.offline_step_seconds = bad;
    rejected(bad_model_latency, "offline_step_seconds");
    bad_model_latency = ControllerConfig();
    bad_model_latency.offline_hop_seconds = bad;
    rejected(bad_model_latency, "offline_hop_seconds");
  }

  ControllerConfig bad_warmup;
  bad_warmup.driver.warmup_trials = 0;
  rejected(bad_warmup, "warmup_trials = 0");

  ControllerConfig bad_model;
  bad_model.model.M = -1.0;
  rejected(bad_model, "M");

  // A model that is not the hopper: the mapping names the missing element.
  const std::string path = ::testing::TempDir() + "ddoc_not_a_hopper.xml";
  std::FILE* f = std::fopen(path.c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fputs("<mujoco><worldbody><body name='b'><freejoint/><geom size='0.1'/></body>"
             "</worldbody></mujoco>", f);
  std::fclose(f);
  char err[256] = "";
  mjModel* box = mj_loadXML(path.c_str(), nullptr, err, sizeof(err));
  ASSERT_NE(box, nullptr) << err;
  EXPECT_EQ(HopperController::Create(box, {}, &error), nullptr);
  EXPECT_NE(error.find("torso"), std::string::npos) << error;
  mj_deleteModel(box);
}

TEST(HopperControllerTest, SwitchesPhaseOnContactAndRecordsTheMappedState) {
  ControllerConfig config;
  config.driver.warmup_trials = 1;  // the first hop initializes the learner (checked at the end)
  Robot rig("hopper.xml", config, true);
  ASSERT_TRUE(rig.ok());
  HopperController& c = rig.c();
  const double dt = rig.m()->opt.timestep;
  // The hop starts at the nominal gait's takeoff state.
  const Eigen::Matrix<double, 14, 1> x_start = FlightState(c.mapping(), rig.d(), c.vsa());
  EXPECT_TRUE(x_start.isApprox(c.gait().x0, 1e-12));

  // Touchdown: the plugin switches at the step whose collision pass first has the foot contact,
  // i.e. one step before MuJoCo reports a normal force. Takeoff: after the force vanished.
  int mode = c.mode();
  double first_force_time = -1, touchdown_time = -1, takeoff_time = -1;
  std::vector<double> force_gone;  // steps after which the force dropped below the threshold
  const double threshold = c.config().contact.takeoff_force;
  double prev_force = 0;
  while (c.hop() < 1 && rig.d()->time < 2.0) {
    const double t_before = rig.d()->time;
    const double force = rig.Step();
    if (t_before < 0.05) continue;  // the start state is a takeoff with the foot on the floor
    if (first_force_time < 0 && force > 0) first_force_time = t_before;
    if (prev_force >= threshold && force < threshold) force_gone.push_back(t_before);
    prev_force = force;
    if (c.mode() != mode) {
      (c.mode() == hopper::kStance ? touchdown_time : takeoff_time) = t_before;
      mode = c.mode();
    }
  }
  ASSERT_GE(touchdown_time, 0.0) << "no touchdown within 2 s";
  ASSERT_GE(takeoff_time, 0.0) << "no takeoff within 2 s";
  EXPECT_NEAR(touchdown_time, first_force_time, 1.5 * dt);
  // The takeoff follows the last drop of the force below the plugin's threshold (the impact may
  // bounce for a few steps, which the plugin's minimum phase time ignores).
  double last_gone = -1;
  for (double t : force_gone) {
    if (t <= takeoff_time) last_gone = t;
  }
  ASSERT_GT(last_gone, touchdown_time + 0.1);
  EXPECT_GE(takeoff_time, last_gone - 0.5 * dt);
  EXPECT_LE(takeoff_time, last_gone + 2.5 * dt);

  const std::vector<HopReport> reports = c.TakeReports();
  ASSERT_EQ(reports.size(), 1u);
  const HopReport& r = reports[0];
  EXPECT_NEAR(r.t_touchdown, touchdown_time, 1e-9);
  EXPECT_GT(r.t1, 0.1);
  EXPECT_GT(r.t2, r.t1 + 0.1);
  EXPECT_LT(std::abs(r.foot_height_td), 3e-3);  // touchdown at the floor: I4 ~ 0
  EXPECT_GT(r.apex, 0.7);

  // The first trial seen by the learner starts at the mapped state of the robot.
  ASSERT_NE(c.learner(), nullptr);
  const Trajectory& nominal = c.learner()->nominal();
  ASSERT_EQ(nominal.num_modes(), 2);
  EXPECT_TRUE(nominal.x0.isApprox(Eigen::VectorXd(x_start), 1e-12));
  EXPECT_EQ(nominal.modes[0].x.rows(), hopper::kFlightDim);
  EXPECT_EQ(nominal.modes[1].x.rows(), hopper::kStanceDim);
  EXPECT_NEAR(nominal.T(0), r.t1, 1e-9);
  EXPECT_NEAR(nominal.T(1), r.t2, 1e-9);
}

TEST(HopperControllerTest, ReentryAtTheSameTimeChangesNothing) {
  Robot rig("hopper.xml", ControllerConfig(), true);
  ASSERT_TRUE(rig.ok());
  HopperController& c = rig.c();
  for (int i = 0; i < 50; ++i) rig.Step();
  // The first call at a new time is the step (here an mj_forward, as a viewer would do)...
  mj_forward(rig.m(), rig.d());
  const VsaState vsa = c.vsa();
  const double u[4] = {c.last_input()[0], c.last_input()[1], c.last_input()[2], c.last_input()[3]};
  const double ctrl0 = rig.d()->ctrl[0], ctrl1 = rig.d()->ctrl[1];
  const int hop = c.hop(), mode = c.mode();
  // ... and every further call at the same time, including the mj_step that follows, only
  // rewrites the held input.
  for (int i = 0; i < 3; ++i) mj_forward(rig.m(), rig.d());
  EXPECT_EQ(c.vsa().k_hip, vsa.k_hip);
  EXPECT_EQ(c.vsa().kd_leg, vsa.kd_leg);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(c.last_input()[i], u[i]);
  EXPECT_EQ(rig.d()->ctrl[0], ctrl0);
  EXPECT_EQ(rig.d()->ctrl[1], ctrl1);
  EXPECT_EQ(c.hop(), hop);
  EXPECT_EQ(c.mode(), mode);
  // A nested call (Compute inside Compute) is held as well: simulate it through the hold flag
  // that Compute raises, by holding explicitly.
  {
    HoldScope hold(&c);
    rig.d()->time += rig.m()->opt.timestep;
    mj_forward(rig.m(), rig.d());
    rig.d()->time -= rig.m()->opt.timestep;
  }
  EXPECT_EQ(c.vsa().k_hip, vsa.k_hip);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(c.last_input()[i], u[i]);
}

TEST(HopperControllerTest, AnotherModelsPassesDoNotReachTheController) {
  // mjcb_control is global: compiling another MJCF (mj_setConst runs forward passes on a scratch
  // mjData) or stepping another model calls the attached controller. It must ignore them: no
  // step, no write into the foreign mjData (whose actuators may not exist).
  Robot rig("hopper.xml", ControllerConfig(), true);
  ASSERT_TRUE(rig.ok());
  rig.Step();
  const int hop = rig.c().hop();
  const double u0 = rig.c().last_input()[0];
  MjModelPtr other = LoadMjcf(ModelPath("hopper_m12.xml"));  // compiled while attached
  MjDataPtr other_data(mj_makeData(other.get()));
  for (int i = 0; i < 20; ++i) mj_step(other.get(), other_data.get());
  EXPECT_EQ(other_data->ctrl[0], 0.0);
  EXPECT_EQ(rig.c().hop(), hop);
  EXPECT_EQ(rig.c().last_input()[0], u0);
  // The robot's own steps go on from where they were.
  const double t = rig.d()->time;
  rig.Step();
  EXPECT_GT(rig.d()->time, t);
  EXPECT_FALSE(rig.c().failed()) << rig.c().error();
}

TEST(HopperControllerTest, MujocoFiniteDifferencingAdvancesTime) {
  // A measured fact of MuJoCo 2.2.2 that shapes the plugin: mjd_transitionFD steps the model
  // and does not restore d->time, so a callback cannot tell its calls from real steps by time.
  // Hence HoldScope. If this test fails, MuJoCo changed and the note in plugin/README.md can go.
  MjModelPtr model = LoadMjcf(ModelPath("hopper.xml"));
  MjDataPtr data(mj_makeData(model.get()));
  data->qpos[1] = 0.9;
  mj_forward(model.get(), data.get());
  const int n = 2 * model->nv + model->na;
  std::vector<mjtNum> A(n * n), B(n * model->nu);
  mjd_transitionFD(model.get(), data.get(), 1e-6, 0, A.data(), B.data(), nullptr, nullptr);
  EXPECT_GT(data->time, 5 * model->opt.timestep);
}

TEST(HopperControllerTest, BadStatesNeverGiveNaNOrOutOfBoundsControls) {
  Robot rig("hopper.xml", ControllerConfig(), true);
  ASSERT_TRUE(rig.ok());
  HopperController& c = rig.c();
  for (int i = 0; i < 20; ++i) rig.Step();
  const HopperMapping& map = c.mapping();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    const char* what;
    int qpos;
    int dof;
    double value;
  };
  const Case cases[] = {
      {"NaN pitch", map.qpos_pitch, -1, nan},   {"NaN leg rate", -1, map.dof_leg, nan},
      {"inf height", map.qpos_z, -1, inf},      {"absurd leg angle", map.qpos_hip, -1, 1e3},
      {"absurd speed", -1, map.dof_x, 1e6},     {"absurd leg length", map.qpos_leg, -1, -50.0},
  };
  for (const Case& k : cases) {
    SCOPED_TRACE(k.what);
    const mjtNum saved_q = k.qpos >= 0 ? rig.d()->qpos[k.qpos] : 0;
    const mjtNum saved_v = k.dof >= 0 ? rig.d()->qvel[k.dof] : 0;
    if (k.qpos >= 0) rig.d()->qpos[k.qpos] = k.value;
    if (k.dof >= 0) rig.d()->qvel[k.dof] = k.value;
    rig.d()->time += rig.m()->opt.timestep;  // a new step for the controller
    c.Compute(rig.m(), rig.d());
    ExpectInputInBounds(c);
    EXPECT_TRUE(std::isfinite(rig.d()->ctrl[map.act_hip]));
    EXPECT_TRUE(std::isfinite(rig.d()->ctrl[map.act_leg]));
    if (k.qpos >= 0) rig.d()->qpos[k.qpos] = saved_q;
    if (k.dof >= 0) rig.d()->qvel[k.dof] = saved_v;
  }
  EXPECT_GE(c.nonfinite_steps(), 2);
  EXPECT_FALSE(c.failed()) << c.error();
}

TEST(HopperControllerTest, InputsStayInBoundsOverSeveralHops) {
  Robot rig("hopper_m12.xml", ControllerConfig(), true);
  ASSERT_TRUE(rig.ok());
  while (rig.c().hop() < 3 && rig.d()->time < 4.0) {
    rig.Step();
    ExpectInputInBounds(rig.c());
    ASSERT_FALSE(rig.c().failed()) << rig.c().error();
  }
  EXPECT_EQ(rig.c().hop(), 3);
}

TEST(HopperControllerTest, EachStanceGivesTheMassAboveTheLegSpring) {
  // HopReport::stance_mass: the floor's vertical impulse over the stance, from the actuator
  // forces the controller applied and the leg's turning (J_leg thetadd), over the change of the
  // body's vertical speed plus g T_stance. It weighs what the leg spring carries, the torso and
  // the 1 g leg at the hip (the 2 g foot rests on the floor), whatever the model believes (10 kg
  // here). Without the J_leg thetadd term it is 1-8 g off on these robots.
  for (const char* mjcf : {"hopper_m8.xml", "hopper_m12.xml"}) {
    Robot rig(mjcf, ControllerConfig(), false);
    ASSERT_TRUE(rig.ok());
    const double sprung = rig.m()->body_mass[rig.c().mapping().body_torso] +
                          rig.m()->body_mass[rig.c().mapping().body_leg];
    const std::vector<HopReport> reports = rig.Run(4, Host::kRunsOffline);
    ASSERT_EQ(reports.size(), 4u) << mjcf;
    for (const HopReport& r : reports) {
      EXPECT_NEAR(r.stance_mass, sprung, 1e-4 * sprung) << mjcf << ", hop " << r.hop;
    }
  }
}

// The hops' stance balances (HopReport::identification) determine the robot's mass within 1 %
// after 3 hops, and the 10 kg model is left exactly on the robots it does not match
// (MassIdentification::LeavesModel).
TEST(HopperControllerTest, ThreeHopsIdentifyTheMass) {
  for (const char* mjcf : {"hopper_m8.xml", "hopper_m12.xml", "hopper.xml"}) {
    SCOPED_TRACE(mjcf);
    Robot rig(mjcf, ControllerConfig(), false);
    ASSERT_TRUE(rig.ok());
    const double sprung = rig.m()->body_mass[rig.c().mapping().body_torso] +
                          rig.m()->body_mass[rig.c().mapping().body_leg];
    const std::vector<HopReport> reports = rig.Run(3, Host::kRunsOffline);
    ASSERT_EQ(reports.size(), 3u);
    MassIdentification id;
    for (const HopReport& r : reports) id.Add(r.identification);
    const MassIdentification::Estimate e = id.estimate();
    EXPECT_EQ(e.hops, 3);
    EXPECT_EQ(e.rejected, 0);
    EXPECT_NEAR(e.mass, sprung, 0.01 * sprung);
    EXPECT_LT(e.mass_se, 1e-3 * sprung);
    EXPECT_EQ(id.LeavesModel(10.0), std::abs(sprung - 10.0) > 0.1);
    EXPECT_FALSE(id.LeavesModel(sprung));
  }
}

TEST(HopperControllerTest, ShortLearningRunLowersTheCost) {
  // Algorithm 1 with the paper's inexact model (10 kg, no drag) on the 8 kg robot with drag, on
  // the paper's reading of the hop (I1 against the hop's own start, terminal cost at T_K, no
  // periodic value): the initial law u^0 from the model hops badly on the robot (the last
  // warm-up hop, which initializes the learner, costs ~20), and within a few learning hops the
  // nominal the learner keeps must cost a quarter of that or less. (With the exact model, or
  // with the default reading, whose u^0 hops well on this robot, there is little to learn: the
  // hop-to-hop cost varies more than a few hops of learning can gain.)
  ControllerConfig config;
  config.driver.warmup_trials = 3;  // the learner starts from the third hop of u^0, a bad one
  for (LearnerSettings* s : {&config.driver.learner, &config.model_learner}) {
    s->backward.cyclic_value = 0.0;
    s->backward.terminal_event = false;
  }
  config.anchor_reference = false;
  Robot rig("hopper_m8.xml", config, false);  // the model: 10 kg, no drag
  ASSERT_TRUE(rig.ok());
  std::vector<HopReport> reports;
  double initial = std::numeric_limits<double>::quiet_NaN();
  while (rig.c().hop() < 10 && rig.d()->time < 10.0) {
    rig.Step();
    for (const HopReport& r : rig.c().TakeReports()) {
      if (r.hop + 1 == rig.c().config().driver.warmup_trials) initial = rig.c().learner()->nominal_cost();
      reports.push_back(r);
    }
    ASSERT_FALSE(rig.c().failed()) << rig.c().error();
  }
  ASSERT_EQ(reports.size(), 10u);
  ASSERT_GT(initial, 5.0) << "the model's law should hop badly on the lighter robot";
  int accepted = 0;
  for (const HopReport& r : reports) {
    accepted += r.hop >= rig.c().config().driver.warmup_trials && r.accepted && !r.remeasured;
  }
  EXPECT_GE(accepted, 2);
  EXPECT_LT(rig.c().learner()->nominal_cost(), 0.25 * initial);
}

TEST(HopperControllerTest, DefaultScenarioSurvivesTwelveHopsWithBoundedApexPitchSpeedAndCost) {
  // The default scenario (models/scenarios/default.xml: the 10 kg drag-free model on the 8 kg
  // robot with drag, 0.5 m/s) for 12 hops, enough to see a fall: a law that is wrong (no state
  // feedback, a broken jump term, a bad line search) keeps the inputs in bounds but falls within
  // a few hops or hops far worse. Measured on this tree (Release, issue 19), per hop:
  //   apex 0.773-0.791 m, max |pitch| 0.013-0.027 rad, speed 0.47-0.48 m/s from hop 3 on,
  //   cost 1.39 / 7.05 / 6.66 in hops 0-2 (the transient from the model gait's start state),
  //   1.09-2.90 in hops 3-11, 1.16-1.28 in the last four. (Issue 23's tree, with the paper's
  //   reading of the hop and 3 warm-up hops: 1.5 / 12.9 / 22.3, then 1.08-3.30.)
  // Bounds: as measured on issue 23's tree, with margin: apex 0.73-0.84 m, pitch < 0.1 rad,
  // speed 0.40-0.75 m/s, transient cost < 30, cost from hop 3 < 6.6, mean of the last four < 2.2.
  constexpr double APEX_LO = 0.73, APEX_HI = 0.84, PITCH_HI = 0.1, WARM_COST_HI = 30.0,
                   SPEED_LO = 0.40, SPEED_HI = 0.75, COST_HI = 6.6, LAST_COST_HI = 2.2;
  Robot rig("hopper_m8.xml", ControllerConfig(), false);
  ASSERT_TRUE(rig.ok());
  const int hops = 12;
  // Hops 0-2 are the transient from the model gait's start state (warm-up hops of u^0 on issue
  // 23's tree, learning hops since the hopper's single "Initialize" hop; costs 1.39 / 7.05 /
  // 6.66 on this tree); the bounds of the learning hops apply from hop 3 on.
  const int warmup = 3;
  const int pitch_q = rig.c().mapping().qpos_pitch;
  std::vector<HopReport> reports;
  std::vector<double> pitch(1, 0.0);  // max |pitch| of each hop
  while (static_cast<int>(reports.size()) < hops && rig.d()->time < 12.0) {
    rig.Step();
    pitch.back() = std::max(pitch.back(), std::abs(rig.d()->qpos[pitch_q]));
    for (const HopReport& r : rig.c().TakeReports()) {
      reports.push_back(r);
      pitch.push_back(0.0);
    }
    ASSERT_FALSE(rig.c().failed()) << rig.c().error();
  }
  for (size_t i = 0; i < reports.size(); ++i) {
    const HopReport& r = reports[i];
    std::printf("hop %2d  apex %.4f  pitch %.4f  speed %.4f  cost %.4f  accepted %d\n", r.hop,
                r.apex, pitch[i], r.speed, r.cost, static_cast<int>(r.accepted));
  }
  ASSERT_EQ(reports.size(), static_cast<size_t>(hops)) << "fell or stopped hopping";
  for (int i = 0; i < hops; ++i) {
    const HopReport& r = reports[i];
    EXPECT_GT(r.apex, APEX_LO) << "hop " << i;
    EXPECT_LT(r.apex, APEX_HI) << "hop " << i;
    EXPECT_LT(pitch[i], PITCH_HI) << "hop " << i;
    if (i < warmup) {
      EXPECT_LT(r.cost, WARM_COST_HI) << "transient hop " << i;
    } else {
      EXPECT_GT(r.speed, SPEED_LO) << "hop " << i;
      EXPECT_LT(r.speed, SPEED_HI) << "hop " << i;
      EXPECT_LT(r.cost, COST_HI) << "learning hop " << i;
    }
  }
  double last = 0;
  for (int i = hops - 4; i < hops; ++i) last += reports[i].cost / 4;
  EXPECT_LT(last, LAST_COST_HI) << "mean cost of the last four hops";
}

TEST(HopperControllerTest, LearnerThatNeverAcceptsFallsBackToTheInitialLaw) {
  // (36) can never hold (c huge) and alpha_min lies just below alpha_0, so the first rejected
  // trial terminates the line search with no accepted iteration (the learner is set to terminate:
  // the default restarts the line search instead). From then on the robot must run u^0, the
  // OC-FB law, not a replay of the measured nominal's inputs.
  ControllerConfig config;
  config.driver.learner.restart_on_failure = false;
  config.driver.learner.failure_raises = 0;
  config.driver.learner.c = 1e12;
  // gamma 0.5: one rejection
  config.driver.learner.alpha_min = 0.6 * config.driver.learner.alpha_initial;
  config.driver.warmup_trials = 2;
  Robot rig("hopper_m12.xml", config, true);
  ASSERT_TRUE(rig.ok());
  std::vector<HopReport> reports;
  std::vector<bool> initial_law;  // runs_initial_law() during each hop
  bool during = rig.c().runs_initial_law();
  while (rig.c().hop() < 5 && rig.d()->time < 6.0) {
    const int hop = rig.c().hop();
    rig.Step();
    if (rig.c().hop() != hop) initial_law.push_back(during);
    during = rig.c().runs_initial_law();
    for (const HopReport& r : rig.c().TakeReports()) reports.push_back(r);
    ExpectInputInBounds(rig.c());
    ASSERT_FALSE(rig.c().failed()) << rig.c().error();
  }
  ASSERT_EQ(reports.size(), 5u);
  ASSERT_EQ(initial_law.size(), 5u);
  // hops 0, 1: warm-up with u^0; hop 2: the first trial (rejected, terminates); hops 3, 4: u^0.
  EXPECT_TRUE(initial_law[0]);
  EXPECT_TRUE(initial_law[1]);
  EXPECT_FALSE(initial_law[2]);
  EXPECT_FALSE(reports[2].accepted);
  EXPECT_EQ(reports[2].status, LearnerStatus::kLineSearchFailed);
  EXPECT_TRUE(initial_law[3]);
  EXPECT_TRUE(initial_law[4]);
  EXPECT_EQ(rig.c().learner()->iteration(), 0);
}

// The reports of six hops of the 8 kg robot under `config`, learned offline; none when the
// controller cannot be created.
std::vector<HopReport> SixHopsOfTheEightKgRobot(const ControllerConfig& config) {
  Robot rig("hopper_m8.xml", config, false);
  EXPECT_TRUE(rig.ok());
  if (!rig.ok()) return {};
  return rig.Run(6, Host::kRunsOffline);
}

TEST(HopperControllerTest, LearnerCostIsTheCostUnderTheLearnersReference) {
  // learner_cost is the cost that (36) compared. With I1 against the hop's own start (the
  // paper's reading, anchor_reference = false) it is the reported cost of (42), up to the
  // integration of the effort I2 (the learner's is about 0.1 % of I2 lower, in every hop). With
  // I1 against the model gait's takeoff state (the default) I1 differs, by far more.
  for (bool anchor : {false, true}) {
    ControllerConfig config;
    config.anchor_reference = anchor;
    const std::vector<HopReport> reports = SixHopsOfTheEightKgRobot(config);
    ASSERT_EQ(reports.size(), 6u);
    double largest = 0;
    for (const HopReport& r : reports) {
      ASSERT_TRUE(std::isfinite(r.learner_cost)) << "hop " << r.hop;
      largest = std::max(largest, std::abs(r.learner_cost - r.cost) / (1.0 + r.cost));
    }
    if (anchor) {
      EXPECT_GT(largest, 0.1);
    } else {
      EXPECT_LT(largest, 2e-3);
    }
  }
}

TEST(HopperControllerTest, AFilteredReferenceShiftsTheNominalsCost) {
  // reference_filter < 1 moves the learner's I1 reference between hops, so each judged hop
  // compares with the nominal's cost under the present reference (start_shift, the nominal's
  // change since it was adopted); with the hop's own start unfiltered there is nothing to shift.
  for (double filter : {1.0, 0.1}) {
    ControllerConfig config;
    config.anchor_weight = 0.5;
    config.reference_filter = filter;
    const std::vector<HopReport> reports = SixHopsOfTheEightKgRobot(config);
    ASSERT_EQ(reports.size(), 6u);
    int shifted = 0;
    for (size_t h = 1; h < reports.size(); ++h) {
      ASSERT_TRUE(std::isfinite(reports[h].start_shift)) << "hop " << h;
      if (reports[h].start_shift != 0.0) ++shifted;
    }
    if (filter == 1.0) {
      EXPECT_EQ(shifted, 0);
    } else {
      EXPECT_EQ(shifted, 5);
    }
  }
}

TEST(HopperControllerTest, TheOverspeedLatchHoldsTheGaitOnARobotThatRunsAway) {
  // With the filtered reference, the 12 kg robot under the 10 kg model's laws starts its second
  // hop about 0.15 m/s faster than the model gait: a latch of 0.05 m/s holds from that hop on,
  // one of 1 m/s never comes, and 0 is off.
  for (double latch : {0.0, 0.05, 1.0}) {
    ControllerConfig config;
    config.anchor_weight = 0.0;
    config.reference_filter = 0.05;
    config.overspeed_latch = latch;
    Robot rig("hopper_m12.xml", config, false);
    ASSERT_TRUE(rig.ok());
    const std::vector<HopReport> reports = rig.Run(6, Host::kRunsOffline);
    ASSERT_EQ(reports.size(), 6u);
    int first = -1;
    for (const HopReport& r : reports) {
      if (first >= 0) EXPECT_TRUE(r.reference_latched) << "let go at hop " << r.hop;
      if (r.reference_latched && first < 0) first = r.hop;
    }
    if (latch == 0.05) {
      EXPECT_GE(first, 1) << "latched in the Initialize hop";
      EXPECT_LE(first, 3) << "latched late, or never (-1)";
    } else {
      EXPECT_EQ(first, -1) << "latch " << latch;
    }
  }
}

TEST(HopperControllerTest, TheWatchIsSuspendedOnARobotHeavierThanTheModel) {
  // watch_max_mass: after each hop the identified mass decides whether the watch may go back to
  // an earlier law. With the default (1.05) the watch stays on the 8 kg robot and is suspended
  // on the 12 kg one; it stays there without a limit or with a limit above 1.2. The limit is on
  // the given model's M: a model that identification re-solved on 12 kg does not lift it.
  struct Case {
    const char* mjcf;
    double limit;
    bool identify;
    bool watching;
  };
  for (const Case& k : {Case{"hopper_m8.xml", 1.05, false, true},
                        Case{"hopper_m12.xml", 1.05, false, false},
                        Case{"hopper_m12.xml", 1.25, false, true},
                        Case{"hopper_m12.xml", 0.0, false, true},
                        Case{"hopper_m12.xml", 1.05, true, false}}) {
    ControllerConfig config;
    ASSERT_GT(config.driver.guard.watch_trials, 0) << "premise: the default watches";
    ASSERT_EQ(config.watch_max_mass, 1.05) << "premise: the default limit";
    config.watch_max_mass = k.limit;
    config.identification.mass = k.identify;
    Robot rig(k.mjcf, config, false);
    ASSERT_TRUE(rig.ok());
    const std::vector<HopReport> reports = rig.Run(3, Host::kRunsOffline);
    ASSERT_EQ(reports.size(), 3u);
    const double ratio = reports.back().identified_mass / config.model.M;
    ASSERT_NEAR(ratio, k.mjcf == std::string("hopper_m8.xml") ? 0.8 : 1.2, 0.02)
        << "premise: the identified mass";
    ASSERT_NEAR(reports.back().model_mass, k.identify ? reports.back().identified_mass : 10.0,
                0.02 * 12.0)
        << "premise: the model identification re-solved on, or the given one";
    EXPECT_EQ(rig.c().driver().watching(), k.watching)
        << k.mjcf << ", limit " << k.limit << (k.identify ? ", identified" : "");
  }
}

TEST(HopperControllerTest, ReportsCarryWhatTheAcceptanceTestCompared) {
  // nominal_cost, predicted and start_shift of a hop's report are the numbers the learner's test
  // compared, so the log reproduces every decision: accepted exactly when learner_cost -
  // (nominal_cost + start_shift) <= c predicted (Armijo on the predicted decrease; <= 0 when
  // nothing is predicted), and the next hop is compared with this hop's cost exactly when this
  // one was accepted. Hop 0 is the Initialize hop: its own cost is I^0, nothing is predicted.
  const ControllerConfig config;
  const LearnerSettings& ls = config.driver.learner;
  ASSERT_EQ(ls.acceptance, Acceptance::kPredictedDecrease);
  ASSERT_EQ(ls.noise_margin, 0.0);
  ASSERT_FALSE(ls.remeasure_nominal);
  ASSERT_EQ(config.driver.warmup_trials, 1);
  Robot rig("hopper_m8.xml", config, false);
  ASSERT_TRUE(rig.ok());
  // When hop h's report arrives the learner has issued hop h + 1's trial: its prediction is
  // dI_pred(alpha) = alpha dI_lin + alpha^2 / 2 dI_quad + the duration update's model change.
  std::vector<HopReport> reports;
  std::vector<double> next_predicted;
  while (reports.size() < 12 && rig.d()->time < 20.0) {
    rig.Step();
    for (const HopReport& r : rig.c().TakeReports()) {
      reports.push_back(r);
      const Learner& l = *rig.c().learner();
      const double a = l.alpha();
      next_predicted.push_back(a * l.backward_pass().predicted_linear() +
                               0.5 * a * a * l.backward_pass().predicted_quadratic() +
                               l.switching_step().model_change);
    }
    ASSERT_FALSE(rig.c().failed()) << rig.c().error();
  }
  ASSERT_EQ(reports.size(), 12u);
  EXPECT_EQ(reports[0].nominal_cost, reports[0].learner_cost);
  EXPECT_EQ(reports[0].predicted, 0.0);
  // The harm guard's re-runs of an accepted law (remeasured) are not judged: they come in
  // blocks of verify_trials after an accepted hop, predict nothing, and leave the learner as it
  // was, so the identities below relate each judged hop to the last judged one before it.
  const int reruns = config.driver.guard.verify_accepted ? config.driver.guard.verify_trials : 0;
  int accepted = 0, rejected = 0, rerun_left = 0;
  size_t last_judged = 0;
  for (size_t h = 0; h < reports.size(); ++h) {
    const HopReport& r = reports[h];
    ASSERT_TRUE(std::isfinite(r.learner_cost) && std::isfinite(r.nominal_cost)) << "hop " << h;
    EXPECT_EQ(r.remeasured, rerun_left > 0) << "hop " << h;
    if (r.remeasured) {
      --rerun_left;
      EXPECT_TRUE(std::isnan(r.predicted)) << "hop " << h;
      continue;
    }
    ASSERT_TRUE(std::isfinite(r.predicted) && std::isfinite(r.optimality)) << "hop " << h;
    EXPECT_GT(r.optimality, 0.0) << "hop " << h;
    if (h == 0) continue;
    EXPECT_NEAR(r.predicted, next_predicted[h - 1], 1e-12 * (1.0 + std::abs(r.predicted)))
        << "hop " << h;
    const double decrease = r.learner_cost - (r.nominal_cost + r.start_shift);
    const bool armijo =
        r.predicted < 0 ? decrease <= ls.c * r.predicted : decrease <= 0.0;
    EXPECT_EQ(r.accepted, armijo) << "hop " << h << ": decrease " << decrease << ", predicted "
                                  << r.predicted;
    const HopReport& prev = reports[last_judged];
    EXPECT_EQ(r.nominal_cost, prev.accepted ? prev.learner_cost : prev.nominal_cost)
        << "hop " << h;
    (r.accepted ? accepted : rejected) += 1;
    if (r.accepted) rerun_left = reruns;
    last_judged = h;
  }
  // Both kinds of decision happen on this robot in 12 hops, so the identities were exercised.
  EXPECT_GT(accepted, 0);
  EXPECT_GT(rejected, 0);
}

TEST(HopperControllerTest, FrozenLawStopsLearningAndRestartsAreDeterministic) {
  // Freeze(): the learner sees no more trials (its iteration and nominal cost stay), reports go
  // on. RestartHop(x): the hop that follows depends on x and the law only, so two restarts from
  // the same takeoff state end at the same next takeoff state, and a different start state ends
  // elsewhere. These are what ddoc-return-map's finite differences rely on.
  Robot rig("hopper.xml", ControllerConfig(), true);
  ASSERT_TRUE(rig.ok());
  auto next_takeoff = [&rig]() {
    const int hop = rig.c().hop();
    while (rig.c().hop() == hop && rig.d()->time < 30.0) {
      rig.Step();
      ExpectInputInBounds(rig.c());
      EXPECT_FALSE(rig.c().failed()) << rig.c().error();
    }
    return rig.c().TakeReports();
  };
  while (rig.c().hop() < 5) ASSERT_FALSE(next_takeoff().empty());
  const int iteration = rig.c().learner()->iteration();
  const double nominal = rig.c().learner()->nominal_cost();
  rig.c().Freeze();
  EXPECT_TRUE(rig.c().frozen());
  for (int k = 0; k < 3; ++k) {
    const std::vector<HopReport> reports = next_takeoff();
    ASSERT_EQ(reports.size(), 1u);
    EXPECT_TRUE(reports[0].accepted);
    EXPECT_TRUE(std::isfinite(reports[0].learner_cost));
  }
  EXPECT_EQ(rig.c().learner()->iteration(), iteration);
  EXPECT_EQ(rig.c().learner()->nominal_cost(), nominal);

  const Eigen::Matrix<double, 14, 1> x0 = rig.c().hop_start_state();
  std::vector<Eigen::Matrix<double, 14, 1>> ends;
  for (double dphi : {0.0, 0.0, 0.01}) {
    Eigen::Matrix<double, 14, 1> x = x0;
    x(hopper::kPhi) += dphi;
    rig.c().RestartHop(rig.m(), rig.d(), x);
    ASSERT_EQ(next_takeoff().size(), 1u);
    ends.push_back(rig.c().hop_start_state());
  }
  EXPECT_EQ(ends[0], ends[1]);
  EXPECT_GT((ends[2] - ends[0]).norm(), 1e-4);
  EXPECT_TRUE(ends[2].allFinite());

  Eigen::Matrix<double, 14, 1> bad = x0;
  bad(hopper::kYd) = std::numeric_limits<double>::quiet_NaN();
  try {
    rig.c().RestartHop(rig.m(), rig.d(), bad);
    ADD_FAILURE() << "a NaN start state was accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("not finite"), std::string::npos) << e.what();
  }
  rig.c().Reset(rig.m(), rig.d());
  EXPECT_FALSE(rig.c().frozen());
}

}  // namespace
}  // namespace ddoc::plugin
