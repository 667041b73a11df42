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

// One sample decides when the settings say so (decide_after 1): se is then the floors' over
// sqrt(sum phi^2), the measurement's resolution, not 0.
TEST(IdentificationTest, OneSampleDecidesWithTheFloorsAsItsSpread) {
  OriginRegression::Settings s;
  s.min_samples = 2;
  s.decide_after = 1;
  s.relative_floor = 0.0;
  s.absolute_floor = 2e-3;
  OriginRegression r(s);
  EXPECT_TRUE(std::isinf(r.standard_error()));
  ASSERT_TRUE(r.Add(0.5, 1.0));
  EXPECT_EQ(r.theta(), 2.0);
  EXPECT_NEAR(r.standard_error(), 2e-3 / 0.5, 1e-15);
  // The relative floor: relative_floor |theta| rms(phi) over sqrt(sum phi^2).
  s.absolute_floor = 0.0;
  s.relative_floor = 1e-3;
  OriginRegression rel(s);
  ASSERT_TRUE(rel.Add(0.5, 1.0));
  EXPECT_NEAR(rel.standard_error(), 1e-3 * 2.0, 1e-15);
  // The default decides after three samples, as before.
  OriginRegression plain;
  for (int i = 1; i <= 2; ++i) ASSERT_TRUE(plain.Add(i, 2.0 * i + 0.01 * i * i));
  EXPECT_TRUE(std::isinf(plain.standard_error()));
  ASSERT_TRUE(plain.Add(3.0, 6.09));
  EXPECT_TRUE(std::isfinite(plain.standard_error()));
}

// Least squares y = a' theta over blocks, against the normal equations written out, with the
// spread of the residuals; a block that does not fit is gated out.
TEST(IdentificationTest, BlockRegressionIsLeastSquaresOverBlocks) {
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 1e-3);
  std::uniform_real_distribution<double> a_dist(-1.0, 1.0);
  const Eigen::Vector2d truth(2.5, 0.3);
  BlockRegression r;
  Eigen::Matrix2d aa = Eigen::Matrix2d::Zero();
  Eigen::Vector2d ay = Eigen::Vector2d::Zero();
  std::vector<std::pair<Eigen::Vector2d, double>> samples;
  for (int block = 0; block < 4; ++block) {
    BlockRegression::Block b;
    for (int i = 0; i < 50; ++i) {
      const Eigen::Vector2d a(a_dist(rng), a_dist(rng));
      const double y = a.dot(truth) + noise(rng);
      b.Add(a, y);
      aa += a * a.transpose();
      ay += a * y;
      samples.emplace_back(a, y);
    }
    ASSERT_TRUE(r.Add(b)) << block;
  }
  const Eigen::Vector2d theta = aa.ldlt().solve(ay);
  double rss = 0.0;
  for (const auto& [a, y] : samples) rss += std::pow(y - a.dot(theta), 2);
  const double s = std::sqrt(rss / (samples.size() - 2));
  const Eigen::Vector2d se = s * aa.inverse().diagonal().cwiseSqrt();
  EXPECT_NEAR((r.theta() - theta).norm(), 0.0, 1e-12);
  EXPECT_NEAR((r.standard_error() - se).norm(), 0.0, 1e-9);
  EXPECT_LT(((r.theta() - truth).array().abs() / se.array()).maxCoeff(), 4.0);
  // A block from another law (theta_1 doubled: a torque the model does not know) is left out.
  BlockRegression::Block off;
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector2d a(a_dist(rng), a_dist(rng));
    off.Add(a, a.dot(Eigen::Vector2d(5.0, 0.3)));
  }
  const Eigen::Vector2d before = r.theta();
  EXPECT_FALSE(r.Add(off));
  EXPECT_EQ(r.rejected(), 1);
  EXPECT_EQ(r.blocks(), 4);
  EXPECT_TRUE(r.theta() == before);
  // Too few samples or a singular A determine nothing.
  BlockRegression empty;
  BlockRegression::Block one;
  one.Add(Eigen::Vector2d(1.0, 0.0), 1.0);
  one.Add(Eigen::Vector2d(2.0, 0.0), 2.0);
  EXPECT_FALSE(empty.Add(one));  // a_2 never moves: theta_2 is not determined
  EXPECT_TRUE(std::isinf(empty.standard_error()(0)));
  EXPECT_TRUE(std::isnan(empty.theta()(0)));
}

