// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The types every part of ddoc shares: Eigen vector/matrix aliases and the error type.
#ifndef DDOC_TYPES_H_
#define DDOC_TYPES_H_

#include <stdexcept>

#include <Eigen/Dense>

namespace ddoc {

using Vector = Eigen::VectorXd;
using Matrix = Eigen::MatrixXd;
using ConstVectorRef = Eigen::Ref<const Eigen::VectorXd>;
using VectorRef = Eigen::Ref<Eigen::VectorXd>;
using ConstMatrixRef = Eigen::Ref<const Eigen::MatrixXd>;
using MatrixRef = Eigen::Ref<Eigen::MatrixXd>;

/// Thrown on invalid user input. The message names the offending quantity,
/// its expected and actual value, e.g. "Flow(k=1): x has size 9, expected 10".
class InvalidArgument : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

}  // namespace ddoc

#endif  // DDOC_TYPES_H_
