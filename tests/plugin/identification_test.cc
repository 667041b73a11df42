// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Online identification in the controller (ControllerConfig::identification, issue 44): the
// stances' mass estimate makes the controller re-solve u^0 on the robot's mass once, a robot
// that matches the model runs exactly as without it, and hop-to-hop noise never flips the model.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
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

// The re-solves, for a failure message.
std::string Describe(const std::vector<ModelResolve>& resolves) {
  std::string out;
  for (const ModelResolve& q : resolves) {
    out += " (hop " + std::to_string(q.hop) + ":";
    for (const auto& [name, value] : ResolvedTerms(q.model)) {
      out += std::string(" ") + name + " " + std::to_string(value);
    }
    out += ")";
  }
  return out;
}

// The first hop with a flight after `due` (s): the hop in which a law due then takes over.
int FirstFlightAfter(const std::vector<HopReport>& reports, double due) {
  for (const HopReport& h : reports) {
    if (h.t_touchdown > due) return h.hop;
  }
  return -1;
}

// On the 8 and 12 kg robots the 10 kg model leaves the estimate after the first stance: u^0 is
// solved again once, on the robot's mass to 1 %, and takes over in the first flight
// resolve_latency after that hop (the next one); the hops before report the 10 kg model, the
// hops after the new one.
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
    EXPECT_EQ(r.hop, 0) << "identified after the first stance";
    EXPECT_NEAR(r.model.M, sprung, 0.01 * sprung);
    const double due = reports[r.hop].t_end + rig.c().config().identification.resolve_latency;
    EXPECT_EQ(r.took_over_hop, FirstFlightAfter(reports, due));
    EXPECT_EQ(r.took_over_hop, r.hop + 1) << "0.1 s: in the next flight";
    EXPECT_EQ(rig.c().model_params().M, r.model.M);
    for (const HopReport& h : reports) {
      EXPECT_EQ(h.model_mass, h.hop < r.took_over_hop ? 10.0 : r.model.M) << "hop " << h.hop;
      EXPECT_NEAR(h.identified_mass, sprung, 0.01 * sprung) << "hop " << h.hop;
    }
    // The reports' (42) stays on the configured model: its I3 uses M = 10 kg before and after.
    EXPECT_EQ(rig.c().config().model.M, 10.0);
  }
}

// The 10 kg robot matches the 10 kg model within 1 %: no re-solve, and every hop is exactly
// the hop of the same run without identification (whose learner is given the settings that
// identification's model_law gives it).
// Fifteen hops of Algorithm 1 on the 10 kg robot with `identifying` and without identification:
// no re-solve, and every hop the same; the identifying controller is returned for more checks.
std::unique_ptr<Robot> ExpectRunsExactlyAsWithout(const ControllerConfig& identifying) {
  ControllerConfig without;
  if (identifying.identification.model_law) {
    without.driver.learner.blend_feedforward = true;
    without.driver.learner.min_predicted_decrease =
        identifying.identification.min_predicted_decrease;
  }
  Robot plain("hopper.xml", without, false);
  auto rig = std::make_unique<Robot>("hopper.xml", identifying, false);
  EXPECT_TRUE(plain.ok() && rig->ok());
  if (!plain.ok() || !rig->ok()) return rig;
  const std::vector<HopReport> a = RunHops(&plain, 15);
  const std::vector<HopReport> b = RunHops(rig.get(), 15);
  EXPECT_EQ(a.size(), 15u);
  EXPECT_EQ(b.size(), 15u);
  EXPECT_TRUE(rig->c().resolves().empty());
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) {
    EXPECT_EQ(a[i].cost, b[i].cost) << "hop " << i;
    EXPECT_EQ(a[i].accepted, b[i].accepted) << "hop " << i;
    EXPECT_EQ(b[i].model_mass, 10.0);
  }
  return rig;
}

