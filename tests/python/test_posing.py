"""A problem posed as a user writes it (issue 47): the cost's cross term u'N x, the feedback law
in physical time against an independent CARE solution, and why a solve stopped."""
import numpy as np
import pytest

import ddoc


def care(A, B, Q, R, N):
    """Stabilizing solution of A'S + SA - (SB + N')R^-1(B'S + N) + Q = 0 from the stable
    invariant subspace of the Hamiltonian matrix (NumPy only, independent of ddoc)."""
    Ri = np.linalg.inv(R)
    At = A - B @ Ri @ N
    Qt = Q - N.T @ Ri @ N
    H = np.block([[At, -B @ Ri @ B.T], [-Qt, -At.T]])
    w, V = np.linalg.eig(H)
    stable = V[:, w.real < 0]
    n = A.shape[0]
    S = np.real(stable[n:] @ np.linalg.inv(stable[:n]))
    return 0.5 * (S + S.T)


def test_quadratic_cost_cross_term_value():
    Q, R, N = np.diag([2.0, 1.0]), np.eye(1), np.array([[0.3, -0.2]])
    r = np.array([0.5, -1.0])
    cost = ddoc.QuadraticCost(Q=[Q], R=[R], r=[r], N=[N])
    x, u = np.array([0.2, 0.7]), np.array([1.5])
    expected = 0.5 * (x - r) @ Q @ (x - r) + 0.5 * u @ R @ u + u @ N @ (x - r)
    assert cost.running(0, x, u) == pytest.approx(expected, rel=1e-14)
    with pytest.raises(ValueError, match=r"N\[0\]"):
        ddoc.QuadraticCost(Q=[Q], R=[R], N=[np.zeros((2, 1))])
    with pytest.raises(ValueError, match="not positive semidefinite"):
        ddoc.QuadraticCost(Q=[Q], R=[R], N=[np.array([[5.0, 0.0]])])


def test_feedback_law_is_the_care_gain_and_stop_reason_says_why():
    A = np.array([[0.0, 1.0], [2.0, -0.5]])
    B = np.array([[0.0], [1.0]])
    Q, R, N = np.diag([2.0, 1.0]), np.array([[0.5]]), np.array([[0.2, -0.1]])
    S = care(A, B, Q, R, N)
    K_care = -np.linalg.inv(R) @ (B.T @ S + N)
    # Terminal weight S: the Riccati solution is S over the whole horizon.
    T = 3.0
    system = ddoc.LinearSystem([A], [B])
    cost = ddoc.QuadraticCost(Q=[Q], R=[R], S=[S], N=[N])
    bounds = ddoc.Bounds(u_min=[-np.inf], u_max=[np.inf], duration_min=[T], duration_max=[T])
    problem = ddoc.Problem(system, cost, bounds, surface_weights=[0.0])
    learner = ddoc.Learner(problem)
    result = learner.solve([1.0, -0.5], [T])
    assert result.status == "converged"
    assert result.stop_reason.startswith("converged:")
    assert "current cost" in result.stop_reason
    law = learner.feedback_law()
    assert len(law) == 1
    mode = law[0]
    n_samples = mode["t"].shape[0]
    assert mode["K"].shape == (n_samples, 1, 2)
    assert mode["u_ff"].shape == (n_samples, 1) and mode["x"].shape == (n_samples, 2)
    assert mode["t"][0] == 0.0 and mode["t"][-1] == pytest.approx(T)
    np.testing.assert_allclose(mode["K"], np.broadcast_to(K_care, mode["K"].shape),
                               rtol=1e-8, atol=1e-10)
    law0 = learner.feedback_law(alpha=0.0)[0]
    u = law0["u_ff"] + np.einsum("jmn,jn->jm", law0["K"], law0["x"])
    np.testing.assert_allclose(u, law0["u"], atol=1e-12)


def test_stop_reason_names_the_budget():
    A = np.array([[0.0, 1.0], [2.0, -0.5]])
    system = ddoc.LinearSystem([A], [np.array([[0.0], [1.0]])])
    cost = ddoc.QuadraticCost(Q=[np.eye(2)], R=[np.eye(1)])
    bounds = ddoc.Bounds(u_min=[-np.inf], u_max=[np.inf], duration_min=[2.0],
                         duration_max=[2.0])
    settings = ddoc.LearnerSettings()
    settings.max_trials = 1
    learner = ddoc.Learner(ddoc.Problem(system, cost, bounds, surface_weights=[0.0]), settings)
    result = learner.solve([1.0, 0.0], [2.0])
    assert result.status == "max_trials"
    assert "max_trials = 1" in result.stop_reason
    with pytest.raises(ValueError, match="solve first"):
        ddoc.Learner(ddoc.Problem(system, cost, bounds, surface_weights=[0.0])).feedback_law()


def test_defaults_and_named_errors():
    A = [np.array([[0.6, 1.2], [-0.8, 3.4]]), np.array([[4.0, 3.0], [-1.0, 0.0]])]
    B = [np.array([[1.0], [1.0]]), np.array([[2.0], [-1.0]])]
    # A wrong A[1] is named (it used to blame B[1]).
    with pytest.raises(ValueError, match=r"A\[1\] and B\[1\] disagree"):
        ddoc.LinearSystem([A[0], np.eye(3)], B)
    system = ddoc.LinearSystem(A, B)
    cost3 = ddoc.QuadraticCost(Q=[np.eye(2)] * 3, R=[np.eye(1)] * 3)
    bounds = ddoc.Bounds(u_min=[-np.inf], u_max=[np.inf], duration_min=[0.01, 0.01],
                         duration_max=[2.0, 2.0])
    bounds.fix_final_time(2.0)
    with pytest.raises(ValueError, match="the cost has 3 modes, the system 2"):
        ddoc.Problem(system, cost3, bounds)
    with pytest.raises(ValueError, match="R\\[0\\] of the quadratic cost is singular"):
        ddoc.Problem(system, ddoc.QuadraticCost(Q=[np.eye(2)] * 2, R=[np.zeros((1, 1))] * 2),
                     bounds)
    problem = ddoc.Problem(system, ddoc.QuadraticCost(Q=[np.eye(2)] * 2, R=[np.eye(1)] * 2),
                           bounds)
    with pytest.raises(ValueError, match="initial durations add up to 1.5"):
        ddoc.Learner(problem).solve([0.0, 2.0], [1.0, 0.5])


def test_a_fixed_final_time_bounds_the_durations():
    A = [np.array([[0.6, 1.2], [-0.8, 3.4]]), np.array([[4.0, 3.0], [-1.0, 0.0]])]
    B = [np.array([[1.0], [1.0]]), np.array([[2.0], [-1.0]])]
    bounds = ddoc.Bounds(u_min=[-np.inf], u_max=[np.inf], duration_min=[0.01, 0.01])
    bounds.fix_final_time(2.0)
    cost = ddoc.QuadraticCost(Q=[np.diag([0.0, 1.0])] * 2, R=[np.eye(1)] * 2,
                              S=[np.zeros((2, 2)), np.eye(2)],
                              r=[np.array([0.0, 2.0])] * 2, s=[np.zeros(2), np.array([4.0, 2.0])])
    problem = ddoc.Problem(ddoc.LinearSystem(A, B), cost, bounds)
    result = ddoc.Learner(problem).solve([0.0, 2.0], [1.0, 1.0])
    assert result.status == "converged"
    assert result.cost == pytest.approx(9.7665, rel=1e-3)