// A hop of a robot with the given terms, written from the balances themselves (no noise unless
// given): the radial balance's sums with leg_work = M leg_motion + b_leg leg_rate_sq, the pitch
// balance's rows with tau h = J_body dphid + b_hip w h, the flight's momentum with -(M dxd +
// foot_dp) = c_d drag, and a step along the floor line.
HopIdentificationData SyntheticHop(double M, double b_leg, double j_body, double b_hip,
                                   double slope, double x0, std::mt19937* rng, double noise,
                                   double c_d = 0.0) {
  std::normal_distribution<double> n(0.0, 1.0);
  HopIdentificationData h;
  h.stance_velocity = 2.0 * 2.43 + 9.81 * 0.29;
  h.stance_impulse = M * h.stance_velocity * (1 + 1e-4 * noise * n(*rng));
  h.leg_motion = 0.2 + 0.05 * n(*rng);
  h.leg_rate_sq = 0.31 + 0.02 * n(*rng);
  h.leg_work = M * h.leg_motion + b_leg * h.leg_rate_sq + 2e-3 * noise * n(*rng);
  const double dt = 5e-4;
  for (int k = 0; k < 1000; ++k) {  // a hop: the relative rate and the torque in quadrature
    const double w = 4.0 * std::cos(0.02 * k), dphid = 0.01 * std::sin(0.02 * k + 0.3);
    h.hip.Add(Eigen::Vector2d(dphid, w * dt),
              j_body * dphid + b_hip * w * dt + 1e-7 * noise * n(*rng));
  }
  h.flight_drag = 0.07 + 0.01 * n(*rng);
  h.flight_dxd = -1.5e-4 + 2e-5 * n(*rng);
  h.flight_foot_dp = -c_d * h.flight_drag - M * h.flight_dxd + 2e-6 * noise * n(*rng);
  const double step = 0.27 + 0.01 * n(*rng);
  h.start_foot_x = x0;
  h.start_foot_y = x0 * std::tan(slope) + 5e-5 * noise * n(*rng);
  h.end_foot_x = x0 + step;
  h.end_foot_y = (x0 + step) * std::tan(slope) + 5e-5 * noise * n(*rng);
  return h;
}

// The terms of a robot that is not the model: after one hop each estimate is within its
// tolerance of the robot's value, the model is left, and the identified model has the estimates
// (rounded, J_leg scaled with J_body) while the terms that match keep the model's values.
TEST(IdentificationTest, TheTermsOfARobotThatIsNotTheModel) {
  std::mt19937 rng(5);
  TermsIdentification id;
  MassIdentification mass;
  const HopIdentificationData hop =
      SyntheticHop(8.0, 2.0, 3.125, 0.5, -0.02, 0.0, &rng, 1.0, 0.0125);
  mass.Add(hop);
  id.Add(hop, mass.estimate().mass);
  ASSERT_TRUE(id.Determined());
  const TermsIdentification::Estimate e = id.estimate();
  EXPECT_NEAR(e.b_leg.value, 2.0, 0.1);
  EXPECT_NEAR(e.b_hip.value, 0.5, 0.02);
  EXPECT_NEAR(e.j_body.value, 3.125, 0.01 * 3.125);
  EXPECT_NEAR(e.slope.value, -0.02, 0.001);
  EXPECT_NEAR(e.c_d.value, 0.0125, 0.001);
  HopperParams model;  // the paper's: no dampers, no drag, level floor, J_body 2.5
  EXPECT_TRUE(id.LeavesModel(model));
  const HopperParams p = id.Identified(model, TermsIdentification::Resolution());
  EXPECT_NEAR(p.b_leg, 2.0, 0.1);
  EXPECT_EQ(p.b_leg, std::round(p.b_leg / 0.01) * 0.01);
  EXPECT_NEAR(p.b_hip, 0.5, 0.02);
  EXPECT_NEAR(p.J_body, 3.125, 0.03);
  EXPECT_NEAR(p.J_leg / p.J_body, model.J_leg / model.J_body, 1e-12);
  EXPECT_NEAR(p.slope, -0.02, 0.001);
  EXPECT_NEAR(p.c_d, 0.0125, 0.001);
  EXPECT_EQ(p.M, model.M);  // the mass is MassIdentification's
  EXPECT_FALSE(id.LeavesModel(p));
  // A robot with only a leg damper moves only b_leg.
  TermsIdentification leg_only;
  leg_only.Add(SyntheticHop(10.0, 1.0, 2.5, 0.0, 0.0, 0.0, &rng, 1.0), 10.0);
  const HopperParams q = leg_only.Identified(model, TermsIdentification::Resolution());
  EXPECT_NEAR(q.b_leg, 1.0, 0.05);
  EXPECT_EQ(q.b_hip, 0.0);
  EXPECT_EQ(q.J_body, model.J_body);
  EXPECT_EQ(q.J_leg, model.J_leg);
  EXPECT_EQ(q.c_d, 0.0);
  EXPECT_EQ(q.slope, 0.0);
}

