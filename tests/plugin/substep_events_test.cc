// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The controller with ContactPhaseSettings::substep_events: the measured hop (its durations, the
// states at its events, its cost) at the instants the detector locates inside the step.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "robot.h"

namespace ddoc::plugin {
namespace {

// Distance of t from the nearest multiple of the step h, as a fraction of h.
double OffGrid(double t, double h) { return std::abs(t / h - std::round(t / h)); }

TEST(SubstepEventsTest, HopsEndAndTouchDownAtTheLocatedInstants) {
  // The default robot (8 kg, drag) under Algorithm 1 for 8 hops (its trials learned from the
  // recorded hops: their samples must be in time order, or the learner throws and the
  // controller fails).
  //  - x^-(T1) is the state at the touchdown instant: its foot height (the analytic switching
  //    surface, 0 at contact) is 0 to the interpolation's error (below 1e-5 mm over the default
  //    run's 100 hops), where at the step it is the penetration of up to one step's fall
  //    (0.11-2.1 mm there).
  //  - A hop starts where the previous one ended (at the takeoff instant); at the step the next
  //    hop starts one step after the last stance sample.
  //  - T1 and T2 are off the step grid.
  ControllerConfig config;
  config.contact.substep_events = true;
  Robot rig("hopper_m8.xml", config, false);
  ASSERT_TRUE(rig.ok());
  const std::vector<HopReport> reports = rig.Run(8, Host::kRunsOffline);
  ASSERT_EQ(reports.size(), 8u);
  const double h = rig.m()->opt.timestep;
  int off_grid = 0;
  for (size_t i = 0; i < reports.size(); ++i) {
    const HopReport& r = reports[i];
    EXPECT_LT(std::abs(r.foot_height_td), 1e-5) << "hop " << i;
    EXPECT_LT(r.terms.i4, 1e-12) << "hop " << i;
    if (i > 0) EXPECT_EQ(r.t_start, reports[i - 1].t_end) << "hop " << i;
    EXPECT_NEAR(r.t_end - r.t_start, r.t2, 1e-12);
    EXPECT_NEAR(r.t_touchdown - r.t_start, r.t1, 1e-12);
    EXPECT_GT(r.t1, 0.2);
    EXPECT_GT(r.t2, r.t1 + 0.2);
    off_grid += OffGrid(r.t1, h) > 0.01 && OffGrid(r.t2, h) > 0.01 ? 1 : 0;
    EXPECT_TRUE(std::isfinite(r.cost)) << "hop " << i;
  }
  EXPECT_GE(off_grid, 6) << "T1 and T2 on the step grid: not located inside the step";
}

}  // namespace
}  // namespace ddoc::plugin
