// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The extension module `ddoc._ddoc` of the Python package `ddoc` (python/ddoc/): a thin pybind11
// layer over the engine's public API (docs/python.md).
// What lives here and not in the engine:
//   - LinearSystem / QuadraticCost: a matrix-given linear-quadratic switched system that runs
//     entirely in C++ (the engine has no public LQ class; the tests' ones are not installed);
//   - CallbackSystem / CallbackCost: SwitchedSystem / SwitchedCost whose parts are Python
//     callables, missing derivatives by ddoc::CentralDifferenceJacobian;
//   - Plant: a pybind11 trampoline (PyPlant) so that a Plant can be written in Python; its run
//     gets the trial's Policy as a view valid only during the call;
//   - Learner.solve: Learner::Solve's trial loop driven through Initialize / NextTrial /
//     CompleteTrial, so that the GIL is released during each trial and Ctrl-C and the progress
//     callback are handled between trials.
#include <pybind11/eigen.h>
#include <pybind11/eval.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "ddoc/check_derivatives.h"
#include "ddoc/learner.h"
#include "ddoc/linear_system.h"
#include "ddoc/quadratic_cost.h"
#include "ddoc/plant.h"
#include "ddoc/policy.h"
#include "ddoc/problem.h"

namespace py = pybind11;

