// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The offline part (trial driver: (36), (30), (31)) runs outside Compute: in RunOffline() called
// by the host between steps, or on the controller's worker thread; the learned law takes effect
// offline_latency after the hop's end. Results are identical run to run, and the worker thread
// gives what the host gives when the host waits for it.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "robot.h"

namespace ddoc::plugin {
namespace {

void ExpectSameReports(const std::vector<HopReport>& a, const std::vector<HopReport>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    SCOPED_TRACE("hop " + std::to_string(i));
    EXPECT_EQ(a[i].hop, b[i].hop);
    EXPECT_EQ(a[i].t_start, b[i].t_start);
    EXPECT_EQ(a[i].t_end, b[i].t_end);
    EXPECT_EQ(a[i].cost, b[i].cost);
    EXPECT_EQ(a[i].speed, b[i].speed);
    EXPECT_EQ(a[i].alpha, b[i].alpha);
    EXPECT_EQ(a[i].du2, b[i].du2);
    EXPECT_EQ(a[i].accepted, b[i].accepted);
    EXPECT_EQ(a[i].learner_cost, b[i].learner_cost);
    EXPECT_EQ(a[i].status, b[i].status);
    EXPECT_EQ(a[i].body_takeoff, b[i].body_takeoff);
  }
}

ControllerConfig LearningFromHop0(double latency) {
  ControllerConfig config;
  config.driver.warmup_trials = 1;  // hop 0's end initializes the learner
  config.offline_latency = latency;
  return config;
}

TEST(OfflinePartTest, RunsOutsideComputeAndTheLawTakesEffectAfterTheLatency) {
  const double latency = 0.02;
  Robot robot("hopper_m8.xml", LearningFromHop0(latency), false);
  ASSERT_TRUE(robot.ok());
  HopperController& c = robot.c();
  while (c.hop() == 0) robot.Step(Host::kNothing);
  // The takeoff step handed hop 0 over; nothing of the offline part ran inside Compute.
  const double t_end = robot.d()->time;
  EXPECT_TRUE(c.offline_pending());
  EXPECT_EQ(c.learner()->nominal().num_modes(), 0) << "the learner was initialized in Compute";
  EXPECT_TRUE(c.TakeReports().empty());  // the report waits for its outcome
  c.RunOffline();
  EXPECT_FALSE(c.offline_pending());
  EXPECT_EQ(c.learner()->nominal().num_modes(), 2);
  const std::vector<HopReport> reports = c.TakeReports();
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_TRUE(reports[0].accepted);
  // u^0 runs until t_end + latency, then the learned law.
  double switched = -1;
  while (robot.d()->time < t_end + 2 * latency) {
    robot.Step(Host::kRunsOffline);
    if (switched < 0 && !c.runs_initial_law()) switched = robot.d()->time;
  }
  ASSERT_GT(switched, 0.0);
  EXPECT_NEAR(switched, t_end + latency, 1.01e-3);  // the step after the due time, 0.5 ms steps
}

TEST(OfflinePartTest, ZeroLatencyLearnsAtTheTakeoffStep) {
  Robot robot("hopper_m8.xml", LearningFromHop0(0.0), false);
  ASSERT_TRUE(robot.ok());
  HopperController& c = robot.c();
  while (c.hop() == 0) {
    robot.Step(Host::kNothing);
    EXPECT_FALSE(c.offline_pending());
  }
  EXPECT_EQ(c.learner()->nominal().num_modes(), 2);
  EXPECT_FALSE(c.runs_initial_law());
  EXPECT_EQ(c.TakeReports().size(), 1u);
}

TEST(OfflinePartTest, IdenticalOutputsRunToRun) {
  ControllerConfig config;  // the defaults: warm-up hops, offline_latency 20 ms
  Robot a("hopper_m8.xml", config, false), b("hopper_m8.xml", config, false);
  ASSERT_TRUE(a.ok() && b.ok());
  const std::vector<HopReport> first = a.Run(8, Host::kRunsOffline);
  a.Restart();
  const std::vector<HopReport> again = a.Run(8, Host::kRunsOffline);
  b.Restart();
  const std::vector<HopReport> other = b.Run(8, Host::kRunsOffline);
  ASSERT_EQ(first.size(), 8u);
  int learned = 0;
  const int warmup = config.driver.warmup_trials;
  for (const HopReport& r : first) learned += r.hop >= warmup ? 1 : 0;
  EXPECT_EQ(learned, 8 - warmup);
  ExpectSameReports(first, again);
  ExpectSameReports(first, other);
}

TEST(OfflinePartTest, WorkerThreadGivesTheHostsResultsWhenTheHostWaits) {
  ControllerConfig host_config;
  ControllerConfig thread_config;
  thread_config.offline_thread = true;
  Robot host("hopper_m8.xml", host_config, false);
  Robot threaded("hopper_m8.xml", thread_config, false);
  ASSERT_TRUE(host.ok() && threaded.ok());
  const std::vector<HopReport> a = host.Run(7, Host::kRunsOffline);
  const std::vector<HopReport> b = threaded.Run(7, Host::kWaitsForWorker);
  EXPECT_FALSE(threaded.c().offline_pending());  // the worker, not the host, runs it
  ExpectSameReports(a, b);
}

// offline_latency = "measured": the law never takes effect sooner than the offline part that
// made it took on this computer.
TEST(OfflinePartTest, AMeasuredLatencyIsNeverShorterThanTheOfflinePart) {
  ControllerConfig config = LearningFromHop0(1e-4);  // far below any offline part's time
  config.measured_latency = true;
  config.modeled_latency = false;
  Robot robot("hopper_m8.xml", config, false);
  ASSERT_TRUE(robot.ok());
  HopperController& c = robot.c();
  while (c.hop() == 0) robot.Step(Host::kNothing);
  const double t_end = robot.d()->time;
  const auto start = std::chrono::steady_clock::now();
  c.RunOffline();
  const double host_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  const std::vector<HopReport> reports = c.TakeReports();
  ASSERT_EQ(reports.size(), 1u);
  const double offline_ms = reports[0].offline_ms;
  EXPECT_GT(offline_ms, 0.0);
  EXPECT_LE(offline_ms, host_ms);
  EXPECT_DOUBLE_EQ(reports[0].latency_ms, std::max(0.1, offline_ms));
  double switched = -1, touchdown = -1;
  while (switched < 0 && robot.d()->time < t_end + 2.0) {
    robot.Step(Host::kRunsOffline);
    if (touchdown < 0 && c.mode() == hopper::kStance) touchdown = robot.d()->time;
    if (!c.runs_initial_law()) switched = robot.d()->time;
  }
  ASSERT_GT(switched, 0.0);
  const double due = t_end + 1e-3 * reports[0].latency_ms;
  EXPECT_GE(switched, due);
  // In the flight where it is due, or (a slow computer) in the flight of the next hop.
  if (touchdown < 0 || due < touchdown) EXPECT_LE(switched, due + 1.01e-3);
  EXPECT_EQ(c.mode(), hopper::kFlight);
}

// A law that comes after a touchdown waits for the next flight; the hops that ran u^0 meanwhile
// are reported but not learned from, and the hop in which the law takes effect is its trial.
TEST(OfflinePartTest, ALawDueInStanceWaitsForTheNextFlight) {
  ControllerConfig probe_config = LearningFromHop0(0.02);
  Robot probe("hopper_m8.xml", probe_config, false);
  ASSERT_TRUE(probe.ok());
  const NominalGait& gait = probe.c().gait();
  // Due in the middle of hop 2's stance (unless this computer's offline part is slower still).
  ControllerConfig config = LearningFromHop0(gait.period + gait.T0(0) + 0.5 * gait.stance_time);
  config.measured_latency = true;
  config.modeled_latency = false;
  Robot robot("hopper_m8.xml", config, false);
  ASSERT_TRUE(robot.ok());
  HopperController& c = robot.c();
  std::vector<HopReport> reports;
  double switched = -1;
  int switched_hop = -1, switched_mode = -1;
  while (reports.size() < 5 && robot.d()->time < 10.0) {
    robot.Step(Host::kRunsOffline);
    for (const HopReport& r : c.TakeReports()) reports.push_back(r);
    if (switched < 0 && !c.runs_initial_law()) {
      switched = robot.d()->time;
      switched_hop = c.hop();
      switched_mode = c.mode();
    }
  }
  ASSERT_FALSE(c.failed()) << c.error();
  ASSERT_GE(reports.size(), 5u);
  ASSERT_TRUE(std::isfinite(reports[0].learner_cost));  // hop 0 initialized the learner
  ASSERT_GT(switched, 0.0);
  // The hop in which the law is due (its handover was hop 1's takeoff step).
  const double due = reports[1].t_start + 1e-3 * reports[0].latency_ms;
  int h = 1;
  while (h + 1 < static_cast<int>(reports.size()) && reports[h + 1].t_start <= due) ++h;
  ASSERT_LT(h + 1, static_cast<int>(reports.size()));
  const bool in_stance = due >= reports[h].t_touchdown;
  RecordProperty("due_in_stance", in_stance ? 1 : 0);
  EXPECT_EQ(switched_mode, hopper::kFlight);
  EXPECT_GE(switched, due);
  if (in_stance) {  // at the next takeoff
    EXPECT_EQ(switched_hop, h + 1);
    EXPECT_NEAR(switched, reports[h + 1].t_start, 1.01e-3);
  } else {
    EXPECT_EQ(switched_hop, h);
    EXPECT_NEAR(switched, due, 1.01e-3);
  }
  // Every hop before the law's trial ran u^0 and was not learned from; the trial was.
  for (int i = 1; i < switched_hop; ++i) {
    EXPECT_TRUE(std::isnan(reports[i].learner_cost)) << "hop " << i;
    EXPECT_TRUE(std::isnan(reports[i].offline_ms)) << "hop " << i;
  }
  EXPECT_TRUE(std::isfinite(reports[switched_hop].learner_cost));
}

// The latency model: a hop's law takes effect max(offline_latency, offline_hop_seconds +
// offline_step_seconds x the integration steps of its backward passes) after it, the same in
// every run (wall time plays no part).
TEST(OfflinePartTest, AModeledLatencyCountsTheBackwardPassesWork) {
  ControllerConfig config = LearningFromHop0(1e-4);
  config.offline_hop_seconds = 2e-3;
  config.offline_step_seconds = 2e-5;  // a slow computer: the Initialize hop's pass ~0.1 s
  std::vector<HopReport> runs[2];
  for (std::vector<HopReport>& reports : runs) {
    Robot robot("hopper_m8.xml", config, false);
    ASSERT_TRUE(robot.ok());
    reports = robot.Run(6, Host::kRunsOffline);
    ASSERT_GE(reports.size(), 6u);
  }
  ExpectSameReports(runs[0], runs[1]);
  int with_pass = 0, without = 0;
  for (size_t i = 0; i < runs[0].size(); ++i) {
    const HopReport& r = runs[0][i];
    SCOPED_TRACE("hop " + std::to_string(i));
    EXPECT_EQ(r.offline_steps, runs[1][i].offline_steps);
    EXPECT_EQ(r.latency_ms, runs[1][i].latency_ms);
    if (std::isnan(r.latency_ms)) continue;  // not handed to the offline part
    ASSERT_GE(r.offline_steps, 0);
    EXPECT_DOUBLE_EQ(r.latency_ms, 1e3 * std::max(1e-4, 2e-3 + 2e-5 * r.offline_steps));
    (r.offline_steps > 0 ? with_pass : without) += 1;
  }
  EXPECT_GE(with_pass, 1) << "hop 0 initializes the learner with a pass";
  EXPECT_GT(runs[0][0].offline_steps, 1000) << "its sweeps over ~1000 samples";
  EXPECT_GE(without, 1) << "a rejected trial runs no pass";
  // Off, the latency is the configured one whatever the work.
  config.modeled_latency = false;
  Robot fixed("hopper_m8.xml", config, false);
  ASSERT_TRUE(fixed.ok());
  for (const HopReport& r : fixed.Run(2, Host::kRunsOffline)) EXPECT_DOUBLE_EQ(r.latency_ms, 0.1);
}

TEST(OfflinePartTest, AFixedLatencyIsReportedWithTheOfflineTime) {
  ControllerConfig config = LearningFromHop0(0.02);
  config.modeled_latency = false;
  Robot robot("hopper_m8.xml", config, false);
  ASSERT_TRUE(robot.ok());
  const std::vector<HopReport> reports = robot.Run(2, Host::kRunsOffline);
  ASSERT_EQ(reports.size(), 2u);
  for (const HopReport& r : reports) {
    EXPECT_GT(r.offline_ms, 0.0);
    EXPECT_DOUBLE_EQ(r.latency_ms, 20.0);
  }
}

}  // namespace
}  // namespace ddoc::plugin