TEST(ControllerIdentificationTest, AMatchingRobotRunsExactlyAsWithout) {
  ExpectRunsExactlyAsWithout(Identifying(Method::kAlg1));
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

// The same run twice on the host, and once with the offline part on the worker thread: a runs
// `hops_a` hops, b and c `hops`; each re-solves once, at the same hop, on the same model, and the
// first `hops` hops are the same. The rigs stay for more checks.
struct ThreeRuns {
  std::unique_ptr<Robot> a, b, c;
};
ThreeRuns ExpectDeterministic(const char* mjcf, const ControllerConfig& config,
                              void (*edit)(mjModel*), int hops_a, int hops) {
  ControllerConfig worker = config;
  worker.offline_thread = true;
  ThreeRuns t{std::make_unique<Robot>(mjcf, config, false, edit),
              std::make_unique<Robot>(mjcf, config, false, edit),
              std::make_unique<Robot>(mjcf, worker, false, edit)};
  EXPECT_TRUE(t.a->ok() && t.b->ok() && t.c->ok());
  if (!t.a->ok() || !t.b->ok() || !t.c->ok()) return t;
  const std::vector<HopReport> ra = RunHops(t.a.get(), hops_a);
  const std::vector<HopReport> rb = RunHops(t.b.get(), hops);
  const std::vector<HopReport> rc = RunHops(t.c.get(), hops, Host::kWaitsForWorker);
  EXPECT_EQ(ra.size(), static_cast<size_t>(hops_a));
  EXPECT_EQ(rb.size(), static_cast<size_t>(hops));
  EXPECT_EQ(rc.size(), static_cast<size_t>(hops));
  EXPECT_EQ(t.a->c().resolves().size(), 1u);
  if (t.a->c().resolves().empty()) return t;
  const ModelResolve& first = t.a->c().resolves()[0];
  EXPECT_GE(first.took_over_hop, 0);
  for (Robot* r : {t.b.get(), t.c.get()}) {
    EXPECT_EQ(r->c().resolves().size(), 1u);
    if (r->c().resolves().empty()) continue;
    EXPECT_EQ(r->c().resolves()[0].model.M, first.model.M);
    EXPECT_EQ(r->c().resolves()[0].model.b_leg, first.model.b_leg);
    EXPECT_EQ(r->c().resolves()[0].took_over_hop, first.took_over_hop);
  }
  for (size_t i = 0; i < std::min({ra.size(), rb.size(), rc.size()}); ++i) {
    EXPECT_EQ(ra[i].cost, rb[i].cost) << "hop " << i;
    EXPECT_EQ(ra[i].cost, rc[i].cost) << "hop " << i;
    EXPECT_EQ(ra[i].model_mass, rc[i].model_mass) << "hop " << i;
  }
  return t;
}

// The same run twice gives the same hops, and the worker thread re-solves as the host does.
TEST(ControllerIdentificationTest, ReSolvingIsDeterministicOnTheHostAndTheWorker) {
  ExpectDeterministic("hopper_m12.xml", Identifying(Method::kMrl), nullptr, 10, 10);
}

// Learning inside Compute (offline_latency 0): the new u^0 takes over at the takeoff that ends
// the identifying hop, and the new driver's "Initialize" hop is settle_hops whole hops later.
TEST(ControllerIdentificationTest, SynchronousLearningTakesOverAtTheTakeoff) {
  ControllerConfig config = Identifying(Method::kAlg1);
  config.offline_latency = 0.0;
  config.identification.settle_hops = 1;
  config.identification.settle_cost = 0.0;  // "Initialize" whatever the hop's cost
  Robot rig("hopper_m8.xml", config, false);
  ASSERT_TRUE(rig.ok());
  const std::vector<HopReport> reports = RunHops(&rig, 8);
  ASSERT_EQ(reports.size(), 8u);
  ASSERT_EQ(rig.c().resolves().size(), 1u) << Describe(rig.c().resolves());
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

ControllerConfig IdentifyingTerms(Method method) {
  ControllerConfig config = Identifying(method);
  config.identification.terms = true;
  return config;
}

// Both motors at 80 % of the commanded force (a <general> motor's gainprm, as --robot-variant
// hip_gain=0.8,leg_gain=0.8 makes it).
void WeakerMotors(mjModel* m) {
  for (int a = 0; a < m->nu; ++a) m->actuator_gainprm[a * mjNGAIN] *= 0.8;
}

// The terms of the MJCF variants, one test each (10 kg robots with a leg damper of 4 N s/m, a
// hip damper of 0.5 N m s/rad, a floor 2 deg down hill, or motors at 80 %; no drag): after the
// first hop (the slope: the second, the first between two takeoffs) the 10 kg paper's model
// leaves the estimates, u^0 is solved again once on the identified terms (each within its
// tolerance of the robot's, the slope within 1.5 mrad; the others as they were) and takes over
// in the next flight; after 8 hops every estimate is within 1 % (slope: 0.5 mrad, drag 1e-4 kg/m) of the robot's.
void ExpectTheTermsIdentified(const char* mjcf, void (*edit)(mjModel*), double gain) {
  Robot rig(mjcf, IdentifyingTerms(Method::kOcfb), false, edit);
  ASSERT_TRUE(rig.ok());
  const HopperMapping& map = rig.c().mapping();
  // What the robot has, in the model's terms: a motor of strength g reads as M, the inertias
  // and the dampers / g.
  const double b_leg = map.leg_damping / gain, b_hip = map.hip_damping / gain;
  const double j_body = rig.m()->body_inertia[3 * map.body_torso + 1] / gain;
  const double slope = map.floor_slope;
  const double c_d = map.drag_cd / gain;
  const std::vector<HopReport> reports = RunHops(&rig, 8);
  ASSERT_EQ(reports.size(), 8u);
  // One re-solve; on the slope a second may refine its first pair's estimate (1.5-1.9 mrad off
  // on this robot, depending on the hops the learner ran).
  ASSERT_GE(rig.c().resolves().size(), 1u);
  ASSERT_LE(rig.c().resolves().size(), slope != 0.0 ? 2u : 1u) << Describe(rig.c().resolves());
  const ModelResolve& first = rig.c().resolves()[0];
  EXPECT_EQ(first.hop, slope != 0.0 ? 1 : 0);
  EXPECT_EQ(first.took_over_hop, first.hop + 1);
  EXPECT_NEAR(first.model.slope, slope, 3e-3);
  const ModelResolve& r = rig.c().resolves().back();
  const TermsIdentification::Settings tol;
  EXPECT_NEAR(r.model.b_leg, b_leg, tol.b_leg_tolerance);
  EXPECT_NEAR(r.model.b_hip, b_hip, tol.b_hip_tolerance);
  EXPECT_NEAR(r.model.J_body, j_body, tol.inertia_tolerance * j_body);
  EXPECT_NEAR(r.model.J_leg / r.model.J_body, 0.25 / 2.5, 1e-12);
  // The slope's re-solve is refined only while the estimate leaves the model by more than the
  // tolerance: the model's slope is within the tolerance of the final estimate (itself within
  // 0.5 mrad of the robot's, below), so within 1.5 mrad of the robot's.
  EXPECT_NEAR(r.model.slope, slope, tol.slope_tolerance + 5e-4);
  EXPECT_FALSE(rig.c().terms_identification().LeavesModel(rig.c().model_params()));
  EXPECT_NEAR(r.model.c_d, c_d, tol.drag_tolerance);
  const HopperParams& p = rig.c().model_params();
  EXPECT_EQ(p.b_leg, r.model.b_leg);
  EXPECT_EQ(p.slope, r.model.slope);
  const TermsIdentification::Estimate e = rig.c().terms_identification().estimate();
  EXPECT_NEAR(e.b_leg.value, b_leg, 0.01 * b_leg + 0.02);
  EXPECT_NEAR(e.b_hip.value, b_hip, 0.01 * b_hip + 1e-3);
  EXPECT_NEAR(e.j_body.value, j_body, 0.01 * j_body);
  EXPECT_NEAR(e.slope.value, slope, 5e-4);
  // With weaker motors the mass reads M / g but the 2 g foot's momentum does not: the drag reads
  // 0.003 kg/m on this drag-free robot, inside the tolerance.
  EXPECT_NEAR(e.c_d.value, c_d, gain == 1.0 ? 1e-4 : tol.drag_tolerance);
  EXPECT_EQ(e.b_leg.rejected + e.b_hip.rejected + e.slope.rejected, 0);
  for (const HopReport& h : reports) {  // the reports say which model ran
    EXPECT_EQ(h.model_params.b_leg, h.hop < first.took_over_hop ? 0.0 : first.model.b_leg) << h.hop;
    EXPECT_EQ(h.model_params.J_body, h.hop < first.took_over_hop ? 2.5 : first.model.J_body) << h.hop;
    if (h.hop >= r.took_over_hop) EXPECT_EQ(h.model_params.slope, r.model.slope) << h.hop;
  }
}

TEST(ControllerIdentificationTest, TheLegDamperIsIdentified) {
  ExpectTheTermsIdentified("hopper_damped_leg.xml", nullptr, 1.0);
}
TEST(ControllerIdentificationTest, TheHipDamperIsIdentified) {
  ExpectTheTermsIdentified("hopper_damped_hip.xml", nullptr, 1.0);
}
TEST(ControllerIdentificationTest, TheSlopeIsIdentified) {
  ExpectTheTermsIdentified("hopper_slope_down.xml", nullptr, 1.0);
}
TEST(ControllerIdentificationTest, WeakerMotorsAreIdentifiedAsInertiasAndMass) {
  ExpectTheTermsIdentified("hopper.xml", WeakerMotors, 0.8);
}

// With the terms on, the 10 kg robot (no dampers, level floor, full-strength motors) is the 10
// kg model: no re-solve, and every hop exactly the hop of the run without identification.
TEST(ControllerIdentificationTest, AMatchingRobotRunsExactlyAsWithoutTheTerms) {
  const std::unique_ptr<Robot> rig = ExpectRunsExactlyAsWithout(IdentifyingTerms(Method::kAlg1));
  ASSERT_TRUE(rig->ok());
  EXPECT_FALSE(rig->c().terms_identification().LeavesModel(rig->c().model_params()));
}

// A leg damper of 2 N s/m (the joint's damping in the compiled model).
void DampedLeg(mjModel* m) {
  m->dof_damping[m->jnt_dofadr[mj_name2id(m, mjOBJ_JOINT, "leg")]] = 2.0;
}

// Forty hops of Algorithm 1 on a damped leg (every trial a different law): one re-solve, and
// the model is never moved back or again; the same run twice and on the worker thread gives the
// same hops and the same identified model.
TEST(ControllerIdentificationTest, TheTermsNeverFlipAndAreDeterministic) {
  const ThreeRuns t =
      ExpectDeterministic("hopper_m8.xml", IdentifyingTerms(Method::kAlg1), DampedLeg, 40, 12);
  ASSERT_TRUE(t.a->ok());
  const HopperController& a = t.a->c();
  ASSERT_EQ(a.resolves().size(), 1u);
  // The 8 kg robot's drag (0.01 kg/m) and the damper, on the 10 kg drag-free model.
  EXPECT_NEAR(a.resolves()[0].model.c_d, 0.01, 2e-4);
  EXPECT_NEAR(a.resolves()[0].model.b_leg, 2.0, 0.1);
  EXPECT_NEAR(a.terms_identification().estimate().c_d.value, 0.01, 1e-4);
  EXPECT_FALSE(a.terms_identification().LeavesModel(a.model_params()));
  EXPECT_FALSE(a.mass_identification().LeavesModel(a.model_params().M));
}

// Bad identification settings fail Create, naming the field and the bound.
// The hop of a run that initialized the new driver: the last hop of u^0 (alpha 0) from
// `from` on before the first learning trial (alpha > 0); -1 when no trial ran.
int InitializeHop(const std::vector<HopReport>& reports, int from) {
  for (const HopReport& h : reports) {
    if (h.hop > from && h.alpha > 0.0) return h.hop - 1;
  }
  return -1;
}

// settle_cost: after settle_hops, "Initialize" is the first hop of the new u^0 whose cost (42)
// is at most settle_cost x u^0's cost on the model, or the hop settle_hops_max after the
// takeover hop when none is.
TEST(ControllerIdentificationTest, InitializeWaitsForASettledHop) {
  int delayed = 0;  // robots on which the threshold moved "Initialize" past settle_hops
  for (const char* mjcf : {"hopper_m8.xml", "hopper_m12.xml"}) {
    SCOPED_TRACE(mjcf);
    ControllerConfig config = Identifying(Method::kAlg1);
    config.offline_latency = 0.0;  // every hop learned from: the hop counts are exact
    config.identification.settle_hops = 1;
    config.identification.settle_cost = 1.05;
    config.identification.settle_hops_max = 12;
    Robot rig(mjcf, config, false);
    ASSERT_TRUE(rig.ok());
    const std::vector<HopReport> reports = RunHops(&rig, 20);
    ASSERT_EQ(reports.size(), 20u);
    ASSERT_EQ(rig.c().resolves().size(), 1u) << Describe(rig.c().resolves());
    const int took_over = rig.c().resolves()[0].took_over_hop;
    const int init = InitializeHop(reports, took_over);
    EXPECT_EQ(rig.c().resolves()[0].initialize_hop, init);
    ASSERT_GE(init, took_over + 2) << "at least settle_hops whole hops of the new u^0";
    ASSERT_LE(init, took_over + 1 + 12) << "at most settle_hops_max";
    const double threshold = 1.05 * rig.c().model_cost();
    for (int h = took_over; h <= init; ++h) EXPECT_EQ(reports[h].alpha, 0.0) << "hop " << h;
    for (int h = took_over + 2; h < init; ++h) {
      EXPECT_GT(reports[h].cost, threshold) << "hop " << h << " had settled";
    }
    if (init < took_over + 1 + 12) EXPECT_LE(reports[init].cost, threshold);
    if (init > took_over + 2) ++delayed;
    std::printf("%s: took over in hop %d, Initialize hop %d (threshold %.3f)\n", mjcf, took_over,
                init, threshold);
  }
  EXPECT_GT(delayed, 0) << "no robot waited: the test does not exercise the threshold";
  // A threshold no hop meets: "Initialize" after settle_hops_max hops.
  ControllerConfig config = Identifying(Method::kAlg1);
  config.offline_latency = 0.0;
  config.identification.settle_hops = 1;
  config.identification.settle_cost = 1e-6;
  config.identification.settle_hops_max = 4;
  Robot rig("hopper_m8.xml", config, false);
  ASSERT_TRUE(rig.ok());
  const std::vector<HopReport> reports = RunHops(&rig, 10);
  ASSERT_EQ(rig.c().resolves().size(), 1u);
  const int took_over = rig.c().resolves()[0].took_over_hop;
  EXPECT_EQ(InitializeHop(reports, took_over), took_over + 1 + 4);
}

TEST(ControllerIdentificationTest, BadSettingsAreNamed) {
  MjModelPtr m = LoadMjcf(std::string(DDOC_MODELS_DIR) + "/hopper_m8.xml");
  struct Case {
    void (*set)(IdentificationSettings*);
    const char* message;
  };
  const Case cases[] = {
      {[](IdentificationSettings* s) { s->settle_hops = -1; },
       "config.identification.settle_hops = -1, expected >= 0"},
      {[](IdentificationSettings* s) { s->settle_cost = -1.0; },
       "config.identification.settle_cost = -1, expected finite and >= 0"},
      {[](IdentificationSettings* s) { s->settle_hops_max = 1; },
       "config.identification.settle_hops_max = 1, expected >= identification.settle_hops (2)"},
      {[](IdentificationSettings* s) { s->mass_resolution = 0.0; },
       "config.identification.mass_resolution = 0, expected finite and > 0"},
      {[](IdentificationSettings* s) { s->resolve_latency = std::nan(""); },
       "config.identification.resolve_latency = nan, expected finite and >= 0"},
      {[](IdentificationSettings* s) { s->min_predicted_decrease = -0.5; },
       "config.identification.min_predicted_decrease = -0.5, expected finite and >= 0"},
      {[](IdentificationSettings* s) { s->estimator.z = -1.0; }, "MassIdentification: z = -1"},
      {[](IdentificationSettings* s) { s->term_resolution.slope = 0.0; },
       "config.identification.term_resolution.slope = 0, expected finite and > 0"},
      {[](IdentificationSettings* s) { s->terms_estimator.b_leg_tolerance = -1.0; },
       "TermsIdentification: b_leg_tolerance = -1"},
  };
  for (const Case& c : cases) {
    ControllerConfig config;
    c.set(&config.identification);
    std::string error;
    EXPECT_EQ(HopperController::Create(m.get(), config, &error), nullptr);
    EXPECT_NE(error.find(c.message), std::string::npos) << error;
  }
}

// model_law: with identification acting, the driver's learner tends to the nominal law
// exactly (blend_feedforward) and has the floor on the predicted decrease; without it, or with
// model_law off, the learner is the fixed-model one (the paper comparison's).
TEST(ControllerIdentificationTest, AnIdentifiedModelsLearnerTrustsItsLaw) {
  MjModelPtr m = LoadMjcf(std::string(DDOC_MODELS_DIR) + "/hopper_m8.xml");
  struct Case {
    bool mass, terms, model_law, trusted;
  };
  for (const Case& c : {Case{false, false, true, false}, Case{true, false, true, true},
                        Case{false, true, true, true}, Case{true, true, false, false}}) {
    ControllerConfig config;
    config.identification.mass = c.mass;
    config.identification.terms = c.terms;
    config.identification.model_law = c.model_law;
    config.identification.min_predicted_decrease = 0.02;
    std::string error;
    auto controller = HopperController::Create(m.get(), config, &error);
    ASSERT_NE(controller, nullptr) << error;
    const LearnerSettings& l = controller->driver().settings().learner;
    EXPECT_EQ(l.blend_feedforward, c.trusted) << c.mass << c.terms << c.model_law;
    EXPECT_EQ(l.min_predicted_decrease, c.trusted ? 0.02 : 0.0);
  }
}

}  // namespace
}  // namespace ddoc::plugin
