// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/learner.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

namespace ddoc {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

void CheckSetting(bool ok, const std::string& what) {
  if (!ok) throw InvalidArgument("LearnerSettings: " + what);
}

// Linear interpolation of the input of `mode` (with normalized times `tau`) at tau, advancing a
// cursor.
void InterpolateInput(const Trajectory& traj, int k, double tau, int* cursor, VectorRef u) {
  const ModeTrajectory& mode = traj.modes[k];
  const int N = mode.num_samples();
  int j = std::min(*cursor, N - 2);
  while (j > 0 && traj.Tau(k, j) > tau) --j;
  while (j < N - 2 && traj.Tau(k, j + 1) < tau) ++j;
  *cursor = j;
  const double t0 = traj.Tau(k, j), t1 = traj.Tau(k, j + 1);
  double w = t1 > t0 ? (tau - t0) / (t1 - t0) : 1.0;
  w = std::min(std::max(w, 0.0), 1.0);
  u = (1.0 - w) * mode.u.col(j) + w * mode.u.col(j + 1);
}

// Raises mu for a failed backward pass: 10x, at least to 1e-6 of the L_uu scale.
double RaisedRegularization(double mu, double luu_scale) {
  return std::max(10.0 * mu, 1e-6 * std::max(luu_scale, 1e-12));
}

constexpr int kMaxRegularizationRaises = 30;

}  // namespace

LearnerSettings LearnerSettings::Paper() {
  LearnerSettings s;
  s.acceptance = Acceptance::kSufficientDecrease;
  s.interpolate_backtracking = false;
  s.alpha_after_accept = AlphaAfterAccept::kReset;
  s.step_convergence = true;
  s.backward.equation = BackwardEquation::kLyapunov;
  s.backward.time_curvature = false;
  s.backward.use_previous_du = true;
  s.start_correction = false;
  s.failure_raises = 0;
  return s;
}

LearnerSettings PresetSettings(Preset preset) {
  return preset == Preset::kPaper ? LearnerSettings::Paper() : LearnerSettings{};
}

const char* LearnerStatusName(LearnerStatus status) {
  switch (status) {
    case LearnerStatus::kRunning: return "running";
    case LearnerStatus::kConverged: return "converged";
    case LearnerStatus::kLineSearchFailed: return "line_search_failed";
    case LearnerStatus::kMaxTrials: return "max_trials";
  }
  return "unknown";
}

Optimality ComputeOptimality(const Problem& problem, const Trajectory& nominal,
                             const BackwardPass& pass) {
  Optimality out;
  const int K = problem.num_modes();
  const int m = problem.input_dim();
  const Vector& umin = problem.bounds.u_min;
  const Vector& umax = problem.bounds.u_max;
  // Inputs: int |P(dI/du(t))|^2 dt = sum_j h_tau |P(grad_j)|^2 / D_k (grad per unit tau).
  double sum_u = 0;
  for (int k = 0; k < K; ++k) {
    const ModeTrajectory& mode = nominal.modes[k];
    const double D = nominal.T(k) - nominal.ModeStart(k);
    if (D == 0) continue;  // a vanished mode: its inputs do not act on the cost
    for (int j = 0; j + 1 < mode.num_samples(); ++j) {
      const double h = pass.tau(k, j + 1) - pass.tau(k, j);
      const auto g = pass.Gradient(k, j);
      double sq = 0;
      for (int i = 0; i < m; ++i) {
        const double u = mode.u(i, j);
        const double tol = 1e-9 * (1.0 + std::abs(u));
        const bool out_low = u <= umin(i) + tol && g(i) > 0;
        const bool out_high = u >= umax(i) - tol && g(i) < 0;
        if (!out_low && !out_high) sq += g(i) * g(i);
      }
      sum_u += h * sq / D;
    }
  }
  out.inputs = std::sqrt(sum_u);
  // Durations: the gradient w.r.t. D (S^T dI/dT) projected onto the tangent cone of (7) and the
  // final-time box: v = argmin 1/2 |v|^2 + g^T v over the cone, |v| = |P(-g)|.
  Vector gD(K);
  const Vector& gT = pass.gradient_T();
  double acc = 0;
  for (int k = K - 1; k >= 0; --k) {
    acc += gT(k);
    gD(k) = acc;
  }
  Vector lo(K), hi(K);
  for (int k = 0; k < K; ++k) {
    const double D = nominal.T(k) - nominal.ModeStart(k);
    const double tol = 1e-12 * std::max(1.0, D);
    lo(k) = D <= problem.bounds.duration_min(k) + tol ? 0.0 : -kInf;
    hi(k) = D >= problem.bounds.MaxDuration(k) - tol ? 0.0 : kInf;
  }
  const double TK = nominal.T(K - 1);
  const double ttol = 1e-12 * std::max(1.0, TK);
  const double sum_lo = TK <= problem.bounds.final_time_min + ttol ? 0.0 : -kInf;
  const double sum_hi = TK >= problem.bounds.final_time_max - ttol ? 0.0 : kInf;
  Vector v;
  SolveDurationQp(Matrix::Identity(K, K), gD, lo, hi, sum_lo, sum_hi, &v);
  out.times = v.norm();
  out.total = std::sqrt(out.inputs * out.inputs + out.times * out.times);
  return out;
}

