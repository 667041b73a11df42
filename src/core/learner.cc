// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/learner.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ddoc {
namespace {

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

}  // namespace

LearnerSettings LearnerSettings::Paper() {
  LearnerSettings s;
  s.backward.equation = BackwardEquation::kLyapunov;
  s.backward.use_previous_du = true;
  s.controller.alpha_scales_feedback = true;
  return s;
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
  CheckSetting(settings.delta_i >= 1, "delta_i must be >= 1");
  CheckSetting(settings.nonmonotone_memory >= 1, "nonmonotone_memory must be >= 1");
  CheckSetting(settings.rebaseline_after >= 0, "rebaseline_after must be >= 0");
  CheckSetting(settings.max_trials >= 1, "max_trials must be >= 1");
  CheckSetting(settings.max_samples >= 2, "max_samples must be >= 2");
  pass_.Allocate(problem, settings.max_samples, settings.backward);
  for (auto& c : controllers_) c.Allocate(problem, settings.max_samples, settings.controller);
}

void Learner::AcceptNominal(const Trajectory& direction, double cost) {
  direction.Validate(*problem_->system);
  const Matrix* du = nullptr;
  if (settings_.backward.use_previous_du && initialized_) {
    // du^{i-1} at the samples of the new nominal: u^{i+1}(tau) - u^i(tau).
    InputDifference(direction, nominal_, &du_prev_);
    du = &du_prev_;
  }
  previous_nominal_ = std::move(nominal_);
  nominal_ = direction;
  nominal_cost_ = cost;
  cost_memory_.push_back(cost);
  const size_t memory = static_cast<size_t>(settings_.nonmonotone_memory);
  if (cost_memory_.size() > memory) {
    cost_memory_.erase(cost_memory_.begin(), cost_memory_.end() - memory);
  }
  pass_.Run(nominal_, du);
}

void Learner::AdoptTrial(const Trajectory& measured, Plant* direction_plant, double cost) {
  if (direction_plant == nullptr) {
    AcceptNominal(measured, cost);
    return;
  }
  // mRL: the direction trajectory is the same law re-run on the direction plant.
  Trajectory direction;
  direction_plant->Run(measured.x0, controllers_[active_], &direction);
  AcceptNominal(direction, cost);
}

void Learner::RecomputeDirection() {
  if (!initialized_) throw InvalidArgument("Learner::RecomputeDirection: call Initialize first");
  if (trial_pending_) {
    throw InvalidArgument("Learner::RecomputeDirection: a trial is pending (call CompleteTrial first)");
  }
  const bool previous = settings_.backward.use_previous_du && iteration_ > 0;
  pass_.Run(nominal_, previous ? &du_prev_ : nullptr);
}

void Learner::Initialize(const Trajectory& measured, const Trajectory* direction) {
  const CostBreakdown cost = EvaluateCost(*problem_, measured);
  if (!std::isfinite(cost.total)) {
    throw InvalidArgument("Learner::Initialize: the initial trial has a non-finite cost");
  }
  initialized_ = false;
  cost_memory_.clear();
  rejections_ = 0;
  AcceptNominal(direction ? *direction : measured, cost.total);
  initialized_ = true;
  alpha_ = settings_.alpha_initial;
  iteration_ = 0;
  trials_ = 0;
  accepted_ = -1;
  active_ = 0;
  trial_pending_ = false;
  status_ = LearnerStatus::kRunning;
  step_history_.clear();
}

OnlineController& Learner::NextTrial() {
  if (!initialized_) throw InvalidArgument("Learner::NextTrial: call Initialize first");
  if (status_ == LearnerStatus::kLineSearchFailed) {
    // Terminated: keep applying the control law of the previous (accepted) iteration.
    trial_pending_ = true;
    if (accepted_ >= 0) return controllers_[accepted_];
    controllers_[active_].Load(nominal_, pass_, 0.0, Vector::Zero(problem_->num_modes()));
    return controllers_[active_];
  }
  switching_step_ = SolveSwitchingTimeUpdate(*problem_, nominal_.T, pass_.P22_initial(),
                                             pass_.p2_initial(), alpha_, settings_.switching);
  controllers_[active_].Load(nominal_, pass_, alpha_, switching_step_.dT);
  trial_pending_ = true;
  return controllers_[active_];
}

