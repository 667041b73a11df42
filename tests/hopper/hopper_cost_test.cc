// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/hopper/hopper_cost.h"

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "ddoc/check_derivatives.h"
#include "ddoc/hopper/hopper_learning.h"
#include "ddoc/trajectory.h"

namespace ddoc {
namespace {


Eigen::VectorXd Random(int n, std::mt19937* rng, double scale) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i) v(i) = scale * u(*rng);
  return v;
}

TEST(HopperCostTest, WeightsFollowOurReadingOfFig2) {
  const HopperCostWeights w;
  Eigen::Matrix<double, 14, 1> q = Eigen::Matrix<double, 14, 1>::Zero();
  q(hopper::kTheta) = 600;
  q(hopper::kPhi) = 1000;
  q(hopper::kXd) = 1000;
  q(hopper::kYd) = 10;
  q(hopper::kThetad) = 1;
  q(hopper::kPhid) = 1;
  EXPECT_EQ(w.q_diag, q);
  EXPECT_EQ(w.r_diag, Eigen::Vector4d(1e-2, 1e-4, 1e-6, 1e-6));
  EXPECT_EQ(w.surface_weight, 1e-3);
  EXPECT_EQ(kHopperSurfaceWeight, 1e-3);
}

TEST(HopperCostTest, DerivativesMatchFiniteDifferences) {
  std::mt19937 rng(5);
  for (const ImpactModel im : {ImpactModel::kMasslessLeg, ImpactModel::kPaperLiteral}) {
    HopperParams p;
    p.impact = im;
    const HopperModel model(p);
    HopperCost cost(model);
    Eigen::VectorXd ref = Random(14, &rng, 1.0);
    ref(hopper::kR) = 0.7;
    cost.SetReference(ref);
    for (int trial = 0; trial < 5; ++trial) {
      for (int k = 0; k < 2; ++k) {
        const int n = model.state_dim(k);
        Eigen::VectorXd x = Random(n, &rng, 1.0);
        x(k == 0 ? static_cast<int>(hopper::kR) : static_cast<int>(hopper::kSR)) =
            0.7 + 0.05 * x(0);
        const Eigen::VectorXd u = Random(4, &rng, 3.0) + Eigen::Vector4d(0, 0, 80, 2000);
        // Running cost.
        Eigen::VectorXd lx(n), lu(4);
        Eigen::MatrixXd lxx(n, n), luu(4, 4), lux(4, n);
        cost.RunningDerivatives(k, x, u, lx, lu, lxx, luu, lux);
        auto l_of_u = [&](const Eigen::VectorXd& uu) {
          return Eigen::VectorXd::Constant(1, cost.Running(k, x, uu));
        };
        auto l_of_x = [&](const Eigen::VectorXd& xx) {
          return Eigen::VectorXd::Constant(1, cost.Running(k, xx, u));
        };
        auto lu_of_u = [&](const Eigen::VectorXd& uu) {
          Eigen::VectorXd a(n), b(4);
          Eigen::MatrixXd c(n, n), d(4, 4), e(4, n);
          cost.RunningDerivatives(k, x, uu, a, b, c, d, e);
          return b;
        };
        EXPECT_LE(EntryError(lu.transpose(), CentralDifferenceJacobian(l_of_u, u), 1e-7, 1e-7),
                  1.0);
        EXPECT_LE(EntryError(lx.transpose(), CentralDifferenceJacobian(l_of_x, x), 1e-7, 1e-7),
                  1.0);
        EXPECT_LE(EntryError(luu, CentralDifferenceJacobian(lu_of_u, u), 1e-7, 1e-7),
                  1.0);
        EXPECT_EQ(lxx.norm(), 0.0);
        EXPECT_EQ(lux.norm(), 0.0);
        // Switching cost: gradient from values, Hessian from gradients.
        Eigen::VectorXd phix(n);
        Eigen::MatrixXd phixx(n, n);
        cost.SwitchingDerivatives(k, x, phix, phixx);
        auto phi = [&](const Eigen::VectorXd& xx) {
          return Eigen::VectorXd::Constant(1, cost.Switching(k, xx));
        };
        auto grad = [&](const Eigen::VectorXd& xx) {
          Eigen::VectorXd g(n);
          Eigen::MatrixXd h(n, n);
          cost.SwitchingDerivatives(k, xx, g, h);
          return g;
        };
        EXPECT_LE(EntryError(phix.transpose(), CentralDifferenceJacobian(phi, x), 1e-6, 1e-6),
                  1.0)
            << "k " << k;
        EXPECT_LE(EntryError(phixx, CentralDifferenceJacobian(grad, x), 1e-6, 1e-6),
                  1.0) << "k " << k;
        EXPECT_LT((phixx - phixx.transpose()).norm(), 1e-9);
      }
    }
  }
}