Learner::Learner(const Problem& problem, const LearnerSettings& settings)
    : problem_(&problem), settings_(settings) {
  problem.Validate();
  CheckSetting(settings.c > 0 && std::isfinite(settings.c), "c must be > 0");
  CheckSetting(settings.gamma > 0 && settings.gamma < 1, "gamma must be in (0, 1)");
  CheckSetting(settings.alpha_initial > 0 && settings.alpha_initial <= 1,
               "alpha_initial must be in (0, 1]");
  CheckSetting(settings.alpha_min >= 0 && settings.alpha_min < settings.alpha_initial,
               "alpha_min must be in [0, alpha_initial)");
  CheckSetting(settings.epsilon > 0, "epsilon must be > 0");
  CheckSetting(settings.restart_alpha >= 0 && settings.restart_alpha <= 1,
               "restart_alpha must be in [0, 1]");
  CheckSetting(settings.noise_margin >= 0 && std::isfinite(settings.noise_margin),
               "noise_margin must be finite and >= 0");
  CheckSetting(settings.min_predicted_decrease >= 0 &&
                   std::isfinite(settings.min_predicted_decrease),
               "min_predicted_decrease must be finite and >= 0");
  CheckSetting(!settings.blend_feedforward || settings.blend_feedback,
               "blend_feedforward needs blend_feedback");
  CheckSetting(settings.delta_i >= 1, "delta_i must be >= 1");
  CheckSetting(settings.failure_raises >= 0, "failure_raises must be >= 0");
  CheckSetting(settings.curvature_scale_min > 0 && settings.curvature_scale_min <= 1,
               "curvature_scale_min must be in (0, 1]");
  CheckSetting(settings.switching.relative_regularization > 0 &&
                   std::isfinite(settings.switching.relative_regularization),
               "switching.relative_regularization must be finite and > 0");
  CheckSetting(settings.optimality_tolerance >= 0 && std::isfinite(settings.optimality_tolerance),
               "optimality_tolerance must be finite and >= 0");
  CheckSetting(settings.convergence_tolerance >= 0 && std::isfinite(settings.convergence_tolerance),
               "convergence_tolerance must be finite and >= 0");
  CheckSetting(settings.regularization_min >= 0 && std::isfinite(settings.regularization_min),
               "regularization_min must be finite and >= 0");
  CheckSetting(settings.max_trials >= 1, "max_trials must be >= 1");
  CheckSetting(settings.max_samples >= 2, "max_samples must be >= 2");
  pass_.Allocate(problem, settings.max_samples, settings.backward);
  for (auto& c : controllers_) c.Allocate(problem, settings.max_samples, settings.controller);
  mu_ = settings.regularization_min;
}

void Learner::CheckInitialPolicy(const Policy& initial_policy) const {
  const Bounds& bounds = problem_->bounds;
  if (bounds.final_time_min == bounds.final_time_max) {
    // A fixed final time: the initial plan must end there (the plant would stretch or cut the
    // last mode silently).
    double sum = 0;
    bool finite = true;
    for (int k = 0; k < problem_->num_modes(); ++k) {
      const double d = initial_policy.PlannedDuration(k);
      finite = finite && std::isfinite(d);
      sum += d;
    }
    if (finite && std::abs(sum - bounds.final_time_max) > 1e-9 * std::max(1.0, sum)) {
      throw InvalidArgument("Learner: the initial durations add up to " +
                            std::to_string(sum) + " s, but the final time is fixed at " +
                            std::to_string(bounds.final_time_max) + " s (Bounds::FixFinalTime)");
    }
  }
}

void Learner::ReserveSamples(int samples) {
  if (samples <= settings_.max_samples) return;
  // A margin for trials whose durations differ from the initial plan's (with a fixed final time
  // the total moves by a few samples per mode).
  settings_.max_samples = samples + samples / 4 + 8 * problem_->num_modes();
  pass_.Allocate(*problem_, settings_.max_samples, settings_.backward);
  for (auto& c : controllers_) c.Allocate(*problem_, settings_.max_samples, settings_.controller);
}