// A model that matches the robot is never left by noisy hops (measurement noise at the levels
// the robot shows, several seeds): no flip-flop; and a damper's estimate below zero (noise on a
// robot without one) is clamped at 0.
TEST(IdentificationTest, NoisyHopsOfAMatchingRobotNeverLeaveTheModel) {
  const HopperParams model;
  for (unsigned seed = 0; seed < 20; ++seed) {
    std::mt19937 rng(seed);
    TermsIdentification id;
    double x = 0.0;
    for (int hop = 0; hop < 100; ++hop) {
      const HopIdentificationData h =
          SyntheticHop(model.M, 0.0, model.J_body, 0.0, 0.0, x, &rng, 1.0);
      x = h.end_foot_x;
      id.Add(h, model.M);
      EXPECT_FALSE(id.LeavesModel(model)) << "seed " << seed << ", hop " << hop;
    }
  }
  HopperParams damped = model;
  damped.b_leg = 0.3;
  TermsIdentification id;
  std::mt19937 rng(1);
  id.Add(SyntheticHop(model.M, 0.0, model.J_body, 0.0, 0.0, 0.0, &rng, 1.0), model.M);
  EXPECT_TRUE(id.LeavesModel(damped));
  EXPECT_GE(id.Identified(damped, TermsIdentification::Resolution()).b_leg, 0.0);
}