namespace ddoc {
namespace python {
namespace {

// ------------------------------------------------------------------------------ conversions

std::string ShapeString(const py::array& a) {
  std::ostringstream s;
  s << "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) {
    if (i > 0) s << ", ";
    s << a.shape(i);
  }
  if (a.ndim() == 1) s << ",";
  s << ")";
  return s.str();
}

std::string ExpectedShape(Eigen::Index rows, Eigen::Index cols = -2) {
  auto dim = [](Eigen::Index d) { return d < 0 ? std::string("any") : std::to_string(d); };
  if (cols == -2) return "(" + dim(rows) + ",)";
  return "(" + dim(rows) + ", " + dim(cols) + ")";
}

py::array_t<double> AsFloatArray(const py::handle& obj, const std::string& name) {
  auto a = py::array_t<double, py::array::forcecast>::ensure(obj);
  if (!a) {
    throw InvalidArgument(name + ": expected an array of floats, got " +
                          std::string(py::str(py::type::handle_of(obj).attr("__name__"))));
  }
  return a;
}

/// A 1-D array of floats of size `size` (-1: any) named `name` in the error message.
Vector AsVector(const py::handle& obj, const std::string& name, Eigen::Index size = -1) {
  const py::array_t<double> a = AsFloatArray(obj, name);
  if (a.ndim() != 1 || (size >= 0 && a.shape(0) != size)) {
    throw InvalidArgument(name + ": shape " + ShapeString(a) + ", expected " + ExpectedShape(size));
  }
  Vector v(a.shape(0));
  auto r = a.unchecked<1>();
  for (py::ssize_t i = 0; i < a.shape(0); ++i) v(i) = r(i);
  return v;
}

/// A 2-D array of floats of shape (rows, cols) (-1: any) named `name` in the error message.
Matrix AsMatrix(const py::handle& obj, const std::string& name, Eigen::Index rows = -1,
                Eigen::Index cols = -1) {
  const py::array_t<double> a = AsFloatArray(obj, name);
  if (a.ndim() != 2 || (rows >= 0 && a.shape(0) != rows) || (cols >= 0 && a.shape(1) != cols)) {
    throw InvalidArgument(name + ": shape " + ShapeString(a) + ", expected " +
                          ExpectedShape(rows, cols));
  }
  Matrix m(a.shape(0), a.shape(1));
  auto r = a.unchecked<2>();
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    for (py::ssize_t j = 0; j < a.shape(1); ++j) m(i, j) = r(i, j);
  }
  return m;
}

double AsFloat(const py::handle& obj, const std::string& name) {
  try {
    return py::cast<double>(obj);
  } catch (const py::cast_error&) {
    throw InvalidArgument(name + ": expected a float, got " +
                          std::string(py::str(py::type::handle_of(obj).attr("__name__"))));
  }
}

std::vector<Matrix> AsMatrices(const py::handle& list, const std::string& name) {
  std::vector<Matrix> out;
  int k = 0;
  for (const py::handle item : list) {
    out.push_back(AsMatrix(item, name + "[" + std::to_string(k) + "]"));
    ++k;
  }
  return out;
}

std::string Indexed(const char* what, int k) { return std::string(what) + "(k=" + std::to_string(k) + ")"; }

// ------------------------------------------------------------------ matrix-given LQ system

/// The Python constructor of ddoc::LinearSystem: lists of arrays, B optional (m = 0), E optional
/// (identities when the state size does not change); errors name the argument and both shapes.
std::unique_ptr<LinearSystem> MakeLinearSystem(const py::list& A_in, const py::object& B_in,
                                             const py::object& E_in) {
  std::vector<Matrix> A = AsMatrices(A_in, "A");
  const size_t K = A.size();
  if (K == 0) throw InvalidArgument("A: expected at least one mode, got an empty list");
  for (size_t k = 0; k < K; ++k) {
    if (A[k].rows() != A[k].cols() || A[k].rows() == 0) {
      throw InvalidArgument("A[" + std::to_string(k) + "]: shape (" +
                            std::to_string(A[k].rows()) + ", " + std::to_string(A[k].cols()) +
                            "), expected a square (n_k, n_k) with n_k > 0");
    }
  }
  std::vector<Matrix> B;
  int m = 0;
  if (!B_in.is_none()) {
    const py::list Bl = B_in;
    if (Bl.size() != K) {
      throw InvalidArgument("B: " + std::to_string(Bl.size()) + " matrices, expected " +
                            std::to_string(K) + " (one per mode)");
    }
    for (size_t k = 0; k < K; ++k) {
      const std::string i = "[" + std::to_string(k) + "]";
      Matrix Bk = AsMatrix(Bl[k], "B" + i);
      if (k == 0) m = static_cast<int>(Bk.cols());
      if (Bk.rows() != A[k].rows()) {
        // Name A[k] too: a wrong A[k] shows up as B[k]'s row count (issue 47).
        throw InvalidArgument("A" + i + " and B" + i + " disagree on mode " +
                              std::to_string(k) + "'s state size: B" + i + ": shape (" +
                              std::to_string(Bk.rows()) + ", " + std::to_string(Bk.cols()) +
                              "), expected (" + std::to_string(A[k].rows()) + ", " +
                              std::to_string(m) + ") as A" + i + " has shape (" +
                              std::to_string(A[k].rows()) + ", " + std::to_string(A[k].cols()) +
                              "); or A" + i + " should be (" + std::to_string(Bk.rows()) + ", " +
                              std::to_string(Bk.rows()) + ")");
      }
      if (Bk.cols() != m) {
        throw InvalidArgument("B" + i + ": shape (" + std::to_string(Bk.rows()) + ", " +
                              std::to_string(Bk.cols()) + "), expected (" +
                              std::to_string(A[k].rows()) + ", " + std::to_string(m) +
                              ") (m inputs, as B[0])");
      }
      B.push_back(std::move(Bk));
    }
  } else {
    for (size_t k = 0; k < K; ++k) B.push_back(Matrix::Zero(A[k].rows(), 0));
  }
  std::vector<Matrix> E;
  if (!E_in.is_none()) {
    const py::list El = E_in;
    if (El.size() != K - 1 && El.size() != K) {
      throw InvalidArgument("E: " + std::to_string(El.size()) + " matrices, expected " +
                            std::to_string(K - 1) + " (K - 1 resets) or " + std::to_string(K) +
                            " (with the cycle reset)");
    }
    for (size_t k = 0; k < El.size(); ++k) {
      E.push_back(AsMatrix(El[k], "E[" + std::to_string(k) + "]", A[(k + 1) % K].rows(),
                           A[k].rows()));
    }
  } else {
    for (size_t k = 0; k + 1 < K; ++k) {
      if (A[k].rows() != A[k + 1].rows()) {
        throw InvalidArgument("E: required when state sizes change (mode " + std::to_string(k) +
                              " has " + std::to_string(A[k].rows()) + " states, mode " +
                              std::to_string(k + 1) + " has " + std::to_string(A[k + 1].rows()) +
                              ")");
      }
      E.push_back(Matrix::Identity(A[k].rows(), A[k].rows()));
    }
  }
  return std::make_unique<LinearSystem>(std::move(A), std::move(B), std::move(E));
}

/// The Python constructor of ddoc::QuadraticTrackingCost (bound as ddoc.QuadraticCost): S, r, s
/// and rho optional (zeros); errors name the argument and both shapes.
std::unique_ptr<QuadraticTrackingCost> MakeQuadraticCost(const py::list& Q_in, const py::list& R_in,
                                                       const py::object& S_in, const py::object& r_in,
                                                       const py::object& s_in, const py::object& rho_in,
                                                       const py::object& N_in) {
  std::vector<Matrix> Q;
  const size_t K = Q_in.size();
  if (K == 0) throw InvalidArgument("Q: expected at least one mode, got an empty list");
  for (size_t k = 0; k < K; ++k) Q.push_back(AsMatrix(Q_in[k], "Q[" + std::to_string(k) + "]"));
  auto check_count = [K](size_t got, const char* name) {
    if (got != K) {
      throw InvalidArgument(std::string(name) + ": " + std::to_string(got) +
                            " entries, expected " + std::to_string(K) + " (one per mode, as Q)");
    }
  };
  check_count(R_in.size(), "R");
  std::vector<Matrix> R, S;
  std::vector<Vector> r, s;
  std::vector<double> rho;
  for (size_t k = 0; k < K; ++k) {
    const auto n = Q[k].rows();
    const std::string idx = "[" + std::to_string(k) + "]";
    if (Q[k].cols() != n) {
      throw InvalidArgument("Q" + idx + ": shape (" + std::to_string(n) + ", " +
                            std::to_string(Q[k].cols()) + "), expected a square matrix");
    }
    R.push_back(AsMatrix(R_in[k], "R" + idx, k == 0 ? -1 : R[0].rows(),
                         k == 0 ? -1 : R[0].rows()));
    if (R[k].rows() != R[k].cols()) {
      throw InvalidArgument("R" + idx + ": shape (" + std::to_string(R[k].rows()) + ", " +
                            std::to_string(R[k].cols()) + "), expected a square matrix");
    }
  }
  auto optional_list = [K, &check_count](const py::object& obj, const char* name) {
    if (obj.is_none()) return py::list();
    py::list l = obj;
    check_count(l.size(), name);
    return l;
  };
  const py::list Sl = optional_list(S_in, "S"), rl = optional_list(r_in, "r"),
                 sl = optional_list(s_in, "s"), rhol = optional_list(rho_in, "rho");
  for (size_t k = 0; k < K; ++k) {
    const auto n = Q[k].rows();
    const std::string idx = "[" + std::to_string(k) + "]";
    S.push_back(S_in.is_none() ? Matrix::Zero(n, n) : AsMatrix(Sl[k], "S" + idx, n, n));
    r.push_back(r_in.is_none() ? Vector::Zero(n) : AsVector(rl[k], "r" + idx, n));
    s.push_back(s_in.is_none() ? Vector::Zero(n) : AsVector(sl[k], "s" + idx, n));
    rho.push_back(rho_in.is_none() ? 0.0 : AsFloat(rhol[k], "rho" + idx));
  }
  std::vector<Matrix> N;  // empty: no cross term
  if (!N_in.is_none()) {
    const py::list Nl = N_in;
    check_count(Nl.size(), "N");
    for (size_t k = 0; k < K; ++k) {
      N.push_back(AsMatrix(Nl[k], "N[" + std::to_string(k) + "]", R[k].rows(), Q[k].rows()));
    }
  }
  return std::make_unique<QuadraticTrackingCost>(std::move(Q), std::move(r), std::move(R),
                                                 std::move(rho), std::move(S), std::move(s),
                                                 std::move(N));
}


// ------------------------------------------------------------- Python-callable system / cost

py::array_t<double> ToArray(const ConstVectorRef& v) {
  py::array_t<double> a(v.size());
  std::copy(v.data(), v.data() + v.size(), a.mutable_data());
  return a;
}

/// A SwitchedSystem whose parts are Python callables (called with the GIL held).
class CallbackSystem : public SwitchedSystem {
 public:
  CallbackSystem(std::vector<int> state_dims, int input_dim, py::function flow, py::object reset,
                 py::object flow_derivatives, py::object reset_derivative,
                 std::vector<int> surface_dims, py::object surface, py::object surface_derivative,
                 bool cycle_reset, double fd_step)
      : SwitchedSystem(state_dims, input_dim, surface_dims, cycle_reset),
        flow_(std::move(flow)), reset_(std::move(reset)),
        flow_derivatives_(std::move(flow_derivatives)),
        reset_derivative_(std::move(reset_derivative)), surface_(std::move(surface)),
        surface_derivative_(std::move(surface_derivative)), fd_step_(fd_step) {
    if (!(fd_step > 0) || !std::isfinite(fd_step)) {
      throw InvalidArgument("fd_step: " + std::to_string(fd_step) + ", expected finite and > 0");
    }
    bool has_surface = false;
    for (int s : surface_dims) has_surface = has_surface || s > 0;
    if (has_surface && surface_.is_none()) {
      throw InvalidArgument("surface: required when surface_dims has a positive entry");
    }
  }

  ~CallbackSystem() override {
    py::gil_scoped_acquire gil;
    flow_ = py::function();
    reset_ = flow_derivatives_ = reset_derivative_ = surface_ = surface_derivative_ = py::object();
  }

 protected:
  int NextDim(int k) const { return state_dim((k + 1) % num_modes()); }