bool Learner::RunPass() {
  const bool previous = settings_.backward.use_previous_du && iteration_ > 0 &&
                        du_prev_.cols() == nominal_.total_samples();
  for (int raise = 0; raise <= kMaxRegularizationRaises; ++raise) {
    if (pass_.Run(nominal_, mu_, previous ? &du_prev_ : nullptr)) {
      luu_scale_ = std::max(luu_scale_, pass_.luu_scale());
      optimality_ = ComputeOptimality(*problem_, nominal_, pass_);
      return true;
    }
    luu_scale_ = std::max(luu_scale_, pass_.luu_scale());
    mu_ = RaisedRegularization(mu_, luu_scale_);
  }
  return false;
}

bool Learner::AcceptNominal(const Trajectory& direction, double cost) {
  direction.Validate(*problem_->system);
  const bool use_du = settings_.backward.use_previous_du && initialized_;
  if (use_du) {
    // du^{i-1} at the samples of the new nominal: u^{i+1}(tau) - u^i(tau).
    InputDifference(direction, nominal_, &du_prev_);
  }
  previous_nominal_ = std::move(nominal_);
  nominal_ = direction;
  if (!RunPass()) {
    nominal_ = std::move(previous_nominal_);
    pass_.Run(nominal_, mu_);  // restore the pass of the previous nominal (it succeeded before)
    return false;
  }
  nominal_cost_ = cost;
  nominal_own_cost_ = settings_.start_correction || settings_.reference_shift
                         ? EvaluateCost(*problem_, nominal_).total
                         : 0.0;
  nominal_samples_ = 0;
  nominal_sample_sum_ = 0;
  last_sample_ = cost;
  return true;
}

double Learner::cost_noise() const {
  return noise_count_ > 0 ? std::sqrt(noise_sum_ / noise_count_) : 0.0;
}

double Learner::StartShift(const ConstVectorRef& x0) const {
  if (!initialized_ || !(settings_.start_correction || settings_.reference_shift)) return 0.0;
  // The nominal's own cost under the cost's current reference (a reference that depends on the
  // trial, e.g. the hopper's I1 against the trial's start) minus the one it was adopted with.
  const double reference = EvaluateCost(*problem_, nominal_).total - nominal_own_cost_;
  if (!settings_.start_correction) return std::isfinite(reference) ? reference : 0.0;
  if (x0.size() != nominal_.x0.size()) return 0.0;
  const Vector dx = x0 - nominal_.x0;
  const Eigen::Index n = dx.size();
  const auto P = pass_.P(0, 0);
  const auto p = pass_.p(0, 0);
  const double value = p.head(n).dot(dx) + 0.5 * dx.dot(P.topLeftCorner(n, n) * dx);
  const double shift = value + reference;
  return std::isfinite(shift) ? shift : 0.0;
}

double Learner::RestartAlpha() const {
  return settings_.restart_alpha > 0 ? settings_.restart_alpha : settings_.alpha_initial;
}

void Learner::RestartLineSearch(TrialResult* r) {
  alpha_ = RestartAlpha();
  ++restarts_;
  r->restarted = true;
  remeasure_pending_ = settings_.remeasure_nominal;
}

void Learner::LineSearchExhausted(TrialResult* r) {
  if (settings_.restart_on_failure && !in_solve_) {
    RestartLineSearch(r);
  } else if (failure_raises_ < settings_.failure_raises && luu_scale_ > 0) {
    // Levenberg-Marquardt after a failed search (as box-constrained DDP raises mu when its
    // forward pass fails): a larger mu shortens the step and shrinks the feedback gains K,
    // whose clipping at the input bounds the predicted decrease does not see. Without inputs
    // (L_uu scale 0) mu changes nothing.
    ++failure_raises_;
    const double mu = mu_;
    mu_ = std::max(10.0 * mu_, luu_scale_);
    if (RunPass()) {
      alpha_ = settings_.alpha_initial;
      return;
    }
    mu_ = mu;
    pass_.Run(nominal_, mu_);  // restore the pass that succeeded before
    status_ = LearnerStatus::kLineSearchFailed;
  } else {
    status_ = LearnerStatus::kLineSearchFailed;
  }
}

void Learner::AddNominalSample(double cost) {
  if (!std::isfinite(cost)) return;
  if (std::isfinite(last_sample_)) {
    noise_sum_ += 0.5 * (cost - last_sample_) * (cost - last_sample_);
    ++noise_count_;
  }
  last_sample_ = cost;
  ++nominal_samples_;
  nominal_sample_sum_ += cost;
  nominal_cost_ = nominal_sample_sum_ / nominal_samples_;
}

