// A complete user-defined switched system solved with ddoc (this file is the README example).
//
// A point mass on a rail is pushed by a force u towards x = 1. In mode 0 it moves freely
// (state x, v). At the switch its thruster starts to heat up: mode 1 adds the temperature
// theta (state x, v, theta; reset [x, v] -> [x, v, 0]) and the force becomes less effective as
// theta rises. When should the switch happen, and what force profile is optimal?
#include <cstdio>

#include <ddoc/ddoc.h>

namespace {

using ddoc::VectorX;

// Dynamics, reset and costs are written once, templated on the scalar; derivatives come from
// Eigen's AutoDiff through the CRTP bases.
class Rail : public ddoc::AutoDiffSystem<Rail> {
 public:
  // K = 2 modes with n_0 = 2, n_1 = 3; m = 1 input; no switching surfaces.
  Rail() : AutoDiffSystem<Rail>({2, 3}, 1) {}

  template <class S>
  void Dynamics(int k, const VectorX<S>& x, const VectorX<S>& u, VectorX<S>& xdot) const {
    xdot(0) = x(1);
    if (k == 0) {
      xdot(1) = u(0) - 0.1 * x(1);
    } else {
      xdot(1) = u(0) / (1.0 + x(2)) - 0.1 * x(1);
      xdot(2) = u(0) * u(0) - 2.0 * x(2);
    }
  }
  template <class S>
  void ResetMap(int /*k*/, const VectorX<S>& x, VectorX<S>& x_next) const {
    x_next(0) = x(0);
    x_next(1) = x(1);
    x_next(2) = S(0.0);
  }
};

class RailCost : public ddoc::AutoDiffCost<RailCost> {
 public:
  template <class S>
  S RunningCost(int k, const VectorX<S>& x, const VectorX<S>& u) const {
    S l = 0.5 * (x(0) - 1.0) * (x(0) - 1.0) + 0.5 * u(0) * u(0) + 0.2;  // 0.2: time cost
    if (k == 1) l += 0.5 * x(2) * x(2);
    return l;
  }
  template <class S>
  S SwitchingCost(int k, const VectorX<S>& x) const {
    if (k == 0) return S(0.0);
    return 3.0 * ((x(0) - 1.0) * (x(0) - 1.0) + x(1) * x(1));  // terminal: at rest at x = 1
  }
};

}  // namespace

int main() {
  Rail rail;
  RailCost cost;

  // Check the (automatic) derivatives against central differences, as for any user model.
  for (int k = 0; k < 2; ++k) {
    const ddoc::Vector x = ddoc::Vector::Constant(rail.state_dim(k), 0.3);
    const ddoc::Vector u = ddoc::Vector::Constant(1, 0.5);
    const ddoc::DerivativeCheckReport report = ddoc::CheckDerivatives(rail, &cost, k, x, u);
    if (!report.Passed(1e-6)) {
      std::printf("derivative check failed in mode %d: %g\n", k, report.max_rel_error());
      return 1;
    }
  }

  ddoc::Problem problem;
  problem.system = &rail;
  problem.cost = &cost;
  problem.bounds.u_min = ddoc::Vector::Constant(1, -2.0);
  problem.bounds.u_max = ddoc::Vector::Constant(1, 2.0);
  problem.bounds.duration_min = ddoc::Vector::Constant(2, 0.2);  // T_min^k
  problem.bounds.duration_max = ddoc::Vector::Constant(2, 3.0);  // T_max^k
  problem.surface_weights = ddoc::Vector::Zero(2);                // w_k of (8): none
  problem.Validate();

  // The "real" plant here is the model itself (Algorithm 1 with an exact model); a robot or a
  // simulator would implement ddoc::Plant.
  ddoc::ModelPlant plant(problem);
  ddoc::FunctionPolicy initial(  // u^0 = 0.5, T^0 = (1, 2)
      Eigen::Vector2d(1.0, 1.0),
      [](int, double, const ddoc::ConstVectorRef&, ddoc::VectorRef u) { u.setConstant(0.5); });

  ddoc::LearnerSettings settings;  // the default preset (commented defaults in learner.h)
  ddoc::Learner learner(problem, settings);
  const ddoc::Vector x0 = ddoc::Vector::Zero(2);
  const ddoc::SolveResult result = learner.Solve(plant, plant, x0, initial);

  const char* status[] = {"running", "converged", "line search failed", "max trials"};
  std::printf("%s: cost %.5f -> %.5f in %d trials (%d accepted), switch at T_0 = %.3f s, end %.3f s\n",
              status[static_cast<int>(result.status)], result.cost_history.front(), result.cost,
              result.trials, result.iterations, result.T(0), result.T(1));
  const bool ok = result.status == ddoc::LearnerStatus::kConverged &&
                  result.cost < 0.5 * result.cost_history.front();
  return ok ? 0 : 1;
}