  void DoFlow(int k, const ConstVectorRef& x, const ConstVectorRef& u,
              VectorRef xdot) const override {
    py::gil_scoped_acquire gil;
    xdot = AsVector(flow_(k, ToArray(x), ToArray(u)), Indexed("flow", k) + " returned",
                    state_dim(k));
  }
  void DoFlowDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u, MatrixRef fx,
                         MatrixRef fu) const override {
    if (!flow_derivatives_.is_none()) {
      py::gil_scoped_acquire gil;
      const py::tuple r = flow_derivatives_(k, ToArray(x), ToArray(u));
      if (r.size() != 2) throw InvalidArgument(Indexed("flow_derivatives", k) + ": expected (fx, fu)");
      fx = AsMatrix(r[0], Indexed("flow_derivatives", k) + " fx", state_dim(k), state_dim(k));
      fu = AsMatrix(r[1], Indexed("flow_derivatives", k) + " fu", state_dim(k), input_dim());
      return;
    }
    const Vector u0 = u, x0 = x;
    fx = CentralDifferenceJacobian(
        [&](const Vector& z) {
          Vector out(state_dim(k));
          DoFlow(k, z, u0, out);
          return out;
        },
        x0, fd_step_);
    if (input_dim() > 0) {
      fu = CentralDifferenceJacobian(
          [&](const Vector& z) {
            Vector out(state_dim(k));
            DoFlow(k, x0, z, out);
            return out;
          },
          u0, fd_step_);
    }
  }
  void DoReset(int k, const ConstVectorRef& x, VectorRef x_next) const override {
    if (reset_.is_none()) {
      if (NextDim(k) != state_dim(k)) {
        throw InvalidArgument(Indexed("reset", k) + ": no reset given and the state size changes");
      }
      x_next = x;
      return;
    }
    py::gil_scoped_acquire gil;
    x_next = AsVector(reset_(k, ToArray(x)), Indexed("reset", k) + " returned", NextDim(k));
  }
  void DoResetDerivative(int k, const ConstVectorRef& x, MatrixRef gx) const override {
    if (reset_.is_none()) {
      if (NextDim(k) != state_dim(k)) {
        throw InvalidArgument(Indexed("reset", k) + ": no reset given and the state size changes");
      }
      gx.setIdentity();
      return;
    }
    if (!reset_derivative_.is_none()) {
      py::gil_scoped_acquire gil;
      gx = AsMatrix(reset_derivative_(k, ToArray(x)), Indexed("reset_derivative", k) + " returned",
                    NextDim(k), state_dim(k));
      return;
    }
    gx = CentralDifferenceJacobian(
        [&](const Vector& z) {
          Vector out(NextDim(k));
          DoReset(k, z, out);
          return out;
        },
        Vector(x), fd_step_);
  }
  void DoSurface(int k, const ConstVectorRef& x, VectorRef h) const override {
    py::gil_scoped_acquire gil;
    h = AsVector(surface_(k, ToArray(x)), Indexed("surface", k) + " returned", surface_dim(k));
  }
  void DoSurfaceDerivative(int k, const ConstVectorRef& x, MatrixRef hx) const override {
    if (!surface_derivative_.is_none()) {
      py::gil_scoped_acquire gil;
      hx = AsMatrix(surface_derivative_(k, ToArray(x)),
                    Indexed("surface_derivative", k) + " returned", surface_dim(k), state_dim(k));
      return;
    }
    hx = CentralDifferenceJacobian(
        [&](const Vector& z) {
          Vector out(surface_dim(k));
          DoSurface(k, z, out);
          return out;
        },
        Vector(x), fd_step_);
  }

 private:
  py::function flow_;
  py::object reset_, flow_derivatives_, reset_derivative_, surface_, surface_derivative_;
  double fd_step_;
};

/// A SwitchedCost whose parts are Python callables. Missing derivatives: the gradient by
/// central differences of the value (step fd_step), the Hessian by central differences of that
/// gradient (step fd_hessian_step), symmetrized.
class CallbackCost : public SwitchedCost {
 public:
  CallbackCost(py::function running, py::object switching, py::object running_derivatives,
               py::object switching_derivatives, double fd_step, double fd_hessian_step)
      : running_(std::move(running)), switching_(std::move(switching)),
        running_derivatives_(std::move(running_derivatives)),
        switching_derivatives_(std::move(switching_derivatives)), fd_step_(fd_step),
        fd_hessian_step_(fd_hessian_step) {
    for (double h : {fd_step, fd_hessian_step}) {
      if (!(h > 0) || !std::isfinite(h)) {
        throw InvalidArgument("fd_step / fd_hessian_step: " + std::to_string(h) +
                              ", expected finite and > 0");
      }
    }
  }
  ~CallbackCost() override {
    py::gil_scoped_acquire gil;
    running_ = py::function();
    switching_ = running_derivatives_ = switching_derivatives_ = py::object();
  }

 protected:
  double DoRunning(int k, const ConstVectorRef& x, const ConstVectorRef& u) const override {
    py::gil_scoped_acquire gil;
    return AsFloat(running_(k, ToArray(x), ToArray(u)), Indexed("running", k) + " returned");
  }
  void DoRunningDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u, VectorRef lx,
                            VectorRef lu, MatrixRef lxx, MatrixRef luu,
                            MatrixRef lux) const override {
    const auto n = x.size(), m = u.size();
    if (!running_derivatives_.is_none()) {
      py::gil_scoped_acquire gil;
      const std::string name = Indexed("running_derivatives", k);
      const py::tuple r = running_derivatives_(k, ToArray(x), ToArray(u));
      if (r.size() != 5) throw InvalidArgument(name + ": expected (lx, lu, lxx, luu, lux)");
      lx = AsVector(r[0], name + " lx", n);
      lu = AsVector(r[1], name + " lu", m);
      lxx = AsMatrix(r[2], name + " lxx", n, n);
      luu = AsMatrix(r[3], name + " luu", m, m);
      lux = AsMatrix(r[4], name + " lux", m, n);
      return;
    }
    Vector z(n + m);
    z << x, u;
    auto value = [&](const Vector& w) {
      return Vector::Constant(1, DoRunning(k, w.head(n), w.tail(m)));
    };
    auto gradient = [&](const Vector& w) -> Vector {
      return CentralDifferenceJacobian(value, w, fd_step_).transpose();
    };
    const Vector g = gradient(z);
    Matrix H = CentralDifferenceJacobian(gradient, z, fd_hessian_step_);
    H = 0.5 * (H + H.transpose()).eval();
    lx = g.head(n);
    lu = g.tail(m);
    lxx = H.topLeftCorner(n, n);
    luu = H.bottomRightCorner(m, m);
    lux = H.bottomLeftCorner(m, n);
  }
  double DoSwitching(int k, const ConstVectorRef& x) const override {
    if (switching_.is_none()) return 0.0;
    py::gil_scoped_acquire gil;
    return AsFloat(switching_(k, ToArray(x)), Indexed("switching", k) + " returned");
  }
  void DoSwitchingDerivatives(int k, const ConstVectorRef& x, VectorRef phix,
                              MatrixRef phixx) const override {
    const auto n = x.size();
    if (switching_.is_none()) {
      phix.setZero();
      phixx.setZero();
      return;
    }
    if (!switching_derivatives_.is_none()) {
      py::gil_scoped_acquire gil;
      const std::string name = Indexed("switching_derivatives", k);
      const py::tuple r = switching_derivatives_(k, ToArray(x));
      if (r.size() != 2) throw InvalidArgument(name + ": expected (phix, phixx)");
      phix = AsVector(r[0], name + " phix", n);
      phixx = AsMatrix(r[1], name + " phixx", n, n);
      return;
    }
    auto value = [&](const Vector& w) { return Vector::Constant(1, DoSwitching(k, w)); };
    auto gradient = [&](const Vector& w) -> Vector {
      return CentralDifferenceJacobian(value, w, fd_step_).transpose();
    };
    phix = gradient(Vector(x));
    Matrix H = CentralDifferenceJacobian(gradient, Vector(x), fd_hessian_step_);
    phixx = 0.5 * (H + H.transpose());
  }

 private:
  py::function running_;
  py::object switching_, running_derivatives_, switching_derivatives_;
  double fd_step_, fd_hessian_step_;
};

