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

/// A callable of mode k as messages name it, "flow_batch(k=0)"; the string is built only for a
/// message (the per-point callables run ~10^5 times a solve).
struct Callee {
  const char* what;
  int k;
  Eigen::Index points = -1;  ///< a batch call's N (-1: a per-point callable)
  std::string str() const { return Indexed(what, k); }
};

/// fn(k, a[, b]), the GIL held (a vectorcall: no argument tuple). An exception raised in it
/// propagates unchanged, with the note "raised in ddoc's call of flow_batch(k=0) with N points"
/// (PEP 678, shown under the traceback) naming the callable.
py::object Call(const py::object& fn, const Callee& callee, py::handle a,
                py::handle b = py::handle()) {
  const py::int_ k(callee.k);
  // Own references for the call: a nested call of the same callable (from a C function that
  // borrows its arguments) then sees a reused ArgumentArray as taken.
  const py::object hold_a = py::reinterpret_borrow<py::object>(a);
  const py::object hold_b = py::reinterpret_borrow<py::object>(b);
  PyObject* argv[3] = {k.ptr(), a.ptr(), b.ptr()};
  PyObject* r = PyObject_Vectorcall(fn.ptr(), argv, b ? 3 : 2, nullptr);
  if (r == nullptr) {
    py::error_already_set e;
    const py::object value = e.value();
    if (value && py::hasattr(value, "add_note")) {
      std::string note = "raised in ddoc's call of " + callee.str();
      if (callee.points >= 0) note += " with " + std::to_string(callee.points) + " points";
      value.attr("add_note")(note);
    }
    throw e;
  }
  return py::reinterpret_steal<py::object>(r);
}

/// The (n,) float64 array that passes x to a per-point callable, reused from call to call only
/// while Python keeps no reference to it: after a call that stored x (or a view of it), its
/// reference count is above 1 and the next call gets a new array, so an array the user kept
/// never changes. Saves two NumPy allocations a call (~0.2 us of ~0.3 us of overhead). Use
/// with the GIL held.
class ArgumentArray {
 public:
  py::handle Fill(const ConstVectorRef& v) {
    PyObject* a = array_.ptr();
    if (a == nullptr || Py_REFCNT(a) != 1 || !Reusable(a, v.size())) {
      array_ = py::array_t<double>(v.size());
      a = array_.ptr();
    }
    std::copy(v.data(), v.data() + v.size(),
              reinterpret_cast<double*>(py::detail::array_proxy(a)->data));
    return array_;
  }
  void Clear() { array_ = py::object(); }

 private:
  // Still an owning, writeable, contiguous (n,) float64 array (a callable may have changed
  // its shape, dtype or flags in place before dropping it).
  static bool Reusable(PyObject* a, Eigen::Index n) {
    const auto* p = py::detail::array_proxy(a);
    using api = py::detail::npy_api;
    const int flags = api::NPY_ARRAY_C_CONTIGUOUS_ | api::NPY_ARRAY_OWNDATA_ |
                      api::NPY_ARRAY_WRITEABLE_;
    return p->nd == 1 && p->dimensions[0] == n && (p->flags & flags) == flags &&
           py::detail::array_descriptor_proxy(p->descr)->type_num == api::NPY_DOUBLE_ &&
           py::detail::array_descriptor_proxy(p->descr)->byteorder != '>';
  }
  py::object array_;
};

/// A per-point callable's result of `size` floats into `out`: a list or tuple of floats and a
/// 1-D float64 array are read directly, anything else through AsVector (with its messages).
void ReadVector(const py::handle& obj, const Callee& callee, Eigen::Index size, VectorRef out) {
  PyObject* o = obj.ptr();
  if ((PyList_CheckExact(o) || PyTuple_CheckExact(o)) && PySequence_Fast_GET_SIZE(o) == size) {
    PyObject** items = PySequence_Fast_ITEMS(o);
    Eigen::Index i = 0;
    for (; i < size && PyFloat_Check(items[i]); ++i) out(i) = PyFloat_AsDouble(items[i]);
    if (i == size) return;
  } else if (py::isinstance<py::array_t<double>>(obj)) {
    const auto a = py::reinterpret_borrow<py::array_t<double>>(obj);
    if (a.ndim() == 1 && a.shape(0) == size) {
      const auto r = a.unchecked<1>();
      for (Eigen::Index i = 0; i < size; ++i) out(i) = r(i);
      return;
    }
  }
  out = AsVector(obj, callee.str() + " returned", size);
}

