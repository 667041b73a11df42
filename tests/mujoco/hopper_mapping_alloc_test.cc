// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
// The mapping functions the controller plugin calls inside mjcb_control allocate nothing.
#include <gtest/gtest.h>

#include "ddoc/mujoco/hopper_sim.h"
#include "malloc_counter.h"
#include "model_files.h"

namespace ddoc {
namespace {

TEST(HopperMappingAllocTest, PerStepFunctionsDoNotAllocate) {
  ASSERT_TRUE(testing::MallocCountingWorks());
  HopperSim sim(testing::ModelPath("hopper_m12.xml"));
  Eigen::Matrix<double, 14, 1> x0;
  x0 << 0, 0.8, 0.1, 0, 0.7, 50, 2000, 0.5, -0.5, 0, 0, 0, 0, 0;
  sim.SetFlightState(x0);
  const HopperMapping& map = sim.mapping();
  double x14[14], x10[10];
  const double u[4] = {1.0, 0.5, 60.0, 2100.0};
  ContactPhaseDetector detector;
  detector.Reset(hopper::kFlight, 0.0);
  for (int i = 0; i < 300; ++i) {  // through a touchdown
    testing::MallocCounter counter;
    mj_step1(sim.model(), sim.data());
    detector.Update(map, sim.data());
    MapFlightState(map, sim.data(), sim.vsa().state(), x14);
    MapStanceState(map, sim.data(), sim.vsa().state(), x10);
    WriteActuation(map, sim.model(), sim.data(), sim.vsa().state(), u);
    ApplyDragAndPush(map, sim.model(), sim.data(), 0.0);
    FootPosition(map, sim.data());
    mj_step2(sim.model(), sim.data());
    sim.vsa().Advance(sim.timestep(), u[2], u[3]);
    ASSERT_EQ(counter.count(), 0) << "step " << i;
  }
  EXPECT_EQ(detector.mode(), hopper::kStance);
}

}  // namespace
}  // namespace ddoc
