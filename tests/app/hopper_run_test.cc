// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The run's fall limits (src/app/hopper_run.h): on a sloped floor the COM height is measured
// above the floor under it, so a robot hopping down hill has not fallen.
#include <gtest/gtest.h>

#include <cmath>

#include "hopper_run.h"

namespace ddoc::app {
namespace {

Eigen::Matrix<double, 14, 1> At(double x, double y) {
  Eigen::Matrix<double, 14, 1> s = Eigen::Matrix<double, 14, 1>::Zero();
  s(hopper::kX) = x;
  s(hopper::kY) = y;
  s(hopper::kR) = 0.7;
  return s;
}

TEST(FallReasonTest, TheHeightIsAboveTheFloorUnderTheBody) {
  const FallLimits lim;
  // Level floor: the absolute height, as always.
  EXPECT_EQ(FallReason(lim, At(0.0, 0.29), 0.1), "body height 0.290 m below 0.30 m");
  EXPECT_EQ(FallReason(lim, At(20.0, 0.31), 0.1), "");
  // Down hill in +x (slope < 0): 20 m on at 0.02 rad the floor is 0.4 m lower; a body 0.2 m
  // above the origin is 0.6 m above the floor under it.
  const double down = -0.02;
  EXPECT_EQ(FallReason(lim, At(20.0, 0.2), 0.1, down), "");
  EXPECT_EQ(FallReason(lim, At(20.0, -0.15), 0.1, down),
            "body height 0.250 m above the floor below 0.30 m");
  // Up hill: the floor rises under the body.
  EXPECT_EQ(FallReason(lim, At(20.0, 0.6), 0.1, 0.02),
            "body height 0.200 m above the floor below 0.30 m");
  EXPECT_EQ(FallReason(lim, At(20.0, 0.75), 0.1, 0.02), "");
}

}  // namespace
}  // namespace ddoc::app