// IdentifiedModel decides once the mass (when acted on) is determined, moves only what leaves,
// and a term determined later (the slope) can move the model again.
TEST(IdentificationTest, TheIdentifiedModelMovesWhatLeavesOnceTheMassIsKnown) {
  std::mt19937 rng(2);
  const HopperParams model;
  MassIdentification::Settings one_stance;
  one_stance.regression.min_samples = 2;
  one_stance.regression.decide_after = 1;
  MassIdentification mass(one_stance);
  TermsIdentification terms;
  const TermsIdentification::Resolution res;
  // Nothing measured: nothing decided.
  EXPECT_FALSE(IdentifiedModel(model, mass, true, 1e-3, terms, true, res));
  // The first hop: no slope sample yet (no takeoff before it), the robot 12 kg with a damper.
  HopIdentificationData hop = SyntheticHop(12.0, 2.0, 2.5, 0.0, -0.02, 0.0, &rng, 1.0);
  hop.start_foot_x = HopIdentificationData::kNaN;
  terms.Add(hop, 12.0);  // the terms alone: decided without the mass
  EXPECT_FALSE(terms.Determined());
  std::optional<HopperParams> p = IdentifiedModel(model, mass, false, 1e-3, terms, true, res);
  ASSERT_TRUE(p);
  EXPECT_EQ(p->M, model.M);
  EXPECT_NEAR(p->b_leg, 2.0, 0.1);
  EXPECT_EQ(p->slope, 0.0) << "not determined yet: the model's";
  EXPECT_FALSE(IdentifiedModel(model, mass, true, 1e-3, terms, true, res)) << "the mass waits";
  mass.Add(hop);
  p = IdentifiedModel(model, mass, true, 1e-3, terms, true, res);
  ASSERT_TRUE(p);
  EXPECT_NEAR(p->M, 12.0, 1e-3);
  EXPECT_EQ(p->M, std::round(p->M / 1e-3) * 1e-3);
  EXPECT_NEAR(p->b_leg, 2.0, 0.1);
  EXPECT_EQ(p->b_hip, 0.0);  // what the robot does not have stays the model's
  EXPECT_EQ(p->J_body, model.J_body);
  EXPECT_EQ(p->c_d, 0.0);
  EXPECT_EQ(p->slope, 0.0);
  const std::optional<HopperParams> mass_only =
      IdentifiedModel(model, mass, true, 1e-3, terms, false, res);
  ASSERT_TRUE(mass_only);
  EXPECT_NEAR(mass_only->M, 12.0, 1e-3);
  EXPECT_EQ(mass_only->b_leg, 0.0);
  // The next hop determines the slope: the re-solved model is left again, for the slope only.
  hop = SyntheticHop(12.0, 2.0, 2.5, 0.0, -0.02, 0.3, &rng, 1.0);
  mass.Add(hop);
  terms.Add(hop, mass.estimate().mass);
  EXPECT_TRUE(terms.Determined());
  const std::optional<HopperParams> q = IdentifiedModel(*p, mass, true, 1e-3, terms, true, res);
  ASSERT_TRUE(q);
  EXPECT_NEAR(q->slope, -0.02, 0.001);
  EXPECT_EQ(q->M, p->M);
  EXPECT_EQ(q->b_leg, p->b_leg);
  EXPECT_FALSE(IdentifiedModel(*q, mass, true, 1e-3, terms, true, res)) << "no third re-solve";
  EXPECT_FALSE(IdentifiedModel(model, mass, false, 1e-3, terms, false, res)) << "nothing acted on";
}

// `make` throws InvalidArgument with `text` in its message.
template <class F>
void ExpectNamed(F make, const std::string& text) {
  try {
    make();
    ADD_FAILURE() << "no exception; expected one naming " << text;
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
  }
}

// A term that is not acted on is estimated and reported as before, but neither leaves the
// model nor moves it: on a robot with every term off the model, acting on all but b_hip moves
// the four others to the same values as acting on all, and keeps the model's b_hip; acting on
// none leaves nothing; a robot that differs only in b_hip leaves no model that ignores it.
TEST(IdentificationTest, ATermNotActedOnIsEstimatedButKeepsTheModelsValue) {
  std::mt19937 rng(5);
  const HopIdentificationData hop =
      SyntheticHop(8.0, 2.0, 3.125, 0.5, -0.02, 0.0, &rng, 1.0, 0.0125);
  const HopperParams model;
  const TermsIdentification::Resolution res;
  TermsIdentification all;
  all.Add(hop, 8.0);
  TermsIdentification::Settings settings;
  settings.acted = ParseActedTerms("b_leg,j_body,c_d,slope");
  TermsIdentification no_hip(settings);
  no_hip.Add(hop, 8.0);
  EXPECT_NEAR(no_hip.estimate().b_hip.value, 0.5, 0.02) << "still estimated";
  EXPECT_EQ(no_hip.estimate().b_hip.value, all.estimate().b_hip.value);
  const HopperParams p = all.Identified(model, res), q = no_hip.Identified(model, res);
  EXPECT_NEAR(p.b_hip, 0.5, 0.02);
  EXPECT_EQ(q.b_hip, model.b_hip);
  EXPECT_EQ(q.b_leg, p.b_leg);
  EXPECT_EQ(q.J_body, p.J_body);
  EXPECT_EQ(q.J_leg, p.J_leg);
  EXPECT_EQ(q.c_d, p.c_d);
  EXPECT_EQ(q.slope, p.slope);
  EXPECT_TRUE(no_hip.LeavesModel(model));
  EXPECT_FALSE(no_hip.LeavesModel(q)) << "b_hip 0.5 on the robot, 0 in the model: not acted on";
  EXPECT_TRUE(all.LeavesModel(q));
  settings.acted = ParseActedTerms("none");
  TermsIdentification none(settings);
  none.Add(hop, 8.0);
  EXPECT_TRUE(none.Determined());
  EXPECT_FALSE(none.LeavesModel(model));
  EXPECT_FALSE(IdentifiedModel(model, MassIdentification(), false, 1e-3, none, true, res));
  // Only the hip damper differs: ignored when b_hip is not acted on.
  settings.acted = ParseActedTerms("b_leg,j_body,c_d,slope");
  TermsIdentification hip_only(settings);
  hip_only.Add(SyntheticHop(10.0, 0.0, 2.5, 0.3, 0.0, 0.0, &rng, 1.0), 10.0);
  EXPECT_FALSE(hip_only.LeavesModel(model));
  TermsIdentification hip_all;
  hip_all.Add(SyntheticHop(10.0, 0.0, 2.5, 0.3, 0.0, 0.0, &rng, 1.0), 10.0);
  EXPECT_TRUE(hip_all.LeavesModel(model));
}

