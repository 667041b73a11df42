// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The offline part (trial driver: (36), (30), (31)) runs outside Compute: in RunOffline() called
// by the host between steps, or on the controller's worker thread; the learned law takes effect
// offline_latency after the hop's end. Results are identical run to run, and the worker thread
// gives what the host gives when the host waits for it.
#include <gtest/gtest.h>

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

}  // namespace
}  // namespace ddoc::plugin
