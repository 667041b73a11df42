// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/check_derivatives.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <string>

namespace ddoc {
namespace {

DerivativeError Compare(const std::string& name, const Matrix& analytic, const Matrix& fd,
                        const DerivativeCheckSettings& settings) {
  DerivativeError e;
  e.name = name;
  e.max_abs_error = analytic.size() ? (analytic - fd).cwiseAbs().maxCoeff() : 0.0;
  e.max_rel_error = analytic.size() ? RelativeError(analytic, fd) : 0.0;
  e.entry_error = analytic.size()
                      ? EntryError(analytic, fd, settings.abs_tolerance, settings.rel_tolerance)
                      : 0.0;
  return e;
}

// h_i of CentralDifferenceJacobian at the coordinate x_i.
double DifferenceStep(double step, double x_i) { return step * std::max(1.0, std::abs(x_i)); }

void CheckStep(const char* where, double step) {
  if (!(step > 0.0) || !std::isfinite(step)) {
    throw InvalidArgument(std::string(where) + ": step = " + std::to_string(step) +
                          ", expected finite and > 0");
  }
}

}  // namespace

Matrix CentralDifferenceJacobian(const std::function<Vector(const Vector&)>& fn,
                                 const ConstVectorRef& x_in, double step) {
  CheckStep("CentralDifferenceJacobian", step);
  const Vector x = x_in;
  const Eigen::Index n = x.size();
  if (n == 0) return Matrix(fn(x).size(), 0);
  Matrix J;
  Vector xp = x, xm = x;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double h = DifferenceStep(step, x(i));
    xp(i) = x(i) + h;
    xm(i) = x(i) - h;
    const Vector fp = fn(xp), fm = fn(xm);
    if (i == 0) J.resize(fp.size(), n);
    if (fp.size() != J.rows() || fm.size() != J.rows()) {
      throw InvalidArgument("CentralDifferenceJacobian: fn returned " + std::to_string(fp.size()) +
                            " and " + std::to_string(fm.size()) + " values, expected " +
                            std::to_string(J.rows()));
    }
    J.col(i) = (fp - fm) / (2 * h);
    xp(i) = x(i);
    xm(i) = x(i);
  }
  return J;
}

Matrix CentralDifferencePoints(const ConstMatrixRef& Z, double step) {
  CheckStep("CentralDifferencePoints", step);
  const Eigen::Index n = Z.rows();
  Matrix P(n, 2 * n * Z.cols());
  for (Eigen::Index j = 0; j < Z.cols(); ++j) {
    for (Eigen::Index i = 0; i < n; ++i) {
      const double h = DifferenceStep(step, Z(i, j));
      const Eigen::Index c = 2 * (j * n + i);
      P.col(c) = Z.col(j);
      P.col(c + 1) = Z.col(j);
      P(i, c) = Z(i, j) + h;
      P(i, c + 1) = Z(i, j) - h;
    }
  }
  return P;
}

Matrix CentralDifferenceQuotients(const ConstMatrixRef& Z, const ConstMatrixRef& V, double step) {
  CheckStep("CentralDifferenceQuotients", step);
  const Eigen::Index n = Z.rows();
  if (V.cols() != 2 * n * Z.cols()) {
    throw InvalidArgument("CentralDifferenceQuotients: V has " + std::to_string(V.cols()) +
                          " columns, expected 2 n N = " + std::to_string(2 * n * Z.cols()));
  }
  Matrix J(V.rows(), n * Z.cols());
  for (Eigen::Index j = 0; j < Z.cols(); ++j) {
    for (Eigen::Index i = 0; i < n; ++i) {
      const double h = DifferenceStep(step, Z(i, j));
      const Eigen::Index c = 2 * (j * n + i);
      J.col(j * n + i) = (V.col(c) - V.col(c + 1)) / (2 * h);
    }
  }
  return J;
}

double RelativeError(const ConstMatrixRef& a, const ConstMatrixRef& b) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) {
    throw InvalidArgument("RelativeError: sizes " + std::to_string(a.rows()) + "x" +
                          std::to_string(a.cols()) + " and " + std::to_string(b.rows()) + "x" +
                          std::to_string(b.cols()) + " differ");
  }
  if (a.size() == 0) return 0.0;
  const double scale = std::max(1.0, b.cwiseAbs().maxCoeff());
  return (a - b).cwiseAbs().maxCoeff() / scale;
}

const DerivativeError* DerivativeCheckReport::Find(const std::string& name) const {
  for (const auto& e : entries) {
    if (e.name == name) return &e;
  }
  return nullptr;
}

double EntryError(const ConstMatrixRef& a, const ConstMatrixRef& b, double abs_tol,
                  double rel_tol) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) {
    throw InvalidArgument("EntryError: sizes " + std::to_string(a.rows()) + "x" +
                          std::to_string(a.cols()) + " and " + std::to_string(b.rows()) + "x" +
                          std::to_string(b.cols()) + " differ");
  }
  if (!(abs_tol >= 0.0) || !(rel_tol >= 0.0) || !(abs_tol + rel_tol > 0.0)) {
    throw InvalidArgument("EntryError: tolerances abs " + std::to_string(abs_tol) + ", rel " +
                          std::to_string(rel_tol) + ": expected >= 0, not both 0");
  }
  double worst = 0;
  for (Eigen::Index j = 0; j < a.cols(); ++j) {
    for (Eigen::Index i = 0; i < a.rows(); ++i) {
      const double tol = abs_tol + rel_tol * std::abs(b(i, j));
      const double r = std::abs(a(i, j) - b(i, j)) / tol;
      worst = std::isnan(r) ? std::numeric_limits<double>::infinity() : std::max(worst, r);
    }
  }
  return worst;
}