// The list of acted-on terms reads back as written, and a bad one is named.
TEST(IdentificationTest, ActedTermsParseAndNameTheirErrors) {
  using Acted = TermsIdentification::Settings::Acted;
  EXPECT_EQ(ParseActedTerms("all"), Acted());
  EXPECT_EQ(ActedTermsName(Acted()), "all");
  const Acted none = ParseActedTerms("none");
  EXPECT_FALSE(none.b_leg || none.b_hip || none.j_body || none.c_d || none.slope);
  EXPECT_EQ(ActedTermsName(none), "none");
  const Acted some = ParseActedTerms("slope,b_leg");
  EXPECT_TRUE(some.b_leg && some.slope);
  EXPECT_FALSE(some.b_hip || some.j_body || some.c_d);
  EXPECT_EQ(ActedTermsName(some), "b_leg,slope");
  EXPECT_EQ(ParseActedTerms("b_leg,b_hip,j_body,c_d,slope"), Acted());
  for (const std::string list : {"b_leg,j_body,c_d,slope", "b_hip", "c_d,j_body"}) {
    EXPECT_EQ(ParseActedTerms(ActedTermsName(ParseActedTerms(list))), ParseActedTerms(list));
  }
  ExpectNamed([] { ParseActedTerms("b_leg,mass"); }, "unknown term \"mass\"");
  ExpectNamed([] { ParseActedTerms(""); }, "unknown term \"\"");
  ExpectNamed([] { ParseActedTerms("b_leg,"); }, "unknown term \"\" in \"b_leg,\"");
  ExpectNamed([] { ParseActedTerms("b_hip,b_hip"); }, "\"b_hip\" is named twice");
  ExpectNamed([] { ParseActedTerms("B_LEG"); }, "expected all, none or a comma-separated list");
}

TEST(IdentificationTest, BadSettingsAreNamed) {
  OriginRegression::Settings bad_gate;
  bad_gate.gate = 0;
  ExpectNamed([&] { OriginRegression r(bad_gate); }, "gate = 0");
  OriginRegression::Settings few;
  few.min_samples = 1;
  ExpectNamed([&] { OriginRegression r(few); }, "min_samples = 1, expected >= 2");
  OriginRegression::Settings no_floor;
  no_floor.decide_after = 1;
  no_floor.relative_floor = 0.0;
  ExpectNamed([&] { OriginRegression r(no_floor); },
              "decide_after = 1, expected >= 2, or 1 with a floor");
  BlockRegression::Settings no_blocks;
  no_blocks.min_blocks = 0;
  ExpectNamed([&] { BlockRegression r(no_blocks); }, "min_blocks = 0, expected >= 1");
  TermsIdentification::Settings bad_tolerance;
  bad_tolerance.slope_tolerance = -1.0;
  ExpectNamed([&] { TermsIdentification id(bad_tolerance); }, "slope_tolerance = -1");
  MassIdentification::Settings bad_z;
  bad_z.z = std::nan("");
  ExpectNamed([&] { MassIdentification id(bad_z); }, "z = nan");
}

}  // namespace
}  // namespace ddoc
