// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Online identification in the controller (ControllerConfig::identification, issue 44): the
// stances' mass estimate makes the controller re-solve u^0 on the robot's mass once, a robot
// that matches the model runs exactly as without it, and hop-to-hop noise never flips the model.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "robot.h"

namespace ddoc::plugin {
namespace {

// Steps until `hops` hops have reports (or 60 s of simulated time).
std::vector<HopReport> RunHops(Robot* rig, int hops, Host host = Host::kRunsOffline) {
  std::vector<HopReport> reports;
  while (static_cast<int>(reports.size()) < hops && rig->d()->time < 60.0) {
    rig->Step(host);
    for (const HopReport& r : rig->c().TakeReports()) reports.push_back(r);
    EXPECT_FALSE(rig->c().failed()) << rig->c().error();
    if (rig->c().failed()) break;
  }
  return reports;
}

// The robot's sprung mass (torso + leg), what a stance measures.
double SprungMass(Robot& rig) {
  return rig.m()->body_mass[rig.c().mapping().body_torso] +
         rig.m()->body_mass[rig.c().mapping().body_leg];
}

ControllerConfig Identifying(Method method) {
  ControllerConfig config;
  config.driver.method = method;
  config.identification.mass = true;
  return config;
}

// The first hop with a flight after `due` (s): the hop in which a law due then takes over.
int FirstFlightAfter(const std::vector<HopReport>& reports, double due) {
  for (const HopReport& h : reports) {
    if (h.t_touchdown > due) return h.hop;
  }
  return -1;
}

// On the 8 and 12 kg robots the 10 kg model leaves the estimate after the second stance: u^0 is
// solved again once, on the robot's mass to 1 %, and takes over in the first flight
// resolve_latency after that hop; the hops before report the 10 kg model, the hops after the
// new one.
TEST(ControllerIdentificationTest, TheModelsMassIsReSolvedOnceOnTheRobots) {
  for (const char* mjcf : {"hopper_m8.xml", "hopper_m12.xml"}) {
    SCOPED_TRACE(mjcf);
    Robot rig(mjcf, Identifying(Method::kOcfb), false);
    ASSERT_TRUE(rig.ok());
    const double sprung = SprungMass(rig);
    const std::vector<HopReport> reports = RunHops(&rig, 14);
    ASSERT_EQ(reports.size(), 14u);
    ASSERT_EQ(rig.c().resolves().size(), 1u);
    const ModelResolve& r = rig.c().resolves()[0];
    EXPECT_LE(r.hop, 2) << "identified within 3 hops";
    EXPECT_NEAR(r.mass, sprung, 0.01 * sprung);
    const double due = reports[r.hop].t_end + rig.c().config().identification.resolve_latency;
    EXPECT_EQ(r.took_over_hop, FirstFlightAfter(reports, due));
    EXPECT_GT(r.took_over_hop, r.hop + 1) << "1 s is two hops";
    EXPECT_EQ(rig.c().model_params().M, r.mass);
    for (const HopReport& h : reports) {
      EXPECT_EQ(h.model_mass, h.hop < r.took_over_hop ? 10.0 : r.mass) << "hop " << h.hop;
      EXPECT_NEAR(h.identified_mass, sprung, 0.01 * sprung) << "hop " << h.hop;
    }
    // The reports' (42) stays on the configured model: its I3 uses M = 10 kg before and after.
    EXPECT_EQ(rig.c().config().model.M, 10.0);
  }
}

// The 10 kg robot matches the 10 kg model within 1 %: no re-solve, and every hop is exactly
// the hop of the same run without identification.
TEST(ControllerIdentificationTest, AMatchingRobotRunsExactlyAsWithout) {
  ControllerConfig off;
  Robot plain("hopper.xml", off, false);
  Robot identifying("hopper.xml", Identifying(Method::kAlg1), false);
  ASSERT_TRUE(plain.ok() && identifying.ok());
  const std::vector<HopReport> a = RunHops(&plain, 15);
  const std::vector<HopReport> b = RunHops(&identifying, 15);
  ASSERT_EQ(a.size(), 15u);
  ASSERT_EQ(b.size(), 15u);
  EXPECT_TRUE(identifying.c().resolves().empty());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].cost, b[i].cost) << "hop " << i;
    EXPECT_EQ(a[i].accepted, b[i].accepted) << "hop " << i;
    EXPECT_EQ(b[i].model_mass, 10.0);
  }
}

// Forty hops of Algorithm 1 on the 8 kg robot (every trial a different law, every hop a little
// different): one re-solve, and the model is never moved back or again.
TEST(ControllerIdentificationTest, HopToHopNoiseNeverFlipsTheModel) {
  Robot rig("hopper_m8.xml", Identifying(Method::kAlg1), false);
  ASSERT_TRUE(rig.ok());
  const std::vector<HopReport> reports = RunHops(&rig, 40);
  ASSERT_EQ(reports.size(), 40u);
  EXPECT_EQ(rig.c().resolves().size(), 1u);
  const MassIdentification::Estimate e = rig.c().mass_identification().estimate();
  EXPECT_EQ(e.hops + e.rejected, 40);
  EXPECT_FALSE(rig.c().mass_identification().LeavesModel(rig.c().model_params().M));
}