bool Learner::AdoptTrial(const Trajectory& measured, Plant* direction_plant, double cost) {
  if (direction_plant == nullptr) return AcceptNominal(measured, cost);
  // mRL: the direction trajectory is the same law re-run on the direction plant.
  Trajectory direction;
  direction_plant->Run(measured.x0, controllers_[active_], &direction);
  return AcceptNominal(direction, cost);
}

void Learner::RecomputeDirection() {
  if (!initialized_) throw InvalidArgument("Learner::RecomputeDirection: call Initialize first");
  if (trial_pending_) {
    throw InvalidArgument("Learner::RecomputeDirection: a trial is pending (call CompleteTrial first)");
  }
  if (!RunPass()) {
    throw InvalidArgument("Learner::RecomputeDirection: the backward pass failed for every "
                          "regularization tried");
  }
}

double Learner::PredictedGain(double* bound) const {
  const SwitchingTimeStep full = SolveSwitchingTimeUpdate(
      *problem_, nominal_.T, pass_.P22_initial(), pass_.p2_initial(), 1.0, settings_.switching);
  const double a = pass_.predicted_linear(), b = pass_.predicted_quadratic();
  const double gain = -(a + 0.5 * b + full.model_change);
  // Relative to the current cost, so that neither the cost's units nor how bad the start was
  // move the decision (|I| + 1e-6 |I^0| stopped a 1e46 start at 1e31, issue 47); the rounding
  // of the gain's own terms is the absolute floor that lets an optimum of cost 0 converge.
  const double rounding = 64 * std::numeric_limits<double>::epsilon() *
                          (std::abs(a) + 0.5 * std::abs(b) + std::abs(full.model_change));
  *bound = settings_.convergence_tolerance * std::abs(nominal_cost_) + rounding;
  return gain;
}

void Learner::UpdateConvergence() {
  bool converged = false;
  if (settings_.step_convergence) {
    // Algorithm 1's test: int |du|^2 + |dT|^2 <= epsilon for the last delta_i accepted trials,
    // guarded by the projected gradient, which must have come down by optimality_tolerance
    // from the initial nominal (a zero step at a bound is no convergence).
    const bool small_gradient =
        optimality_.total <= settings_.optimality_tolerance * initial_optimality_.total;
    const int n = static_cast<int>(step_history_.size());
    bool steps = n >= settings_.delta_i;
    for (int i = std::max(0, n - settings_.delta_i); i < n && steps; ++i) {
      steps = step_history_[i] <= settings_.epsilon;
    }
    converged = small_gradient && steps;
  } else {
    // The full step's predicted gain (the Newton decrement, the projected gradient in the
    // model's metric, bounds included) against the current cost only.
    double bound = 0;
    converged = PredictedGain(&bound) <= bound;
  }
  status_ = converged ? LearnerStatus::kConverged : LearnerStatus::kRunning;
}

namespace {
std::string Figure(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.3g", value);
  return buffer;
}
}  // namespace

std::string Learner::StopReason() const {
  if (!initialized_) return "not started: call Initialize or Solve";
  const std::string cost = "the current cost " + Figure(nominal_cost_);
  double bound = 0;
  const double gain = PredictedGain(&bound);
  const std::string gain_text = "the full step's predicted decrease " + Figure(gain);
  const std::string optimality = "first-order optimality " + Figure(optimality_.total);
  switch (status_) {
    case LearnerStatus::kConverged:
      if (settings_.step_convergence) {
        return "converged: the last " + std::to_string(settings_.delta_i) +
               " accepted steps are below epsilon = " + Figure(settings_.epsilon) + " (" +
               optimality + ", " + cost + ")";
      }
      if (iteration_ == 0 && initial_optimality_.total == 0) {
        return "converged: the initial nominal is stationary (" + optimality + ", " + cost + ")";
      }
      return "converged: " + gain_text + " is at most " + Figure(bound) +
             " (convergence_tolerance " + Figure(settings_.convergence_tolerance) + " of " +
             cost + "; " + optimality + ")";
    case LearnerStatus::kLineSearchFailed:
      return "stopped: the line search failed (alpha " + Figure(alpha_) + " below alpha_min " +
             Figure(settings_.alpha_min) + ") at " + cost + "; " + gain_text +
             " (convergence needs at most " + Figure(bound) + "), " + optimality +
             ": the plant does not follow the model's step, or the problem is ill-posed";
    case LearnerStatus::kMaxTrials:
    case LearnerStatus::kRunning:
      return (status_ == LearnerStatus::kRunning && trials_ < settings_.max_trials
                  ? std::string("running: ")
                  : "stopped: max_trials = " + std::to_string(settings_.max_trials) +
                        " reached; ") +
             gain_text + " is above " + Figure(bound) + " (convergence_tolerance " +
             Figure(settings_.convergence_tolerance) + " of " + cost + "; " + optimality + ")";
  }
  return LearnerStatusName(status_);
}

