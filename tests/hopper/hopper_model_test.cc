// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/hopper/hopper_model.h"

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "ddoc/check_derivatives.h"
#include "ddoc/hopper/hop_simulator.h"
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

HopperParams DragParams() {
  HopperParams p;
  p.M = 12.0;
  p.c_d = 0.01;
  return p;
}

TEST(HopperModelTest, DimensionsAndSurfaces) {
  HopperModel model{HopperParams()};
  EXPECT_EQ(model.num_modes(), 2);
  EXPECT_EQ(model.state_dim(0), 14);
  EXPECT_EQ(model.state_dim(1), 10);
  EXPECT_EQ(model.input_dim(), 4);
  EXPECT_EQ(model.surface_dim(0), 1);
  EXPECT_EQ(model.surface_dim(1), 0);
  EXPECT_TRUE(model.has_cycle_reset());
}

TEST(HopperModelTest, FlowDerivativesMatchFiniteDifferences) {
  std::mt19937 rng(7);
  for (const ImpactModel im : {ImpactModel::kMasslessLeg, ImpactModel::kPaperLiteral}) {
    HopperParams p = DragParams();
    p.impact = im;
    HopperModel model(p);
    for (int trial = 0; trial < 5; ++trial) {
      for (int k = 0; k < 2; ++k) {
        const int n = model.state_dim(k);
        const Eigen::VectorXd x = k == 0 ? Eigen::VectorXd(RandomFlight(&rng))
                                         : Eigen::VectorXd(RandomStance(&rng));
        const Eigen::VectorXd u = RandomInput(&rng);
        Eigen::MatrixXd fx(n, n), fu(n, 4);
        model.FlowDerivatives(k, x, u, fx, fu);
        auto fxu = [&](const Eigen::VectorXd& xx) {
          Eigen::VectorXd out(n);
          model.Flow(k, xx, u, out);
          return out;
        };
        auto fuu = [&](const Eigen::VectorXd& uu) {
          Eigen::VectorXd out(n);
          model.Flow(k, x, uu, out);
          return out;
        };
        // Each entry to its own size (the stiffness entries reach ~2000 beside entries ~1e-3).
        EXPECT_LE(EntryError(fx, CentralDifferenceJacobian(fxu, x), 1e-6, 1e-6), 1.0)
            << "mode " << k;
        EXPECT_LE(EntryError(fu, CentralDifferenceJacobian(fuu, u), 1e-6, 1e-6), 1.0)
            << "mode " << k;
      }
    }
  }
}

TEST(HopperModelTest, ResetAndSurfaceDerivativesMatchFiniteDifferences) {
  std::mt19937 rng(11);
  for (const ImpactModel im : {ImpactModel::kMasslessLeg, ImpactModel::kPaperLiteral}) {
    HopperParams p;
    p.impact = im;
    HopperModel model(p);
    for (int trial = 0; trial < 5; ++trial) {
      const Eigen::VectorXd xf = RandomFlight(&rng);
      const Eigen::VectorXd xs = RandomStance(&rng);
      Eigen::MatrixXd g0(10, 14), g1(14, 10), h0(1, 14);
      model.ResetDerivative(0, xf, g0);
      model.ResetDerivative(1, xs, g1);
      model.SurfaceDerivative(0, xf, h0);
      auto r0 = [&](const Eigen::VectorXd& x) {
        Eigen::VectorXd o(10);
        model.Reset(0, x, o);
        return o;
      };
      auto r1 = [&](const Eigen::VectorXd& x) {
        Eigen::VectorXd o(14);
        model.Reset(1, x, o);
        return o;
      };
      auto s0 = [&](const Eigen::VectorXd& x) {
        Eigen::VectorXd o(1);
        model.Surface(0, x, o);
        return o;
      };
      EXPECT_LE(EntryError(g0, CentralDifferenceJacobian(r0, xf), 1e-7, 1e-7), 1.0);
      EXPECT_LE(EntryError(g1, CentralDifferenceJacobian(r1, xs), 1e-7, 1e-7), 1.0);
      EXPECT_LE(EntryError(h0, CentralDifferenceJacobian(s0, xf), 1e-7, 1e-7), 1.0);
    }
  }
}

