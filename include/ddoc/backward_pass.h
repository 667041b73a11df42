// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The backward pass (30): P(tau), p(tau) of the co-state approximation (29) on the sample grid
// of a nominal (measured or predicted) trajectory, with the jump conditions at tau = k.
#ifndef DDOC_BACKWARD_PASS_H_
#define DDOC_BACKWARD_PASS_H_

#include <memory>
#include <vector>

#include "ddoc/problem.h"
#include "ddoc/time_normalization.h"
#include "ddoc/trajectory.h"

namespace ddoc {

/// Integration scheme between two samples (coefficients interpolated linearly in tau).
enum class BackwardIntegrator {
  kRk4,      ///< classical RK4, 4 products P*F_z per interval, local error O(h^5)
  kMidpoint  ///< explicit midpoint (RK2), 2 products per interval, local error O(h^3)
};

/// Which equation P and p follow.
enum class BackwardEquation {
  /// The paper's (30): Lyapunov-type, no quadratic term; p is the adjoint (plus du_prev).
  kLyapunov,
  /// Extension (not the paper): P gets the Riccati term of the closed-loop cost-to-go,
  ///   dP/dtau = -(P F_z + F_z^T P + L_zz - (P F_u + L_zu) H^{-1} (F_u^T P + L_uz)),
  /// H = L_uu + mu I, so the feedback H^{-1}(L_uz + F_u^T P) of (33) is the (unconstrained)
  /// LQR gain of the linearization; p stays the gradient adjoint of (30) (feed-forward =
  /// preconditioned gradient step).
  kRiccatiFeedback,
  /// Extension (not the paper): the Riccati equations of the unconstrained LQ sub-problem (21),
  /// i.e. (30) with the feedback of (33) substituted into the co-state equation:
  ///   P as kRiccatiFeedback,
  ///   dp/dtau = -(F_z^T p + L_z - (P F_u + L_zu) H^{-1} (L_u + F_u^T p)).
  /// Then (33) with alpha = 1 is a Newton (iLQR-type) step in u and (31) uses the reduced
  /// Hessian/gradient of the cost w.r.t. T. Input bounds are ignored in P and p.
  kRiccati
};

/// How the regularization mu of H = L_uu + diag(mu) is formed, in (33) (OnlineController) and
/// in the Riccati variants of the backward pass. reg is the settings' regularization.
enum class RegularizationScaling {
  /// One scalar for every input: mu_i = reg (1 + max_j |L_uu,jj|). The "1" is in raw input
  /// units, so an input with a small curvature (e.g. a stiffness command in N/m whose R weight
  /// is 1e-6) gets a mu many orders above its own L_uu,ii.
  kScalar,
  /// Per input, in normalized input units v_i = u_i / s_i with s_i = u_max_i - u_min_i:
  ///   mu_i = reg (|L_uu,ii| + s_i^-2),
  /// i.e. Marquardt's scaling by the input's own curvature plus a floor reg that is the same for
  /// every input once measured in fractions of its range (s_i = 1 where the range is 0 or not
  /// finite). Invariant to rescaling an input's units (with its bounds).
  kPerInput
};

/// mu (m) of H = L_uu + diag(mu) for the given scaling; inv_range_sq (m) holds s_i^-2 (see
/// InverseSquaredInputRanges). Does not allocate.
void RegularizationDiagonal(RegularizationScaling scaling, double reg, const ConstMatrixRef& luu,
                            const ConstVectorRef& inv_range_sq, VectorRef mu);

/// s_i^-2 of RegularizationScaling::kPerInput: (u_max_i - u_min_i)^-2, 1 where the range is 0
/// or not finite. Allocates (call at setup).
Vector InverseSquaredInputRanges(const Bounds& bounds);

/// Settings of BackwardPass.
struct BackwardPassSettings {
  /// The equation for P, p (default: the paper's Lyapunov-type (30)).
  BackwardEquation equation = BackwardEquation::kLyapunov;
  /// Legacy switch: true upgrades kLyapunov to kRiccatiFeedback (same as setting `equation`).
  bool riccati = false;
  /// Riccati variants: H = L_uu + mu I, mu = riccati_regularization * (1 + max|diag L_uu|).
  /// Use the same value as OnlineControllerSettings::regularization so that the gain the
  /// controller applies is the gain the Riccati equation assumed. >= 0.
  double riccati_regularization = 0.1;
  /// Riccati variants: how mu is formed from riccati_regularization (default kScalar, the
  /// formula above; kPerInput: mu_i = reg (|L_uu,ii| + (u_max_i - u_min_i)^-2)). Use the same
  /// value as OnlineControllerSettings::regularization_scaling.
  RegularizationScaling regularization_scaling = RegularizationScaling::kScalar;
  /// Option (default false = the exact Hessians): replace each switching-cost Hessian Phi_{k,zz}
  /// by its projection onto the positive semidefinite cone (negative eigenvalues set to 0)
  /// before it enters P. With a large terminal residual the exact Hessian of a squared
  /// residual through a nonlinear map is indefinite, and a Riccati variant can then escape to
  /// infinity inside the mode (measured on the MuJoCo hopper: non-finite P22 after a hop with
  /// I1 ~ 20). Allocates (an eigen-decomposition per switch) when enabled.
  bool psd_switching_hessians = false;
  /// Include the paper's driving term (P F_u + L_zu) du^{i-1} in the p-equation of (30)
  /// (kLyapunov and kRiccatiFeedback only).
  /// false (default): p is the exact adjoint of the linearized cost, so L_u + F_u^T p is the
  /// gradient of the cost w.r.t. u(tau) and p_2(0) the gradient w.r.t. T.
  bool use_previous_du = false;
  /// Integration scheme (default RK4).
  BackwardIntegrator integrator = BackwardIntegrator::kRk4;
  /// Cyclic (periodic) value, NOT in the paper. 0 (default): the problem ends at T_K, as in
  /// (2). gamma_c in (0, 1]: for a system with a cycle reset g_{K-1} (mode K-1 -> mode 0, e.g.
  /// a hopper's takeoff), the terminal condition also values the NEXT cycle:
  ///   P(K) = Phi_{K,zz} + gamma_c G^T P_0 G   (state block; G = dg_{K-1}/dx at x(T_K)),
  /// where P_0 is the state block of P at tau = 0. Run sweeps the pass until P_0 is a fixed
  /// point (the periodic Riccati solution on the nominal), warm-started from the previous Run.
  /// Only P changes at the terminal (p(K) = Phi_{K,z}): the gains see the consequences of a
  /// deviation in all later cycles instead of only in this one; the feed-forward still
  /// descends this cycle's cost. Riccati variants only (kLyapunov ignores it).
  double cyclic_value = 0.0;
  /// Most sweeps per Run for the cyclic value, and the relative change of P_0 (Frobenius) at
  /// which the sweeps stop.
  int cyclic_max_sweeps = 30;
  double cyclic_tolerance = 1e-4;
  /// Event-terminated horizon, NOT in the paper (default false: the paper's terminal
  /// condition P(K) = Phi_{K,zz}, p(K) = Phi_{K,z}). On a plant whose last mode ends at a
  /// state event (a hopper's takeoff) the terminal cost is measured AT the event, so a
  /// deviation along the flow f_{K-1} at the end only moves the event and changes nothing.
  /// With this option, when the system provides SwitchedSystem::GuardGradient for the last
  /// mode, the terminal cost (and the cycle reset of cyclic_value) is taken through
  ///   Pi = I - f gamma_x^T / (gamma_x^T f)      at the nominal's last sample,
  /// i.e. P(K) = Pi^T Phi_{K,xx} Pi, p(K) = Pi^T Phi_{K,x} - l gamma_x / (gamma_x^T f) (state
  /// blocks; the last term is the running cost l of the time the event gains). Intermediate
  /// switches keep the paper's G_{k,x}: there T_k is a decision variable tied to the event by
  /// the surface penalty (8), whose gradient the projection would remove.
  bool terminal_event = false;
};

/// The backward pass (30), derived from (26)-(29) with delta-lambda = P delta-z + p:
///
///   dP/dtau = -(P F_z + F_z^T P + L_zz),                                P(K) = Phi_{K,zz}
///   dp/dtau = -(F_z^T p + L_z + (P F_u + L_zu) du_prev),                 p(K) = Phi_{K,z}
///   P^-(k)  = Phi_{k,zz} + G_{k,z}^T P^+(k) G_{k,z},   p^-(k) = Phi_{k,z} + G_{k,z}^T p^+(k)
///
/// ERRATUM: the printed p-equation of (30) omits L_z; it is included here (without it p is not
/// the co-state of (21) and the gradient test fails). G_{k,z} is (n_{k+1}+K) x (n_k+K), so P
/// and p change size across a jump.
///
/// Zero-based modes: mode k lives on tau in [k, k+1] and its last sample (the pre-switch state
/// x^-(T_k)) carries the jump from mode k+1. Coefficients are evaluated at the samples of the
/// nominal trajectory and interpolated linearly in tau inside each interval.
///
/// Outputs per sample (mode k, sample j): P (n_k+K)^2, p (n_k+K), the gain
/// L_uz + F_u^T P (m x (n_k+K)) and feed-forward L_u + F_u^T p (m) of (34), and L_uu (m x m).
///
/// Lifecycle: Allocate once for the largest horizon; Run allocates nothing.
class BackwardPass {
 public:
  BackwardPass() = default;
  BackwardPass(const BackwardPass&) = delete;
  BackwardPass& operator=(const BackwardPass&) = delete;

