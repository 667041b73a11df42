// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The backward pass (30): P(tau), p(tau) of the co-state approximation (29) on the sample grid
// of a nominal (measured or predicted) trajectory, with the jump conditions at tau = k.
#ifndef DDOC_BACKWARD_PASS_H_
#define DDOC_BACKWARD_PASS_H_

#include <memory>
#include <vector>

#include "ddoc/box_qp.h"
#include "ddoc/problem.h"
#include "ddoc/sample_layout.h"
#include "ddoc/trajectory.h"

namespace ddoc {
/// Which equations P and p follow (docs/engine.md derives both).
enum class BackwardEquation {
  /// The paper's (30): Lyapunov-type P (no quadratic term), p the adjoint of the linearized
  /// cost (plus the previous control variation with use_previous_du). Pairs with alpha on all
  /// of b in (33).
  kLyapunov,
  /// The recommended default: the Riccati equations of the box-constrained LQ sub-problem (21)
  /// (box-constrained DDP in continuous time). On each sample interval the full step
  /// k = argmin_{u_min <= u + k <= u_max} 1/2 k^T H k + k^T (L_u + F_u^T p) fixes the free set F;
  ///   dP/dtau = -(P F_z + F_z^T P + L_zz - M_F H_FF^{-1} M_F^T),   M = P F_u + L_zu,
  ///   dp/dtau = -(F_z^T p + L_z + M k),
  /// so clamped inputs get no feedback and (33) with alpha = 1 is a Newton step in u, and (31)
  /// is a Newton step in T on the reduced Hessian P22(0). Pairs with alpha on the feed-forward
  /// only.
  kRiccati,
};

/// Integration scheme on each sample interval (coefficients constant on the interval).
enum class BackwardIntegrator {
  kMidpoint,  ///< explicit midpoint (2 stages), second order like the coefficients' quadrature
  kRk4        ///< classical RK4 (4 stages), for stiff Riccati equations
};

/// box_aware: a nominal input within this fraction of its range (of 1 when the range is below 1
/// or infinite) of a bound is on the bound (free only if its step points inward). Default 1e-9.
constexpr double kOnBoundTolerance = 1e-9;

/// Settings of BackwardPass. Presets: LearnerSettings{} (kRiccati, time_curvature) and
/// LearnerSettings::Paper() (kLyapunov, use_previous_du).
struct BackwardPassSettings {
  BackwardEquation equation = BackwardEquation::kRiccati;  ///< default kRiccati
  BackwardIntegrator integrator = BackwardIntegrator::kMidpoint;  ///< default midpoint
  /// kRiccati: the free set of each interval's full step enters P and p (clamped inputs get no
  /// feedback; an input within kOnBoundTolerance of its bound is on it; default true). false:
  /// the unconstrained Riccati equations (the bounds act only in the online QP of (33)), which
  /// the hopper's learner keeps (docs/experiments.md).
  bool box_aware = true;
  /// Exact second-order terms of the time normalization in the Hamiltonian: the curvature
  /// p_x^T d^2 F / (dT dx) = +-p_x^T f_x and p_x^T d^2 F / (dT du) = +-p_x^T f_u (the sign of
  /// D_k's dependence on T_k, T_{k-1}) added to L_zT and L_uT. They need no second derivative
  /// of f and make P22(0) the exact Hessian w.r.t. T of the LQ model. Default true.
  bool time_curvature = true;
  /// The printed (30)'s driving term (P F_u + L_zu) du^{i-1} in the p-equation (kLyapunov
  /// only; then p is not the gradient adjoint). Default false; the paper preset sets it.
  bool use_previous_du = false;
  /// Replace each switching-cost Hessian Phi_{k,zz} by its projection onto the positive
  /// semidefinite cone before it enters P (allocates an eigen-decomposition per switch).
  /// Default false.
  bool psd_switching_hessians = false;
  /// kRiccati: most sub-steps per sample interval where h |S^-1 A_cl S|_inf > 1 (stiff; S the
  /// diagonal balancing of the closed loop A_cl). >= 1; default 1000.
  int max_substeps = 1000;
  /// Fewest sub-steps per sample interval, any equation (a finer reference solution of the same
  /// grid). >= 1; default 1.
  int min_substeps = 1;
  /// Cyclic (periodic) value gamma_c in [0, 1], NOT in the paper, kRiccati only. 0 (default):
  /// the problem ends at T_K. > 0, for a system with a cycle reset g_{K-1}:
  /// P_xx(K) = Phi_xx + gamma_c G^T P_0 G (G = dg_{K-1}/dx at the end of the nominal, P_0 the
  /// state block of P(0)), swept to a fixed point (at most cyclic_max_sweeps sweeps, relative
  /// change cyclic_tolerance), warm-started from the previous Run.
  double cyclic_value = 0.0;
  int cyclic_max_sweeps = 30;      ///< default 30
  double cyclic_tolerance = 1e-4;  ///< default 1e-4
  /// Event-terminated horizon, NOT in the paper (default false): with
  /// SwitchedSystem::GuardGradient gamma_x for the last mode, the terminal condition is taken
  /// through the event, Pi = I - f gamma_x^T / (gamma_x^T f):
  /// P_xx(K) = Pi^T Phi_xx Pi, p_x(K) = Pi^T Phi_x - l gamma_x / (gamma_x^T f).
  bool terminal_event = false;
  /// Keep P at every sample for P(k, j) (diagnostics, tests); default false: only at the first
  /// and last sample of each mode (what the jumps, (31) and the cyclic value need), which saves
  /// writing (n+K)^2 doubles per sample.
  bool keep_P_trajectory = false;
};

/// Why a Run did not produce usable results.
enum class BackwardStatus {
  kOk = 0,
  kNotPositiveDefinite,  ///< H = L_uu + mu I (on the free set) was not positive definite
  kNonFinite,            ///< P or p became non-finite (raise the regularization)
};

/// The backward pass (30), derived from (26)-(29) with delta-lambda = P delta-z + p:
///
///   dP/dtau = -(P F_z + F_z^T P + L_zz)             [- M_F H_FF^{-1} M_F^T, kRiccati]
///   dp/dtau = -(F_z^T p + L_z)                      [- M k, kRiccati]
///   P^-(k)  = Phi_{k,zz} + G_{k,z}^T P^+(k) G_{k,z},   p^-(k) = Phi_{k,z} + G_{k,z}^T p^+(k)
///   P(K) = Phi_{K,zz},  p(K) = Phi_{K,z}
///
/// ERRATUM: the printed p-equation of (30) omits L_z; it is included here.
/// The time normalization (12)-(17) is used in structured form: F_z = [D f_x, f c^T; 0, 0] with
/// c = e_k - e_{k-1} (D_k = T_k - T_{k-1}), L_z = [D l_x; l c], L_zz = [D l_xx, l_x c^T; ., 0],
/// F_u = [D f_u; 0], L_uz = [D l_ux, l_u c^T], L_uu = D l_uu.
///
/// Zero-order hold: the input u_j is held on [tau_j, tau_{j+1}], so the coefficients of that
/// interval are evaluated once, at (x_mid, u_j) with x_mid = (x_j + x_{j+1}) / 2, and held
/// constant while (P, p) are integrated across it. The outputs of sample j (Gain, Feedforward,
/// Hessian, Gradient) are those of interval j at its midpoint, the quantities the input u_j
/// acts through; the last sample of a mode repeats the last interval's.
///
/// Alongside p the pass integrates the gradient adjoint lambda (dlambda/dtau = -(F_z^T lambda
/// + L_z)), so Gradient() and gradient_T() are the first-order derivatives of the cost whatever
/// the equation (for kLyapunov without use_previous_du, lambda = p).
///
/// Lifecycle: Allocate once for the largest horizon; Run allocates nothing (except the
/// eigen-decompositions of psd_switching_hessians).
class BackwardPass {
 public:
  BackwardPass();
  ~BackwardPass();
  BackwardPass(const BackwardPass&) = delete;
  BackwardPass& operator=(const BackwardPass&) = delete;