TEST(HopperModelTest, StanceAndFlightConserveEnergyWithConstantStiffness) {
  // An independent check of (38)/(39) and of the sign of the hip torque: with k = k0 at rest and
  // no drag the only source of energy change is the integrator.
  HopperParams p;
  HopperModel model(p);
  const Eigen::Vector4d u(1.5, 2.0, 90.0, 2100.0);
  V10 xs;
  xs << 0.15, -0.1, 0.66, 90.0, 2100.0, -0.8, 0.4, -0.9, 0.0, 0.0;
  auto flight_of = [&](const V10& s) {
    Eigen::VectorXd f(14);
    model.TakeoffMap(s, 0.0, f);
    V14 out = f;
    out(hopper::kRd) = s(hopper::kSRd);  // keep the leg's radial velocity for the energy
    return out;
  };
  const auto traj = IntegrateMode(model, 1, xs, u, 0.2, 1e-4);
  const double e0 = FlightEnergy(p, flight_of(xs), u);
  double drift = 0.0;
  for (const auto& s : traj) {
    drift = std::max(drift, std::abs(FlightEnergy(p, flight_of(V10(s.x)), u) - e0));
  }
  EXPECT_LT(drift, 1e-8 * std::abs(e0) + 1e-9);
  // Stance must actually exchange energy between terms (not trivially constant).
  EXPECT_GT(std::abs(traj.back().x(hopper::kSR) - xs(hopper::kSR)), 1e-3);

  V14 xf;
  xf << 0.0, 1.0, 0.1, -0.2, 0.7, 90.0, 2100.0, 0.5, 1.0, 0.7, -0.3, 0.0, 0.0, 0.0;
  const auto tf = IntegrateMode(model, 0, xf, u, 0.3, 1e-4);
  const double ef0 = FlightEnergy(p, xf, u);
  double fdrift = 0.0;
  for (const auto& s : tf) fdrift = std::max(fdrift, std::abs(FlightEnergy(p, V14(s.x), u) - ef0));
  EXPECT_LT(fdrift, 1e-8 * std::abs(ef0));
}

TEST(HopperModelTest, TouchdownResetLosesExactlyTheEnergyOf41) {
  // The massless-leg reset conserves angular momentum about the foot; the kinetic energy it
  // removes must equal Delta E of (41) with J_leg, and the foot must be at rest afterwards.
  std::mt19937 rng(3);
  HopperParams p;
  HopperModel model(p);
  for (int trial = 0; trial < 10; ++trial) {
    V14 x = RandomFlight(&rng);
    Eigen::VectorXd xs(10);
    model.Reset(0, x, xs);
    Eigen::VectorXd xa(14);
    model.TakeoffMap(xs, HopperModel::FootX(x), xa);  // post-impact hip velocity, foot at rest
    const double ke_before = 0.5 * p.M * (x(7) * x(7) + x(8) * x(8)) + 0.5 * p.J_leg * x(9) * x(9);
    const double ke_after =
        0.5 * p.M * (xa(7) * xa(7) + xa(8) * xa(8)) + 0.5 * p.J_leg * xa(9) * xa(9);
    // The radial velocity is continuous (impulse normal to the leg), so the loss is all normal.
    const double radial_before = -x(7) * std::sin(x(2)) + x(8) * std::cos(x(2));
    EXPECT_NEAR(xs(hopper::kSRd), radial_before, 1e-12);
    EXPECT_NEAR(ke_before - ke_after, model.ImpactEnergyLoss(x), 1e-9);
    EXPECT_NEAR(model.ImpactRatio(x(4)), p.J_leg / (p.J_leg + p.M * x(4) * x(4)), 1e-15);
  }
  // Default parameters: J_leg / (J_leg + M r0^2) = 0.0485, the paper's J_body version 0.338.
  EXPECT_NEAR(model.ImpactRatio(0.7), 0.25 / (0.25 + 10 * 0.49), 1e-12);
  HopperParams lit = p;
  lit.impact = ImpactModel::kPaperLiteral;
  EXPECT_NEAR(HopperModel(lit).ImpactRatio(0.7), 2.5 / (2.5 + 4.9), 1e-12);
}