/// The N points X.col(j) (n x N, any stride) as an (N, n) float64 array, row j = point j.
py::array_t<double> PointsToArray(const ConstMatrixRef& X) {
  py::array_t<double> a(std::vector<py::ssize_t>{X.cols(), X.rows()});
  double* out = a.mutable_data();
  for (Eigen::Index j = 0; j < X.cols(); ++j) {
    std::copy(X.col(j).data(), X.col(j).data() + X.rows(), out + j * X.rows());
  }
  return a;
}

/// One part of what a batch callable returned, as it must look: `ndim` 1 (N,), 2 (N, rows) or 3
/// (N, rows, cols); `legend` names the axes in messages, e.g. "(N, n_k, m)".
struct BatchPart {
  const char* name;  ///< "" for a callable returning one array, else "FX", "lu", ...
  int ndim;
  Eigen::Index rows, cols;
  const char* legend;
};

std::string PointString(const ConstMatrixRef& X, Eigen::Index j) {
  std::ostringstream s;
  s << "[";
  for (Eigen::Index i = 0; i < X.rows(); ++i) s << (i ? ", " : "") << X(i, j);
  s << "]";
  return s.str();
}

/// Reads part `p` of what the batch callable `callee` returned at the N points (X, U) into
/// `out`: 1 x N for ndim 1, rows x N for ndim 2 (column j = point j), rows x (cols N) for ndim 3
/// (block j, columns j cols .., = point j's matrix). Errors name the callable, the part, a wrong
/// type or dtype, both shapes, and the first non-finite entry with its point's x and u.
void ReadBatch(const py::handle& obj, const Callee& callee, const BatchPart& p,
               const ConstMatrixRef& X, const ConstMatrixRef& U, MatrixRef out) {
  const Eigen::Index N = X.cols();
  const std::string name =
      callee.str() + " returned" + (p.name[0] != '\0' ? std::string(" ") + p.name : "");
  if (!py::isinstance<py::array>(obj) && !py::isinstance<py::list>(obj) &&
      !py::isinstance<py::tuple>(obj)) {
    throw InvalidArgument(name + ": expected an array of shape " + p.legend + ", got " +
                          std::string(py::str(py::type::handle_of(obj).attr("__name__"))));
  }
  const py::array any = py::array::ensure(obj);
  if (!any) throw InvalidArgument(name + ": not convertible to an array of floats");
  const char kind = any.dtype().kind();
  if (kind != 'f' && kind != 'i' && kind != 'u') {
    throw InvalidArgument(name + ": dtype " + std::string(py::str(any.dtype())) +
                          ", expected real numbers (float64)");
  }
  std::vector<py::ssize_t> expected{N};
  if (p.ndim >= 2) expected.push_back(p.rows);
  if (p.ndim == 3) expected.push_back(p.cols);
  bool same = any.ndim() == p.ndim;
  for (int d = 0; same && d < p.ndim; ++d) same = any.shape(d) == expected[d];
  if (!same) {
    std::ostringstream e;
    e << "(";
    for (size_t d = 0; d < expected.size(); ++d) e << (d ? ", " : "") << expected[d];
    e << (expected.size() == 1 ? ",)" : ")");
    throw InvalidArgument(name + ": shape " + ShapeString(any) + ", expected " + e.str() + " " +
                          p.legend + " for " + std::to_string(N) + " points");
  }
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(any);
  const double* v = a.data();
  const Eigen::Index rows = p.ndim >= 2 ? p.rows : 1, cols = p.ndim == 3 ? p.cols : 1;
  for (Eigen::Index j = 0; j < N; ++j) {
    for (Eigen::Index r = 0; r < rows; ++r) {
      for (Eigen::Index c = 0; c < cols; ++c) {
        const double x = v[(j * rows + r) * cols + c];
        if (!std::isfinite(x)) {
          std::ostringstream s;
          s << name << ": non-finite value " << x << " at [" << j;
          if (p.ndim >= 2) s << ", " << r;
          if (p.ndim == 3) s << ", " << c;
          s << "], point " << j << " of " << N << " (x = " << PointString(X, j)
            << ", u = " << PointString(U, j) << ")";
          throw InvalidArgument(s.str());
        }
        out(r, j * cols + c) = x;
      }
    }
  }
}