  /// Sizes all buffers for up to max_samples samples in total (allocates). Validates the
  /// problem and the settings; the problem must outlive this object.
  void Allocate(const Problem& problem, int max_samples, const BackwardPassSettings& settings = {});
  /// Runs the pass on the grid of `nominal` (must match the problem's dimensions, at most
  /// max_samples samples) with H = L_uu + mu I, mu = `regularization` >= 0 (in the units of
  /// L_uu = D l_uu). `du_prev` (m x total samples, mode-major) is the previous control
  /// variation, used only with use_previous_du (nullptr = 0). Returns status() == kOk; on
  /// kNotPositiveDefinite or kNonFinite the results are invalid (raise the regularization).
  /// Does not allocate. Throws InvalidArgument on size mismatches.
  bool Run(const Trajectory& nominal, double regularization = 0.0,
           const Matrix* du_prev = nullptr);
  /// Forget the cyclic P_0 of the previous Run (the next Run starts from P_0 = 0).
  void ResetCyclicValue() { cyclic_valid_ = false; }
  /// The cyclic P_0 (state block of P(0), n_0 x n_0) that the next Run's sweeps start from: the
  /// last Run's fixed point or a seed; empty when they start from P_0 = 0.
  Matrix cyclic_value() const;
  /// Start the next Run's sweeps from `P0` (n_0 x n_0, finite) instead of the last Run's fixed
  /// point, e.g. the fixed point of a pass on a similar nominal (the model's solve of the law
  /// that is about to run). Throws InvalidArgument on a wrong size or a non-finite entry.
  void SeedCyclicValue(const Matrix& P0);