TEST(HopperModelTest, GuardsAndFootKinematics) {
  HopperModel model{HopperParams()};
  V14 x = V14::Zero();
  x(hopper::kY) = 0.8;
  x(hopper::kTheta) = 0.2;
  x(hopper::kR) = 0.7;
  const Eigen::Vector4d u(0.0, 3.0, 50.0, 2000.0);
  EXPECT_NEAR(model.Guard(0, x, u), 0.8 - 0.7 * std::cos(0.2), 1e-15);
  EXPECT_NEAR(HopperModel::FootX(x), 0.7 * std::sin(0.2), 1e-15);
  V10 xs = V10::Zero();
  xs(hopper::kSR) = 0.69;
  xs(hopper::kSKleg) = 2000.0;
  EXPECT_NEAR(model.Guard(1, xs, u), 3.0 - 2000.0 * (0.69 - 0.7), 1e-12);
  EXPECT_THROW(model.Guard(1, x, u), InvalidArgument);
}

TEST(HopperModelTest, GuardGradientMatchesFiniteDifferencesOfTheGuard) {
  HopperModel model{HopperParams()};
  std::mt19937 rng(7);
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::Vector4d u = RandomInput(&rng);
    for (int k = 0; k < 2; ++k) {
      Eigen::VectorXd x = k == 0 ? Eigen::VectorXd(RandomFlight(&rng))
                                 : Eigen::VectorXd(RandomStance(&rng));
      Eigen::VectorXd hx(x.size());
      ASSERT_TRUE(model.GuardGradient(k, x, u, hx));
      const Eigen::MatrixXd fd = CentralDifferenceJacobian(
          [&](const Eigen::VectorXd& xv) {
            return Eigen::VectorXd::Constant(1, model.Guard(k, xv, u));
          },
          x);
      for (int i = 0; i < x.size(); ++i) {
        EXPECT_NEAR(hx(i), fd(0, i), 1e-6 * std::max(1.0, std::abs(fd(0, i))))
            << "k " << k << " i " << i;
      }
    }
  }
}

TEST(HopperModelTest, InvalidParametersNameTheField) {
  HopperParams p;
  p.J_leg = 0.0;
  try {
    HopperModel m(p);
    FAIL() << "expected InvalidArgument";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("J_leg"), std::string::npos) << e.what();
  }
  p = HopperParams();
  p.M = -1.0;
  EXPECT_THROW(HopperModel{p}, InvalidArgument);
  p = HopperParams();
  p.c_d = -0.1;
  EXPECT_THROW(HopperModel{p}, InvalidArgument);
  p = HopperParams();
  p.beta = std::nan("");
  EXPECT_THROW(HopperModel{p}, InvalidArgument);
}