/// The tuple (or list) of `parts` parts a batch callable returned.
py::sequence BatchTuple(const py::object& obj, const Callee& callee, size_t parts,
                        const char* names) {
  if ((!py::isinstance<py::tuple>(obj) && !py::isinstance<py::list>(obj)) ||
      py::len(obj) != parts) {
    const std::string got = py::isinstance<py::tuple>(obj) || py::isinstance<py::list>(obj)
                                ? "a sequence of length " + std::to_string(py::len(obj))
                                : std::string(py::str(py::type::handle_of(obj).attr("__name__")));
    throw InvalidArgument(callee.str() + " returned " + got + ", expected a tuple " + names);
  }
  return py::reinterpret_borrow<py::sequence>(obj);
}

/// `fn` if it is None or callable, else InvalidArgument naming the argument.
py::object Callable(py::object fn, const char* name) {
  if (!fn.is_none() && !PyCallable_Check(fn.ptr())) {
    throw InvalidArgument(std::string(name) + ": expected a callable or None, got " +
                          std::string(py::str(py::type::handle_of(fn).attr("__name__"))));
  }
  return fn;
}

/// Z = [X; U] (n + m x N), the points the finite differences perturb.
Matrix Stacked(const ConstMatrixRef& X, const ConstMatrixRef& U) {
  Matrix Z(X.rows() + U.rows(), X.cols());
  Z.topRows(X.rows()) = X;
  Z.bottomRows(U.rows()) = U;
  return Z;
}

/// A one-point batch (n x 1) of the contiguous vector x.
Eigen::Map<const Matrix> OnePoint(const ConstVectorRef& x) {
  return Eigen::Map<const Matrix>(x.data(), x.size(), 1);
}

/// X (N, n) and U (N, m) given to a batch method as the engine's n x N and m x N points
/// (n, m: -1 = any).
std::pair<Matrix, Matrix> PointsFromArrays(const py::object& X, const py::object& U,
                                           Eigen::Index n, Eigen::Index m) {
  Matrix x = AsMatrix(X, "X", -1, n).transpose();
  Matrix u = AsMatrix(U, "U", x.cols(), m).transpose();
  return {std::move(x), std::move(u)};
}

/// The N blocks rows x cols of M (rows x cols N) as an (N, rows, cols) array.
py::array_t<double> BlocksToArray(const ConstMatrixRef& M, Eigen::Index N, Eigen::Index rows,
                                  Eigen::Index cols) {
  py::array_t<double> a(std::vector<py::ssize_t>{N, rows, cols});
  auto w = a.mutable_unchecked<3>();
  for (Eigen::Index j = 0; j < N; ++j) {
    for (Eigen::Index r = 0; r < rows; ++r) {
      for (Eigen::Index c = 0; c < cols; ++c) w(j, r, c) = M(r, j * cols + c);
    }
  }
  return a;
}

/// A SwitchedSystem whose parts are Python callables (called with the GIL held). The flow is
/// given per point (flow, flow_derivatives), batched over the points of a mode (flow_batch,
/// flow_derivatives_batch: (N, n_k) arrays in and out), or both; with a batch callable the
/// system prefers_batch(), so the backward pass calls it once per mode and Run. The simulation
/// calls the flow per point (flow_batch with N = 1 when no flow is given).
class CallbackSystem : public SwitchedSystem {
 public:
  CallbackSystem(std::vector<int> state_dims, int input_dim, py::object flow, py::object reset,
                 py::object flow_derivatives, py::object reset_derivative,
                 std::vector<int> surface_dims, py::object surface, py::object surface_derivative,
                 bool cycle_reset, double fd_step, py::object flow_batch,
                 py::object flow_derivatives_batch)
      : SwitchedSystem(state_dims, input_dim, surface_dims, cycle_reset),
        flow_(Callable(std::move(flow), "flow")), reset_(Callable(std::move(reset), "reset")),
        flow_derivatives_(Callable(std::move(flow_derivatives), "flow_derivatives")),
        reset_derivative_(Callable(std::move(reset_derivative), "reset_derivative")),
        surface_(Callable(std::move(surface), "surface")),
        surface_derivative_(Callable(std::move(surface_derivative), "surface_derivative")),
        flow_batch_(Callable(std::move(flow_batch), "flow_batch")),
        flow_derivatives_batch_(
            Callable(std::move(flow_derivatives_batch), "flow_derivatives_batch")),
        fd_step_(fd_step) {
    if (!(fd_step > 0) || !std::isfinite(fd_step)) {
      throw InvalidArgument("fd_step: " + std::to_string(fd_step) + ", expected finite and > 0");
    }
    if (flow_.is_none() && flow_batch_.is_none()) {
      throw InvalidArgument(
          "flow: give flow(k, x, u) -> xdot or flow_batch(k, X, U) -> Xdot (or both)");
    }
    bool has_surface = false;
    for (int s : surface_dims) has_surface = has_surface || s > 0;
    if (has_surface && surface_.is_none()) {
      throw InvalidArgument("surface: required when surface_dims has a positive entry");
    }
  }