TEST(HopperCostTest, TermsAreTheFourPiecesOf42) {
  const HopperModel model{HopperParams()};
  HopperCost cost(model);
  Eigen::Matrix<double, 14, 1> x0 = Eigen::Matrix<double, 14, 1>::Zero();
  x0 << 0, 0.7, 0, 0, 0.7, 50, 2000, 0.3, 1.2, 0, 0, 0, 0, 0;
  cost.SetReference(x0);
  // A stance state whose takeoff is x0 except for theta (+0.01) gives I1 = 600 * 1e-4 plus the
  // change it induces in xd, yd through the takeoff map.
  Eigen::Matrix<double, 10, 1> xs = Eigen::Matrix<double, 10, 1>::Zero();
  xs << 0.01, 0, 0.7, 50, 2000, 0, 0, 1.2, 0, 0;
  Eigen::VectorXd xf(14);
  model.TakeoffMap(xs, 0.0, xf);
  double expect_i1 = 0.0;
  const HopperCostWeights w;
  for (int i = 0; i < 14; ++i) expect_i1 += w.q_diag(i) * std::pow(xf(i) - x0(i), 2);
  Eigen::Matrix<double, 14, 1> xtd = x0;
  xtd(hopper::kY) = 0.7 + 0.02;  // foot 2 cm above the ground at the planned touchdown
  xtd(hopper::kYd) = -1.2;
  xtd(hopper::kTheta) = 0.1;
  const HopperCostTerms t = cost.Terms(xtd, xs, 0.123);
  EXPECT_NEAR(t.i1, expect_i1, 1e-12);
  EXPECT_GT(t.i1, 0.06);
  EXPECT_EQ(t.i2, 0.123);
  EXPECT_NEAR(t.i3, model.ImpactEnergyLoss(xtd), 1e-15);
  EXPECT_NEAR(t.i4, 1e-3 * std::pow(0.72 - 0.7 * std::cos(0.1), 2), 1e-15);
  EXPECT_NEAR(t.total(), t.i1 + t.i2 + t.i3 + t.i4, 1e-15);
  EXPECT_NEAR(cost.InputCost(Eigen::Vector4d(1, 2, 3, 4)),
              0.5 * (1e-2 + 1e-4 * 4 + 1e-6 * 9 + 1e-6 * 16), 1e-15);
}

TEST(HopperCostTest, BadInputIsRejected) {
  const HopperModel model{HopperParams()};
  HopperCost cost(model);
  EXPECT_THROW(cost.SetReference(Eigen::VectorXd::Zero(10)), InvalidArgument);
  HopperCostWeights w;
  w.r_diag(2) = 0.0;
  EXPECT_THROW(HopperCost(model, w), InvalidArgument);
  EXPECT_THROW(cost.Terms(Eigen::VectorXd::Zero(10), Eigen::VectorXd::Zero(10), 0.0),
               InvalidArgument);
}

