// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "standard_problems.h"

#include <cmath>
#include <limits>
#include <utility>

#include "ddoc/linear_system.h"
#include "ddoc/plant.h"
#include "ddoc/quadratic_cost.h"

namespace ddoc {
namespace testing {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
/// Shortest mode the suite allows (s): 10 plant steps at the default dt = 1e-3 s. No
/// reference optimum has a duration near it.
constexpr double kMinDuration = 0.01;


/// The fishing problem's dynamics (FishingData), m = 0, hand-written derivatives.
class FishingSystem : public SwitchedSystem {
 public:
  explicit FishingSystem(const FishingData& d)
      : SwitchedSystem(std::vector<int>(d.fishing.size(), 2), 0), d_(d) {}

 protected:
  void DoFlow(int k, const ConstVectorRef& x, const ConstVectorRef&,
              VectorRef xdot) const override {
    const double w = d_.fishing[k];
    xdot(0) = x(0) - x(0) * x(1) - d_.c0 * x(0) * w;
    xdot(1) = -x(1) + x(0) * x(1) - d_.c1 * x(1) * w;
  }
  void DoFlowDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef&, MatrixRef fx,
                         MatrixRef) const override {
    const double w = d_.fishing[k];
    fx(0, 0) = 1 - x(1) - d_.c0 * w;
    fx(0, 1) = -x(0);
    fx(1, 0) = x(1);
    fx(1, 1) = -1 + x(0) - d_.c1 * w;
  }
  void DoReset(int, const ConstVectorRef& x, VectorRef x_next) const override { x_next = x; }
  void DoResetDerivative(int, const ConstVectorRef&, MatrixRef gx) const override {
    gx.setIdentity();
  }

 private:
  FishingData d_;
};

/// The three modes of Xu & Antsaklis' example 2 (Exp1Data), m = 1, hand-written derivatives.
class Exp1System : public SwitchedSystem {
 public:
  Exp1System() : SwitchedSystem({2, 2, 2}, 1) {}

 protected:
  void DoFlow(int k, const ConstVectorRef& x, const ConstVectorRef& u,
              VectorRef xdot) const override {
    const double v = u(0);
    if (k == 0) {
      xdot(0) = x(0) + v * std::sin(x(0));
      xdot(1) = -x(1) - v * std::cos(x(1));
    } else if (k == 1) {
      xdot(0) = x(1) + v * std::sin(x(1));
      xdot(1) = -x(0) - v * std::cos(x(0));
    } else {
      xdot(0) = -x(0) - v * std::sin(x(0));
      xdot(1) = x(1) + v * std::cos(x(1));
    }
  }
  void DoFlowDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u, MatrixRef fx,
                         MatrixRef fu) const override {
    const double v = u(0);
    const double s0 = std::sin(x(0)), c0 = std::cos(x(0));
    const double s1 = std::sin(x(1)), c1 = std::cos(x(1));
    if (k == 0) {
      fx << 1 + v * c0, 0, 0, -1 + v * s1;
      fu << s0, -c1;
    } else if (k == 1) {
      fx << 0, 1 + v * c1, -1 + v * s0, 0;
      fu << s1, -c0;
    } else {
      fx << -1 - v * c0, 0, 0, 1 - v * s1;
      fu << -s0, c1;
    }
  }
  void DoReset(int, const ConstVectorRef& x, VectorRef x_next) const override { x_next = x; }
  void DoResetDerivative(int, const ConstVectorRef&, MatrixRef gx) const override {
    gx.setIdentity();
  }
};

/// Bounds of a suite problem: the given input box, durations in [kMinDuration, T] (K > 1) or
/// [T, T] (K = 1), final time fixed at T, no surface weights.
void SetBounds(StandardProblem* sp, const Vector& u_min, const Vector& u_max, double t_final) {
  const int K = sp->system->num_modes();
  Problem& p = sp->problem;
  p.system = sp->system.get();
  p.cost = sp->cost.get();
  p.bounds.u_min = u_min;
  p.bounds.u_max = u_max;
  p.bounds.duration_min = Vector::Constant(K, K == 1 ? t_final : kMinDuration);
  p.bounds.duration_max = Vector::Constant(K, t_final);
  p.bounds.FixFinalTime(t_final);
  p.surface_weights = Vector::Zero(K);
}

