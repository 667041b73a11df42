// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/plant.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace ddoc {

ModelPlant::ModelPlant(const SwitchedSystem& system, const Bounds& bounds,
                       const ModelPlantSettings& settings)
    : system_(&system), bounds_(bounds), settings_(settings) {
  const int K = system.num_modes();
  const bool final_time_finite = std::isfinite(bounds.final_time_max);
  if (bounds.duration_min.size() != K ||
      (bounds.duration_max.size() != K && !(final_time_finite && bounds.duration_max.size() == 0))) {
    throw InvalidArgument("ModelPlant: duration bounds have sizes " +
                          std::to_string(bounds.duration_min.size()) + "/" +
                          std::to_string(bounds.duration_max.size()) + ", expected K = " +
                          std::to_string(K));
  }
  for (int k = 0; k < K; ++k) {
    // duration_min = 0 is legal: the mode may vanish (two samples at the same instant).
    if (!(bounds.duration_min(k) >= 0) || !(bounds.duration_min(k) <= bounds.MaxDuration(k)) ||
        !std::isfinite(bounds.MaxDuration(k))) {
      std::ostringstream os;
      os << "ModelPlant: duration bounds of mode " << k << " (duration_min(" << k
         << ") = " << bounds.duration_min(k) << ", upper bound " << bounds.MaxDuration(k)
         << ") must satisfy 0 <= min <= max < inf (max: duration_max, or final_time_max when "
            "smaller)";
      throw InvalidArgument(os.str());
    }
  }
  if (!(settings.dt > 0) || !std::isfinite(settings.dt)) {
    throw InvalidArgument("ModelPlant: dt = " + std::to_string(settings.dt) + ", expected > 0");
  }
  const int n = system.max_state_dim();
  k1_.resize(n);
  k2_.resize(n);
  k3_.resize(n);
  k4_.resize(n);
  tmp_.resize(n);
  int s = 1;
  for (int k = 0; k < K; ++k) s = std::max(s, system.surface_dim(k));
  h_.resize(s);
}

ModelPlant::ModelPlant(const Problem& problem, const ModelPlantSettings& settings)
    : ModelPlant((problem.Validate(), *problem.system), problem.bounds, settings) {}

void ModelPlant::Rk4(int k, const Vector& x, const Vector& u, double h, Vector* out) {
  const int n = static_cast<int>(x.size());
  auto k1 = k1_.head(n), k2 = k2_.head(n), k3 = k3_.head(n), k4 = k4_.head(n), t = tmp_.head(n);
  system_->Flow(k, x, u, k1);
  t = x + 0.5 * h * k1;
  system_->Flow(k, t, u, k2);
  t = x + 0.5 * h * k2;
  system_->Flow(k, t, u, k3);
  t = x + h * k3;
  system_->Flow(k, t, u, k4);
  *out = x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
}

bool ModelPlant::TimeBased(int k) const {
  return settings_.time_based_only || (!guard_ && system_->surface_dim(k) == 0);
}

double ModelPlant::GuardValue(int k, const Vector& x, const Vector& u) {
  if (guard_) return guard_(k, x, u);
  auto h = h_.head(system_->surface_dim(k));
  system_->Surface(k, x, h);
  return h(0);
}

void ModelPlant::Run(const ConstVectorRef& x0, Policy& policy, Trajectory* out) {
  const int K = system_->num_modes();
  const int m = system_->input_dim();
  if (x0.size() != system_->state_dim(0) || !x0.allFinite()) {
    throw InvalidArgument("ModelPlant::Run: x0 has size " + std::to_string(x0.size()) +
                          " (expected n_0 = " + std::to_string(system_->state_dim(0)) +
                          ") or is not finite");
  }
  int max_steps = 2;
  for (int k = 0; k < K; ++k) {
    max_steps = std::max(max_steps,
                         static_cast<int>(std::ceil(bounds_.MaxDuration(k) / settings_.dt)) + 4);
  }
  recorder_.Reserve(*system_, max_steps);
  policy.BeginTrial();
  Vector x = x0;
  Vector u(m), x_next, x_try;
  double t = 0;
  for (int k = 0; k < K; ++k) {
    const double dmin = bounds_.duration_min(k);
    const double dmax = bounds_.MaxDuration(k);
    const bool time_based = TimeBased(k);
    double planned = policy.PlannedDuration(k);
    if (!std::isfinite(planned)) planned = dmax;
    const double end_time = std::min(std::max(planned, dmin), dmax);  // time-based end
    const double start = t;
    recorder_.BeginMode(k);
    double elapsed = 0;
    u.setZero();
    while (true) {
      policy.Step(k, elapsed, x, u);
      if (!u.allFinite()) {
        throw InvalidArgument("ModelPlant::Run: policy returned a non-finite input in mode " +
                              std::to_string(k) + " at t = " + std::to_string(t));
      }
      recorder_.AddSample(t, x, u);
      // Step length: land exactly on dmin, dmax and the time-based end.
      double h = settings_.dt;
      const double limit = time_based ? end_time : dmax;
      if (elapsed < dmin) h = std::min(h, dmin - elapsed);
      h = std::min(h, limit - elapsed);
      const double g_prev = time_based ? 1.0 : GuardValue(k, x, u);
      Rk4(k, x, u, h, &x_next);
      double new_elapsed = elapsed + h;
      if (limit - new_elapsed <= 1e-12 * (1.0 + limit)) new_elapsed = limit;
      bool ended = new_elapsed >= limit;
      if (!time_based && new_elapsed >= dmin - 1e-12 * (1.0 + dmin)) {
        if (GuardValue(k, x_next, u) <= 0) {
          ended = true;
          // Locate the crossing by bisection on the step length, not before dmin:
          // invariant g(x(h_lo)) > 0 >= g(x(h_hi)).
          double h_lo = std::max(0.0, dmin - elapsed);
          double h_hi = h;
          if (g_prev > 0 && h_lo < h_hi) {
            if (h_lo > 0) {
              Rk4(k, x, u, h_lo, &x_try);
              if (GuardValue(k, x_try, u) <= 0) h_hi = h_lo;
            }
            for (int it = 0; it < settings_.max_bisections &&
                             h_hi - h_lo > settings_.event_tolerance;
                 ++it) {
              const double h_mid = 0.5 * (h_lo + h_hi);
              Rk4(k, x, u, h_mid, &x_try);
              if (GuardValue(k, x_try, u) > 0) {
                h_lo = h_mid;
              } else {
                h_hi = h_mid;
              }
            }
            if (h_hi < h) {
              Rk4(k, x, u, h_hi, &x_next);
              new_elapsed = elapsed + h_hi;
            }
          }
        }
      }
      x = x_next;
      elapsed = new_elapsed;
      t = start + elapsed;
      if (!x.allFinite()) {
        throw InvalidArgument("ModelPlant::Run: state became non-finite in mode " +
                              std::to_string(k) + " at t = " + std::to_string(t));
      }
      if (ended) break;
    }
    recorder_.AddSample(t, x, u);  // pre-switch state x^-(T_k), last input held
    recorder_.EndMode();
    if (k + 1 < K) {
      Vector x_plus(system_->state_dim(k + 1));
      system_->Reset(k, x, x_plus);
      x = x_plus;
    }
  }
  recorder_.Finish(out);
}

}  // namespace ddoc