void Learner::Initialize(const Trajectory& measured, const Trajectory* direction,
                         std::optional<double> given_cost) {
  CostBreakdown cost = EvaluateCost(*problem_, measured);
  if (given_cost) cost.total = *given_cost;
  if (!std::isfinite(cost.total)) {
    throw InvalidArgument("Learner::Initialize: the initial trial has a non-finite cost");
  }
  initialized_ = false;
  iteration_ = 0;
  mu_ = settings_.regularization_min;
  luu_scale_ = 0;
  if (!AcceptNominal(direction ? *direction : measured, cost.total)) {
    throw InvalidArgument("Learner::Initialize: the backward pass failed for every "
                          "regularization tried (mu up to " + std::to_string(mu_) + ")");
  }
  initialized_ = true;
  alpha_ = settings_.alpha_initial;
  curvature_scale_ = 1;
  trials_ = 0;
  restarts_ = 0;
  failure_raises_ = 0;
  remeasure_pending_ = false;
  remeasure_trial_ = false;
  noise_sum_ = 0;
  noise_count_ = 0;
  accepted_ = -1;
  active_ = 0;
  trial_pending_ = false;
  step_history_.clear();
  initial_optimality_ = optimality_;
  initial_cost_ = nominal_cost_;
  status_ = LearnerStatus::kRunning;
  // A nominal that is already optimal (zero gradient) has converged; with the step test it
  // still needs delta_i accepted iterations.
  if (!settings_.step_convergence && initial_optimality_.total == 0) {
    status_ = LearnerStatus::kConverged;
  }
}

LearnerCheckpoint Learner::Save() const {
  if (!initialized_) throw InvalidArgument("Learner::Save: call Initialize first");
  LearnerCheckpoint c;
  c.valid = true;
  c.nominal = nominal_;
  c.cost = nominal_cost_;
  c.own_cost = nominal_own_cost_;
  c.initial = accepted_ < 0;
  if (!c.initial) c.law = controllers_[accepted_];
  if (settings_.backward.use_previous_du) {
    c.previous_nominal = previous_nominal_;
    c.du_prev = du_prev_;
  }
  return c;
}

void Learner::Restore(const LearnerCheckpoint& c) {
  if (!initialized_) throw InvalidArgument("Learner::Restore: call Initialize first");
  if (!c.valid) throw InvalidArgument("Learner::Restore: the checkpoint is empty (use Save)");
  nominal_ = c.nominal;
  nominal_cost_ = c.cost;
  nominal_own_cost_ = c.own_cost;
  if (c.initial) {
    accepted_ = -1;
  } else {
    accepted_ = 0;
    active_ = 1;
    controllers_[0] = c.law;
  }
  if (settings_.backward.use_previous_du) {
    previous_nominal_ = c.previous_nominal;
    du_prev_ = c.du_prev;
  }
  trial_pending_ = false;
  remeasure_pending_ = false;
  remeasure_trial_ = false;
  nominal_samples_ = 0;
  nominal_sample_sum_ = 0;
  last_sample_ = c.cost;
  failure_raises_ = 0;
  curvature_scale_ = 1;
  alpha_ = RestartAlpha();
  status_ = LearnerStatus::kRunning;
  if (!RunPass()) {
    throw InvalidArgument("Learner::Restore: the backward pass failed along the checkpoint's "
                          "nominal for every regularization tried");
  }
}

void Learner::SetNominalCost(double cost) {
  if (!std::isfinite(cost)) {
    throw InvalidArgument("Learner::SetNominalCost: cost = " + std::to_string(cost) +
                          ", expected finite");
  }
  nominal_cost_ = cost;
  last_sample_ = cost;
}

OnlineController& Learner::NominalLaw() {
  if (accepted_ >= 0) return controllers_[accepted_];
  controllers_[active_].Load(nominal_, pass_, 0.0, Vector::Zero(problem_->num_modes()));
  return controllers_[active_];
}

