// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/trajectory.h"

#include <cmath>
#include <sstream>

namespace ddoc {
namespace {

[[noreturn]] void Fail(const std::string& what) { throw InvalidArgument("Trajectory: " + what); }

// Relative tolerance for "sample time equals switching instant".
constexpr double kTimeTolerance = 1e-9;

bool SameTime(double a, double b) {
  return std::abs(a - b) <= kTimeTolerance * (1.0 + std::abs(a) + std::abs(b));
}

}  // namespace

int Trajectory::total_samples() const {
  int total = 0;
  for (const auto& mode : modes) total += mode.num_samples();
  return total;
}

double Trajectory::Tau(int k, int j) const {
  const double start = ModeStart(k);
  const double duration = T(k) - start;
  // A mode of zero duration (duration_min = 0): its samples share one instant and are spread
  // evenly over [k, k+1] in tau.
  if (duration == 0) return k + static_cast<double>(j) / (modes[k].num_samples() - 1);
  return k + (modes[k].t(j) - start) / duration;
}

void Trajectory::Validate() const {
  const int K = num_modes();
  if (K == 0) Fail("empty mode sequence (K = 0)");
  if (T.size() != K) {
    std::ostringstream os;
    os << "T has size " << T.size() << ", expected K = " << K;
    Fail(os.str());
  }
  const Eigen::Index m = modes[0].u.rows();
  for (int k = 0; k < K; ++k) {
    const ModeTrajectory& mode = modes[k];
    const Eigen::Index N = mode.t.size();
    auto where_str = [k]() { return "mode " + std::to_string(k) + ": "; };
    if (N < 2) Fail(where_str() + "has " + std::to_string(N) + " samples, expected >= 2");
    if (mode.x.cols() != N || mode.u.cols() != N) {
      std::ostringstream os;
      os << where_str() << "t has " << N << " samples but x has " << mode.x.cols()
         << " columns and u has " << mode.u.cols();
      Fail(os.str());
    }
    if (mode.x.rows() == 0) Fail(where_str() + "x has 0 rows");
    if (mode.u.rows() != m) {
      std::ostringstream os;
      os << where_str() << "u has " << mode.u.rows() << " rows, expected m = " << m;
      Fail(os.str());
    }
    for (Eigen::Index j = 0; j < N; ++j) {
      if (!std::isfinite(mode.t(j))) {
        Fail(where_str() + "t(" + std::to_string(j) + ") is not finite");
      }
      if (j > 0 && mode.t(j) < mode.t(j - 1)) {
        std::ostringstream os;
        os << where_str() << "decreasing sample times t(" << j - 1 << ") = " << mode.t(j - 1)
           << " > t(" << j << ") = " << mode.t(j);
        Fail(os.str());
      }
      for (Eigen::Index i = 0; i < mode.x.rows(); ++i) {
        if (!std::isfinite(mode.x(i, j))) {
          std::ostringstream os;
          os << where_str() << "x(" << i << ", " << j << ") = " << mode.x(i, j) << " is not finite";
          Fail(os.str());
        }
      }
      for (Eigen::Index i = 0; i < m; ++i) {
        if (!std::isfinite(mode.u(i, j))) {
          std::ostringstream os;
          os << where_str() << "u(" << i << ", " << j << ") = " << mode.u(i, j) << " is not finite";
          Fail(os.str());
        }
      }
    }
    const double start = ModeStart(k);
    if (!SameTime(mode.t(0), start)) {
      std::ostringstream os;
      os << where_str() << "first sample at t = " << mode.t(0) << ", expected the mode start "
         << start << (k == 0 ? " (trials start at t = 0)" : " (= T(k-1))");
      Fail(os.str());
    }
    if (!std::isfinite(T(k)) || !SameTime(mode.t(N - 1), T(k))) {
      std::ostringstream os;
      os << where_str() << "last sample at t = " << mode.t(N - 1) << ", expected T(" << k
         << ") = " << T(k);
      Fail(os.str());
    }
    if (!(T(k) >= start)) {  // zero is legal: a vanished mode (Bounds::duration_min = 0)
      std::ostringstream os;
      os << where_str() << "negative duration T(k) - T(k-1) = " << T(k) - start;
      Fail(os.str());
    }
  }
  if (x0.size() != modes[0].x.rows()) {
    std::ostringstream os;
    os << "x0 has size " << x0.size() << ", expected n_0 = " << modes[0].x.rows();
    Fail(os.str());
  }
  if (!x0.allFinite()) Fail("x0 is not finite");
  if ((x0 - modes[0].x.col(0)).cwiseAbs().maxCoeff() >
      1e-9 * (1.0 + x0.cwiseAbs().maxCoeff())) {
    Fail("x0 differs from the first state of mode 0");
  }
}

void Trajectory::Validate(const SwitchedSystem& system) const {
  Validate();
  if (num_modes() != system.num_modes()) {
    std::ostringstream os;
    os << "has " << num_modes() << " modes, the system has K = " << system.num_modes();
    Fail(os.str());
  }
  for (int k = 0; k < num_modes(); ++k) {
    if (modes[k].x.rows() != system.state_dim(k)) {
      std::ostringstream os;
      os << "mode " << k << ": x has " << modes[k].x.rows() << " rows, expected n_" << k << " = "
         << system.state_dim(k);
      Fail(os.str());
    }
    if (modes[k].u.rows() != system.input_dim()) {
      std::ostringstream os;
      os << "mode " << k << ": u has " << modes[k].u.rows() << " rows, expected m = "
         << system.input_dim();
      Fail(os.str());
    }
  }
}

// ------------------------------------------------------------------------ TrajectoryRecorder

void TrajectoryRecorder::Reserve(const std::vector<int>& state_dims, int input_dim,
                                 int max_samples_per_mode) {
  if (state_dims.empty()) throw InvalidArgument("TrajectoryRecorder::Reserve: K = 0 modes");
  if (max_samples_per_mode < 2) {
    throw InvalidArgument("TrajectoryRecorder::Reserve: max_samples_per_mode = " +
                          std::to_string(max_samples_per_mode) + ", expected >= 2");
  }
  buffers_.resize(state_dims.size());
  for (size_t k = 0; k < state_dims.size(); ++k) {
    buffers_[k].t.reserve(max_samples_per_mode);
    buffers_[k].x.resize(state_dims[k], max_samples_per_mode);
    buffers_[k].u.resize(input_dim, max_samples_per_mode);
  }
  Clear();
}

void TrajectoryRecorder::Reserve(const SwitchedSystem& system, int max_samples_per_mode) {
  std::vector<int> dims(system.num_modes());
  for (int k = 0; k < system.num_modes(); ++k) dims[k] = system.state_dim(k);
  Reserve(dims, system.input_dim(), max_samples_per_mode);
}

void TrajectoryRecorder::Clear() {
  for (auto& b : buffers_) {
    b.t.clear();
    b.count = 0;
  }
  current_ = -1;
  completed_ = 0;
}

void TrajectoryRecorder::BeginMode(int k) {
  if (k != completed_ || k >= static_cast<int>(buffers_.size()) || current_ != -1) {
    throw InvalidArgument("TrajectoryRecorder::BeginMode(" + std::to_string(k) +
                          "): expected mode " + std::to_string(completed_) +
                          " next (modes are recorded in order, each ended by EndMode)");
  }
  current_ = k;
  buffers_[k].t.clear();
  buffers_[k].count = 0;
}

void TrajectoryRecorder::AddSample(double t, const ConstVectorRef& x, const ConstVectorRef& u) {
  if (current_ < 0) throw InvalidArgument("TrajectoryRecorder::AddSample: no mode begun");
  Buffer& b = buffers_[current_];
  if (x.size() != b.x.rows() || u.size() != b.u.rows()) {
    throw InvalidArgument("TrajectoryRecorder::AddSample(mode " + std::to_string(current_) +
                          "): x has size " + std::to_string(x.size()) + " (expected " +
                          std::to_string(b.x.rows()) + "), u has size " +
                          std::to_string(u.size()) + " (expected " + std::to_string(b.u.rows()) +
                          ")");
  }
  if (b.count == b.x.cols()) {  // grow (allocates): only when the reservation was too small
    const Eigen::Index cap = std::max<Eigen::Index>(2, 2 * b.x.cols());
    b.x.conservativeResize(Eigen::NoChange, cap);
    b.u.conservativeResize(Eigen::NoChange, cap);
  }
  b.t.push_back(t);
  b.x.col(b.count) = x;
  b.u.col(b.count) = u;
  ++b.count;
}

void TrajectoryRecorder::EndMode() {
  if (current_ < 0) throw InvalidArgument("TrajectoryRecorder::EndMode: no mode begun");
  current_ = -1;
  ++completed_;
}

void TrajectoryRecorder::Finish(Trajectory* out) const {
  const int K = static_cast<int>(buffers_.size());
  if (completed_ != K) {
    throw InvalidArgument("TrajectoryRecorder::Finish: " + std::to_string(completed_) + " of " +
                          std::to_string(K) + " modes recorded");
  }
  out->modes.resize(K);
  out->T.resize(K);
  for (int k = 0; k < K; ++k) {
    const Buffer& b = buffers_[k];
    ModeTrajectory& mode = out->modes[k];
    mode.t = Eigen::Map<const Vector>(b.t.data(), b.count);
    mode.x = b.x.leftCols(b.count);
    mode.u = b.u.leftCols(b.count);
    out->T(k) = b.count > 0 ? b.t[b.count - 1] : 0.0;
  }
  out->x0 = out->modes[0].x.col(0);
}

}  // namespace ddoc
