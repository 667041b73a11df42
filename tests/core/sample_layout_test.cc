// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// SampleLayout: mode-major global sample indices, the checks of Assign, no allocation per Assign.
#include "ddoc/sample_layout.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "malloc_counter.h"
#include "test_systems.h"
#include "test_util.h"

namespace ddoc {
namespace testing {
namespace {

// A trajectory of NonlinearSystem (dims 3, 2, 3; m = 2) with N_k samples in mode k.
Trajectory MakeTrajectory(const std::vector<int>& counts) {
  const int dims[3] = {3, 2, 3};
  Trajectory t;
  t.modes.resize(counts.size());
  for (size_t k = 0; k < counts.size(); ++k) {
    t.modes[k].t = Vector::LinSpaced(counts[k], 0.0, 1.0);
    t.modes[k].x = Matrix::Zero(dims[k % 3], counts[k]);
    t.modes[k].u = Matrix::Zero(2, counts[k]);
  }
  return t;
}

TEST(SampleLayout, IndicesAreModeMajor) {
  NonlinearSystem sys;
  SampleLayout layout;
  layout.Allocate(sys, 20, "Test");
  EXPECT_EQ(layout.num_modes(), 3);
  EXPECT_EQ(layout.input_dim(), 2);
  EXPECT_EQ(layout.dim(1), 2);
  EXPECT_EQ(layout.Assign(MakeTrajectory({4, 2, 5}), "Test"), 11);
  EXPECT_EQ(layout.total(), 11);
  EXPECT_EQ(layout.offset(0), 0);
  EXPECT_EQ(layout.offset(1), 4);
  EXPECT_EQ(layout.offset(2), 6);
  EXPECT_EQ(layout.count(2), 5);
  EXPECT_EQ(layout.index(2, 4), 10);
  // A second trajectory with other counts moves the offsets; sizes stay.
  EXPECT_EQ(layout.Assign(MakeTrajectory({2, 7, 3}), "Test"), 12);
  EXPECT_EQ(layout.index(1, 0), 2);
  EXPECT_EQ(layout.index(2, 0), 9);
}

TEST(SampleLayout, AssignDoesNotAllocate) {
  if (!MallocCountingWorks()) GTEST_SKIP() << "malloc interposition unavailable";
  NonlinearSystem sys;
  SampleLayout layout;
  layout.Allocate(sys, 100, "Test");
  const Trajectory a = MakeTrajectory({30, 20, 40}), b = MakeTrajectory({10, 10, 10});
  MallocCounter counter;
  layout.Assign(a, "Test");
  layout.Assign(b, "Test");
  EXPECT_EQ(counter.count(), 0);
}

TEST(SampleLayout, BadInputIsNamed) {
  NonlinearSystem sys;
  SampleLayout layout;
  ExpectThrowsWith([&] { layout.Allocate(sys, 1, "Who::Allocate"); },
                   "Who::Allocate: max_samples = 1, expected >= 2");
  layout.Allocate(sys, 10, "Who");
  ExpectThrowsWith([&] { layout.Assign(MakeTrajectory({3, 3}), "Who::Run"); },
                   "Who::Run: trajectory has 2 modes, expected K = 3");
  ExpectThrowsWith([&] { layout.Assign(MakeTrajectory({3, 1, 3}), "Who::Run"); },
                   "Who::Run: mode 1 has 1 samples");
  Trajectory wide = MakeTrajectory({3, 3, 3});
  wide.modes[2].x = Matrix::Zero(2, 3);
  ExpectThrowsWith([&] { layout.Assign(wide, "Who::Run"); }, "x n_k = 3 rows");
  Trajectory bad_u = MakeTrajectory({3, 3, 3});
  bad_u.modes[0].u = Matrix::Zero(2, 2);
  ExpectThrowsWith([&] { layout.Assign(bad_u, "Who::Run"); }, "mode 0 has 3 samples");
  ExpectThrowsWith([&] { layout.Assign(MakeTrajectory({4, 4, 4}), "Who::Run"); },
                   "Who::Run: trajectory has 12 samples, more than max_samples = 10");
}

}  // namespace
}  // namespace testing
}  // namespace ddoc