// ------------------------------------------------------------------------------- solving


LearnerSettings PresetByName(const std::string& name) {
  if (name == "default") return PresetSettings(Preset::kDefault);
  if (name == "paper") return PresetSettings(Preset::kPaper);
  throw InvalidArgument("preset: unknown preset '" + name + "', expected 'default' or 'paper'");
}

// ------------------------------------------------------------------------------ plants

/// The policy of one trial, as Plant.run sees it: valid only during that run (afterwards its
/// methods raise), so that Python cannot keep a dangling C++ policy.
struct PolicyView {
  Policy* policy = nullptr;
  int input_dim = 0;
  Policy& Get() const {
    if (policy == nullptr) throw InvalidArgument("policy: used outside the Plant.run it was given to");
    return *policy;
  }
};

/// A Plant written in Python: Plant.run(x0, policy) returns the measured ddoc.Trajectory.
class PyPlant : public Plant {
 public:
  void Run(const ConstVectorRef& x0, Policy& policy, Trajectory* out) override {
    py::gil_scoped_acquire gil;
    py::function run = py::get_override(static_cast<const Plant*>(this), "run");
    if (!run) throw InvalidArgument("Plant: a subclass must define run(x0, policy)");
    auto view = std::make_shared<PolicyView>();
    view->policy = &policy;
    view->input_dim = input_dim;
    struct Invalidate {
      PolicyView* v;
      ~Invalidate() { v->policy = nullptr; }
    } invalidate{view.get()};
    py::object result = run(ToArray(x0), view);
    if (!py::isinstance<Trajectory>(result)) {
      throw InvalidArgument("Plant.run returned " +
                            std::string(py::str(py::type::handle_of(result).attr("__name__"))) +
                            ", expected a ddoc.Trajectory");
    }
    *out = result.cast<Trajectory>();
  }
  int input_dim = 0;  ///< m of the problem it runs (set by Learner.solve)
};

/// Trajectory(t, x, u): per mode k the sample times t[k] (N_k,), states x[k] (n_k, N_k) and
/// inputs u[k] (m, N_k); T(k) = t[k][-1], x0 = x[0][:, 0]; Trajectory::Validate checks the rest.
Trajectory MakeTrajectory(const py::sequence& t, const py::sequence& x, const py::sequence& u) {
  if (x.size() != t.size() || u.size() != t.size()) {
    throw InvalidArgument("Trajectory: t, x and u have " + std::to_string(t.size()) + ", " +
                          std::to_string(x.size()) + " and " + std::to_string(u.size()) +
                          " modes, expected the same number");
  }
  Trajectory out;
  const size_t K = t.size();
  out.T.resize(static_cast<Eigen::Index>(K));
  for (size_t k = 0; k < K; ++k) {
    const std::string at = "[" + std::to_string(k) + "]";
    ModeTrajectory mode;
    mode.t = AsVector(t[k], "t" + at);
    const Eigen::Index N = mode.t.size();
    mode.x = AsMatrix(x[k], "x" + at, -1, N);
    mode.u = AsMatrix(u[k], "u" + at, -1, N);
    if (N == 0) throw InvalidArgument("t" + at + ": no samples");
    out.T(static_cast<Eigen::Index>(k)) = mode.t(N - 1);
    out.modes.push_back(std::move(mode));
  }
  if (K > 0) out.x0 = out.modes[0].x.col(0);
  out.Validate();
  return out;
}

/// SolveResult plus what the binding adds: whether Ctrl-C stopped the solve.
struct PySolveResult {
  SolveResult result;
  bool interrupted = false;
};

/// A Learner with its problem (kept alive by the Python object) and the plants of its solves.
class PyLearner {
 public:
  PyLearner(const Problem& problem, const LearnerSettings& settings)
      : problem_(&problem), learner_(std::make_unique<Learner>(problem, settings)) {}

