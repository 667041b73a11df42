// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/hopper/vsa.h"

#include <cmath>

#include <gtest/gtest.h>

#include "ddoc/switched_system.h"

namespace ddoc {
namespace {

// Reference: the ODE kdd = beta^2 (k0 - k) - 2 beta kd integrated with tiny RK4 steps.
void Rk4Reference(double beta, double t, double k0, double* k, double* kd) {
  const int n = 20000;
  const double h = t / n;
  auto f = [&](double a, double b, double* da, double* db) {
    *da = b;
    *db = beta * beta * (k0 - a) - 2 * beta * b;
  };
  for (int i = 0; i < n; ++i) {
    double a1, b1, a2, b2, a3, b3, a4, b4;
    f(*k, *kd, &a1, &b1);
    f(*k + 0.5 * h * a1, *kd + 0.5 * h * b1, &a2, &b2);
    f(*k + 0.5 * h * a2, *kd + 0.5 * h * b2, &a3, &b3);
    f(*k + h * a3, *kd + h * b3, &a4, &b4);
    *k += h / 6 * (a1 + 2 * a2 + 2 * a3 + a4);
    *kd += h / 6 * (b1 + 2 * b2 + 2 * b3 + b4);
  }
}

TEST(VsaTest, ExactStepMatchesTheOde) {
  for (double beta : {5.0, 20.0, 60.0}) {
    double k = 1800.0, kd = 300.0, kr = k, kdr = kd;
    AdvanceStiffness(beta, 0.137, 2300.0, &k, &kd);
    Rk4Reference(beta, 0.137, 2300.0, &kr, &kdr);
    EXPECT_NEAR(k, kr, 1e-8 * 2300);
    EXPECT_NEAR(kd, kdr, 1e-7 * 2300);
  }
}

TEST(VsaTest, StepsCompose) {
  // Exact ZOH: two half steps equal one full step with the same k0.
  Vsa a(20.0, VsaState{50.0, 2000.0, 10.0, -100.0});
  Vsa b = a;
  a.Advance(0.01, 120.0, 2200.0);
  a.Advance(0.01, 120.0, 2200.0);
  b.Advance(0.02, 120.0, 2200.0);
  EXPECT_NEAR(a.state().k_hip, b.state().k_hip, 1e-10);
  EXPECT_NEAR(a.state().k_leg, b.state().k_leg, 1e-9);
  EXPECT_NEAR(a.state().kd_hip, b.state().kd_hip, 1e-9);
  EXPECT_NEAR(a.state().kd_leg, b.state().kd_leg, 1e-8);
  // It settles at k0 without overshoot (critically damped) from rest.
  Vsa c(20.0, VsaState{10.0, 1780.0, 0.0, 0.0});
  double prev = 10.0;
  for (int i = 0; i < 2000; ++i) {
    c.Advance(0.001, 150.0, 2350.0);
    EXPECT_GE(c.state().k_hip, prev - 1e-12);
    EXPECT_LE(c.state().k_hip, 150.0 + 1e-9);
    prev = c.state().k_hip;
  }
  EXPECT_NEAR(c.state().k_hip, 150.0, 1e-9);
}

TEST(VsaTest, RejectsBadBetaAndDt) {
  EXPECT_THROW(Vsa(0.0), InvalidArgument);
  EXPECT_THROW(Vsa(-3.0), InvalidArgument);
  Vsa v;
  EXPECT_THROW(v.Advance(-1e-3, 10, 2000), InvalidArgument);
  EXPECT_EQ(v.beta(), kDefaultVsaBeta);
}

}  // namespace
}  // namespace ddoc
