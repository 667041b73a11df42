// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/online_controller.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>

namespace ddoc {

namespace {

void CheckStateFeedbackScale(const std::vector<Vector>& scale, const SwitchedSystem& sys) {
  if (scale.empty()) return;
  const std::string what = "OnlineControllerSettings: state_feedback_scale";
  if (static_cast<int>(scale.size()) != sys.num_modes()) {
    throw InvalidArgument(what + " has " + std::to_string(scale.size()) + " vectors, expected " +
                          std::to_string(sys.num_modes()) + " (one per mode) or none");
  }
  for (int k = 0; k < sys.num_modes(); ++k) {
    const Vector& v = scale[static_cast<size_t>(k)];
    if (v.size() != sys.state_dim(k)) {
      throw InvalidArgument(what + "[" + std::to_string(k) + "] has " + std::to_string(v.size()) +
                            " entries, expected the state dimension " +
                            std::to_string(sys.state_dim(k)));
    }
    for (Eigen::Index i = 0; i < v.size(); ++i) {
      if (!(v(i) >= 0.0) || !std::isfinite(v(i))) {
        throw InvalidArgument(what + "[" + std::to_string(k) + "](" + std::to_string(i) +
                              ") = " + std::to_string(v(i)) + ", expected finite and >= 0");
      }
    }
  }
}

}  // namespace

std::uint64_t OnlineController::NextRevision() {
  static std::atomic<std::uint64_t> next{0};
  return ++next;
}

void OnlineController::Allocate(const Problem& problem, int max_samples,
                                const OnlineControllerSettings& settings) {
  problem.Validate();
  if (max_samples < 2) {
    throw InvalidArgument("OnlineController::Allocate: max_samples = " +
                          std::to_string(max_samples) + ", expected >= 2");
  }
  const SwitchedSystem& sys = *problem.system;
  CheckStateFeedbackScale(settings.state_feedback_scale, sys);
  problem_ = &problem;
  settings_ = settings;
  K_ = sys.num_modes();
  m_ = sys.input_dim();
  n_max_ = sys.max_state_dim();
  layout_.Allocate(sys, max_samples, "OnlineController::Allocate");
  cursor_.assign(K_, 0);
  dT_.setZero(K_);
  planned_T_.setZero(K_);
  nominal_T_.setZero(K_);
  planned_durations_.setOnes(K_);
  tau_.setZero(max_samples);
  x_.setZero(n_max_, max_samples);
  u_.setZero(m_, max_samples);
  Kx_.setZero(m_ * n_max_, max_samples);
  c_.setZero(m_, max_samples);
  huu_.setZero(m_ * m_, max_samples);
  qp_ = BoxQP(m_, settings.qp);
  dx_.setZero(n_max_);
  xnom_.setZero(n_max_);
  unom_.setZero(m_);
  b_.setZero(m_);
  H_.setZero(m_, m_);
  lo_.setZero(m_);
  hi_.setZero(m_);
  du_.setZero(m_);
  llt_ = Eigen::LLT<Matrix>(m_);
  blend_g_.resize(static_cast<Eigen::Index>(m_) * n_max_, 0);  // sized by the first blend
  blend_ok_.clear();
  blend_tau_.resize(0);
  blend_T_.setZero(K_);
  blend_counts_.assign(K_, -1);
  blend_law_revision_ = 0;
  loaded_ = false;
  revision_ = NextRevision();
}

void OnlineController::SetStateFeedbackScale(const std::vector<Vector>& scale) {
  if (problem_ == nullptr) {
    throw InvalidArgument("OnlineController::SetStateFeedbackScale: call Allocate first");
  }
  CheckStateFeedbackScale(scale, *problem_->system);
  settings_.state_feedback_scale = scale;
}

void OnlineController::Load(const Trajectory& nominal, const BackwardPass& pass, double alpha,
                            const ConstVectorRef& dT) {
  if (problem_ == nullptr) throw InvalidArgument("OnlineController::Load: call Allocate first");
  if (!pass.valid()) throw InvalidArgument("OnlineController::Load: backward pass has not run");
  if (nominal.num_modes() != K_ || pass.num_modes() != K_ || dT.size() != K_ ||
      nominal.T.size() != K_) {
    throw InvalidArgument("OnlineController::Load: trajectory/pass/dT sizes do not match K = " +
                          std::to_string(K_));
  }
  if (!(alpha >= 0) || !std::isfinite(alpha) || !dT.allFinite()) {
    throw InvalidArgument("OnlineController::Load: alpha = " + std::to_string(alpha) +
                          " must be finite and >= 0, dT finite");
  }
  layout_.Assign(nominal, "OnlineController::Load");
  for (int k = 0; k < K_; ++k) {
    const int N = layout_.count(k);
    if (N != pass.num_samples(k)) {
      throw InvalidArgument("OnlineController::Load: mode " + std::to_string(k) +
                            " of the trajectory does not match the backward pass (" +
                            std::to_string(N) + " vs " + std::to_string(pass.num_samples(k)) +
                            " samples)");
    }
  }
  alpha_ = alpha;
  // The convention of the equation: alpha on all of b (the paper) or on the feed-forward.
  const bool scale_all = pass.alpha_scales_feedback();
  feedback_factor_ = scale_all ? alpha : 1.0;
  CheckPlannedDurations(nominal.T, dT, "OnlineController::Load");
  dT_ = dT;
  nominal_T_ = nominal.T;
  PlanDurations();
  for (int k = 0; k < K_; ++k) {
    const int n = layout_.dim(k);
    for (int j = 0; j < layout_.count(k); ++j) {
      const int s = layout_.index(k, j);
      tau_(s) = pass.tau(k, j);
      x_.col(s).head(n) = nominal.modes[k].x.col(j);
      u_.col(s) = nominal.modes[k].u.col(j);
      const auto gain = pass.Gain(k, j);
      Eigen::Map<Matrix>(Kx_.col(s).data(), m_, n) = gain.leftCols(n);
      auto c = c_.col(s);
      if (scale_all) {
        c = alpha * pass.Feedforward(k, j);  // (34) as printed
      } else {
        // kRiccati: the feed-forward is the full step k of the pass's box QP, scaled by alpha
        // (box-constrained DDP): with dx = 0 the QP's minimizer is alpha k, which lies in the
        // box for alpha <= 1. Unconstrained, -H k is L_u + F_u^T p, the printed constant.
        c.noalias() = -alpha * (pass.Hessian(k, j) * pass.Step(k, j));
      }
      c.noalias() += (scale_all ? alpha : 1.0) * (gain.rightCols(K_) * dT);
      huu_.col(s) = Eigen::Map<const Vector>(pass.Hessian(k, j).data(), m_ * m_);
    }
  }
  loaded_ = true;
  revision_ = NextRevision();
  BeginTrial();
}

void OnlineController::CheckPlannedDurations(const ConstVectorRef& nominal_T,
                                             const ConstVectorRef& dT, const char* who) const {
  double previous = 0.0;
  for (int k = 0; k < K_; ++k) {
    const double planned = nominal_T(k) + dT(k);
    // A vanished mode (duration_min = 0) may plan zero, up to the rounding of T + dT.
    const bool may_vanish = problem_->bounds.duration_min(k) == 0 &&
                            planned - previous >= -1e-12 * (1.0 + std::abs(planned));
    if (!(planned - previous > 0) && !may_vanish) {
      throw InvalidArgument(std::string(who) + ": planned duration of mode " + std::to_string(k) +
                            " is " + std::to_string(planned - previous) + ", expected > 0");
    }
    previous = planned;
  }
}

void OnlineController::PlanDurations() {
  planned_T_ = nominal_T_ + dT_;
  for (int k = 0; k < K_; ++k) {
    planned_durations_(k) = planned_T_(k) - (k == 0 ? 0.0 : planned_T_(k - 1));
    // A vanished mode (duration_min = 0): T + dT within rounding of T_{k-1} plans exactly 0.
    const bool vanished = problem_->bounds.duration_min(k) == 0 &&
                          planned_durations_(k) <= 1e-12 * (1.0 + std::abs(planned_T_(k)));
    if (planned_durations_(k) < 0 || vanished) planned_durations_(k) = 0;
  }
}

OnlineControllerLaw OnlineController::ExportLaw() const {
  if (!loaded_) throw InvalidArgument("OnlineController::ExportLaw: no law is loaded");
  const int S = layout_.total();
  OnlineControllerLaw law;
  law.alpha = alpha_;
  law.feedback_factor = feedback_factor_;
  law.dT = dT_;
  law.nominal_T = nominal_T_;
  law.samples.resize(K_);
  for (int k = 0; k < K_; ++k) law.samples[k] = layout_.count(k);
  law.tau = tau_.head(S);
  law.x = x_.leftCols(S);
  law.u = u_.leftCols(S);
  law.Kx = Kx_.leftCols(S);
  law.c = c_.leftCols(S);
  law.huu = huu_.leftCols(S);
  return law;
}

void OnlineController::ImportLaw(const OnlineControllerLaw& law) {
  // No std::string unless a check fails: the import does not allocate.
  auto fail = [](const std::string& what) {
    throw InvalidArgument("OnlineController::ImportLaw: " + what);
  };
  if (problem_ == nullptr) fail("call Allocate first");
  if (!(law.alpha >= 0) || !std::isfinite(law.alpha)) {
    fail("alpha = " + std::to_string(law.alpha) + ", expected finite and >= 0");
  }
  if (law.feedback_factor != law.alpha && law.feedback_factor != 1.0) {
    fail("feedback_factor = " + std::to_string(law.feedback_factor) + ", expected alpha or 1");
  }
  const int S = layout_.CheckCounts(law.samples, "OnlineController::ImportLaw");
  auto check = [&](const char* name, const auto& a, Eigen::Index rows, Eigen::Index cols) {
    if (a.rows() != rows || a.cols() != cols) {
      fail(std::string(name) + " is " + std::to_string(a.rows()) + "x" +
           std::to_string(a.cols()) + ", expected " + std::to_string(rows) + "x" +
           std::to_string(cols));
    }
    if (!a.allFinite()) fail(std::string(name) + " has a non-finite entry");
  };
  check("dT", law.dT, K_, 1);
  check("nominal_T", law.nominal_T, K_, 1);
  check("tau", law.tau, S, 1);
  check("x", law.x, n_max_, S);
  check("u", law.u, m_, S);
  check("Kx", law.Kx, static_cast<Eigen::Index>(m_) * n_max_, S);
  check("c", law.c, m_, S);
  check("huu", law.huu, static_cast<Eigen::Index>(m_) * m_, S);
  CheckPlannedDurations(law.nominal_T, law.dT, "OnlineController::ImportLaw");
  for (int k = 0, s = 0; k < K_; ++k) {
    for (int j = 0; j < law.samples[k]; ++j, ++s) {
      const double tau = law.tau(s);
      if (tau < k || tau > k + 1 || (j > 0 && tau < law.tau(s - 1))) {
        fail("tau(" + std::to_string(s) + ") = " + std::to_string(tau) + " in mode " +
             std::to_string(k) + ", expected in [k, k+1] and nondecreasing");
      }
    }
  }
  layout_.AssignCounts(law.samples, "OnlineController::ImportLaw");
  alpha_ = law.alpha;
  feedback_factor_ = law.feedback_factor;
  dT_ = law.dT;
  nominal_T_ = law.nominal_T;
  PlanDurations();
  tau_.head(S) = law.tau;
  x_.leftCols(S) = law.x;
  u_.leftCols(S) = law.u;
  Kx_.leftCols(S) = law.Kx;
  c_.leftCols(S) = law.c;
  huu_.leftCols(S) = law.huu;
  loaded_ = true;
  revision_ = NextRevision();
  BeginTrial();
}

void OnlineController::BlendStateFeedback(const OnlineController& law, double w,
                                          bool feedforward) {
  const char* what = "OnlineController::BlendStateFeedback: ";
  if (!loaded_ || !law.loaded_) {
    throw InvalidArgument(std::string(what) + "both laws must be loaded");
  }
  if (law.K_ != K_ || law.m_ != m_) {
    throw InvalidArgument(std::string(what) + "the other law has " + std::to_string(law.K_) +
                          " modes and " + std::to_string(law.m_) + " inputs, this one " +
                          std::to_string(K_) + " and " + std::to_string(m_));
  }
  if (!(w >= 0.0 && w <= 1.0)) {
    throw InvalidArgument(std::string(what) + "w = " + std::to_string(w) +
                          ", expected in [0, 1]");
  }
  for (int k = 0; k < K_; ++k) {  // every check before anything changes
    if (law.layout_.dim(k) != layout_.dim(k)) {
      throw InvalidArgument(std::string(what) + "mode " + std::to_string(k) + " has state size " +
                            std::to_string(law.layout_.dim(k)) + " in the other law, " +
                            std::to_string(layout_.dim(k)) + " in this one");
    }
  }
  if (w == 1.0) return;
  // A law whose state feedback is scaled by alpha = 0 (kLyapunov) has none to replace.
  if (!(feedback_factor_ > 0.0)) return;
  // H_law^{-1} G_law at this controller's samples depends on `law` and on this controller's
  // grid, not on w or this law's gains: computed once for the trials of a nominal.
  const int S = layout_.total();
  if (blend_g_.cols() < S) {  // the first blend, or a nominal with more samples: allocates
    const Eigen::Index cols = S + S / 4;
    blend_g_.resize(blend_g_.rows(), cols);
    blend_e_.setZero(m_, cols);
    blend_dx_.resize(x_.rows());
    blend_ok_.assign(static_cast<size_t>(cols), 0);
    blend_tau_.resize(cols);
    blend_law_revision_ = 0;
  }
  bool reuse = blend_law_revision_ == law.revision_ && law.revision_ != 0 &&
               blend_T_ == nominal_T_ && blend_tau_.head(S) == tau_.head(S);
  for (int k = 0; k < K_ && reuse; ++k) reuse = blend_counts_[k] == layout_.count(k);
  if (feedforward && !blend_has_e_) reuse = false;
  for (int k = 0; k < K_ && !reuse; ++k) {
    const int n = layout_.dim(k);
    const double nominal_duration = nominal_T_(k) - (k == 0 ? 0.0 : nominal_T_(k - 1));
    int j = 0;
    for (int i = 0; i < layout_.count(k); ++i) {
      const int s = layout_.index(k, i);
      // The nominal passed sample s at t = (tau - k) D_k^i (its own durations); `law` acted
      // there at k + t / D_k(law), its planned duration. That gain belongs to x^i(tau).
      const double t = (tau_(s) - k) * nominal_duration;
      const double tau = NormalizedTime(k, t, law.planned_durations_(k));  // D = 0: tau = k
      const double a = law.Interval(k, tau, &j);
      const int s0 = law.layout_.index(k, j), s1 = s0 + 1;
      law.InterpolateHessian(s0, s1, a, &H_);
      Eigen::Map<Matrix> g(blend_g_.col(s).data(), m_, n);  // G_law, then H_law^{-1} G_law
      g = ((1.0 - a) * law.feedback_factor_) *
              Eigen::Map<const Matrix>(law.Kx_.col(s0).data(), m_, n) +
          (a * law.feedback_factor_) * Eigen::Map<const Matrix>(law.Kx_.col(s1).data(), m_, n);
      llt_.compute(H_);
      blend_ok_[s] = llt_.info() == Eigen::Success;  // else no feedback to take: keep this law's
      if (!blend_ok_[s]) continue;
      if (feedforward) {  // e = law's unconstrained command at x^i(tau) minus u^i(tau)
        auto dx = blend_dx_.head(n);
        dx = x_.col(s).head(n) -
             ((1.0 - a) * law.x_.col(s0).head(n) + a * law.x_.col(s1).head(n));
        b_ = (1.0 - a) * law.c_.col(s0) + a * law.c_.col(s1);
        b_.noalias() += g * dx;
        auto e = blend_e_.col(s);
        e = (1.0 - a) * law.u_.col(s0) + a * law.u_.col(s1) - u_.col(s);
        llt_.solveInPlace(b_);
        e -= b_;
      }
      llt_.solveInPlace(g);
    }
  }
  if (!reuse) {
    blend_law_revision_ = law.revision_;
    blend_has_e_ = feedforward;
    blend_T_ = nominal_T_;
    blend_tau_.head(S) = tau_.head(S);
    for (int k = 0; k < K_; ++k) blend_counts_[k] = layout_.count(k);
  }
  for (int k = 0; k < K_; ++k) {
    const int n = layout_.dim(k);
    for (int i = 0; i < layout_.count(k); ++i) {
      const int s = layout_.index(k, i);
      if (!blend_ok_[s]) continue;
      const Eigen::Map<const Matrix> g(blend_g_.col(s).data(), m_, n);  // H_law^{-1} G_law
      Eigen::Map<Matrix> K(Kx_.col(s).data(), m_, n);
      K *= w;
      const Eigen::Map<const Matrix> H(huu_.col(s).data(), m_, m_);
      K.noalias() += ((1.0 - w) / feedback_factor_) * (H * g);
      if (feedforward) c_.col(s).noalias() -= (1.0 - w) * (H * blend_e_.col(s));
    }
  }
  revision_ = NextRevision();
}

void OnlineController::BeginTrial() {
  std::fill(cursor_.begin(), cursor_.end(), 0);
  du_integral_ = 0;
  last_tau_ = 0;
  last_mode_ = -1;
  last_du_sq_ = 0;
  nonfinite_count_ = 0;
  qp_failures_ = 0;
  du_.setZero();
}

double OnlineController::Interval(int k, double tau, int* j_inout) const {
  const int off = layout_.offset(k);
  const int N = layout_.count(k);
  int j = std::min(*j_inout, N - 2);
  while (j > 0 && tau_(off + j) > tau) --j;
  while (j < N - 2 && tau_(off + j + 1) < tau) ++j;
  *j_inout = j;
  const double span = tau_(off + j + 1) - tau_(off + j);
  const double w = span > 0 ? (tau - tau_(off + j)) / span : 1.0;
  return std::min(std::max(w, 0.0), 1.0);
}

double OnlineController::Locate(int k, double tau, int* j_out) {
  const double w = Interval(k, tau, &cursor_[k]);
  *j_out = cursor_[k];
  if (!settings_.interpolate) return tau >= tau_(layout_.index(k, *j_out) + 1) ? 1.0 : 0.0;
  return w;
}

void OnlineController::InterpolateHessian(int s0, int s1, double a, Matrix* H) const {
  *H = (1.0 - a) * Eigen::Map<const Matrix>(huu_.col(s0).data(), m_, m_) +
       a * Eigen::Map<const Matrix>(huu_.col(s1).data(), m_, m_);
}

void OnlineController::Accumulate(int k, double tau) {
  // Left Riemann sum of |du|^2 over tau: the previous du was held until now.
  if (last_mode_ == k && tau > last_tau_) du_integral_ += last_du_sq_ * (tau - last_tau_);
  last_du_sq_ = du_.squaredNorm();
  last_tau_ = tau;
  last_mode_ = k;
}

void OnlineController::Step(int k, double t_since_mode_start, const ConstVectorRef& x_measured,
                            VectorRef u_out) {
  if (!loaded_) throw InvalidArgument("OnlineController::Step: no control law loaded");
  if (k < 0 || k >= K_) {
    throw InvalidArgument("OnlineController::Step: mode k = " + std::to_string(k) +
                          " out of range [0, " + std::to_string(K_) + ")");
  }
  const int n = layout_.dim(k);
  if (x_measured.size() != n || u_out.size() != m_) {
    throw InvalidArgument("OnlineController::Step(k=" + std::to_string(k) + "): x has size " +
                          std::to_string(x_measured.size()) + " (expected " + std::to_string(n) +
                          "), u has size " + std::to_string(u_out.size()) + " (expected " +
                          std::to_string(m_) + ")");
  }
  const Vector& umin = problem_->bounds.u_min;
  const Vector& umax = problem_->bounds.u_max;
  const bool finite_time = std::isfinite(t_since_mode_start);
  const double tau = NormalizedTime(k, finite_time ? t_since_mode_start : 0.0,
                                    planned_durations_(k));
  int j = 0;
  const double w = Locate(k, tau, &j);
  const int s0 = layout_.index(k, j);
  const int s1 = s0 + 1;
  // Nominal input at tau.
  unom_ = (1.0 - w) * u_.col(s0) + w * u_.col(s1);
  if (!finite_time || !x_measured.allFinite()) {
    ++nonfinite_count_;
    du_.setZero();
    u_out = unom_.cwiseMax(umin).cwiseMin(umax);
    Accumulate(k, tau);
    return;
  }
  // dx and b of (34): b = (1-w)(Kx_0 dx + c_0) + w (Kx_1 dx + c_1).
  auto dx = dx_.head(n);
  dx = x_measured - ((1.0 - w) * x_.col(s0).head(n) + w * x_.col(s1).head(n));
  if (!settings_.state_feedback_scale.empty()) {  // validated by Allocate/SetStateFeedbackScale
    dx.array() *= settings_.state_feedback_scale[static_cast<size_t>(k)].array();
  }
  Eigen::Map<const Matrix> K0(Kx_.col(s0).data(), m_, n);
  Eigen::Map<const Matrix> K1(Kx_.col(s1).data(), m_, n);
  b_ = (1.0 - w) * c_.col(s0) + w * c_.col(s1);
  b_.noalias() += ((1.0 - w) * feedback_factor_) * K0 * dx;
  b_.noalias() += (w * feedback_factor_) * K1 * dx;
  // H = L_uu(tau) + mu I, as the backward pass assumed.
  InterpolateHessian(s0, s1, w, &H_);
  lo_ = umin - unom_;
  hi_ = umax - unom_;
  // The nominal can sit slightly outside the box (interpolation, measured inputs).
  lo_ = lo_.cwiseMin(0.0);
  hi_ = hi_.cwiseMax(0.0);
  if (!settings_.warm_start) du_.setZero();
  const BoxQPStatus status = qp_.Solve(H_, b_, lo_, hi_, du_);
  if (status != BoxQPStatus::kConverged) ++qp_failures_;
  if (!du_.allFinite()) {
    du_.setZero();
    ++qp_failures_;
  }
  u_out = (unom_ + du_).cwiseMax(umin).cwiseMin(umax);
  // int |du|^2 dtau (left Riemann sum within a mode).
  Accumulate(k, tau);
}

}  // namespace ddoc