  BackwardStatus status() const { return status_; }
  bool valid() const { return valid_; }
  const BackwardPassSettings& settings() const { return settings_; }
  /// True when (33) scales all of b by alpha (kLyapunov, the paper) rather than the
  /// feed-forward only (kRiccati, the DDP convention): the convention that makes the step a
  /// descent direction for the equation.
  bool alpha_scales_feedback() const { return settings_.equation == BackwardEquation::kLyapunov; }
  /// Sweeps of the last Run (1 without a cyclic value).
  int sweeps() const { return sweeps_; }
  /// Integration steps of the last Run over all its sweeps (sample intervals plus the extra
  /// sub-steps of stiff ones).
  long substeps() const { return substeps_; }
  /// Integration steps of every Run since Allocate (the work the passes did; a run-time model's
  /// clock, docs/design.md "Honest latency").
  long total_substeps() const { return total_substeps_; }
  double regularization() const { return mu_; }  ///< mu of the last Run
  /// max |diag L_uu| over the intervals of the last Run (before mu; a scale for mu).
  double luu_scale() const { return luu_scale_; }
  int num_modes() const { return K_; }
  int input_dim() const { return m_; }
  int max_samples() const { return max_samples_; }
  /// Number of samples of mode k in the last Run.
  int num_samples(int k) const { return layout_.count(k); }
  /// Global (mode-major) index of sample (k, j).
  int index(int k, int j) const { return layout_.index(k, j); }
  /// n_k + K.
  int augmented_dim(int k) const { return layout_.dim(k) + K_; }