// The same run twice gives the same hops, and the worker thread re-solves as the host does.
TEST(ControllerIdentificationTest, ReSolvingIsDeterministicOnTheHostAndTheWorker) {
  ControllerConfig worker = Identifying(Method::kMrl);
  worker.offline_thread = true;
  Robot a("hopper_m12.xml", Identifying(Method::kMrl), false);
  Robot b("hopper_m12.xml", Identifying(Method::kMrl), false);
  Robot c("hopper_m12.xml", worker, false);
  ASSERT_TRUE(a.ok() && b.ok() && c.ok());
  const std::vector<HopReport> ra = RunHops(&a, 10);
  const std::vector<HopReport> rb = RunHops(&b, 10);
  const std::vector<HopReport> rc = RunHops(&c, 10, Host::kWaitsForWorker);
  ASSERT_EQ(ra.size(), 10u);
  ASSERT_EQ(rb.size(), 10u);
  ASSERT_EQ(rc.size(), 10u);
  ASSERT_EQ(a.c().resolves().size(), 1u);
  EXPECT_GE(a.c().resolves()[0].took_over_hop, 0);
  for (Robot* r : {&b, &c}) {
    ASSERT_EQ(r->c().resolves().size(), 1u);
    EXPECT_EQ(r->c().resolves()[0].mass, a.c().resolves()[0].mass);
    EXPECT_EQ(r->c().resolves()[0].took_over_hop, a.c().resolves()[0].took_over_hop);
  }
  for (size_t i = 0; i < ra.size(); ++i) {
    EXPECT_EQ(ra[i].cost, rb[i].cost) << "hop " << i;
    EXPECT_EQ(ra[i].cost, rc[i].cost) << "hop " << i;
    EXPECT_EQ(ra[i].model_mass, rc[i].model_mass) << "hop " << i;
  }
}

// Learning inside Compute (offline_latency 0): the new u^0 takes over at the takeoff that ends
// the identifying hop, and the new driver's "Initialize" hop is settle_hops whole hops later.
TEST(ControllerIdentificationTest, SynchronousLearningTakesOverAtTheTakeoff) {
  ControllerConfig config = Identifying(Method::kAlg1);
  config.offline_latency = 0.0;
  config.identification.settle_hops = 1;
  Robot rig("hopper_m8.xml", config, false);
  ASSERT_TRUE(rig.ok());
  const std::vector<HopReport> reports = RunHops(&rig, 8);
  ASSERT_EQ(reports.size(), 8u);
  ASSERT_EQ(rig.c().resolves().size(), 1u);
  const ModelResolve& r = rig.c().resolves()[0];
  EXPECT_EQ(r.took_over_hop, r.hop + 1);
  // Hops took_over, took_over + 1 run u^0 (warm-up), took_over + 2 initializes; the learner's
  // first trial (alpha > 0) is the hop after it.
  for (const HopReport& h : reports) {
    if (h.hop >= r.took_over_hop && h.hop <= r.took_over_hop + 2) {
      EXPECT_EQ(h.alpha, 0.0) << "hop " << h.hop << " runs the new u^0";
    }
  }
  ASSERT_GT(static_cast<int>(reports.size()), r.took_over_hop + 3);
  EXPECT_GT(reports[r.took_over_hop + 3].alpha, 0.0);
}

// Bad identification settings fail Create, naming the field and the bound.
TEST(ControllerIdentificationTest, BadSettingsAreNamed) {
  MjModelPtr m = LoadMjcf(std::string(DDOC_MODELS_DIR) + "/hopper_m8.xml");
  struct Case {
    void (*set)(IdentificationSettings*);
    const char* message;
  };
  const Case cases[] = {
      {[](IdentificationSettings* s) { s->settle_hops = -1; },
       "config.identification.settle_hops = -1, expected >= 0"},
      {[](IdentificationSettings* s) { s->mass_resolution = 0.0; },
       "config.identification.mass_resolution = 0, expected finite and > 0"},
      {[](IdentificationSettings* s) { s->resolve_latency = std::nan(""); },
       "config.identification.resolve_latency = nan, expected finite and >= 0"},
      {[](IdentificationSettings* s) { s->estimator.z = -1.0; }, "MassIdentification: z = -1"},
  };
  for (const Case& c : cases) {
    ControllerConfig config;
    c.set(&config.identification);
    std::string error;
    EXPECT_EQ(HopperController::Create(m.get(), config, &error), nullptr);
    EXPECT_NE(error.find(c.message), std::string::npos) << error;
  }
}

}  // namespace
}  // namespace ddoc::plugin