  PySolveResult Solve(const py::object& x0_in, const py::object& durations_in,
                      const py::object& u0, const py::object& plant_in,
                      const std::string& method, double dt, const py::object& progress) {
    // plant: None, a System (run by a ModelPlant) or a Plant (e.g. written in Python).
    const SwitchedSystem* plant_system = nullptr;
    Plant* user_plant = nullptr;
    if (py::isinstance<Plant>(plant_in)) {
      user_plant = plant_in.cast<Plant*>();
    } else if (py::isinstance<SwitchedSystem>(plant_in)) {
      plant_system = plant_in.cast<const SwitchedSystem*>();
    } else if (!plant_in.is_none()) {
      throw InvalidArgument("plant: expected None, a System or a Plant, got " +
                            std::string(py::str(py::type::handle_of(plant_in).attr("__name__"))));
    }
    if (method != "alg1" && method != "mrl") {
      throw InvalidArgument("method: unknown method '" + method + "', expected 'alg1' or 'mrl'");
    }
    if (method == "mrl" && plant_system == nullptr && user_plant == nullptr) {
      throw InvalidArgument("method: 'mrl' needs a plant (a system other than the model)");
    }
    const Problem& problem = *problem_;
    problem.Validate();
    const int K = problem.num_modes(), m = problem.input_dim();
    const Vector x0 = AsVector(x0_in, "x0", problem.system->state_dim(0));
    if (!x0.allFinite()) throw InvalidArgument("x0: non-finite entry");
    const Vector durations = AsVector(durations_in, "durations", K);
    if (!(durations.array() > 0).all() || !durations.allFinite()) {
      throw InvalidArgument("durations: expected finite entries > 0");
    }
    FunctionPolicy::Function fn;
    if (u0.is_none()) {
      fn = [](int, double, const ConstVectorRef&, VectorRef u) { u.setZero(); };
    } else if (PyCallable_Check(u0.ptr())) {
      py::function f = u0;
      fn = [f, m](int k, double tau, const ConstVectorRef& x, VectorRef u) {
        py::gil_scoped_acquire gil;
        u = AsVector(f(k, tau, ToArray(x)), "u0(k=" + std::to_string(k) + ") returned", m);
      };
    } else {
      const Vector u_const = AsVector(u0, "u0", m);
      fn = [u_const](int, double, const ConstVectorRef&, VectorRef u) { u = u_const; };
    }
    FunctionPolicy initial_policy(durations, fn);
    learner_->CheckInitialPolicy(initial_policy);
    ModelPlantSettings plant_settings;
    plant_settings.dt = dt;
    ModelPlant model(problem, plant_settings);
    std::unique_ptr<ModelPlant> real;
    if (plant_system != nullptr) {
      real = std::make_unique<ModelPlant>(*plant_system, problem.bounds, plant_settings);
    }
    if (auto* py_plant = dynamic_cast<PyPlant*>(user_plant)) py_plant->input_dim = m;
    // Algorithm 1 on the plant (or the model); mRL: directions from the model.
    Plant& cost_plant = user_plant ? *user_plant : real ? static_cast<Plant&>(*real) : model;
    Plant& direction_plant = method == "mrl" ? static_cast<Plant&>(model) : cost_plant;
    const bool same = &direction_plant == &cost_plant;
    Learner& learner = *learner_;
    // Learner::Solve's loop, one trial per GIL release.
    PySolveResult out;
    SolveResult& result = out.result;
    Trajectory measured, direction;
    auto fill = [&]() {
      result.status = learner.status() == LearnerStatus::kRunning ? LearnerStatus::kMaxTrials
                                                                   : learner.status();
      result.trials = learner.trials();
      result.iterations = learner.iteration();
      result.cost = learner.nominal_cost();
      result.T = learner.nominal().T;
      result.optimality = learner.optimality();
      result.stop_reason = learner.StopReason();
    };
    bool initialized = false;
    try {
      {
        py::gil_scoped_release release;
        cost_plant.Run(x0, initial_policy, &measured);
        if (same) {
          learner.ReserveSamples(measured.total_samples());
          learner.Initialize(measured);
        } else {
          direction_plant.Run(x0, initial_policy, &direction);
          learner.ReserveSamples(std::max(measured.total_samples(), direction.total_samples()));
          learner.Initialize(measured, &direction);
        }
      }
      initialized = true;
      result.cost_history.push_back(learner.nominal_cost());
      while (learner.status() == LearnerStatus::kRunning &&
             learner.trials() < learner.settings().max_trials) {
        TrialResult r;
        {
          py::gil_scoped_release release;
          OnlineController& policy = learner.NextTrial();
          cost_plant.Run(x0, policy, &measured);
          r = learner.CompleteTrial(measured, same ? nullptr : &direction_plant);
        }
        if (r.accepted) result.cost_history.push_back(learner.nominal_cost());
        if (PyErr_CheckSignals() != 0) throw py::error_already_set();
        if (!progress.is_none()) {
          py::dict info;
          info["trial"] = r.trial;
          info["iteration"] = r.iteration;
          info["accepted"] = r.accepted;
          info["cost"] = r.cost;
          info["nominal_cost"] = learner.nominal_cost();
          info["alpha"] = r.alpha;
          info["optimality"] = r.optimality;
          info["status"] = LearnerStatusName(r.status);
          progress(info);
        }
      }
    } catch (py::error_already_set& e) {
      if (!e.matches(PyExc_KeyboardInterrupt) || !initialized) throw;
      fill();
      out.interrupted = true;
      // KeyboardInterrupt carrying the partial result.
      py::object cls = py::module_::import("ddoc").attr("SolveInterrupted");
      py::object exc = cls("solve interrupted after " + std::to_string(learner.trials()) +
                           " trials; the partial result is in .result");
      exc.attr("result") = py::cast(out);
      PyErr_SetObject(cls.ptr(), exc.ptr());
      throw py::error_already_set();
    }
    fill();
    return out;
  }

  const Learner& learner() const { return *learner_; }

 private:
  const Problem* problem_;
  std::unique_ptr<Learner> learner_;
};

py::array_t<double> VectorToArray(const Vector& v) { return ToArray(v); }

}  // namespace

#ifdef DDOC_PYTHON_HOPPER
void BindHopper(py::module_& mod);  // hopper_binding.cc
#endif

}  // namespace python
}  // namespace ddoc

using namespace ddoc;          // NOLINT
using namespace ddoc::python;  // NOLINT

PYBIND11_MODULE(_ddoc, mod) {  // re-exported by the package ddoc (python/ddoc/__init__.py)
  mod.doc() =
      "ddoc: data-driven iterative optimal control of switched systems (Algorithm 1 of Chen, Li "
      "& Braun, RA-L 2023). A thin layer over the C++ engine; see docs/python.md.";

  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InvalidArgument& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    }
  });
  // KeyboardInterrupt carrying the partial result of Learner.solve in .result.
  py::exec(R"(
class SolveInterrupted(KeyboardInterrupt):
    """Ctrl-C during Learner.solve; .result holds the SolveResult of the trials done so far."""
    result = None
)", mod.attr("__dict__"));
  mod.attr("SolveInterrupted").attr("__module__") = "ddoc";

#ifdef DDOC_PYTHON_HOPPER
  BindHopper(mod);