  double tau(int k, int j) const { return tau_(index(k, j)); }
  /// P and p at sample (k, j). P only at the first and last sample of a mode unless
  /// keep_P_trajectory (InvalidArgument otherwise).
  Eigen::Map<const Matrix> P(int k, int j) const;
  Eigen::Map<const Vector> p(int k, int j) const;
  /// L_uz + F_u^T P, m x (n_k+K): the state/time feedback part of b in (34).
  Eigen::Map<const Matrix> Gain(int k, int j) const;
  /// L_u + F_u^T p, m: the constant part of b in (34).
  Eigen::Map<const Vector> Feedforward(int k, int j) const;
  /// H = L_uu + mu I, m x m: the Hessian of (33).
  Eigen::Map<const Matrix> Hessian(int k, int j) const;
  /// L_u + F_u^T lambda, m: the gradient density of the cost w.r.t. u(tau) (per unit tau).
  Eigen::Map<const Vector> Gradient(int k, int j) const;
  /// The full (alpha = 1) step k of interval (k, j) within the input box (kRiccati; zero for
  /// kLyapunov).
  Eigen::Map<const Vector> Step(int k, int j) const;
  /// p_2(0) (K): the linear term of (31).
  Eigen::Map<const Vector> p2_initial() const;
  /// P_22(0) (K x K) of (31).
  Matrix P22_initial() const;
  /// lambda_2(0) (K): the gradient of the cost w.r.t. T.
  const Vector& gradient_T() const { return gradient_T_; }
  /// The predicted change of the cost for the input part of the step with alpha on the
  /// feed-forward: alpha * linear + alpha^2 / 2 * quadratic, with linear = int k^T (L_u + F_u^T p)
  /// dtau and quadratic = int k^T H k dtau (kRiccati; both 0 for kLyapunov).
  double predicted_linear() const { return predicted_linear_; }
  double predicted_quadratic() const { return predicted_quadratic_; }

 private:
  // Coefficients of one sample interval, evaluated at (x_mid, u_j) (sized for n_max; top blocks
  // used).
  struct Interval {
    Vector f;      // n: f_k
    Matrix fx;     // n x n: D f_x
    Matrix fu;     // n x m: D f_u
    Matrix fx_unit;  // n x n: f_x, kept only for a mode of zero duration (D = 0)
    Matrix fu_unit;  // n x m: f_u, likewise
    double l = 0;  // l_k
    Vector lx;     // n: l_x (unscaled)
    Vector lu;     // m: l_u (unscaled)
    Matrix lxx;    // n x n: D l_xx
    Matrix lux;    // m x n: D l_ux
    Matrix H;      // m x m: D l_uu + mu I
    Matrix Hinv;   // m x m: H_FF^{-1} on the free set, 0 elsewhere
    Vector kc;     // m: the clamped part of the step (bound offsets on C, 0 on F)
    Vector lo, hi; // m: the box of the step, u_min - u_j, u_max - u_j
    double D = 1;  // duration of the mode
    void Allocate(int n, int m);
  };
  // Stage state and derivative.
  void Evaluate(int k, const Trajectory& nominal, int j, const Matrix* du_prev);
  // The coefficients of every interval of the nominal by one batch call per mode (the system's
  // and/or the cost's, those that prefer_batch()), for Evaluate to read in every sweep.
  void EvaluateBatch(const Trajectory& nominal);
  bool FreeSet(int n, const ConstMatrixRef& P, const ConstVectorRef& p);
  // FreeSet of a mode of zero duration (kRiccati): no free input, the Hamiltonian's minimizer.
  bool VanishedStep(int n, const ConstVectorRef& p);
  // max |eigenvalue| bound of the closed loop: |S^-1 A_cl S|_inf, S rebalanced when above limit.
  double RiccatiStiffness(int n, const ConstMatrixRef& P, double limit);
  // Y = X A for the interval's [D f_x, f] (fx = true) or D f_u, A's nonzero pattern known.
  void Product(int rows, int depth, const double* X, int ldx, bool fx, double* Y, int ldy);
  void Derivative(int k, int n, const ConstMatrixRef& P, const ConstVectorRef& p,
                  const ConstVectorRef& lam, MatrixRef dP, VectorRef dp, VectorRef dlam,
                  bool store_mid, int s);
  bool Sweep(const Trajectory& nominal, const Matrix* du_prev, bool cyclic);
  void IntegrateStep(int k, int n, double h, int s, bool store, double interval);
  void JumpOrTerminal(int k, const Trajectory& nominal, bool cyclic);
  bool EventProjection(int k, const Trajectory& nominal);
  void StoreState(int k, int j);
  void CopyOutputs(int from, int to);