TEST(HopSimulatorTest, VerticalHopMatchesTheClosedForm) {
  // Theta = 0, F0 = 0, constant k: flight is ballistic and stance a linear spring under gravity,
  // r(t) = r_eq + A sin(...). Stance time = (pi + 2 asin(Mg/(k A))) / omega.
  HopperParams p;
  HopperModel model(p);
  const double k = 2000.0, yd0 = 1.4;
  V14 x0 = V14::Zero();
  x0 << 0, 0.7, 0, 0, 0.7, 50, k, 0, yd0, 0, 0, 0, 0, 0;
  const HopResult r = SimulateHop(model, x0, Eigen::Vector4d(0, 0, 50, k));
  ASSERT_TRUE(r.ok) << r.message;
  const double w = std::sqrt(k / p.M);
  const double a = std::sqrt(std::pow(p.M * p.g / k, 2) + std::pow(yd0 / w, 2));
  const double stance = (M_PI + 2.0 * std::asin(p.M * p.g / (k * a))) / w;
  EXPECT_NEAR(r.t1, 2.0 * yd0 / p.g, 1e-9);
  EXPECT_NEAR(r.t2 - r.t1, stance, 1e-7);
  EXPECT_NEAR(r.apex, 0.7 + yd0 * yd0 / (2 * p.g), 1e-3);  // sampled apex
  EXPECT_NEAR(r.x_to_plus(hopper::kYd), yd0, 1e-7);
}

// CheckRk4Step's hip bound is where RK4 on the model's own flight flow turns unstable: the hip
// spring at k_hip = 150 (VSA at rest, beta small) rings down or grows over 0.3 s of flight with
// J_leg set for omega dt = 2.75 and 2.9.
TEST(HopperModelTest, TheRk4StepBoundIsWhereTheFlightHipSpringGrows) {
  const double dt = 1e-3, k_hip = 150.0;
  auto j_leg_for = [&](double omega_dt, double J_body) {
    const double w = omega_dt / dt;
    return 1.0 / (w * w / k_hip - 1.0 / J_body);
  };
  for (double omega_dt : {2.75, 2.9}) {
    HopperParams p;
    p.J_leg = j_leg_for(omega_dt, p.J_body);
    p.beta = 1e-3;  // the stiffness stays at k0
    const bool stable = omega_dt < 2.0 * std::sqrt(2.0);
    if (stable) {
      EXPECT_NO_THROW(p.CheckRk4Step(dt, "test"));
    } else {
      try {
        p.CheckRk4Step(dt, "test");
        ADD_FAILURE() << "no error at omega dt = " << omega_dt;
      } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find("the flight hip spring"), std::string::npos)
            << e.what();
      }
    }
    const HopperModel model(p);
    V14 x = V14::Zero();
    x(hopper::kY) = 5.0;
    x(hopper::kR) = p.r0;
    x(hopper::kTheta) = 0.01;  // hip deflection phi - theta = -0.01
    x(hopper::kKhip) = k_hip;
    x(hopper::kKleg) = 2000.0;
    const std::vector<HopSample> run =
        IntegrateMode(model, hopper::kFlight, x, Eigen::Vector4d(0, 0, k_hip, 2000.0), 0.3, dt);
    const V14 end = run.back().x;
    const double deflection = std::abs(end(hopper::kPhi) - end(hopper::kTheta));
    if (stable) {
      EXPECT_LT(deflection, 0.011) << omega_dt;
    } else {
      EXPECT_GT(deflection, 1.0) << omega_dt;
    }
  }
  HopperParams stiff_vsa;
  stiff_vsa.beta = 3000.0;  // beta dt = 3 > 2.785
  EXPECT_THROW(stiff_vsa.CheckRk4Step(dt, "test"), InvalidArgument);
  HopperParams light;
  light.M = 0.2;  // sqrt(2350 / 0.2) dt = 0.108: fine
  EXPECT_NO_THROW(light.CheckRk4Step(dt, "test"));
  EXPECT_NO_THROW(HopperParams().CheckRk4Step(dt, "test"));
}