double DerivativeCheckReport::max_entry_error() const {
  double worst = 0;
  for (const auto& e : entries) worst = std::max(worst, e.entry_error);
  return worst;
}

double DerivativeCheckReport::max_rel_error() const {
  double worst = 0;
  for (const auto& e : entries) worst = std::max(worst, e.max_rel_error);
  return worst;
}

DerivativeCheckReport CheckDerivatives(const SwitchedSystem& system, const SwitchedCost* cost,
                                       int k, const ConstVectorRef& x_in,
                                       const ConstVectorRef& u_in,
                                       const DerivativeCheckSettings& settings) {
  const int n = system.state_dim(k);
  const int m = system.input_dim();
  const int K = system.num_modes();
  if (x_in.size() != n || u_in.size() != m) {
    throw InvalidArgument("CheckDerivatives(k=" + std::to_string(k) + "): x has size " +
                          std::to_string(x_in.size()) + " (expected " + std::to_string(n) +
                          "), u has size " + std::to_string(u_in.size()) + " (expected " +
                          std::to_string(m) + ")");
  }
  const Vector x = x_in, u = u_in;
  const double step = settings.step;
  const auto Fd = [step](const std::function<Vector(const Vector&)>& fn, const Vector& v) {
    return CentralDifferenceJacobian(fn, v, step);
  };
  DerivativeCheckReport report;

  Matrix fx(n, n), fu(n, m);
  system.FlowDerivatives(k, x, u, fx, fu);
  auto flow_x = [&](const Vector& xv) {
    Vector f(n);
    system.Flow(k, xv, u, f);
    return f;
  };
  auto flow_u = [&](const Vector& uv) {
    Vector f(n);
    system.Flow(k, x, uv, f);
    return f;
  };
  report.entries.push_back(Compare("fx", fx, Fd(flow_x, x), settings));
  report.entries.push_back(Compare("fu", fu, Fd(flow_u, u), settings));

  if (k < K - 1 || system.has_cycle_reset()) {
    const int nn = system.state_dim((k + 1) % K);
    Matrix gx(nn, n);
    system.ResetDerivative(k, x, gx);
    auto reset = [&](const Vector& xv) {
      Vector g(nn);
      system.Reset(k, xv, g);
      return g;
    };
    report.entries.push_back(Compare("gx", gx, Fd(reset, x), settings));
  }
  const int s = system.surface_dim(k);
  if (s > 0) {
    Matrix hx(s, n);
    system.SurfaceDerivative(k, x, hx);
    auto surface = [&](const Vector& xv) {
      Vector h(s);
      system.Surface(k, xv, h);
      return h;
    };
    report.entries.push_back(Compare("hx", hx, Fd(surface, x), settings));
  }
  if (cost == nullptr) return report;

  Vector lx(n), lu(m);
  Matrix lxx(n, n), luu(m, m), lux(m, n);
  cost->RunningDerivatives(k, x, u, lx, lu, lxx, luu, lux);
  auto l_x = [&](const Vector& xv) {
    Vector v(1);
    v(0) = cost->Running(k, xv, u);
    return v;
  };
  auto l_u = [&](const Vector& uv) {
    Vector v(1);
    v(0) = cost->Running(k, x, uv);
    return v;
  };
  report.entries.push_back(Compare("lx", lx.transpose(), Fd(l_x, x), settings));
  report.entries.push_back(Compare("lu", lu.transpose(), Fd(l_u, u), settings));
  // Second derivatives from the analytic gradients.
  auto grad_x_of_x = [&](const Vector& xv) {
    Vector gx(n), gu(m);
    Matrix a(n, n), b(m, m), c(m, n);
    cost->RunningDerivatives(k, xv, u, gx, gu, a, b, c);
    return gx;
  };
  auto grad_u_of_u = [&](const Vector& uv) {
    Vector gx(n), gu(m);
    Matrix a(n, n), b(m, m), c(m, n);
    cost->RunningDerivatives(k, x, uv, gx, gu, a, b, c);
    return gu;
  };
  auto grad_u_of_x = [&](const Vector& xv) {
    Vector gx(n), gu(m);
    Matrix a(n, n), b(m, m), c(m, n);
    cost->RunningDerivatives(k, xv, u, gx, gu, a, b, c);
    return gu;
  };
  report.entries.push_back(Compare("lxx", lxx, Fd(grad_x_of_x, x), settings));
  report.entries.push_back(Compare("luu", luu, Fd(grad_u_of_u, u), settings));
  report.entries.push_back(Compare("lux", lux, Fd(grad_u_of_x, x), settings));

  Vector phix(n);
  Matrix phixx(n, n);
  cost->SwitchingDerivatives(k, x, phix, phixx);
  auto phi = [&](const Vector& xv) {
    Vector v(1);
    v(0) = cost->Switching(k, xv);
    return v;
  };
  auto phi_grad = [&](const Vector& xv) {
    Vector g(n);
    Matrix H(n, n);
    cost->SwitchingDerivatives(k, xv, g, H);
    return g;
  };
  report.entries.push_back(Compare("phix", phix.transpose(), Fd(phi, x), settings));
  report.entries.push_back(Compare("phixx", phixx, Fd(phi_grad, x), settings));
  return report;
}

}  // namespace ddoc