void ZeroInput(int, double, const ConstVectorRef&, VectorRef u) { u.setZero(); }

Vector Values(std::initializer_list<double> v) {
  Vector out(static_cast<int>(v.size()));
  int i = 0;
  for (double x : v) out(i++) = x;
  return out;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

LinearQuadraticData LqrData() {
  LinearQuadraticData d;
  Matrix A(2, 2), B(2, 1);
  A << 0, 1, 0, 0;
  B << 0, 1;
  d.A = {A};
  d.B = {B};
  d.Q = {Matrix::Identity(2, 2)};
  d.r = {Vector::Zero(2)};
  d.R = {Matrix::Identity(1, 1)};
  d.rho = {0.0};
  d.S = {Matrix::Zero(2, 2)};
  d.s = {Vector::Zero(2)};
  d.u_min = Vector::Constant(1, -kInf);
  d.u_max = Vector::Constant(1, kInf);
  d.x0 = Values({1, 0});
  d.final_time = 4;
  return d;
}

LinearQuadraticData StoLinearData(int num_modes) {
  LinearQuadraticData d;
  Matrix A0(2, 2), A1(2, 2);
  A0 << -1, 0, 1, 2;
  A1 << 1, 1, 1, -2;
  for (int k = 0; k < num_modes; ++k) {
    d.A.push_back(k % 2 == 0 ? A0 : A1);
    d.B.push_back(Matrix(2, 0));
    if (k + 1 < num_modes) d.E.push_back(Matrix::Identity(2, 2));
    d.Q.push_back(2 * Matrix::Identity(2, 2));  // l = x'x
    d.r.push_back(Vector::Zero(2));
    d.R.push_back(Matrix(0, 0));
    d.rho.push_back(0.0);
    d.S.push_back(Matrix::Zero(2, 2));
    d.s.push_back(Vector::Zero(2));
  }
  d.u_min = Vector(0);
  d.u_max = Vector(0);
  d.x0 = Values({1, 1});
  d.final_time = 1;
  return d;
}

FishingData FishingProblemData(int num_modes) {
  FishingData d;
  for (int k = 0; k < num_modes; ++k) d.fishing.push_back(k % 2);
  d.x0 = Values({0.5, 0.7});
  return d;
}

LinearQuadraticData Exp0Data(double u_bound) {
  LinearQuadraticData d;
  Matrix A0(2, 2), A1(2, 2), B0(2, 1), B1(2, 1), Q(2, 2);
  A0 << 0.6, 1.2, -0.8, 3.4;
  A1 << 4, 3, -1, 0;
  B0 << 1, 1;
  B1 << 2, -1;
  Q << 0, 0, 0, 1;
  const Vector target = Values({4, 2});
  d.A = {A0, A1};
  d.B = {B0, B1};
  d.E = {Matrix::Identity(2, 2)};
  d.Q = {Q, Q};
  d.r = {target, target};
  d.R = {Matrix::Identity(1, 1), Matrix::Identity(1, 1)};
  d.rho = {0.0, 0.0};
  d.S = {Matrix::Zero(2, 2), Matrix::Identity(2, 2)};
  d.s = {target, target};
  d.u_min = Vector::Constant(1, -u_bound);
  d.u_max = Vector::Constant(1, u_bound);
  d.x0 = Values({0, 2});
  d.final_time = 2;
  return d;
}

Exp1Data Exp1ProblemData() {
  Exp1Data d;
  d.target = Values({1, -1});
  d.x0 = Values({2, 3});
  d.final_time = 3;
  return d;
}

LinearQuadraticData StateSizeData() {
  LinearQuadraticData d;
  Matrix A0(2, 2), B0(2, 1), A1(3, 3), B1(3, 1), E(3, 2);
  A0 << 0, 1, 0, 0;
  B0 << 0, 1;
  A1 << 0, 1, 0, -1, -0.4, 0, 1, 0, 0;
  B1 << 0, 0.5, 0;
  E << 1, 0, 0, 1, 0, 0;
  d.A = {A0, A1};
  d.B = {B0, B1};
  d.E = {E};
  d.Q = {Matrix(Values({1, 0.1}).asDiagonal()), Matrix(Values({1, 0.1, 1}).asDiagonal())};
  d.r = {Vector::Zero(2), Vector::Zero(3)};
  d.R = {Matrix::Identity(1, 1), Matrix::Identity(1, 1)};
  d.rho = {0.3, 0.0};
  d.S = {Matrix::Zero(2, 2), Matrix(Values({2, 1, 2}).asDiagonal())};
  d.s = {Vector::Zero(2), Vector::Zero(3)};
  d.u_min = Vector::Constant(1, -kInf);
  d.u_max = Vector::Constant(1, kInf);
  d.x0 = Values({1, 0});
  d.final_time = 3;
  return d;
}

// ---------------------------------------------------------------------------------------------


std::vector<std::string> StandardProblemNames() {
  return {"lqr", "sto2_linear", "sto9_linear", "fishing",
          "exp0", "exp0_bounded", "exp1", "state_size_lq"};
}

RandomStart DrawRandomStart(const StandardProblem& sp, std::mt19937* rng) {
  const int K = sp.num_modes();
  std::uniform_real_distribution<double> weight(0.2, 1.0), offset(-1.0, 1.0);
  RandomStart start;
  start.durations.resize(K);
  for (int k = 0; k < K; ++k) start.durations(k) = weight(*rng);
  start.durations *= sp.final_time() / start.durations.sum();
  for (int k = 0; k < K; ++k) {
    start.durations(k) = std::max(start.durations(k), sp.problem.bounds.duration_min(k) + 1e-3);
  }
  start.durations *= sp.final_time() / start.durations.sum();
  start.offset = offset(*rng);
  return start;
}

FunctionPolicy RandomStartPolicy(const StandardProblem& sp, const RandomStart& start) {
  const FunctionPolicy::Function input = sp.initial_input;
  const double u0 = start.offset;
  return FunctionPolicy(start.durations,
                        [input, u0](int k, double t, const ConstVectorRef& x, VectorRef u) {
                          input(k, t, x, u);
                          u.array() += u0;
                        });
}

std::unique_ptr<StandardProblem> StandardProblemFromLq(const LinearQuadraticData& d) {
  auto sp = std::make_unique<StandardProblem>();
  sp->system = std::make_unique<LinearSystem>(d.A, d.B, d.E);
  sp->cost = std::make_unique<QuadraticTrackingCost>(d.Q, d.r, d.R, d.rho, d.S, d.s);
  SetBounds(sp.get(), d.u_min, d.u_max, d.final_time);
  sp->x0 = d.x0;
  sp->initial_input = ZeroInput;
  return sp;
}

SolveResult SolveOnModel(const StandardProblem& sp, Policy& initial,
                         const LearnerSettings& settings) {
  ModelPlant plant(sp.problem);
  Learner learner(sp.problem, settings);
  return learner.Solve(plant, plant, sp.x0, initial);
}

std::unique_ptr<StandardProblem> MakeStandardProblem(const std::string& name) {
  std::unique_ptr<StandardProblem> sp;
  if (name == "lqr") {
    sp = StandardProblemFromLq(LqrData());
    sp->citation = "finite-horizon LQR of a double integrator (one mode, T = 4 s)";
    sp->initial_durations = Values({4});
    sp->reference_cost = 0.86264301298;
    sp->reference_T = Values({4});
  } else if (name == "sto2_linear") {
    sp = StandardProblemFromLq(StoLinearData(2));
    sp->citation =
        "Stellato et al., IEEE TAC 2017 / SwitchTimeOpt.jl test/linsys.jl: two linear modes, "
        "no input";
    sp->initial_durations = Values({0.5, 0.5});
    sp->reference_cost = 5.25454294492;
    sp->reference_T = Values({0.264866099041, 1});
  } else if (name == "sto9_linear") {
    sp = StandardProblemFromLq(StoLinearData(9));
    sp->citation =
        "SwitchTimeOpt.jl examples/linear.jl dynamics with 8 switches: nine alternating linear "
        "modes, no input";
    sp->initial_durations = Vector::Constant(9, 1.0 / 9);
    sp->reference_cost = 4.46071496467;
    sp->reference_T = Values({0.0760134243023, 0.210006059983, 0.305285325056, 0.443551715601,
                              0.534431631762, 0.679256572495, 0.764891105875, 0.92075699038, 1});
  } else if (name == "fishing") {
    const FishingData d = FishingProblemData(3);
    sp = std::make_unique<StandardProblem>();
    sp->system = std::make_unique<FishingSystem>(d);
    const Matrix Q = 2 * d.weight * Matrix::Identity(2, 2);
    sp->cost = std::make_unique<QuadraticTrackingCost>(
        std::vector<Matrix>(3, Q), std::vector<Vector>(3, Vector::Ones(2)),
        std::vector<Matrix>(3, Matrix(0, 0)), std::vector<double>(3, 0.0),
        std::vector<Matrix>(3, Matrix::Zero(2, 2)), std::vector<Vector>(3, Vector::Zero(2)));
    SetBounds(sp.get(), Vector(0), Vector(0), d.final_time);
    sp->x0 = d.x0;
    sp->initial_input = ZeroInput;
    sp->citation =
        "Lotka-Volterra fishing (Sager 2012; SwitchTimeOpt.jl examples/fishing.jl), one fishing "
        "interval, no input";
    sp->initial_durations = Values({4, 4, 4});
    sp->reference_cost = 0.691377708023;
    sp->reference_T = Values({2.61213321936, 4.34088778443, 12});
  } else if (name == "exp0" || name == "exp0_bounded") {
    const bool bounded = name == "exp0_bounded";
    sp = StandardProblemFromLq(Exp0Data(bounded ? kExp0InputBound : kInf));
    sp->citation = "Xu & Antsaklis, IEEE TAC 2004, example 1 (OCS2 EXP0)";
    if (bounded) sp->citation += " with |u| <= 8 (active at the optimum)";
    sp->bounds_active = bounded;
    sp->initial_durations = Values({1, 1});
    sp->reference_cost = bounded ? 11.3589491026 : 9.76654882536;
    sp->reference_T = Values({bounded ? 0.317209912689 : 0.189671105461, 2});
  } else if (name == "exp1") {
    const Exp1Data d = Exp1ProblemData();
    sp = std::make_unique<StandardProblem>();
    sp->system = std::make_unique<Exp1System>();
    std::vector<Matrix> S(3, Matrix::Zero(2, 2));
    S[2] = Matrix::Identity(2, 2);
    sp->cost = std::make_unique<QuadraticTrackingCost>(
        std::vector<Matrix>(3, Matrix::Identity(2, 2)), std::vector<Vector>(3, d.target),
        std::vector<Matrix>(3, Matrix::Identity(1, 1)), std::vector<double>(3, 0.0), S,
        std::vector<Vector>(3, d.target));
    SetBounds(sp.get(), Vector::Constant(1, -kInf), Vector::Constant(1, kInf), d.final_time);
    sp->x0 = d.x0;
    sp->initial_input = ZeroInput;
    sp->citation = "Xu & Antsaklis, IEEE TAC 2004, example 2 (OCS2 EXP1): three nonlinear modes";
    sp->initial_durations = Values({1, 1, 1});
    sp->reference_cost = 5.44097350240;
    sp->reference_T = Values({0.224518463358, 1.02002462586, 3});
  } else if (name == "state_size_lq") {
    sp = StandardProblemFromLq(StateSizeData());
    sp->citation =
        "constructed for this suite: LQ, 2 states then 3 (rectangular reset [I; 0])";
    sp->initial_durations = Values({1.5, 1.5});
    sp->reference_cost = 1.22282454645;
    sp->reference_T = Values({1.19006843338, 3});
  } else {
    throw InvalidArgument("MakeStandardProblem: unknown problem '" + name + "'");
  }
  sp->name = name;
  sp->problem.Validate();
  return sp;
}

}  // namespace testing
}  // namespace ddoc