  /// Sizes all buffers for up to max_samples samples in total (allocates). Validates the
  /// problem; the problem must outlive this object.
  void Allocate(const Problem& problem, int max_samples, const BackwardPassSettings& settings = {});
  /// Invalidates the results (keeps the buffers).
  void Reset() { valid_ = false; }
  /// Runs (30) on the grid of `nominal` (must match the problem's dimensions, at most
  /// max_samples samples). `du_prev` (m x total samples, mode-major) is the previous control
  /// variation at the samples; used only with settings.use_previous_du (nullptr = 0).
  /// Does not allocate. Throws InvalidArgument on size mismatches.
  void Run(const Trajectory& nominal, const Matrix* du_prev = nullptr);
  /// Sweeps of the last Run (1 without a cyclic value).
  int sweeps() const { return sweeps_; }
  /// Forget the cyclic P_0 of the previous Run (the next Run starts from P_0 = 0).
  void ResetCyclicValue() { cyclic_valid_ = false; }

  bool valid() const { return valid_; }
  const BackwardPassSettings& settings() const { return settings_; }
  BackwardPassSettings& mutable_settings() { return settings_; }
  int num_modes() const { return K_; }
  int input_dim() const { return m_; }
  int max_samples() const { return max_samples_; }
  /// Number of samples of mode k in the last Run.
  int num_samples(int k) const { return counts_[k]; }
  /// Global (mode-major) index of sample (k, j).
  int index(int k, int j) const { return offsets_[k] + j; }
  /// n_k + K.
  int augmented_dim(int k) const { return dims_[k] + K_; }