#endif

  py::class_<Bounds>(mod, "Bounds",
                     "Input bounds (6), per-mode duration bounds (7) and a box on the final time. "
                     "u_min/u_max have m entries (may be -inf/inf; empty for m = 0), "
                     "duration_min/duration_max K entries.")
      .def(py::init([](const py::object& u_min, const py::object& u_max,
                       const py::object& duration_min, const py::object& duration_max,
                       double final_time_min, double final_time_max) {
             Bounds b;
             b.u_min = AsVector(u_min, "u_min");
             b.u_max = AsVector(u_max, "u_max");
             b.duration_min = AsVector(duration_min, "duration_min");
             b.duration_max = AsVector(duration_max, "duration_max");
             b.final_time_min = final_time_min;
             b.final_time_max = final_time_max;
             return b;
           }),
           py::arg("u_min") = py::array_t<double>(0), py::arg("u_max") = py::array_t<double>(0),
           py::arg("duration_min") = py::array_t<double>(0),
           py::arg("duration_max") = py::array_t<double>(0), py::arg("final_time_min") = 0.0,
           py::arg("final_time_max") = std::numeric_limits<double>::infinity())
      .def_readwrite("u_min", &Bounds::u_min)
      .def_readwrite("u_max", &Bounds::u_max)
      .def_readwrite("duration_min", &Bounds::duration_min)
      .def_readwrite("duration_max", &Bounds::duration_max)
      .def_readwrite("final_time_min", &Bounds::final_time_min)
      .def_readwrite("final_time_max", &Bounds::final_time_max)
      .def("fix_final_time", &Bounds::FixFinalTime, py::arg("t_final"),
           "Fixes the final time: final_time_min = final_time_max = t_final (s).")
      .def_property_readonly("final_time_bounded", &Bounds::final_time_bounded);

  py::class_<SwitchedSystem>(mod, "System",
                             "A switched system (f_k, g_k, h_k). Use LinearSystem or "
                             "CallbackSystem; the methods evaluate it with the engine's checks.")
      .def_property_readonly("num_modes", &SwitchedSystem::num_modes)
      .def_property_readonly("input_dim", &SwitchedSystem::input_dim)
      .def("state_dim", &SwitchedSystem::state_dim, py::arg("k"))
      .def("surface_dim", &SwitchedSystem::surface_dim, py::arg("k"))
      .def(
          "flow",
          [](const SwitchedSystem& s, int k, const py::object& x, const py::object& u) {
            if (k < 0 || k >= s.num_modes()) throw InvalidArgument("k: out of range");
            Vector xd(s.state_dim(k));
            s.Flow(k, AsVector(x, "x", s.state_dim(k)), AsVector(u, "u", s.input_dim()), xd);
            return xd;
          },
          py::arg("k"), py::arg("x"), py::arg("u"), "xdot = f_k(x, u).")
      .def(
          "flow_derivatives",
          [](const SwitchedSystem& s, int k, const py::object& x, const py::object& u) {
            if (k < 0 || k >= s.num_modes()) throw InvalidArgument("k: out of range");
            const int n = s.state_dim(k), m = s.input_dim();
            Matrix fx(n, n), fu(n, m);
            s.FlowDerivatives(k, AsVector(x, "x", n), AsVector(u, "u", m), fx, fu);
            return py::make_tuple(fx, fu);
          },
          py::arg("k"), py::arg("x"), py::arg("u"), "(fx, fu) = (df_k/dx, df_k/du).")
      .def(
          "reset",
          [](const SwitchedSystem& s, int k, const py::object& x) {
            if (k < 0 || k >= s.num_modes()) throw InvalidArgument("k: out of range");
            Vector xn(s.state_dim((k + 1) % s.num_modes()));
            s.Reset(k, AsVector(x, "x", s.state_dim(k)), xn);
            return xn;
          },
          py::arg("k"), py::arg("x"), "x+ = g_k(x).");

  py::class_<LinearSystem, SwitchedSystem>(
      mod, "LinearSystem",
      "xdot = A_k x + B_k u in mode k, x+ = E_k x at the end of mode k < K-1 (E_{K-1}, if given, "
      "is the cycle reset). Runs entirely in C++. B = None: m = 0 (no inputs); E = None: "
      "identity resets (equal state sizes).")
      .def(py::init(&MakeLinearSystem), py::arg("A"), py::arg("B") = py::none(),
           py::arg("E") = py::none());

  py::class_<SwitchedCost>(mod, "Cost", "Running costs l_k(x, u) and switching costs phi_k(x).")
      .def(
          "running",
          [](const SwitchedCost& c, int k, const py::object& x, const py::object& u) {
            return c.Running(k, AsVector(x, "x"), AsVector(u, "u"));
          },
          py::arg("k"), py::arg("x"), py::arg("u"))
      .def(
          "switching",
          [](const SwitchedCost& c, int k, const py::object& x) {
            return c.Switching(k, AsVector(x, "x"));
          },
          py::arg("k"), py::arg("x"));

  py::class_<QuadraticTrackingCost, SwitchedCost>(
      mod, "QuadraticCost",
      "l_k = 1/2 (x - r_k)' Q_k (x - r_k) + 1/2 u' R_k u + u' N_k (x - r_k) + rho_k, "
      "phi_k = 1/2 (x - s_k)' S_k (x - s_k) (phi_{K-1}: the terminal cost). Lists of K entries; "
      "S, r, s, rho, N (m x n_k cross terms) default to zero. Runs entirely in C++.")
      .def(py::init(&MakeQuadraticCost), py::arg("Q"), py::arg("R"), py::arg("S") = py::none(),
           py::arg("r") = py::none(), py::arg("s") = py::none(), py::arg("rho") = py::none(),
           py::arg("N") = py::none());

  py::class_<CallbackSystem, SwitchedSystem>(
      mod, "CallbackSystem",
      "A switched system given by Python callables: flow(k, x, u) -> xdot; reset(k, x) -> x+ "
      "(None: identity); optional flow_derivatives(k, x, u) -> (fx, fu), reset_derivative(k, x) "
      "-> gx, surface(k, x) -> h (s_k entries), surface_derivative(k, x) -> hx. Derivatives not "
      "given are central differences (ddoc's CentralDifferenceJacobian, step fd_step * max(1, "
      "|x_i|)).")
      .def(py::init<std::vector<int>, int, py::function, py::object, py::object, py::object,
                    std::vector<int>, py::object, py::object, bool, double>(),
           py::arg("state_dims"), py::arg("input_dim"), py::arg("flow"),
           py::arg("reset") = py::none(), py::arg("flow_derivatives") = py::none(),
           py::arg("reset_derivative") = py::none(),
           py::arg("surface_dims") = std::vector<int>(), py::arg("surface") = py::none(),
           py::arg("surface_derivative") = py::none(), py::arg("cycle_reset") = false,
           py::arg("fd_step") = 1e-6);

  py::class_<CallbackCost, SwitchedCost>(
      mod, "CallbackCost",
      "A cost given by Python callables: running(k, x, u) -> float, switching(k, x) -> float "
      "(None: 0); optional running_derivatives(k, x, u) -> (lx, lu, lxx, luu, lux) and "
      "switching_derivatives(k, x) -> (phix, phixx). Missing derivatives: gradient by central "
      "differences (fd_step), Hessian by central differences of that gradient (fd_hessian_step).")
      .def(py::init<py::function, py::object, py::object, py::object, double, double>(),
           py::arg("running"), py::arg("switching") = py::none(),
           py::arg("running_derivatives") = py::none(),
           py::arg("switching_derivatives") = py::none(), py::arg("fd_step") = 1e-6,
           py::arg("fd_hessian_step") = 1e-4);

  py::class_<Problem>(mod, "Problem",
                      "The problem (9)-(10): a system, its cost, bounds and surface weights w_k "
                      "(default zeros). Keeps system and cost alive.")
      .def(py::init([](const SwitchedSystem& system, const SwitchedCost& cost,
                       const Bounds& bounds, const py::object& weights) {
             Problem p;
             p.system = &system;
             p.cost = &cost;
             p.bounds = bounds;
             p.surface_weights = weights.is_none() ? Vector(Vector::Zero(system.num_modes()))
                                                   : AsVector(weights, "surface_weights");
             p.Validate();
             return p;
           }),
           py::arg("system"), py::arg("cost"), py::arg("bounds"),
           py::arg("surface_weights") = py::none(), py::keep_alive<1, 2>(),
           py::keep_alive<1, 3>())
      .def_readwrite("bounds", &Problem::bounds)
      .def_readwrite("surface_weights", &Problem::surface_weights)
      .def_property_readonly("num_modes", &Problem::num_modes)
      .def_property_readonly("input_dim", &Problem::input_dim)
      .def("validate", &Problem::Validate,
           "Raises ValueError naming the first problem found (sizes, bounds, weights).");

  py::enum_<BackwardEquation>(mod, "BackwardEquation")
      .value("LYAPUNOV", BackwardEquation::kLyapunov)
      .value("RICCATI", BackwardEquation::kRiccati);
  py::enum_<BackwardIntegrator>(mod, "BackwardIntegrator")
      .value("MIDPOINT", BackwardIntegrator::kMidpoint)
      .value("RK4", BackwardIntegrator::kRk4);
  py::class_<BackwardPassSettings>(mod, "BackwardPassSettings", "Settings of the backward pass (30).")
      .def(py::init<>())
      .def_readwrite("equation", &BackwardPassSettings::equation)
      .def_readwrite("integrator", &BackwardPassSettings::integrator)
      .def_readwrite("cyclic_value", &BackwardPassSettings::cyclic_value)
      .def_readwrite("terminal_event", &BackwardPassSettings::terminal_event)
      .def_readwrite("box_aware", &BackwardPassSettings::box_aware)
      .def_readwrite("time_curvature", &BackwardPassSettings::time_curvature)
      .def_readwrite("use_previous_du", &BackwardPassSettings::use_previous_du)
      .def_readwrite("psd_switching_hessians", &BackwardPassSettings::psd_switching_hessians)
      .def_readwrite("max_substeps", &BackwardPassSettings::max_substeps)
      .def_readwrite("min_substeps", &BackwardPassSettings::min_substeps);

  py::class_<SwitchingTimeSettings>(mod, "SwitchingTimeSettings", "Settings of the switching-time update (31).")
      .def(py::init<>())
      .def_readwrite("relative_regularization", &SwitchingTimeSettings::relative_regularization)
      .def_readwrite("max_duration_step", &SwitchingTimeSettings::max_duration_step);
  py::class_<OnlineControllerSettings>(mod, "OnlineControllerSettings", "Settings of the online law (33)-(34).")
      .def(py::init<>())
      .def_readwrite("interpolate", &OnlineControllerSettings::interpolate)
      .def_readwrite("warm_start", &OnlineControllerSettings::warm_start);

  py::enum_<Acceptance>(mod, "Acceptance")
      .value("SUFFICIENT_DECREASE", Acceptance::kSufficientDecrease)
      .value("PREDICTED_DECREASE", Acceptance::kPredictedDecrease);
  py::enum_<AlphaAfterAccept>(mod, "AlphaAfterAccept")
      .value("RESET", AlphaAfterAccept::kReset)
      .value("GROW", AlphaAfterAccept::kGrow)
      .value("RATIO", AlphaAfterAccept::kRatio);

  py::class_<LearnerSettings>(mod, "LearnerSettings",
                              "Settings of Learner (Algorithm 1). LearnerSettings() is the "
                              "'default' preset, LearnerSettings.paper() Algorithm 1 as printed.")
      .def(py::init<>())
      .def_static("paper", &LearnerSettings::Paper, "The 'paper' preset.")
      .def_static("preset", &PresetByName, py::arg("name"),
                  "The named preset: 'default' or 'paper' (ValueError otherwise).")
      .def_readwrite("acceptance", &LearnerSettings::acceptance)
      .def_readwrite("c", &LearnerSettings::c)
      .def_readwrite("gamma", &LearnerSettings::gamma)
      .def_readwrite("interpolate_backtracking", &LearnerSettings::interpolate_backtracking)
      .def_readwrite("alpha_initial", &LearnerSettings::alpha_initial)
      .def_readwrite("alpha_after_accept", &LearnerSettings::alpha_after_accept)
      .def_readwrite("alpha_min", &LearnerSettings::alpha_min)
      .def_readwrite("convergence_tolerance", &LearnerSettings::convergence_tolerance)
      .def_readwrite("step_convergence", &LearnerSettings::step_convergence)
      .def_readwrite("epsilon", &LearnerSettings::epsilon)
      .def_readwrite("delta_i", &LearnerSettings::delta_i)
      .def_readwrite("optimality_tolerance", &LearnerSettings::optimality_tolerance)
      .def_readwrite("regularization_min", &LearnerSettings::regularization_min)
      .def_readwrite("failure_raises", &LearnerSettings::failure_raises)
      .def_readwrite("curvature_scale_min", &LearnerSettings::curvature_scale_min)
      .def_readwrite("max_trials", &LearnerSettings::max_trials)
      .def_readwrite("max_samples", &LearnerSettings::max_samples)
      .def_readwrite("backward", &LearnerSettings::backward)
      .def_readwrite("switching", &LearnerSettings::switching)
      .def_readwrite("controller", &LearnerSettings::controller);

  py::class_<ModeTrajectory>(mod, "ModeTrajectory", "Samples of one mode: t (N,), x (n_k, N), u (m, N).")
      .def_readonly("t", &ModeTrajectory::t)
      .def_readonly("x", &ModeTrajectory::x)
      .def_readonly("u", &ModeTrajectory::u);
  py::class_<Trajectory>(mod, "Trajectory", "One trial: modes (list of ModeTrajectory), T (K,), x0.")
      .def(py::init(&MakeTrajectory), py::arg("t"), py::arg("x"), py::arg("u"),
           "A measured trial, per mode k: t[k] (N_k,) sample times from the trial's start, x[k] "
           "(n_k, N_k) states, u[k] (m, N_k) applied inputs; T(k) = t[k][-1], x0 = x[0][:, 0]. "
           "What Plant.run returns. Checked by Trajectory::Validate (ValueError).")
      .def_readonly("modes", &Trajectory::modes)
      .def_readonly("T", &Trajectory::T)
      .def_readonly("x0", &Trajectory::x0);

  py::class_<PolicyView, std::shared_ptr<PolicyView>>(
      mod, "Policy", "The law of one trial, given to Plant.run (valid only during that call).")
      .def("begin_trial", [](const PolicyView& p) { p.Get().BeginTrial(); },
           "Call once at the start of the trial (resets per-trial state).")
      .def("planned_duration", [](const PolicyView& p, int k) { return p.Get().PlannedDuration(k); },
           py::arg("k"), "The planned duration D_k of mode k (s).")
      .def(
          "step",
          [](const PolicyView& p, int k, double t_since_mode_start, const py::object& x) {
            Policy& policy = p.Get();
            const Vector xv = AsVector(x, "x");
            Vector u = Vector::Zero(p.input_dim);
            policy.Step(k, t_since_mode_start, xv, u);
            return ToArray(u);
          },
          py::arg("k"), py::arg("t_since_mode_start"), py::arg("x"),
          "u (m,) = the policy at mode k, time since the mode's start, measured state x (n_k,).")
      .def_readonly("input_dim", &PolicyView::input_dim);
  py::class_<Plant, PyPlant>(mod, "Plant",
                             "Runs one trial of a policy (Algorithm 1's 'system'). Subclass it in "
                             "Python and define run(x0, policy) -> Trajectory: call "
                             "policy.begin_trial(), then u = policy.step(k, t, x) each control "
                             "step, end mode k by policy.planned_duration(k) or a surface, and "
                             "return what was measured. Pass it as Learner.solve(plant=...).")
      .def(py::init<>())
      .def(
          "run",
          [](Plant& plant, const py::object& x0, const PolicyView& policy) {
            Trajectory out;
            plant.Run(AsVector(x0, "x0"), policy.Get(), &out);
            return out;
          },
          py::arg("x0"), py::arg("policy"), "Runs one trial from x0 with policy; the Trajectory.");
  py::class_<ModelPlant, Plant>(mod, "ModelPlant",
                                "The engine's plant: RK4 of a System at step dt with "
                                "zero-order-hold inputs and event detection (ddoc::ModelPlant).")
      .def(py::init([](const SwitchedSystem& system, const Bounds& bounds, double dt) {
             ModelPlantSettings settings;
             settings.dt = dt;
             return std::make_unique<ModelPlant>(system, bounds, settings);
           }),
           py::arg("system"), py::arg("bounds"), py::arg("dt") = 1e-3, py::keep_alive<1, 2>());

  py::class_<PySolveResult>(mod, "SolveResult", "Result of Learner.solve (NumPy arrays).")
      .def_property_readonly("status", [](const PySolveResult& r) { return LearnerStatusName(r.result.status); },
                             "'converged', 'line_search_failed' or 'max_trials'")
      .def_property_readonly("trials", [](const PySolveResult& r) { return r.result.trials; })
      .def_property_readonly("iterations", [](const PySolveResult& r) { return r.result.iterations; })
      .def_property_readonly("cost", [](const PySolveResult& r) { return r.result.cost; })
      .def_property_readonly("T", [](const PySolveResult& r) { return VectorToArray(r.result.T); })
      .def_property_readonly("optimality", [](const PySolveResult& r) { return r.result.optimality.total; })
      .def_property_readonly("optimality_inputs", [](const PySolveResult& r) { return r.result.optimality.inputs; })
      .def_property_readonly("optimality_times", [](const PySolveResult& r) { return r.result.optimality.times; })
      .def_property_readonly("cost_history", [](const PySolveResult& r) {
        return VectorToArray(Eigen::Map<const Vector>(r.result.cost_history.data(),
                                                      static_cast<Eigen::Index>(r.result.cost_history.size())));
      }, "cost of the nominal after each accepted trial, the initial one first")
      .def_property_readonly("stop_reason", [](const PySolveResult& r) { return r.result.stop_reason; },
                             "why it stopped, with the figures of the deciding test")
      .def_readonly("interrupted", &PySolveResult::interrupted)
      .def("__repr__", [](const PySolveResult& r) {
        std::ostringstream s;
        s << "SolveResult(status='" << LearnerStatusName(r.result.status) << "', trials=" << r.result.trials
          << ", iterations=" << r.result.iterations << ", cost=" << r.result.cost << ")";
        return s.str();
      });

  py::class_<PyLearner>(mod, "Learner", "Algorithm 1 on a Problem (kept alive by the learner).")
      .def(py::init<const Problem&, const LearnerSettings&>(), py::arg("problem"),
           py::arg("settings") = LearnerSettings{}, py::keep_alive<1, 2>())
      .def(
          "solve",
          [](PyLearner& self, const py::object& x0, const py::object& durations,
             const py::object& u0, const py::object& plant, const std::string& method,
             double dt, const py::object& progress) {
            return self.Solve(x0, durations, u0, plant, method, dt, progress);
          },
          py::arg("x0"), py::arg("durations"), py::arg("u0") = py::none(),
          py::arg("plant") = py::none(), py::arg("method") = "alg1", py::arg("dt") = 1e-3,
          py::arg("progress") = py::none(),
          R"(Batch Algorithm 1 from x0 with the initial law u^0, T^0.

x0: initial state (n_0,). durations: planned mode durations of T^0 (K,).
u0: None (zeros), a constant input (m,), or a callable u0(k, tau, x) -> (m,), tau the
normalized time k + t/D_k. plant: None (the model is the plant), another System run as the
real plant by a ModelPlant (model error), or a Plant (a ddoc.Plant subclass written in Python, or
a ddoc.ModelPlant). method: 'alg1' (directions and costs from the plant) or 'mrl'
(directions from the model, costs from the plant). dt: RK4 step of the ModelPlant(s).
progress: optional callable(dict) after each trial. The GIL is released during each trial;
Ctrl-C raises ddoc.SolveInterrupted (a KeyboardInterrupt) whose .result is the partial result.)")
      .def_property_readonly("nominal", [](const PyLearner& l) { return l.learner().nominal(); },
                             "The current nominal trajectory (a copy).")
      .def_property_readonly("status", [](const PyLearner& l) { return LearnerStatusName(l.learner().status()); })
      .def_property_readonly("trials", [](const PyLearner& l) { return l.learner().trials(); })
      .def_property_readonly("iteration", [](const PyLearner& l) { return l.learner().iteration(); })
      .def_property_readonly("settings", [](const PyLearner& l) { return l.learner().settings(); })
      .def(
          "feedback_law",
          [](const PyLearner& l, double alpha) {
            if (!l.learner().initialized()) {
              throw InvalidArgument("feedback_law: no nominal yet (call solve first)");
            }
            py::list modes;
            for (const ModeFeedbackLaw& mode : l.learner().FeedbackLaw(alpha)) {
              const auto N = static_cast<py::ssize_t>(mode.t.size());
              const auto m = static_cast<py::ssize_t>(mode.u.rows());
              const auto n = static_cast<py::ssize_t>(mode.x.rows());
              py::array_t<double> K({N, m, n});
              auto k = K.mutable_unchecked<3>();
              for (py::ssize_t j = 0; j < N; ++j) {
                for (py::ssize_t i = 0; i < m; ++i) {
                  for (py::ssize_t c = 0; c < n; ++c) k(j, i, c) = mode.K[j](i, c);
                }
              }
              py::dict d;
              d["t"] = VectorToArray(mode.t);
              d["x"] = py::cast(Matrix(mode.x.transpose()));
              d["u"] = py::cast(Matrix(mode.u.transpose()));
              d["u_ff"] = py::cast(Matrix(mode.u_ff.transpose()));
              d["K"] = K;
              modes.append(d);
            }
            return modes;
          },
          py::arg("alpha") = 1.0,
          R"(The converged nominal's feedback law in physical time, one dict per mode: t (N,),
x (N, n), u (N, m), u_ff (N, m) and K (N, m, n), with u(t) = u_ff(t) + K(t) x(t) =
u(t)_nominal + K(t) (x - x_nominal) + the remaining feed-forward step (~0 at convergence);
K = -H^-1 (L_ux + F_u' P), for an LQ problem the continuous-time LQR gain -R^-1 (B'S + N).
alpha: that of Learner::ConvergedPolicy (1: what OC-FB applies; 0: no feed-forward step).)");
}