  const Problem* problem_ = nullptr;
  BackwardPassSettings settings_;
  int K_ = 0, m_ = 0, n_max_ = 0, nz_max_ = 0, max_samples_ = 0;
  bool valid_ = false;
  BackwardStatus status_ = BackwardStatus::kOk;
  double mu_ = 0;
  double luu_scale_ = 0;
  bool box_ = false;  // some input bound is finite
  Vector on_bound_tol_;  // m: kOnBoundTolerance x max(1, u_max - u_min) (1 for an infinite range)
  SampleLayout layout_;      // n_k, N_k of the last run, mode-major sample indices
  // Per-sample storage, one column per global sample (leading entries used).
  Vector tau_;         // S
  Matrix P_store_;     // nz_max^2 x S
  Matrix p_store_;     // nz_max x S
  Matrix gain_store_;  // m * nz_max x S
  Matrix ff_store_;    // m x S
  Matrix grad_store_;  // m x S
  Matrix step_store_;  // m x S
  Matrix h_store_;     // m^2 x S
  Vector gradient_T_;  // K
  double predicted_linear_ = 0, predicted_quadratic_ = 0;
  // Workspace.
  Interval c_;
  struct Sparsity;                      // the nonzero patterns of c_.fx and c_.fu (the .cc's)
  std::unique_ptr<Sparsity> sparsity_;
  struct Batch;  // EvaluateBatch's coefficients of all intervals (the .cc's); null: per point
  std::unique_ptr<Batch> batch_;
  const Matrix* du_prev_ = nullptr;
  int du_index_ = 0;
  Vector xmid_;             // n_max
  Vector phiz_;             // n_max: Phi_x
  Matrix phizz_;            // n_max x n_max: Phi_xx
  Matrix gx_;               // n_max x n_max: g_x of the jump
  Vector h_;                // s_max
  Matrix hx_;               // s_max x n_max
  Matrix P_, Ps_, dP_[4];   // nz_max x nz_max: current, stage, stage derivatives
  Vector p_, ps_, dp_[4];   // nz_max
  Vector lam_, lams_, dlam_[4];  // nz_max: gradient adjoint
  Matrix Z_;                // nz_max x n_max: P(:, 0:n) (D f_x)
  Vector w_;                // nz_max: P(:, 0:n) f
  Matrix M_;                // nz_max x m: P F_u + L_zu
  Matrix W_;                // nz_max x m: M Hinv
  Matrix Mt_;               // m x nz_max: M^T
  Vector hx_curv_, hu_curv_;  // n, m: f_x^T p_x, f_u^T p_x
  Vector gu_, k_, tmpm_;    // m
  Matrix tmp_;              // nz_max x nz_max (the Riccati term M_F H_FF^-1 M_F^T of a stage)
  bool riccati_term_ = false;  // tmp_ holds the Riccati term of the last Derivative
  Eigen::LLT<Matrix> llt_;  // m x m
  Matrix hff_;              // m x m
  Matrix stiff_gain_;       // m x n_max: H_FF^-1 (F_u^T P_xx + L_ux) of the stiffness estimate
  Matrix stiff_k_;          // m x n_max: H_FF^-1 stiff_gain_
  Matrix stiff_acl_;        // n_max x n_max: the closed-loop D f_x - F_u gain
  Vector stiff_scale_;      // n_max: the diagonal S of the balanced closed loop (this mode's)
  Matrix stiff_rows_;       // n_max x 2: row sums of |D f_x S| and |F_u| (the cheap bound)
  std::vector<int> free_;   // m
  BoxQP qp_;
  // Terminal event projection.
  Vector event_f_, event_hx_;  // n_max
  Matrix event_Pi_;            // n_max x n_max
  double event_cost_rate_ = 0;
  bool terminal_projected_ = false;
  // Cyclic value.
  Matrix cyclic_P0_, cyclic_G_, cyclic_tmp_;  // n_max x n_max
  bool cyclic_valid_ = false;
  int sweeps_ = 0;
  long substeps_ = 0;
  long total_substeps_ = 0;
};

}  // namespace ddoc

#endif  // DDOC_BACKWARD_PASS_H_
