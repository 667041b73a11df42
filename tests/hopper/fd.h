// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
// Central finite differences for the hopper tests.
#ifndef DDOC_TESTS_HOPPER_FD_H_
#define DDOC_TESTS_HOPPER_FD_H_

#include <functional>

#include <Eigen/Dense>

namespace ddoc {
namespace testing {

/// Central-difference Jacobian of f: R^n -> R^p at x with step h (relative to max(1, |x_i|)).
inline Eigen::MatrixXd FdJacobian(const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f,
                                  const Eigen::VectorXd& x, double h = 1e-6) {
  const Eigen::VectorXd f0 = f(x);
  Eigen::MatrixXd jac(f0.size(), x.size());
  for (int i = 0; i < x.size(); ++i) {
    const double hi = h * std::max(1.0, std::abs(x(i)));
    Eigen::VectorXd xp = x, xm = x;
    xp(i) += hi;
    xm(i) -= hi;
    jac.col(i) = (f(xp) - f(xm)) / (2.0 * hi);
  }
  return jac;
}

/// Max |A - B| / max(1, max|B|).
inline double RelErr(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).cwiseAbs().maxCoeff() / std::max(1.0, b.cwiseAbs().maxCoeff());
}

}  // namespace testing
}  // namespace ddoc

#endif  // DDOC_TESTS_HOPPER_FD_H_