// The learner's I1 reference: the trial's own start for reported costs, the anchor (gait
// takeoff state) for the learner's, and with anchor_weight w the point w anchor + (1 - w) x(0)
// on the segment between them, computed here coordinate by coordinate.
TEST(HopperCostTest, TheLearnersReferenceBlendsTheAnchorAndTheHopsStart) {
  const HopperModel model{HopperParams()};
  HopperCost cost(model);
  std::mt19937 rng(11);
  Trajectory trial;
  trial.x0 = Random(14, &rng, 1.0);
  const Eigen::VectorXd anchor = Random(14, &rng, 1.0);
  for (double w : {0.0, 0.25, 0.9, 1.0}) {
    const TrialDriver::CostReference ref = HopperCostReference(&cost, anchor, w);
    ref(trial, false);
    EXPECT_EQ(Eigen::VectorXd(cost.reference()), trial.x0) << "w " << w;
    ref(trial, true);
    for (int i = 0; i < 14; ++i) {
      EXPECT_NEAR(cost.reference()(i), w * anchor(i) + (1.0 - w) * trial.x0(i), 1e-15)
          << "w " << w << " coordinate " << i;
    }
  }
  // Without an anchor the weight does nothing: the trial's own start, as (42).
  HopperCostReference(&cost, Eigen::VectorXd(), 0.5)(trial, true);
  EXPECT_EQ(Eigen::VectorXd(cost.reference()), trial.x0);
  for (double bad : {-0.1, 1.5, std::numeric_limits<double>::quiet_NaN()}) {
    try {
      HopperCostReference(&cost, anchor, bad);
      ADD_FAILURE() << "no error for anchor_weight " << bad;
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find("anchor_weight"), std::string::npos) << e.what();
    }
  }
}

// reference_filter b < 1: the hop's own start in the blend is replaced by s, s <- s + b (x(0) - s)
// at each learner call from s = anchor, computed here as a running sum; a call for the reported
// cost neither moves s nor uses it, and a start of the wrong size or with a NaN leaves s.
TEST(HopperCostTest, TheFilteredReferenceFollowsTheHopsStartsAtItsGain) {
  const HopperModel model{HopperParams()};
  HopperCost cost(model);
  std::mt19937 rng(12);
  const Eigen::VectorXd anchor = Random(14, &rng, 1.0);
  const double w = 0.25, b = 0.2;
  const TrialDriver::CostReference ref = HopperCostReference(&cost, anchor, w, b);
  // s after k starts: (1 - b)^k anchor + sum_j b (1 - b)^(k - 1 - j) x_j.
  std::vector<Eigen::VectorXd> starts;
  Trajectory trial;
  for (int k = 1; k <= 4; ++k) {
    trial.x0 = Random(14, &rng, 1.0);
    starts.push_back(trial.x0);
    ref(trial, false);
    EXPECT_EQ(Eigen::VectorXd(cost.reference()), trial.x0) << "reported, call " << k;
    ref(trial, true);
    Eigen::VectorXd s = std::pow(1.0 - b, k) * anchor;
    for (int j = 0; j < k; ++j) s += b * std::pow(1.0 - b, k - 1 - j) * starts[j];
    for (int i = 0; i < 14; ++i) {
      EXPECT_NEAR(cost.reference()(i), w * anchor(i) + (1.0 - w) * s(i), 1e-14)
          << "call " << k << " coordinate " << i;
    }
  }
  const Eigen::VectorXd before = cost.reference();
  trial.x0(3) = std::numeric_limits<double>::quiet_NaN();
  ref(trial, true);
  EXPECT_EQ(Eigen::VectorXd(cost.reference()), before) << "a NaN start moved the filter";
  trial.x0 = Eigen::VectorXd::Zero(10);
  ref(trial, true);
  EXPECT_EQ(Eigen::VectorXd(cost.reference()), before) << "a start of another size moved the filter";
  // With the gait alone (w = 1) the filter has nothing to act on.
  HopperCostReference(&cost, anchor, 1.0, b)(trial, true);
  EXPECT_EQ(Eigen::VectorXd(cost.reference()), anchor);
  // The reference moves (and the learner needs reference_shift) exactly in the filtered case.
  EXPECT_TRUE(HopperReferenceMoves(anchor, w, b));
  EXPECT_FALSE(HopperReferenceMoves(anchor, 1.0, b));
  EXPECT_FALSE(HopperReferenceMoves(anchor, w, 1.0));
  EXPECT_FALSE(HopperReferenceMoves(Eigen::VectorXd(), w, b));
  for (double bad : {0.0, -0.1, 1.5, std::numeric_limits<double>::quiet_NaN()}) {
    try {
      HopperCostReference(&cost, anchor, w, bad);
      ADD_FAILURE() << "no error for filter " << bad;
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find("filter"), std::string::npos) << e.what();
    }
  }
}

