// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
// The model and cost evaluations the engine calls in its hot loops allocate nothing.
#include <gtest/gtest.h>

#include "ddoc/hopper/hopper_cost.h"
#include "ddoc/hopper/hopper_model.h"
#include "malloc_counter.h"

namespace ddoc {
namespace {

TEST(HopperAllocTest, ModelAndCostEvaluationsDoNotAllocate) {
  ASSERT_TRUE(testing::MallocCountingWorks());
  const HopperModel model{HopperParams()};
  HopperCost cost(model);
  // Buffers sized once, outside the counted region.
  Eigen::VectorXd xf = Eigen::VectorXd::Constant(14, 0.3), xs = Eigen::VectorXd::Constant(10, 0.2);
  xf(hopper::kR) = 0.7;
  xs(hopper::kSR) = 0.68;
  const Eigen::VectorXd u = Eigen::Vector4d(1, 1, 50, 2000);
  Eigen::VectorXd f14(14), f10(10), h(1), lx14(14), lx10(10), lu(4);
  Eigen::MatrixXd fx14(14, 14), fu14(14, 4), fx10(10, 10), fu10(10, 4), g0(10, 14), g1(14, 10),
      hx(1, 14), lxx14(14, 14), lxx10(10, 10), luu(4, 4), lux14(4, 14);
  testing::MallocCounter counter;
  model.Flow(0, xf, u, f14);
  model.Flow(1, xs, u, f10);
  model.FlowDerivatives(0, xf, u, fx14, fu14);
  model.FlowDerivatives(1, xs, u, fx10, fu10);
  model.Reset(0, xf, f10);
  model.Reset(1, xs, f14);
  model.ResetDerivative(0, xf, g0);
  model.ResetDerivative(1, xs, g1);
  model.Surface(0, xf, h);
  model.SurfaceDerivative(0, xf, hx);
  model.Guard(0, xf, u);
  model.Guard(1, xs, u);
  model.GuardGradient(0, xf, u, lx14);
  model.GuardGradient(1, xs, u, lx10);
  cost.Running(0, xf, u);
  cost.RunningDerivatives(0, xf, u, lx14, lu, lxx14, luu, lux14);
  cost.Switching(0, xf);
  cost.Switching(1, xs);
  cost.SwitchingDerivatives(0, xf, lx14, lxx14);
  cost.SwitchingDerivatives(1, xs, lx10, lxx10);
  EXPECT_EQ(counter.count(), 0);
}

}  // namespace
}  // namespace ddoc
