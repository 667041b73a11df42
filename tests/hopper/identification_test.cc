// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// OriginRegression and MassIdentification against answers computed here from the samples
// (least squares through the origin written out), outliers, and the confidence decision.
#include "ddoc/hopper/identification.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "ddoc/types.h"

namespace ddoc {
namespace {

TEST(IdentificationTest, RegressionIsLeastSquaresThroughTheOriginWithItsStandardError) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.05);
  std::uniform_real_distribution<double> phi_dist(0.5, 2.0);
  OriginRegression r;
  std::vector<double> phi, y;
  for (int i = 0; i < 40; ++i) {
    phi.push_back(phi_dist(rng));
    y.push_back(2.5 * phi.back() + noise(rng));
    ASSERT_TRUE(r.Add(phi.back(), y.back())) << i;
  }
  // The same fit from the samples, two passes.
  double spp = 0, spy = 0;
  for (size_t i = 0; i < phi.size(); ++i) {
    spp += phi[i] * phi[i];
    spy += phi[i] * y[i];
  }
  const double theta = spy / spp;
  double rss = 0;
  for (size_t i = 0; i < phi.size(); ++i) rss += std::pow(y[i] - theta * phi[i], 2);
  const double se = std::sqrt(rss / (phi.size() - 1)) / std::sqrt(spp);
  EXPECT_NEAR(r.theta(), theta, 1e-12);
  EXPECT_NEAR(r.standard_error(), se, 1e-9);
  EXPECT_NEAR(r.theta(), 2.5, 4 * se);
  EXPECT_EQ(r.samples(), 40);
  EXPECT_EQ(r.rejected(), 0);
}

TEST(IdentificationTest, AnOutlierIsGatedOutAndLeavesTheFitAsItWas) {
  OriginRegression r;
  for (double phi : {1.0, 1.1, 0.9, 1.05, 0.95}) ASSERT_TRUE(r.Add(phi, 8.0 * phi * (1 + 1e-4)));
  const double before = r.theta();
  EXPECT_FALSE(r.Add(1.0, 9.0));  // a push in the stance: 12 % off
  EXPECT_EQ(r.rejected(), 1);
  EXPECT_EQ(r.theta(), before);
  // Exact data: the spread is 0, the relative floor (1e-3) keeps a sample 1e-4 off.
  OriginRegression exact;
  for (int i = 1; i <= 4; ++i) ASSERT_TRUE(exact.Add(i, 3.0 * i));
  EXPECT_TRUE(exact.Add(2.0, 6.0 * (1 + 1e-4)));
  EXPECT_FALSE(exact.Add(2.0, 6.0 * (1 + 1e-2)));
  // Nothing to learn from a non-finite sample or phi = 0.
  EXPECT_FALSE(exact.Add(std::nan(""), 1.0));
  EXPECT_FALSE(exact.Add(0.0, 1.0));
  EXPECT_TRUE(std::isinf(OriginRegression().standard_error()));
  EXPECT_TRUE(std::isnan(OriginRegression().theta()));
}

// A stance of a robot of mass M, written from the balance itself, with relative noise on the
// impulse.
HopIdentificationData SyntheticStance(double M, double noise) {
  HopIdentificationData h;
  h.stance_velocity = 2.0 * 2.43 + 9.81 * 0.29;  // dyd + g T_stance
  h.stance_impulse = M * h.stance_velocity * (1 + noise);
  return h;
}

TEST(IdentificationTest, TheMassOfARobotThatIsNotTheModel) {
  MassIdentification id;
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 2e-3);
  for (int hop = 0; hop < 2; ++hop) id.Add(SyntheticStance(8.0, noise(rng)));
  EXPECT_FALSE(id.LeavesModel(10.0));  // not determined before min_samples (3) stances
  id.Add(SyntheticStance(8.0, noise(rng)));
  const MassIdentification::Estimate e = id.estimate();
  EXPECT_EQ(e.hops, 3);
  EXPECT_NEAR(e.mass, 8.0, 0.01 * 8.0);  // within 1 % after 3 hops
  EXPECT_TRUE(id.LeavesModel(10.0));     // the paper's 10 kg model
  EXPECT_FALSE(id.LeavesModel(8.0));
  id.Add(SyntheticStance(9.0, 0.0));     // a push in the stance
  EXPECT_EQ(id.estimate().rejected, 1);
}

// A model that matches the robot is never left, however the noisy stances fall: no flip-flop.
TEST(IdentificationTest, NoisyStancesOfAMatchingRobotNeverLeaveTheModel) {
  for (unsigned seed = 0; seed < 20; ++seed) {
    MassIdentification id;
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 3e-3);
    for (int hop = 0; hop < 100; ++hop) {
      id.Add(SyntheticStance(10.0, noise(rng)));
      EXPECT_FALSE(id.LeavesModel(10.0)) << "seed " << seed << ", hop " << hop;
    }
  }
}

TEST(IdentificationTest, BadSettingsAreNamed) {
  OriginRegression::Settings bad_gate;
  bad_gate.gate = 0;
  EXPECT_THROW(
      try { OriginRegression r(bad_gate); } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find("gate = 0"), std::string::npos) << e.what();
        throw;
      },
      InvalidArgument);
  OriginRegression::Settings few;
  few.min_samples = 1;
  EXPECT_THROW(OriginRegression r(few), InvalidArgument);
  MassIdentification::Settings bad_z;
  bad_z.z = std::nan("");
  EXPECT_THROW(
      try { MassIdentification id(bad_z); } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find("z = nan"), std::string::npos) << e.what();
        throw;
      },
      InvalidArgument);
}

}  // namespace
}  // namespace ddoc