// The stiffness servo of eq. (41), kdd + 2 beta kd + beta^2 k = beta^2 k0, in both modes. With
// e = k - k0 (k0 held) it is critically damped; its closed form, derived here, is
//   e(t)  = exp(-beta t) [e0 + (ed0 + beta e0) t],
//   ed(t) = exp(-beta t) [ed0 - beta (ed0 + beta e0) t]
// (check: e(0) = e0, ed(0) = ed0, and e'' + 2 beta e' + beta^2 e = 0). The model integrated by RK4
// after a step in both stiffness commands, from stiffnesses already moving (kd != 0), must follow
// it for the hip and the leg, in flight and in stance. The other model tests hold k = k0, kd = 0,
// where the servo lines do nothing.
TEST(HopperModelTest, StiffnessServoFollowsTheCriticallyDampedClosedFormAfterAStep) {
  HopperParams p;
  const double b = p.beta;
  const HopperModel model(p);
  auto closed_form = [b](double k0, double k_start, double kd_start, double t, double* k,
                         double* kd) {
    const double e0 = k_start - k0;
    const double c = kd_start + b * e0;
    const double decay = std::exp(-b * t);
    *k = k0 + decay * (e0 + c * t);
    *kd = decay * (kd_start - b * c * t);
  };
  // Commands after the step, and the stiffnesses and rates before it.
  const double k0_hip = 140.0, k0_leg = 2600.0;
  const double hip0 = 80.0, hipd0 = 300.0, leg0 = 2000.0, legd0 = -1500.0;
  const Eigen::Vector4d u(0.5, 5.0, k0_hip, k0_leg);
  V14 xf;
  xf << 0.0, 1.5, 0.05, 0.0, 0.7, hip0, leg0, 0.5, 0.0, 0.2, -0.1, 0.0, hipd0, legd0;
  V10 xs;
  xs << 0.05, 0.0, 0.66, hip0, leg0, -0.5, 0.2, -0.3, hipd0, legd0;
  struct Case {
    int mode;
    Eigen::VectorXd x0;
    int k_hip, k_leg, kd_hip, kd_leg;
  };
  const Case cases[] = {
      {hopper::kFlight, xf, hopper::kKhip, hopper::kKleg, hopper::kKhipd, hopper::kKlegd},
      {hopper::kStance, xs, hopper::kSKhip, hopper::kSKleg, hopper::kSKhipd, hopper::kSKlegd}};
  for (const Case& c : cases) {
    const std::vector<HopSample> run = IntegrateMode(model, c.mode, c.x0, u, 0.3, 1e-4);
    double err_k_hip = 0, err_k_leg = 0, err_kd_hip = 0, err_kd_leg = 0;
    for (const HopSample& s : run) {
      double k, kd;
      closed_form(k0_hip, hip0, hipd0, s.t, &k, &kd);
      err_k_hip = std::max(err_k_hip, std::abs(s.x(c.k_hip) - k));
      err_kd_hip = std::max(err_kd_hip, std::abs(s.x(c.kd_hip) - kd));
      closed_form(k0_leg, leg0, legd0, s.t, &k, &kd);
      err_k_leg = std::max(err_k_leg, std::abs(s.x(c.k_leg) - k));
      err_kd_leg = std::max(err_kd_leg, std::abs(s.x(c.kd_leg) - kd));
    }
    // RK4 at beta dt = 2e-3: errors near 1e-12 of the step; the tolerances are 1e-6 of it
    // (hip step 60 N m/rad, leg step 600 N/m; rates up to beta times that).
    EXPECT_LT(err_k_hip, 1e-6 * 60.0) << "mode " << c.mode;
    EXPECT_LT(err_kd_hip, 1e-6 * 60.0 * b) << "mode " << c.mode;
    EXPECT_LT(err_k_leg, 1e-6 * 600.0) << "mode " << c.mode;
    EXPECT_LT(err_kd_leg, 1e-6 * 600.0 * b) << "mode " << c.mode;
    // The step has moved both stiffnesses most of the way to the command.
    EXPECT_NEAR(run.back().x(c.k_hip), k0_hip, 0.05 * 60.0) << "mode " << c.mode;
    EXPECT_NEAR(run.back().x(c.k_leg), k0_leg, 0.05 * 600.0) << "mode " << c.mode;
  }
}

}  // namespace
}  // namespace ddoc