OnlineController& Learner::NextTrial() {
  if (!initialized_) throw InvalidArgument("Learner::NextTrial: call Initialize first");
  if (status_ == LearnerStatus::kLineSearchFailed || remeasure_pending_) {
    // Terminated: keep applying the control law of the previous (accepted) iteration.
    // Re-measuring: the same law, whose cost is a sample of I^i (remeasure_nominal).
    trial_pending_ = true;
    remeasure_trial_ = remeasure_pending_ && status_ != LearnerStatus::kLineSearchFailed;
    return NominalLaw();
  }
  // The model with its curvature scaled by sigma: the step alpha / sigma along (31) and (33).
  const double step = alpha_ / curvature_scale_;
  switching_step_ = SolveSwitchingTimeUpdate(*problem_, nominal_.T, pass_.P22_initial(),
                                             pass_.p2_initial(), step, settings_.switching);
  controllers_[active_].Load(nominal_, pass_, step, switching_step_.dT);
  if (settings_.blend_feedback) {
    // The law that produced the nominal: the accepted trial's (another slot), else u^0.
    const OnlineController* nominal_law =
        accepted_ >= 0 ? &controllers_[accepted_] : initial_law_;
    if (nominal_law != nullptr && nominal_law->loaded()) {
      controllers_[active_].BlendStateFeedback(*nominal_law,
                                               std::min(1.0, alpha_ / settings_.alpha_initial),
                                               settings_.blend_feedforward);
    }
  }
  trial_pending_ = true;
  return controllers_[active_];
}

OnlineController& Learner::ConvergedPolicy(double alpha) {
  if (!initialized_) throw InvalidArgument("Learner::ConvergedPolicy: call Initialize first");
  const int slot = accepted_ == active_ ? 1 - active_ : active_;
  controllers_[slot].Load(nominal_, pass_, alpha, Vector::Zero(problem_->num_modes()));
  return controllers_[slot];
}

std::vector<ModeFeedbackLaw> Learner::FeedbackLaw(double alpha) const {
  if (!initialized_) throw InvalidArgument("Learner::FeedbackLaw: call Initialize first");
  OnlineController law;
  law.Allocate(*problem_, settings_.max_samples, settings_.controller);
  law.Load(nominal_, pass_, alpha, Vector::Zero(problem_->num_modes()));
  const OnlineControllerLaw plain = law.ExportLaw();
  const int K = problem_->num_modes();
  const Eigen::Index m = problem_->input_dim();
  std::vector<ModeFeedbackLaw> out(static_cast<size_t>(K));
  int s = 0;
  for (int k = 0; k < K; ++k) {
    const ModeTrajectory& mode = nominal_.modes[k];
    const int N = mode.num_samples();
    const Eigen::Index n = mode.x.rows();
    ModeFeedbackLaw& o = out[static_cast<size_t>(k)];
    o.t = mode.t;
    o.x = mode.x;
    o.u = mode.u;
    o.u_ff.resize(m, N);
    o.K.assign(static_cast<size_t>(N), Matrix::Zero(m, n));
    for (int j = 0; j < N; ++j, ++s) {
      if (m == 0) continue;
      const Matrix H = Eigen::Map<const Matrix>(plain.huu.col(s).data(), m, m);
      const Matrix G =
          plain.feedback_factor * Eigen::Map<const Matrix>(plain.Kx.col(s).data(), m, n);
      const Eigen::LDLT<Matrix> ldlt(H);
      Matrix& gain = o.K[static_cast<size_t>(j)];
      gain = -ldlt.solve(G);
      const auto& scale = settings_.controller.state_feedback_scale;
      if (!scale.empty()) gain *= scale[static_cast<size_t>(k)].asDiagonal();
      o.u_ff.col(j) = mode.u.col(j) - ldlt.solve(Matrix(plain.c.col(s))) - gain * mode.x.col(j);
    }
  }
  return out;
}

double Learner::InputDistance(const Trajectory& a, const Trajectory& b) {
  double total = 0;
  Vector ub(a.modes[0].u.rows());
  for (int k = 0; k < a.num_modes(); ++k) {
    int cursor = 0;
    const int N = a.modes[k].num_samples();
    double prev = 0;
    for (int j = 0; j < N; ++j) {
      const double tau = a.Tau(k, j);
      InterpolateInput(b, k, tau, &cursor, ub);
      const double cur = (a.modes[k].u.col(j) - ub).squaredNorm();
      if (j > 0) total += 0.5 * (tau - a.Tau(k, j - 1)) * (prev + cur);
      prev = cur;
    }
  }
  return total;
}