  double tau(int k, int j) const { return tau_(index(k, j)); }
  Eigen::Map<const Matrix> P(int k, int j) const;
  Eigen::Map<const Vector> p(int k, int j) const;
  /// L_uz + F_u^T P, m x (n_k+K): the state/time feedback part of b in (34).
  Eigen::Map<const Matrix> Gain(int k, int j) const;
  /// L_u + F_u^T p, m: the constant part of b in (34); with use_previous_du = false the
  /// gradient density of the cost w.r.t. u(tau).
  Eigen::Map<const Vector> Feedforward(int k, int j) const;
  /// L_uu, m x m.
  Eigen::Map<const Matrix> Luu(int k, int j) const;
  /// p_2(0) (K): with use_previous_du = false, the gradient of the cost w.r.t. T.
  Eigen::Map<const Vector> p2_initial() const;
  /// P_22(0) (K x K) of (31).
  Matrix P22_initial() const;

 private:
  // Coefficients of (30) at one point of the grid (sized for n_max; top blocks used).
  struct Coefficients {
    Matrix A;    // nz_max x nz_max: F_z; only the top n rows are used (the bottom K are zero)
    Matrix Q;    // nz_max x nz_max: L_zz
    Vector Lz;   // nz_max
    Matrix B;    // nz_max x m: F_u; only the top n rows are used
    Matrix Lzu;  // nz_max x m
    Matrix Luz;  // m x nz_max
    Vector Lu;   // m
    Matrix Luu;  // m x m
    Vector du;   // m: previous control variation (0 unless use_previous_du)
    Matrix LuuInv;  // m x m: (L_uu + mu I)^{-1} (Riccati variants only)
    void Allocate(int nz_max, int m);
  };
  void Evaluate(int k, const Trajectory& nominal, int j, const Matrix* du_prev, Coefficients* c);
  void Interpolate(int n, int nz, const Coefficients& a, const Coefficients& b, Coefficients* c);
  // dP/ds = P A + A^T P + Q, dp/ds = A^T p + Lz + (P B + Lzu) du in backward time s.
  void Derivative(int n, int nz, const Coefficients& c, const ConstMatrixRef& P,
                  const ConstVectorRef& p, MatrixRef dP, VectorRef dp);
  void Step(int n, int nz, double h, const Coefficients& hi, const Coefficients& lo,
            MatrixRef P, VectorRef p);
  // kLyapunov: the same RK4/midpoint step as Step on P_, p_, with the stages fused (one
  // product P(:, 0:n) A per stage, one pass forming dP and the next stage's P).
  void LyapunovStep(int n, int nz, double h, const Coefficients& hi, const Coefficients& lo);
  // dp/ds of the kLyapunov equation at stage (X, x).
  void LyapunovDp(int n, int nz, const Coefficients& c, const ConstMatrixRef& X,
                  const ConstVectorRef& x, VectorRef dp);
  void StoreOutputs(int k, int j, const Coefficients& c);

