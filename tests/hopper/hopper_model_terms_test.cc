// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The model terms robots have (issue 44): leg damping b_leg, hip damping b_hip and a floor slope.
// Derivatives against central differences, the signs against the energy balance, the floor
// against its geometry, and bad values named in errors.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "ddoc/check_derivatives.h"
#include "ddoc/hopper/hop_simulator.h"
#include "ddoc/hopper/hopper_cost.h"
#include "ddoc/hopper/hopper_model.h"
#include "ddoc/hopper/nominal_gait.h"
#include "flight_energy.h"
#include "random_states.h"

namespace ddoc {
namespace {

using testing::FlightEnergy;
using V14 = Eigen::Matrix<double, 14, 1>;
using V10 = Eigen::Matrix<double, 10, 1>;

using testing::RandomFlight;
using testing::RandomInput;
using testing::RandomStance;

// All three terms at once, with drag, so every cross term is exercised.
HopperParams AllTerms() {
  HopperParams p;
  p.M = 12.0;
  p.c_d = 0.01;
  p.b_leg = 40.0;
  p.b_hip = 3.0;
  p.slope = -0.03;
  return p;
}

TEST(HopperModelTermsTest, DerivativesMatchFiniteDifferences) {
  std::mt19937 rng(44);
  double worst_entry = 0.0, worst_rel = 0.0;
  for (const ImpactModel im : {ImpactModel::kMasslessLeg, ImpactModel::kPaperLiteral}) {
    HopperParams p = AllTerms();
    p.impact = im;
    const HopperModel model(p);
    const HopperCost cost(model);
    for (int trial = 0; trial < 8; ++trial) {
      for (int k = 0; k < 2; ++k) {
        const Eigen::VectorXd x = k == 0 ? Eigen::VectorXd(RandomFlight(&rng))
                                         : Eigen::VectorXd(RandomStance(&rng));
        const Eigen::VectorXd u = RandomInput(&rng);
        // f_x, f_u, g_x (touchdown / takeoff), h_x and the cost's derivatives.
        const DerivativeCheckReport r = CheckDerivatives(model, &cost, k, x, u);
        EXPECT_TRUE(r.PassedPerEntry()) << "mode " << k << " entry error " << r.max_entry_error();
        worst_entry = std::max(worst_entry, r.max_entry_error());
        worst_rel = std::max(worst_rel, r.max_rel_error());
        // The guard's gradient (takeoff: the damped leg force; touchdown: the sloped clearance).
        Eigen::VectorXd hx(x.size());
        ASSERT_TRUE(model.GuardGradient(k, x, u, hx));
        const Eigen::MatrixXd fd = CentralDifferenceJacobian(
            [&](const Eigen::VectorXd& xv) {
              return Eigen::VectorXd::Constant(1, model.Guard(k, xv, u));
            },
            x);
        const double e = EntryError(hx.transpose(), fd, 1e-6, 1e-6);
        EXPECT_LE(e, 1.0) << "guard gradient, mode " << k;
        worst_entry = std::max(worst_entry, e);
      }
    }
  }
  std::printf("new terms: worst per-entry error %.3g (1 = tolerance 1e-6 abs + 1e-6 rel), worst "
              "relative error %.3g\n", worst_entry, worst_rel);
}

TEST(HopperModelTermsTest, TheDampersTakeExactlyTheirPowerOut) {
  // Sign check: with constant stiffness and no drag the mechanical energy (spring potentials
  // included) may only fall, at the dampers' power b_leg rd^2 + b_hip (phid - thetad)^2.
  HopperParams p;
  p.b_leg = 60.0;
  p.b_hip = 4.0;
  const HopperModel model(p);
  const Eigen::Vector4d u(1.5, 2.0, 90.0, 2100.0);
  const double dt = 1e-4;
  // Flight: only the hip damper acts (rd = 0).
  V14 xf;
  xf << 0.0, 1.0, 0.1, -0.2, 0.7, 90.0, 2100.0, 0.5, 1.0, 0.7, -0.3, 0.0, 0.0, 0.0;
  const auto tf = IntegrateMode(model, 0, xf, u, 0.3, dt);
  double dissipated = 0.0;
  for (size_t i = 1; i < tf.size(); ++i) {  // trapezoid of the damper power
    auto power = [&](const Eigen::VectorXd& x) {
      const double w = x(hopper::kPhid) - x(hopper::kThetad);
      return p.b_hip * w * w;
    };
    dissipated += 0.5 * dt * (power(tf[i - 1].x) + power(tf[i].x));
  }
  const double ef = FlightEnergy(p, V14(tf.back().x), u) - FlightEnergy(p, xf, u);
  EXPECT_LT(ef, -0.05) << "the hip damper must remove energy";
  EXPECT_NEAR(ef, -dissipated, 1e-5 * dissipated);

  // Stance: both dampers act. Energy of a stance state through the takeoff map with rd kept.
  auto energy_of = [&](const V10& s) {
    Eigen::VectorXd f(14);
    model.TakeoffMap(s, 0.0, f);
    V14 out = f;
    out(hopper::kRd) = s(hopper::kSRd);
    return FlightEnergy(p, out, u);
  };
  V10 xs;
  xs << 0.15, -0.1, 0.66, 90.0, 2100.0, -0.8, 0.4, -0.9, 0.0, 0.0;
  const auto ts = IntegrateMode(model, 1, xs, u, 0.2, dt);
  double leg = 0.0, hip = 0.0;
  for (size_t i = 1; i < ts.size(); ++i) {
    auto pl = [&](const Eigen::VectorXd& x) { return p.b_leg * x(hopper::kSRd) * x(hopper::kSRd); };
    auto ph = [&](const Eigen::VectorXd& x) {
      const double w = x(hopper::kSPhid) - x(hopper::kSThetad);
      return p.b_hip * w * w;
    };
    leg += 0.5 * dt * (pl(ts[i - 1].x) + pl(ts[i].x));
    hip += 0.5 * dt * (ph(ts[i - 1].x) + ph(ts[i].x));
  }
  const double es = energy_of(V10(ts.back().x)) - energy_of(xs);
  EXPECT_GT(leg, 0.1);
  EXPECT_GT(hip, 0.01);
  EXPECT_NEAR(es, -(leg + hip), 1e-5 * (leg + hip));
}

TEST(HopperModelTermsTest, TheDampedLegLeavesTheGroundWhereItsForceVanishes) {
  HopperParams p;
  p.b_leg = 50.0;
  const HopperModel model(p);
  V10 xs = V10::Zero();
  xs(hopper::kSR) = 0.69;
  xs(hopper::kSKleg) = 2000.0;
  xs(hopper::kSRd) = 0.4;  // extending: the damper pulls the foot's load down by b_leg rd
  const Eigen::Vector4d u(0.0, 3.0, 50.0, 2000.0);
  EXPECT_NEAR(model.Guard(1, xs, u), 3.0 - 2000.0 * (0.69 - 0.7) - 50.0 * 0.4, 1e-12);
  // And the stance flow sees the same force: rdd = r thd^2 - g cos th + F / M.
  Eigen::VectorXd f(10);
  model.Flow(1, xs, u, f);
  EXPECT_NEAR(f(hopper::kSRd), -p.g + model.Guard(1, xs, u) / p.M, 1e-12);
}

TEST(HopperModelTermsTest, TheSlopedFloorIsALineThroughTheFoothold) {
  for (const double a : {-0.05, 0.035}) {
    HopperParams p;
    p.slope = a;
    const HopperModel model(p);
    // Takeoff from a foothold at absolute x_f: the foot of the flight state is on the floor.
    V10 xs = V10::Zero();
    xs(hopper::kSTheta) = 0.2;
    xs(hopper::kSR) = 0.68;
    xs(hopper::kSRd) = 0.5;
    xs(hopper::kSKleg) = 2000.0;
    for (const double foot_x : {0.0, 1.7, -0.4}) {
      Eigen::VectorXd xf(14);
      model.TakeoffMap(xs, foot_x, xf);
      EXPECT_NEAR(HopperModel::FootX(xf), foot_x, 1e-14);
      EXPECT_NEAR(HopperModel::FootHeight(xf), foot_x * std::tan(a), 1e-14);
      EXPECT_NEAR(model.FootClearance(xf), 0.0, 1e-14);
      EXPECT_NEAR(model.Guard(0, xf, Eigen::Vector4d(0, 0, 50, 2000)), 0.0, 1e-14);
    }
    // A foot 10 cm straight above the floor line at x_f = 2 m has clearance 0.1 cos(a).
    V14 x = V14::Zero();
    x(hopper::kR) = 0.7;
    x(hopper::kX) = 2.0;
    x(hopper::kY) = 0.7 + 2.0 * std::tan(a) + 0.1;
    EXPECT_NEAR(model.FootClearance(x), 0.1 * std::cos(a), 1e-14);
    // A vertical drop touches down where the foot meets the sloped floor (the level-floor model
    // would touch down 2 tan(a) m earlier or later).
    x(hopper::kYd) = -0.5;
    HopSimSettings s;
    s.dt = 1e-4;
    s.stop_at_touchdown = true;
    const HopResult r = SimulateHop(model, x, Eigen::Vector4d(0, 0, 50, 2000), s);
    ASSERT_TRUE(r.ok) << r.message;
    EXPECT_NEAR(HopperModel::FootHeight(r.x_td_minus), 2.0 * std::tan(a), 2e-4);
  }
}

TEST(HopperModelTermsTest, ZeroTermsAreThePaperModelBitForBit) {
  // The defaults are 0 and the zero terms take no branch: the same numbers as without them.
  const HopperParams p;
  EXPECT_EQ(p.b_leg, 0.0);
  EXPECT_EQ(p.b_hip, 0.0);
  EXPECT_EQ(p.slope, 0.0);
  const HopperModel model(p);
  std::mt19937 rng(5);
  for (int trial = 0; trial < 5; ++trial) {
    const V14 x = RandomFlight(&rng);
    EXPECT_EQ(model.FootClearance(x), HopperModel::FootHeight(x));
    Eigen::VectorXd xf(14);
    const V10 xs = RandomStance(&rng);
    model.TakeoffMap(xs, 1.3, xf);
    EXPECT_EQ(xf(hopper::kY), xs(hopper::kSR) * std::cos(xs(hopper::kSTheta)));
  }
}

TEST(HopperModelTermsTest, BadValuesAreNamed) {
  struct Case {
    const char* field;
    void (*set)(HopperParams*);
    const char* bound;
  };
  const Case cases[] = {
      {"b_leg", [](HopperParams* p) { p->b_leg = -1.0; }, ">= 0"},
      {"b_hip", [](HopperParams* p) { p->b_hip = std::nan(""); }, ">= 0"},
      {"slope", [](HopperParams* p) { p->slope = 0.6; }, "|slope| < 0.5"},
      {"slope", [](HopperParams* p) { p->slope = std::nan(""); }, "|slope| < 0.5"},
  };
  for (const Case& c : cases) {
    HopperParams p;
    c.set(&p);
    try {
      HopperModel m(p);
      FAIL() << "expected InvalidArgument for " << c.field;
    } catch (const InvalidArgument& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(c.field), std::string::npos) << what;
      EXPECT_NE(what.find(c.bound), std::string::npos) << what;
    }
  }
}

TEST(HopperModelTermsTest, TheNominalGaitOfAModelWithTermsStartsFromThePapersGait) {
  // No constant input is periodic with a damper or a slope (before: "no periodic gait", I1 0.03-0.15,
  // so no controller could be built on such a model). x0, u0 are the terms-free gait's; the hop is
  // the full model's.
  NominalGaitSettings gs;
  gs.forward_speed = 1.0;
  const NominalGait paper = FindNominalGait(HopperParams(), gs);
  for (const HopperParams& p : {AllTerms(), [] {
         HopperParams q;
         q.b_leg = 4.0;
         return q;
       }()}) {
    HopperParams no_terms = p;
    no_terms.b_leg = no_terms.b_hip = no_terms.slope = 0.0;
    const NominalGait g = FindNominalGait(p, gs);
    const NominalGait g0 = FindNominalGait(no_terms, gs);
    EXPECT_EQ(g.x0, g0.x0);
    EXPECT_EQ(g.u0, g0.u0);
    EXPECT_NE(g.hop.t2, g0.hop.t2);  // the full model's hop
    HopSimSettings hs;
    hs.dt = gs.dt;
    const HopResult r = SimulateHop(HopperModel(p), g.x0, g.u0, hs);
    EXPECT_EQ(g.T0(0), r.t1);
    EXPECT_EQ(g.T0(1), r.t2);
    EXPECT_GT(g.periodicity, g0.periodicity);
  }
  // Zero terms: the search itself, unchanged.
  EXPECT_LT(paper.periodicity, 1e-15);
}

}  // namespace
}  // namespace ddoc