void Learner::InputDifference(const Trajectory& new_nominal, const Trajectory& old_nominal,
                              Matrix* du) {
  const Eigen::Index m = new_nominal.modes[0].u.rows();
  du->resize(m, new_nominal.total_samples());
  Vector ub(m);
  int s = 0;
  for (int k = 0; k < new_nominal.num_modes(); ++k) {
    int cursor = 0;
    for (int j = 0; j < new_nominal.modes[k].num_samples(); ++j, ++s) {
      InterpolateInput(old_nominal, k, new_nominal.Tau(k, j), &cursor, ub);
      du->col(s) = new_nominal.modes[k].u.col(j) - ub;
    }
  }
}

TrialResult Learner::AbortTrial() {
  if (!initialized_) throw InvalidArgument("Learner::AbortTrial: call Initialize first");
  TrialResult r;
  ++trials_;
  r.trial = trials_;
  r.alpha = alpha_;
  r.cost = kInf;
  r.nominal_cost = nominal_cost_;
  r.decrease = r.cost;
  r.optimality = optimality_.total;
  trial_pending_ = false;
  if (remeasure_trial_) {  // a failed re-measurement: no sample; the restarted search goes on
    remeasure_trial_ = false;
    remeasure_pending_ = false;
    r.remeasured = true;
  } else if (status_ != LearnerStatus::kLineSearchFailed) {
    alpha_ *= settings_.interpolate_backtracking ? 0.1 : settings_.gamma;
    if (alpha_ < settings_.alpha_min) LineSearchExhausted(&r);
  }
  r.iteration = iteration_;
  r.status = status_;
  return r;
}

TrialResult Learner::CompleteTrial(const Trajectory& measured, Plant* direction_plant,
                                   std::optional<double> cost) {
  if (!initialized_) throw InvalidArgument("Learner::CompleteTrial: call Initialize first");
  if (!trial_pending_) {
    throw InvalidArgument("Learner::CompleteTrial: no trial pending (call NextTrial first)");
  }
  // A trial that produced non-finite data cannot be measured: rejected.
  bool finite = measured.T.allFinite() && measured.x0.allFinite();
  for (const auto& mode : measured.modes) {
    finite = finite && mode.t.allFinite() && mode.x.allFinite() && mode.u.allFinite();
  }
  if (!finite) return AbortTrial();

  TrialResult r;
  r.breakdown = EvaluateCost(*problem_, measured);  // validates the trajectory
  ++trials_;
  r.trial = trials_;
  r.alpha = alpha_;
  r.cost = cost ? *cost : r.breakdown.total;
  r.nominal_cost = nominal_cost_;
  r.start_shift = StartShift(measured.x0);
  r.decrease = r.cost - (nominal_cost_ + r.start_shift);
  const Vector dT = measured.T - nominal_.T;
  r.step = InputDistance(measured, nominal_) + dT.squaredNorm();
  // The predicted change: alpha / sigma on the feed-forward of the u-part, the (31) model for T,
  // both with their curvature scaled by sigma (1 unless curvature_scale_min relaxed it).
  const double sigma = curvature_scale_;
  const double a = alpha_ / sigma;
  const double linear_T = pass_.p2_initial().dot(switching_step_.dT);
  r.predicted = a * pass_.predicted_linear() + 0.5 * a * a * sigma * pass_.predicted_quadratic() +
                linear_T + sigma * (switching_step_.model_change - linear_T);
  trial_pending_ = false;
  if (remeasure_trial_) {  // a sample of the nominal's cost, not a candidate
    remeasure_trial_ = false;
    remeasure_pending_ = false;
    r.remeasured = true;
    r.predicted = 0;
    r.alpha = accepted_ >= 0 ? controllers_[accepted_].alpha() : 0.0;
    AddNominalSample(r.cost - r.start_shift);
    return Reported(r);
  }
  if (status_ == LearnerStatus::kLineSearchFailed) return Reported(r);  // terminated: only report
  const double margin = settings_.noise_margin * cost_noise();
  if (settings_.acceptance == Acceptance::kSufficientDecrease) {
    r.accepted = std::isfinite(r.cost) && r.decrease <= -settings_.c * r.step - margin;
  } else {
    // Armijo on the predicted change; a step predicted not to decrease the cost (rounding
    // level) is accepted only if the measured cost did not rise.
    r.accepted = std::isfinite(r.cost) &&
                 (r.predicted < 0 ? r.decrease <= settings_.c * r.predicted - margin
                                  : r.decrease <= -margin);
  }
  // A step predicted to gain less than min_predicted_decrease |I^i| is not one (36) can tell
  // from the plant's noise: adopting it would only replace the nominal by another sample.
  const double floor = settings_.min_predicted_decrease * std::abs(nominal_cost_);
  if (settings_.min_predicted_decrease > 0 && r.accepted && !(r.predicted < -floor)) {
    r.accepted = false;
  }
  if (r.accepted && !AdoptTrial(measured, direction_plant, r.cost)) r.accepted = false;
  if (r.accepted) {
    ++iteration_;
    failure_raises_ = 0;
    step_history_.push_back(r.step);
    accepted_ = active_;
    active_ = 1 - active_;
    const bool ratio = settings_.alpha_after_accept == AlphaAfterAccept::kRatio &&
                       settings_.acceptance == Acceptance::kPredictedDecrease && r.predicted < 0;
    if (ratio) {
      const double rho = r.decrease / r.predicted;
      // A model that the plant shows to be too steep: at the full step the measured decrease
      // beat the prediction by half, so the next step may go further (sigma halves).
      if (rho > 1.5 && alpha_ >= settings_.alpha_initial) {
        curvature_scale_ = std::max(settings_.curvature_scale_min, 0.5 * curvature_scale_);
      } else if (rho < 0.75) {
        curvature_scale_ = std::min(1.0, 2.0 * curvature_scale_);
      }
      if (rho > 0.75) {
        alpha_ = std::min(settings_.alpha_initial, 2.0 * alpha_);
      } else if (rho < 0.25) {
        alpha_ = std::max(0.5 * alpha_, settings_.alpha_min);
      }
    } else if (settings_.alpha_after_accept == AlphaAfterAccept::kGrow) {
      alpha_ = std::min(settings_.alpha_initial, alpha_ / settings_.gamma);
    } else {
      alpha_ = settings_.alpha_initial;
    }
    // Levenberg-Marquardt: the regularization shrinks after a success (to the floor).
    mu_ = std::max(settings_.regularization_min, 0.1 * mu_);
    if (mu_ < 1e-6 * luu_scale_) mu_ = settings_.regularization_min;
    UpdateConvergence();
  } else {
    if (curvature_scale_ < 1) {
      // A relaxed model that overshot: the next trial is the unscaled model at the same alpha.
      curvature_scale_ = 1;
      return Reported(r);
    }
    double next = settings_.gamma * alpha_;
    if (settings_.interpolate_backtracking && std::isfinite(r.decrease)) {
      // The quadratic through phi(0) = 0, phi'(0) = slope and phi(alpha) = decrease.
      const double slope = pass_.predicted_linear() +
                           (alpha_ > 0 ? switching_step_.model_change / alpha_ : 0.0);
      const double curvature = r.decrease - slope * alpha_;
      if (slope < 0 && curvature > 0) {
        next = -slope * alpha_ * alpha_ / (2.0 * curvature);
      }
      next = std::min(std::max(next, 0.1 * alpha_), settings_.gamma * alpha_);
    }
    alpha_ = next;
    if (alpha_ < settings_.alpha_min) LineSearchExhausted(&r);
  }
  return Reported(r);
}