  const Problem* problem_ = nullptr;
  BackwardPassSettings settings_;
  std::unique_ptr<TimeNormalization> normalization_;
  int K_ = 0, m_ = 0, n_max_ = 0, nz_max_ = 0, max_samples_ = 0;
  bool valid_ = false;
  std::vector<int> dims_;     // n_k
  std::vector<int> counts_;   // N_k of the last run
  std::vector<int> offsets_;  // first global index of mode k
  // Per-sample storage, one column per global sample (only the leading entries are used).
  Vector tau_;         // S
  Matrix P_store_;     // nz_max^2 x S
  Matrix p_store_;     // nz_max x S
  Matrix gain_store_;  // m * nz_max x S
  Matrix ff_store_;    // m x S
  Matrix luu_store_;   // m^2 x S
  // Workspace.
  Coefficients coef_[3];  // hi (tau_{j+1}), lo (tau_j), mid
  Vector z_;              // nz_max
  Vector phiz_;           // nz_max
  Matrix phizz_;          // nz_max x nz_max
  Matrix Gz_;             // nz_max x nz_max (rectangular top-left block used)
  Vector event_f_;        // n_max: f_k at the pre-switch sample (terminal_event)
  Vector event_hx_;       // n_max: guard gradient
  Matrix event_Pi_;       // n_max x n_max: the projection Pi_k
  Matrix event_tmp_;      // nz_max x nz_max
  double event_cost_rate_ = 0;  // l / (gamma_x^T f) at that sample
  bool terminal_projected_ = false;  // this Run projects the terminal (event_Pi_ is set)
  Matrix tmp_;            // nz_max x nz_max
  Matrix P_;              // nz_max x nz_max: current P
  Vector p_;              // nz_max: current p
  Matrix Ps_;             // stage P
  Vector ps_;             // stage p
  Matrix kP_[4];          // stage derivatives of P
  Vector kp_[4];          // stage derivatives of p
  Matrix PA_;             // nz_max x nz_max: P(:, 0:n) F_z(0:n, :) of a stage
  Vector Bdu_;            // n_max
  Matrix Bt_;             // m x n_max: F_u(0:n, :)^T of the stored sample
  Matrix M_;              // nz_max x m: P F_u + L_zu (Riccati variants)
  Matrix W_;              // nz_max x m: M H^{-1} (Riccati variants)
  Vector r_;              // m: L_u + F_u^T p (kRiccati)
  Eigen::LLT<Matrix> llt_;  // m x m (Riccati variants)
  Vector inv_range_sq_;     // m: (u_max - u_min)^-2 (kPerInput)
  Vector mu_;               // m: regularization diagonal (Riccati variants)
  // Cyclic value (settings.cyclic_value > 0).
  Matrix cyclic_P0_;        // n_0 x n_0: state block of P(0) of the last sweep
  Matrix cyclic_G_;         // n_0 x n_{K-1}: dg_{K-1}/dx at the end of the nominal
  Matrix cyclic_tmp_;       // n_0 x n_{K-1}
  bool cyclic_valid_ = false;
  int sweeps_ = 0;
  void Sweep(const Trajectory& nominal, const Matrix* du_prev, bool cyclic);
  // terminal_event: Pi_k into event_Pi_ (n_k x n_k) and l / (gamma_x^T f) into
  // event_cost_rate_, at mode k's last nominal sample. Returns false (no projection) when the
  // system has no guard gradient or the flow is tangent to the guard.
  bool EventProjection(int k, const Trajectory& nominal);
  BackwardEquation equation_ = BackwardEquation::kLyapunov;  // effective equation
  bool riccati() const { return equation_ != BackwardEquation::kLyapunov; }
  void Invert(Coefficients* c);
};

}  // namespace ddoc

#endif  // DDOC_BACKWARD_PASS_H_