// overspeed_latch d: the filtered reference until the first learner call whose start has xd above
// the anchor's by more than d, then the anchor at every call, also for slower starts; a start
// just under d faster, a slower one, a reported call, a NaN start or a latch without the moving
// reference (b = 1) do not latch.
TEST(HopperCostTest, TheOverspeedLatchHoldsTheGaitsStateOnceAHopStartsTooFast) {
  const HopperModel model{HopperParams()};
  HopperCost cost(model);
  std::mt19937 rng(13);
  const Eigen::VectorXd anchor = Random(14, &rng, 1.0);
  const double w = 0.0, b = 0.5, d = 0.05;
  const TrialDriver::CostReference ref = HopperCostReference(&cost, anchor, w, b, d);
  Trajectory trial;
  Eigen::VectorXd s = anchor;
  // Not latched: slower by far, as fast, just under d faster, and a NaN start.
  for (double dxd : {-0.5, 0.0, 0.99 * d}) {
    trial.x0 = Random(14, &rng, 1.0);
    trial.x0(hopper::kXd) = anchor(hopper::kXd) + dxd;
    s += b * (trial.x0 - s);
    ref(trial, true);
    EXPECT_TRUE(cost.reference().isApprox(s, 1e-14)) << "latched at xd - gait " << dxd;
  }
  trial.x0(hopper::kXd) = anchor(hopper::kXd) + 1.0;
  trial.x0(3) = std::numeric_limits<double>::quiet_NaN();
  ref(trial, true);
  EXPECT_TRUE(cost.reference().isApprox(s, 1e-14)) << "a NaN start latched";
  trial.x0(3) = 0.0;
  ref(trial, false);
  EXPECT_EQ(Eigen::VectorXd(cost.reference()), trial.x0) << "reported cost";
  // The fast start latches (the reported call before it did not), and the latch holds.
  trial.x0(hopper::kXd) = anchor(hopper::kXd) + 1.5 * d;
  ref(trial, true);
  EXPECT_EQ(Eigen::VectorXd(cost.reference()), anchor) << "not latched at 1.5 d";
  for (double dxd : {-0.5, 0.0}) {
    trial.x0 = Random(14, &rng, 1.0);
    trial.x0(hopper::kXd) = anchor(hopper::kXd) + dxd;
    ref(trial, false);
    EXPECT_EQ(Eigen::VectorXd(cost.reference()), trial.x0) << "reported cost after the latch";
    ref(trial, true);
    EXPECT_EQ(Eigen::VectorXd(cost.reference()), anchor) << "the latch let go at " << dxd;
  }
  // Without a moving reference there is nothing to latch: the unfiltered blend (b = 1) stays.
  trial.x0 = Random(14, &rng, 1.0);
  trial.x0(hopper::kXd) = anchor(hopper::kXd) + 1.0;
  HopperCostReference(&cost, anchor, 0.5, 1.0, d)(trial, true);
  EXPECT_TRUE(cost.reference().isApprox(0.5 * anchor + 0.5 * trial.x0, 1e-14));
  for (double bad : {-0.1, std::numeric_limits<double>::quiet_NaN(),
                     std::numeric_limits<double>::infinity()}) {
    try {
      HopperCostReference(&cost, anchor, w, b, bad);
      ADD_FAILURE() << "no error for overspeed_latch " << bad;
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find("overspeed_latch"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace ddoc
