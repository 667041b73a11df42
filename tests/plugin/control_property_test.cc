// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The controller's promise as a property test (issue 20): whatever state mjData holds (NaN, Inf,
// huge, random), at every phase of a hop and in both modes of the offline part (host: RunOffline
// between steps; worker: a thread), every control Compute writes to mjData is finite, every
// actuator with a ctrlrange gets a ctrl inside it, and the input u is finite and inside its box.
// Fixed seed; the phases are found on a reference run, then each is reached again after a Reset
// of the same controller (the runs are deterministic) and hit with random states. Reset must
// clear what the random states did: the reference run is repeated exactly at the end.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "hopper_controller.h"
#include "robot.h"

namespace ddoc::plugin {
namespace {

// Where in a hop the controller is: the hop's role, the contact mode, which law runs, and what
// the offline part does. A probe is taken at the first and the middle step of each.
struct Phase {
  bool warmup;          // a warm-up hop (u^0) or a learning hop
  int mode;             // hopper::kFlight / kStance
  bool initial_law;     // u^0 (warm-up, or the latency after a hop) or a learned law
  bool offline_pending; // a hop waits for the offline part (host mode, right after a takeoff)
  bool operator==(const Phase& o) const { return !(*this < o) && !(o < *this); }
  bool operator<(const Phase& o) const {
    return std::tie(warmup, mode, initial_law, offline_pending) <
           std::tie(o.warmup, o.mode, o.initial_law, o.offline_pending);
  }
  std::string Name() const {
    char buf[120];
    std::snprintf(buf, sizeof(buf), "%s hop, %s, %s%s", warmup ? "warm-up" : "learning",
                  mode == hopper::kFlight ? "flight" : "stance",
                  initial_law ? "u^0" : "learned law", offline_pending ? ", offline pending" : "");
    return buf;
  }
};

ControllerConfig Config(bool worker) {
  ControllerConfig config;
  config.offline_thread = worker;
  return config;
}

Host HostOf(bool worker) { return worker ? Host::kWaitsForWorker : Host::kRunsOffline; }

// The warm-up hops (HopperTrialSettings) and two learning hops: the second learning hop is the
// first that runs a law learned from a learning hop.
int Hops(Robot& rig) { return rig.c().config().driver.warmup_trials + 2; }

// The reference run from a Reset: the phase after each step, until Hops() hops are complete.
std::vector<Phase> PhasesOfAReferenceRun(Robot& rig, bool worker) {
  std::vector<Phase> phases;
  rig.Restart();
  const int warmup = rig.c().config().driver.warmup_trials;
  while (rig.c().hop() < Hops(rig) && rig.d()->time < 10.0) {
    // Step(HostOf(worker)) in two parts, to see the phase before the offline part runs.
    rig.Step(Host::kNothing);
    HopperController& c = rig.c();
    phases.push_back({c.hop() < warmup, c.mode(), c.runs_initial_law(), c.offline_pending()});
    if (worker) c.FinishOffline();
    if (!worker && c.offline_pending()) c.RunOffline();
  }
  return phases;
}

// A random value of the kinds that break arithmetic.
double RandomBadValue(std::mt19937_64& rng) {
  const double inf = std::numeric_limits<double>::infinity();
  std::uniform_int_distribution<int> kind(0, 8);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_real_distribution<double> exponent(-3.0, 300.0);
  switch (kind(rng)) {
    case 0: return std::numeric_limits<double>::quiet_NaN();
    case 1: return inf;
    case 2: return -inf;
    case 3: return unit(rng) > 0 ? 1e300 : -1e300;
    case 4: return std::numeric_limits<double>::max() * (unit(rng) > 0 ? 1 : -1);
    case 5: return 1e-310;  // subnormal
    case 6: return 0.0;
    default: return unit(rng) * std::pow(10.0, exponent(rng));
  }
}

// Every control written to mjData is finite (and inside ctrlrange where the MJCF has one); the
// held input is finite and inside the input box.
void ExpectPromiseKept(const mjModel* m, const mjData* d, const HopperController& c,
                       const std::string& where) {
  for (int a = 0; a < m->nu; ++a) {
    ASSERT_TRUE(std::isfinite(d->ctrl[a])) << where << ": ctrl[" << a << "] = " << d->ctrl[a];
    if (m->actuator_ctrllimited[a]) {
      EXPECT_GE(d->ctrl[a], m->actuator_ctrlrange[2 * a]) << where;
      EXPECT_LE(d->ctrl[a], m->actuator_ctrlrange[2 * a + 1]) << where;
    }
  }
  for (int i = 0; i < 4; ++i) {
    const double u = c.last_input()[i];
    ASSERT_TRUE(std::isfinite(u)) << where << ": u[" << i << "] = " << u;
    ASSERT_GE(u, c.u_min()(i)) << where << ": u[" << i << "]";
    ASSERT_LE(u, c.u_max()(i)) << where << ": u[" << i << "]";
  }
}

// Reaches step `step` of the run after a Reset, then calls Compute on `trials` random states
// (each a new, slightly later instant of the same step, so that Compute does the full step),
// restoring mjData between them. Then 50 real steps go on from the last corrupted controller.
void ProbeAt(Robot& rig, bool worker, int step, const std::string& phase, std::mt19937_64& rng,
             int trials) {
  rig.Restart();
  // The probe comes after the step's physics, before the host's part: a hop handed over at this
  // step is still pending (host) or running on the worker thread (worker).
  for (int i = 0; i + 1 < step; ++i) rig.Step(HostOf(worker));
  rig.Step(Host::kNothing);
  const mjModel* m = rig.m();
  mjData* d = rig.d();
  HopperController& c = rig.c();
  ExpectPromiseKept(m, d, c, phase + " (before the probe)");
  const std::vector<mjtNum> qpos(d->qpos, d->qpos + m->nq), qvel(d->qvel, d->qvel + m->nv);
  const double t = d->time;
  std::uniform_int_distribution<int> how_many(1, m->nq + m->nv);
  std::uniform_int_distribution<int> which(0, m->nq + m->nv - 1);
  for (int k = 0; k < trials; ++k) {
    std::copy(qpos.begin(), qpos.end(), d->qpos);
    std::copy(qvel.begin(), qvel.end(), d->qvel);
    const int n = how_many(rng);
    for (int j = 0; j < n; ++j) {
      const int i = which(rng);
      (i < m->nq ? d->qpos[i] : d->qvel[i - m->nq]) = RandomBadValue(rng);
    }
    d->time = t + 1e-9 * (k + 1);  // a new instant: Compute steps the law, not only re-writes
    c.Compute(m, d);
    ExpectPromiseKept(m, d, c, phase + ", random state " + std::to_string(k));
    if (::testing::Test::HasFatalFailure()) return;
  }
  std::copy(qpos.begin(), qpos.end(), d->qpos);
  std::copy(qvel.begin(), qvel.end(), d->qvel);
  d->time = t;
  // The controller after all that still keeps the promise on real steps.
  for (int i = 0; i < 50; ++i) {
    rig.Step(HostOf(worker));
    ExpectPromiseKept(m, d, c, phase + ", real step " + std::to_string(i) + " after the probe");
    if (::testing::Test::HasFatalFailure()) return;
  }
}

void CheckEveryPhase(bool worker) {
  // One controller for every probe: Create derives u^0 on the model (seconds; a minute under
  // the sanitizers), a Reset does not.
  Robot rig("hopper_m8.xml", Config(worker), false);
  ASSERT_TRUE(rig.ok());
  const std::vector<Phase> phases = PhasesOfAReferenceRun(rig, worker);
  ASSERT_GT(phases.size(), 1000u) << "the reference run did not hop";
  // The first and the middle step of every run of equal phases, and the takeoff steps (the step
  // that hands a hop to the offline part).
  std::vector<std::pair<int, Phase>> probes;
  size_t begin = 0;
  for (size_t i = 1; i <= phases.size(); ++i) {
    if (i == phases.size() || phases[i] < phases[begin] || phases[begin] < phases[i]) {
      probes.push_back({static_cast<int>(begin) + 1, phases[begin]});
      probes.push_back({static_cast<int>((begin + i) / 2) + 1, phases[begin]});
      begin = i;
    }
  }
  std::set<Phase> kinds;
  for (const auto& p : probes) kinds.insert(p.second);
  // Warm-up and learning hops, flight and stance, u^0 and a learned law must all be probed.
  bool learned_flight = false, learned_stance = false, warmup = false;
  for (const Phase& k : kinds) {
    learned_flight = learned_flight || (!k.initial_law && k.mode == hopper::kFlight);
    learned_stance = learned_stance || (!k.initial_law && k.mode == hopper::kStance);
    warmup = warmup || k.warmup;
  }
  EXPECT_TRUE(learned_flight && learned_stance && warmup) << kinds.size() << " phase kinds";
  std::mt19937_64 rng(20);  // fixed seed
  // Probes in several hops are the same phase kinds; every kind is probed at the first and the
  // middle step of its first occurrence.
  std::vector<std::pair<int, Phase>> chosen;
  for (const Phase& k : kinds) {
    int taken = 0;
    for (const auto& p : probes) {
      if (!(p.second < k) && !(k < p.second) && taken < 2) {
        chosen.push_back(p);
        ++taken;
      }
    }
  }
  for (const auto& [step, phase] : chosen) {
    SCOPED_TRACE(phase.Name() + " at step " + std::to_string(step));
    ProbeAt(rig, worker, step, phase.Name(), rng, 200);
    if (::testing::Test::HasFatalFailure()) return;
  }
  // Whatever the probes left in the controller, a Reset starts the same run again.
  EXPECT_TRUE(PhasesOfAReferenceRun(rig, worker) == phases) << "Reset left a trace of the probes";
  std::printf("%s mode: %zu probes over %zu phase kinds, 200 random states each\n",
              worker ? "worker" : "host", chosen.size(), kinds.size());
}

TEST(ControlPropertyTest, EveryControlIsFiniteAndInBoundsHostMode) { CheckEveryPhase(false); }

TEST(ControlPropertyTest, EveryControlIsFiniteAndInBoundsWorkerMode) { CheckEveryPhase(true); }

}  // namespace
}  // namespace ddoc::plugin