TrialResult Learner::Reported(TrialResult r) const {
  r.iteration = iteration_;
  r.status = status_;
  r.optimality = optimality_.total;
  return r;
}

SolveResult Learner::Solve(Plant& direction_plant, Plant& cost_plant, const ConstVectorRef& x0,
                           Policy& initial_policy) {
  const bool same = &direction_plant == &cost_plant;
  CheckInitialPolicy(initial_policy);
  Trajectory measured;
  cost_plant.Run(x0, initial_policy, &measured);
  if (same) {
    ReserveSamples(measured.total_samples());
    Initialize(measured);
  } else {
    Trajectory direction;
    direction_plant.Run(x0, initial_policy, &direction);
    ReserveSamples(std::max(measured.total_samples(), direction.total_samples()));
    Initialize(measured, &direction);
  }
  SolveResult result;
  result.cost_history.push_back(nominal_cost_);
  in_solve_ = true;  // a batch solve from one start terminates instead of restarting
  while (status_ == LearnerStatus::kRunning && trials_ < settings_.max_trials) {
    OnlineController& policy = NextTrial();
    cost_plant.Run(x0, policy, &measured);
    const TrialResult r = CompleteTrial(measured, same ? nullptr : &direction_plant);
    if (r.accepted) result.cost_history.push_back(nominal_cost_);
  }
  in_solve_ = false;
  result.status = status_ == LearnerStatus::kRunning ? LearnerStatus::kMaxTrials : status_;
  result.trials = trials_;
  result.iterations = iteration_;
  result.cost = nominal_cost_;
  result.T = nominal_.T;
  result.optimality = optimality_;
  result.stop_reason = StopReason();
  return result;
}

}  // namespace ddoc