  ~CallbackSystem() override {
    py::gil_scoped_acquire gil;
    flow_ = reset_ = flow_derivatives_ = reset_derivative_ = surface_ = surface_derivative_ =
        flow_batch_ = flow_derivatives_batch_ = py::object();
    x_arg_.Clear();
    u_arg_.Clear();
  }

  bool prefers_batch() const override {
    return !flow_batch_.is_none() || !flow_derivatives_batch_.is_none();
  }

 protected:
  int NextDim(int k) const { return state_dim((k + 1) % num_modes()); }

  void DoFlow(int k, const ConstVectorRef& x, const ConstVectorRef& u,
              VectorRef xdot) const override {
    if (flow_.is_none()) {
      Eigen::Map<Matrix> out(xdot.data(), xdot.size(), 1);
      FlowBatchCall(k, OnePoint(x), OnePoint(u), out);
      return;
    }
    py::gil_scoped_acquire gil;
    const Callee c{"flow", k};
    ReadVector(Call(flow_, c, x_arg_.Fill(x), u_arg_.Fill(u)), c, state_dim(k), xdot);
  }
  void DoFlowDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u, MatrixRef fx,
                         MatrixRef fu) const override {
    if (!flow_derivatives_.is_none()) {
      py::gil_scoped_acquire gil;
      const Callee c{"flow_derivatives", k};
      const py::tuple r = Call(flow_derivatives_, c, x_arg_.Fill(x), u_arg_.Fill(u));
      if (r.size() != 2) throw InvalidArgument(c.str() + ": expected (fx, fu)");
      fx = AsMatrix(r[0], c.str() + " fx", state_dim(k), state_dim(k));
      fu = AsMatrix(r[1], c.str() + " fu", state_dim(k), input_dim());
      return;
    }
    DoFlowDerivativesBatch(k, OnePoint(x), OnePoint(u), fx, fu);  // a batch of one point
  }
  void DoFlowBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                   MatrixRef F) const override {
    if (flow_batch_.is_none()) return SwitchedSystem::DoFlowBatch(k, X, U, F);
    FlowBatchCall(k, X, U, F);
  }
  void DoFlowDerivativesBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                              MatrixRef FX, MatrixRef FU) const override {
    const Eigen::Index n = X.rows(), m = U.rows(), N = X.cols();
    if (!flow_derivatives_batch_.is_none()) {
      py::gil_scoped_acquire gil;
      const Callee c{"flow_derivatives_batch", k, N};
      const py::sequence r = BatchTuple(
          Call(flow_derivatives_batch_, c, PointsToArray(X), PointsToArray(U)), c,
          2, "(FX, FU)");
      ReadBatch(r[0], c, {"FX", 3, n, n, "(N, n_k, n_k)"}, X, U, FX);
      ReadBatch(r[1], c, {"FU", 3, n, m, "(N, n_k, m)"}, X, U, FU);
      return;
    }
    if (!flow_derivatives_.is_none()) {  // exact per point
      return SwitchedSystem::DoFlowDerivativesBatch(k, X, U, FX, FU);
    }
    // Central differences of the flow in z = [x; u] (CentralDifferenceJacobian's points and
    // quotients), the perturbed points of all N points evaluated together: one flow_batch
    // call, or flow per point.
    const Matrix Z = Stacked(X, U);
    const Matrix P = CentralDifferencePoints(Z, fd_step_);
    Matrix V(n, P.cols());
    if (!flow_batch_.is_none()) {
      FlowBatchCall(k, P.topRows(n), P.bottomRows(m), V);
    } else {
      for (Eigen::Index j = 0; j < P.cols(); ++j) {
        DoFlow(k, P.col(j).head(n), P.col(j).tail(m), V.col(j));
      }
    }
    const Matrix J = CentralDifferenceQuotients(Z, V, fd_step_);
    for (Eigen::Index j = 0; j < N; ++j) {
      FX.middleCols(j * n, n) = J.middleCols(j * (n + m), n);
      FU.middleCols(j * m, m) = J.middleCols(j * (n + m) + n, m);
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
    const Callee c{"reset", k};
    ReadVector(Call(reset_, c, x_arg_.Fill(x)), c, NextDim(k), x_next);
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
      const Callee c{"reset_derivative", k};
      gx = AsMatrix(Call(reset_derivative_, c, x_arg_.Fill(x)), c.str() + " returned",
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
    const Callee c{"surface", k};
    ReadVector(Call(surface_, c, x_arg_.Fill(x)), c, surface_dim(k), h);
  }
  void DoSurfaceDerivative(int k, const ConstVectorRef& x, MatrixRef hx) const override {
    if (!surface_derivative_.is_none()) {
      py::gil_scoped_acquire gil;
      const Callee c{"surface_derivative", k};
      hx = AsMatrix(Call(surface_derivative_, c, x_arg_.Fill(x)), c.str() + " returned",
                    surface_dim(k), state_dim(k));
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
  // flow_batch at the N points (X, U) into F (n_k x N).
  void FlowBatchCall(int k, const ConstMatrixRef& X, const ConstMatrixRef& U, MatrixRef F) const {
    py::gil_scoped_acquire gil;
    const Callee c{"flow_batch", k, X.cols()};
    const py::object r = Call(flow_batch_, c, PointsToArray(X), PointsToArray(U));
    ReadBatch(r, c, {"", 2, X.rows(), 1, "(N, n_k)"}, X, U, F);
  }

  py::object flow_, reset_, flow_derivatives_, reset_derivative_, surface_, surface_derivative_;
  py::object flow_batch_, flow_derivatives_batch_;
  mutable ArgumentArray x_arg_, u_arg_;  // the x and u of the per-point callables
  double fd_step_;
};

/// A SwitchedCost whose parts are Python callables. The running cost per point (running,
/// running_derivatives), batched (running_batch, running_derivatives_batch), or both; with a
/// batch callable the cost prefers_batch() (the backward pass and EvaluateCost call it once per
/// mode). Missing derivatives: the gradient by central differences of the value (step fd_step),
/// the Hessian by central differences of that gradient (step fd_hessian_step), symmetrized;
/// with running_batch only, all of a mode's perturbed points in one call.
class CallbackCost : public SwitchedCost {
 public:
  CallbackCost(py::object running, py::object switching, py::object running_derivatives,
               py::object switching_derivatives, double fd_step, double fd_hessian_step,
               py::object running_batch, py::object running_derivatives_batch)
      : running_(Callable(std::move(running), "running")),
        switching_(Callable(std::move(switching), "switching")),
        running_derivatives_(Callable(std::move(running_derivatives), "running_derivatives")),
        switching_derivatives_(
            Callable(std::move(switching_derivatives), "switching_derivatives")),
        running_batch_(Callable(std::move(running_batch), "running_batch")),
        running_derivatives_batch_(
            Callable(std::move(running_derivatives_batch), "running_derivatives_batch")),
        fd_step_(fd_step), fd_hessian_step_(fd_hessian_step) {
    for (double h : {fd_step, fd_hessian_step}) {
      if (!(h > 0) || !std::isfinite(h)) {
        throw InvalidArgument("fd_step / fd_hessian_step: " + std::to_string(h) +
                              ", expected finite and > 0");
      }
    }
    if (running_.is_none() && running_batch_.is_none()) {
      throw InvalidArgument(
          "running: give running(k, x, u) -> float or running_batch(k, X, U) -> l (or both)");
    }
  }
  ~CallbackCost() override {
    py::gil_scoped_acquire gil;
    running_ = switching_ = running_derivatives_ = switching_derivatives_ = running_batch_ =
        running_derivatives_batch_ = py::object();
    x_arg_.Clear();
    u_arg_.Clear();
  }

  bool prefers_batch() const override {
    return !running_batch_.is_none() || !running_derivatives_batch_.is_none();
  }

 protected:
  double DoRunning(int k, const ConstVectorRef& x, const ConstVectorRef& u) const override {
    if (running_.is_none()) {
      double l = 0;
      Eigen::Map<Vector> out(&l, 1);
      RunningBatchCall(k, OnePoint(x), OnePoint(u), out);
      return l;
    }
    py::gil_scoped_acquire gil;
    const Callee c{"running", k};
    return AsFloat(Call(running_, c, x_arg_.Fill(x), u_arg_.Fill(u)), c.str() + " returned");
  }
  void DoRunningDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u, VectorRef lx,
                            VectorRef lu, MatrixRef lxx, MatrixRef luu,
                            MatrixRef lux) const override {
    const auto n = x.size(), m = u.size();
    if (!running_derivatives_.is_none()) {
      py::gil_scoped_acquire gil;
      const Callee c{"running_derivatives", k};
      const std::string name = c.str();
      const py::tuple r = Call(running_derivatives_, c, x_arg_.Fill(x), u_arg_.Fill(u));
      if (r.size() != 5) throw InvalidArgument(name + ": expected (lx, lu, lxx, luu, lux)");
      lx = AsVector(r[0], name + " lx", n);
      lu = AsVector(r[1], name + " lu", m);
      lxx = AsMatrix(r[2], name + " lxx", n, n);
      luu = AsMatrix(r[3], name + " luu", m, m);
      lux = AsMatrix(r[4], name + " lux", m, n);
      return;
    }
    Eigen::Map<Matrix> LX(lx.data(), n, 1), LU(lu.data(), m, 1);  // a batch of one point
    DoRunningDerivativesBatch(k, OnePoint(x), OnePoint(u), LX, LU, lxx, luu, lux);
  }
  void DoRunningBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                      VectorRef l) const override {
    if (running_batch_.is_none()) return SwitchedCost::DoRunningBatch(k, X, U, l);
    RunningBatchCall(k, X, U, l);
  }
  void DoRunningDerivativesBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                                 MatrixRef LX, MatrixRef LU, MatrixRef LXX, MatrixRef LUU,
                                 MatrixRef LUX) const override {
    const Eigen::Index n = X.rows(), m = U.rows(), N = X.cols(), r = n + m;
    if (!running_derivatives_batch_.is_none()) {
      py::gil_scoped_acquire gil;
      const Callee c{"running_derivatives_batch", k, N};
      const py::sequence out = BatchTuple(
          Call(running_derivatives_batch_, c, PointsToArray(X), PointsToArray(U)),
          c, 5, "(LX, LU, LXX, LUU, LUX)");
      ReadBatch(out[0], c, {"LX", 2, n, 1, "(N, n_k)"}, X, U, LX);
      ReadBatch(out[1], c, {"LU", 2, m, 1, "(N, m)"}, X, U, LU);
      ReadBatch(out[2], c, {"LXX", 3, n, n, "(N, n_k, n_k)"}, X, U, LXX);
      ReadBatch(out[3], c, {"LUU", 3, m, m, "(N, m, m)"}, X, U, LUU);
      ReadBatch(out[4], c, {"LUX", 3, m, n, "(N, m, n_k)"}, X, U, LUX);
      return;
    }
    if (!running_derivatives_.is_none()) {  // exact per point
      return SwitchedCost::DoRunningDerivativesBatch(k, X, U, LX, LU, LXX, LUU, LUX);
    }
    // Central differences (CentralDifferenceJacobian's points and quotients): the gradient of
    // the value at z = [x; u] (points P1) and, for the Hessian, the gradient at the points Zh
    // (points P2), all of them evaluated together: one running_batch call, or running per point.
    const Matrix Z = Stacked(X, U);
    const Matrix P1 = CentralDifferencePoints(Z, fd_step_);
    const Matrix Zh = CentralDifferencePoints(Z, fd_hessian_step_);
    const Matrix P2 = CentralDifferencePoints(Zh, fd_step_);
    Matrix P(r, P1.cols() + P2.cols());
    P << P1, P2;
    Vector v(P.cols());
    if (!running_batch_.is_none()) {
      RunningBatchCall(k, P.topRows(n), P.bottomRows(m), v);
    } else {
      for (Eigen::Index j = 0; j < P.cols(); ++j) {
        v(j) = DoRunning(k, P.col(j).head(n), P.col(j).tail(m));
      }
    }
    const Matrix g = CentralDifferenceQuotients(Z, v.head(P1.cols()).transpose(), fd_step_);
    const Matrix G = CentralDifferenceQuotients(Zh, v.tail(P2.cols()).transpose(), fd_step_);
    // G (1 x r 2rN) holds the gradient at Zh.col(c) in columns c r ..: an r x 2rN matrix.
    const Matrix H = CentralDifferenceQuotients(
        Z, Eigen::Map<const Matrix>(G.data(), r, Zh.cols()), fd_hessian_step_);
    Matrix Hj(r, r);
    for (Eigen::Index j = 0; j < N; ++j) {
      Hj = H.middleCols(j * r, r);
      Hj = 0.5 * (Hj + Hj.transpose()).eval();
      LX.col(j) = g.middleCols(j * r, n).transpose();
      LU.col(j) = g.middleCols(j * r + n, m).transpose();
      LXX.middleCols(j * n, n) = Hj.topLeftCorner(n, n);
      LUU.middleCols(j * m, m) = Hj.bottomRightCorner(m, m);
      LUX.middleCols(j * n, n) = Hj.bottomLeftCorner(m, n);
    }
  }
  double DoSwitching(int k, const ConstVectorRef& x) const override {
    if (switching_.is_none()) return 0.0;
    py::gil_scoped_acquire gil;
    const Callee c{"switching", k};
    return AsFloat(Call(switching_, c, x_arg_.Fill(x)), c.str() + " returned");
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
      const Callee c{"switching_derivatives", k};
      const std::string name = c.str();
      const py::tuple r = Call(switching_derivatives_, c, x_arg_.Fill(x));
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
  // running_batch at the N points (X, U) into l (N).
  void RunningBatchCall(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                        VectorRef l) const {
    py::gil_scoped_acquire gil;
    const Callee c{"running_batch", k, X.cols()};
    const py::object r = Call(running_batch_, c, PointsToArray(X), PointsToArray(U));
    Eigen::Map<Matrix> out(l.data(), 1, l.size());
    ReadBatch(r, c, {"", 1, 1, 1, "(N,)"}, X, U, out);
  }

  py::object running_, switching_, running_derivatives_, switching_derivatives_;
  py::object running_batch_, running_derivatives_batch_;
  mutable ArgumentArray x_arg_, u_arg_;  // the x and u of the per-point callables
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
    // A ModelPlant of a CallbackSystem spends its run in the flow's Python calls (four per RK4
    // step): it runs with the GIL held instead of taking it for each call (~70 ns of ~130 ns of
    // a call's overhead); the learner's C++ work between runs goes on without the GIL.
    const auto python_model = [&](const Plant& plant) {
      const SwitchedSystem* s = &plant == &model ? problem.system
                                : &plant == real.get() ? plant_system : nullptr;
      return dynamic_cast<const CallbackSystem*>(s) != nullptr;
    };
    const auto run = [&](Plant& plant, Policy& policy, Trajectory* out) {
      if (!python_model(plant)) return plant.Run(x0, policy, out);
      py::gil_scoped_acquire gil;
      plant.Run(x0, policy, out);
    };
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
        run(cost_plant, initial_policy, &measured);
        if (same) {
          learner.ReserveSamples(measured.total_samples());
          learner.Initialize(measured);
        } else {
          run(direction_plant, initial_policy, &direction);
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
          run(cost_plant, policy, &measured);
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
          py::arg("k"), py::arg("x"), "x+ = g_k(x).")
      .def_property_readonly("prefers_batch", &SwitchedSystem::prefers_batch,
                             "True when the backward pass evaluates the flow once per mode "
                             "(a CallbackSystem with a batch callable).")
      .def(
          "flow_batch",
          [](const SwitchedSystem& s, int k, const py::object& X, const py::object& U) {
            if (k < 0 || k >= s.num_modes()) throw InvalidArgument("k: out of range");
            const auto [x, u] = PointsFromArrays(X, U, s.state_dim(k), s.input_dim());
            Matrix F(x.rows(), x.cols());
            s.FlowBatch(k, x, u, F);
            return Matrix(F.transpose());
          },
          py::arg("k"), py::arg("X"), py::arg("U"),
          "Xdot (N, n_k): f_k at the N points, rows of X (N, n_k) and U (N, m).")
      .def(
          "flow_derivatives_batch",
          [](const SwitchedSystem& s, int k, const py::object& X, const py::object& U) {
            if (k < 0 || k >= s.num_modes()) throw InvalidArgument("k: out of range");
            const int n = s.state_dim(k), m = s.input_dim();
            const auto [x, u] = PointsFromArrays(X, U, n, m);
            const Eigen::Index N = x.cols();
            Matrix FX(n, n * N), FU(n, m * N);
            s.FlowDerivativesBatch(k, x, u, FX, FU);
            return py::make_tuple(BlocksToArray(FX, N, n, n), BlocksToArray(FU, N, n, m));
          },
          py::arg("k"), py::arg("X"), py::arg("U"),
          "(FX (N, n_k, n_k), FU (N, n_k, m)): df_k/dx and df_k/du at the N points.");

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
          py::arg("k"), py::arg("x"))
      .def_property_readonly("prefers_batch", &SwitchedCost::prefers_batch,
                             "True when the backward pass and the cost evaluation evaluate the "
                             "running cost once per mode (a CallbackCost with a batch callable).")
      .def(
          "running_batch",
          [](const SwitchedCost& c, int k, const py::object& X, const py::object& U) {
            const auto [x, u] = PointsFromArrays(X, U, -1, -1);
            Vector l(x.cols());
            c.RunningBatch(k, x, u, l);
            return l;
          },
          py::arg("k"), py::arg("X"), py::arg("U"),
          "l (N,): l_k at the N points, rows of X (N, n_k) and U (N, m).")
      .def(
          "running_derivatives_batch",
          [](const SwitchedCost& c, int k, const py::object& X, const py::object& U) {
            const auto [x, u] = PointsFromArrays(X, U, -1, -1);
            const Eigen::Index n = x.rows(), m = u.rows(), N = x.cols();
            Matrix LX(n, N), LU(m, N), LXX(n, n * N), LUU(m, m * N), LUX(m, n * N);
            c.RunningDerivativesBatch(k, x, u, LX, LU, LXX, LUU, LUX);
            return py::make_tuple(Matrix(LX.transpose()), Matrix(LU.transpose()),
                                  BlocksToArray(LXX, N, n, n), BlocksToArray(LUU, N, m, m),
                                  BlocksToArray(LUX, N, m, n));
          },
          py::arg("k"), py::arg("X"), py::arg("U"),
          "(LX (N, n_k), LU (N, m), LXX (N, n_k, n_k), LUU (N, m, m), LUX (N, m, n_k)) at the N "
          "points.");

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
      "|x_i|)). Batched form (instead of or beside flow): flow_batch(k, X, U) -> Xdot with X "
      "(N, n_k), U (N, m), Xdot (N, n_k), and flow_derivatives_batch(k, X, U) -> (FX (N, n_k, "
      "n_k), FU (N, n_k, m)): the backward pass then calls them once per mode (the finite "
      "differences of flow_batch in one call with all the perturbed points); the simulation "
      "calls flow per point (flow_batch with N = 1 when flow is None).")
      .def(py::init<std::vector<int>, int, py::object, py::object, py::object, py::object,
                    std::vector<int>, py::object, py::object, bool, double, py::object,
                    py::object>(),
           py::arg("state_dims"), py::arg("input_dim"), py::arg("flow") = py::none(),
           py::arg("reset") = py::none(), py::arg("flow_derivatives") = py::none(),
           py::arg("reset_derivative") = py::none(),
           py::arg("surface_dims") = std::vector<int>(), py::arg("surface") = py::none(),
           py::arg("surface_derivative") = py::none(), py::arg("cycle_reset") = false,
           py::arg("fd_step") = 1e-6, py::arg("flow_batch") = py::none(),
           py::arg("flow_derivatives_batch") = py::none());

  py::class_<CallbackCost, SwitchedCost>(
      mod, "CallbackCost",
      "A cost given by Python callables: running(k, x, u) -> float, switching(k, x) -> float "
      "(None: 0); optional running_derivatives(k, x, u) -> (lx, lu, lxx, luu, lux) and "
      "switching_derivatives(k, x) -> (phix, phixx). Missing derivatives: gradient by central "
      "differences (fd_step), Hessian by central differences of that gradient (fd_hessian_step). "
      "Batched form (instead of or beside running): running_batch(k, X, U) -> l (N,) and "
      "running_derivatives_batch(k, X, U) -> (LX (N, n_k), LU (N, m), LXX (N, n_k, n_k), LUU "
      "(N, m, m), LUX (N, m, n_k)), called once per mode by the backward pass and the cost "
      "evaluation.")
      .def(py::init<py::object, py::object, py::object, py::object, double, double, py::object,
                    py::object>(),
           py::arg("running") = py::none(), py::arg("switching") = py::none(),
           py::arg("running_derivatives") = py::none(),
           py::arg("switching_derivatives") = py::none(), py::arg("fd_step") = 1e-6,
           py::arg("fd_hessian_step") = 1e-4, py::arg("running_batch") = py::none(),
           py::arg("running_derivatives_batch") = py::none());

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