OnlineController& Learner::ConvergedPolicy(double alpha) {
  if (!initialized_) throw InvalidArgument("Learner::ConvergedPolicy: call Initialize first");
  const int slot = accepted_ == active_ ? 1 - active_ : active_;
  controllers_[slot].Load(nominal_, pass_, alpha, Vector::Zero(problem_->num_modes()));
  return controllers_[slot];
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
  r.cost = std::numeric_limits<double>::infinity();
  r.nominal_cost = nominal_cost_;
  r.decrease = r.cost;
  trial_pending_ = false;
  ++rejections_;
  if (status_ != LearnerStatus::kLineSearchFailed) {
    alpha_ *= settings_.gamma;
    if (alpha_ < settings_.alpha_min) status_ = LearnerStatus::kLineSearchFailed;
  }
  r.iteration = iteration_;
  r.status = status_;
  return r;
}

TrialResult Learner::CompleteTrial(const Trajectory& measured, Plant* direction_plant) {
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
  r.cost = r.breakdown.total;
  r.nominal_cost = nominal_cost_;
  // (36) reference: I^i, or with a non-monotone memory the largest of the remembered costs.
  r.expected_nominal_cost = *std::max_element(cost_memory_.begin(), cost_memory_.end());
  if (settings_.initial_state_correction && measured.x0.size() == nominal_.x0.size()) {
    // Second-order prediction of the nominal's cost from the trial's initial state.
    const Eigen::Index n0 = nominal_.x0.size();
    const Vector dx0 = measured.x0 - nominal_.x0;
    const auto P = pass_.P(0, 0);
    const auto p = pass_.p(0, 0);
    r.expected_nominal_cost += p.head(n0).dot(dx0) +
                               0.5 * dx0.dot(P.topLeftCorner(n0, n0) * dx0);
  }
  r.decrease = r.cost - r.expected_nominal_cost;
  const Vector dT = measured.T - nominal_.T;
  r.step = InputDistance(measured, nominal_) + dT.squaredNorm();
  trial_pending_ = false;
  if (status_ == LearnerStatus::kLineSearchFailed) {  // terminated: only report
    r.iteration = iteration_;
    r.status = status_;
    return r;
  }
  r.accepted = std::isfinite(r.cost) && r.decrease <= -settings_.c * r.step;
  if (r.accepted) {
    rejections_ = 0;
    AdoptTrial(measured, direction_plant, r.cost);
    ++iteration_;
    step_history_.push_back(r.step);
    accepted_ = active_;
    active_ = 1 - active_;
    alpha_ = settings_.reset_alpha_on_accept
                 ? settings_.alpha_initial
                 : std::min(settings_.alpha_initial, alpha_ / settings_.gamma);
    const int n = static_cast<int>(step_history_.size());
    bool converged = n >= settings_.delta_i;
    for (int i = std::max(0, n - settings_.delta_i); i < n && converged; ++i) {
      converged = step_history_[i] <= settings_.epsilon;
    }
    status_ = converged ? LearnerStatus::kConverged : LearnerStatus::kRunning;
  } else {
    ++rejections_;
    alpha_ *= settings_.gamma;
    if (alpha_ < settings_.alpha_min) status_ = LearnerStatus::kLineSearchFailed;
    if (settings_.rebaseline_after > 0 && rejections_ >= settings_.rebaseline_after &&
        std::isfinite(r.cost) && status_ == LearnerStatus::kRunning) {
      // Restart Algorithm 1 from this trial: it is the new x^i with its measured cost.
      cost_memory_.clear();
      AdoptTrial(measured, direction_plant, r.cost);
      accepted_ = active_;
      active_ = 1 - active_;
      rejections_ = 0;
      r.rebaselined = true;
    }
  }
  r.iteration = iteration_;
  r.status = status_;
  return r;
}

SolveResult Learner::Solve(Plant& direction_plant, Plant& cost_plant, const ConstVectorRef& x0,
                           Policy& initial_policy) {
  const bool same = &direction_plant == &cost_plant;
  Trajectory measured;
  cost_plant.Run(x0, initial_policy, &measured);
  if (same) {
    Initialize(measured);
  } else {
    Trajectory direction;
    direction_plant.Run(x0, initial_policy, &direction);
    Initialize(measured, &direction);
  }
  SolveResult result;
  result.cost_history.push_back(nominal_cost_);
  while (trials_ < settings_.max_trials) {
    OnlineController& policy = NextTrial();
    cost_plant.Run(x0, policy, &measured);
    const TrialResult r = CompleteTrial(measured, same ? nullptr : &direction_plant);
    if (r.accepted) result.cost_history.push_back(nominal_cost_);
    if (status_ != LearnerStatus::kRunning) break;
  }
  result.status = status_ == LearnerStatus::kRunning ? LearnerStatus::kMaxTrials : status_;
  result.trials = trials_;
  result.iterations = iteration_;
  result.cost = nominal_cost_;
  result.T = nominal_.T;
  return result;
}

}  // namespace ddoc
