// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// With the offline part outside the control callback, Compute allocates nothing: over several
// hops of learning, every mj_step (which calls Compute through mjcb_control) is counted, the
// host's RunOffline between steps is not.
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "ddoc/mujoco/hopper_sim.h"
#include "hopper_controller.h"
#include "malloc_counter.h"
#include "robot.h"

namespace ddoc::plugin {
namespace {

// Eight hops of learning on the default robot with `config` (host mode): no allocation in Compute.
void ExpectComputeDoesNotAllocate(ControllerConfig config) {
  ASSERT_TRUE(testing::MallocCountingWorks());
  MjModelPtr model = LoadMjcf(std::string(DDOC_MODELS_DIR) + "/hopper_m8.xml");
  MjDataPtr data(mj_makeData(model.get()));
  config.gait.forward_speed = 0.5;
  std::string error;
  std::unique_ptr<HopperController> c = HopperController::Create(model.get(), WithTestLawCache(config), &error);
  ASSERT_TRUE(c) << error;
  c->Reset(model.get(), data.get());
  Attach(c.get());
  long allocations = 0, steps = 0;
  while (c->hop() < 8 && data->time < 10.0) {
    ApplyDragAndPush(c->mapping(), model.get(), data.get(), 0.0);
    {
      testing::MallocCounter counter;
      mj_step(model.get(), data.get());
      allocations += counter.count();
    }
    ++steps;
    if (c->offline_pending()) c->RunOffline();
    c->TakeReports();
    ASSERT_FALSE(c->failed()) << c->error();
  }
  Detach();
  EXPECT_EQ(c->hop(), 8);
  EXPECT_GT(c->learner()->trials(), 2);  // learning happened (in RunOffline)
  EXPECT_EQ(allocations, 0) << "over " << steps << " steps";
}

TEST(ComputeAllocTest, ComputeDoesNotAllocateWhileLearning) {
  ExpectComputeDoesNotAllocate(ControllerConfig());  // defaults: offline_latency 20 ms
}

TEST(ComputeAllocTest, ComputeDoesNotAllocateWithSubstepEvents) {
  ControllerConfig config;
  config.contact.substep_events = true;  // the events located inside the step
  ExpectComputeDoesNotAllocate(config);
}

}  // namespace
}  // namespace ddoc::plugin
