"""A Plant written in Python (ddoc.Plant subclass, a pybind11 trampoline): a Python RK4 plant of the
same system gives Learner.solve the result of the engine's ModelPlant (to 1e-12), of another system
the result of plant=that System (model error); a plant delegating to ddoc.ModelPlant the identical
result; errors name what is wrong."""
import numpy as np
import pytest

import ddoc

A = [np.array([[0.6, 1.2], [-0.8, 3.4]]), np.array([[4.0, 3.0], [-1.0, 0.0]])]
B = [np.array([[1.0], [1.0]]), np.array([[2.0], [-1.0]])]


def problem(a=A):
    system = ddoc.LinearSystem(a, B)
    cost = ddoc.QuadraticCost(Q=[np.diag([0.0, 1.0])] * 2, R=[np.eye(1)] * 2,
                              S=[np.zeros((2, 2)), np.eye(2)], r=[np.array([0.0, 2.0])] * 2,
                              s=[np.zeros(2), np.array([4.0, 2.0])])
    bounds = ddoc.Bounds(u_min=[-np.inf], u_max=[np.inf], duration_min=[0.01, 0.01],
                         duration_max=[2.0, 2.0])
    bounds.fix_final_time(2.0)
    return ddoc.Problem(system, cost, bounds), system, bounds


class Rk4Plant(ddoc.Plant):
    """Classical RK4 of `system` at step dt, inputs held over a step, every mode ended at its planned
    duration clamped into the duration bounds (time-based switching: ModelPlant's rule for a
    system without surfaces), the step shortened to land on it."""

    def __init__(self, system, duration_min, duration_max, dt=1e-3):
        super().__init__()
        self.system, self.dmin, self.dmax, self.dt = system, duration_min, duration_max, dt
        self.runs = 0

    def run(self, x0, policy):
        self.runs += 1
        f = self.system.flow
        policy.begin_trial()
        x, t, ts, xs, us = np.array(x0, dtype=float), 0.0, [], [], []
        for k in range(self.system.num_modes):
            end = min(max(policy.planned_duration(k), self.dmin[k]), self.dmax[k])
            start, elapsed, mt, mx, mu = t, 0.0, [], [], []
            while True:
                u = policy.step(k, elapsed, x)
                mt.append(t), mx.append(x), mu.append(u)
                h = self.dt
                if elapsed < self.dmin[k]:
                    h = min(h, self.dmin[k] - elapsed)
                h = min(h, end - elapsed)
                k1 = f(k, x, u)
                k2 = f(k, x + 0.5 * h * k1, u)
                k3 = f(k, x + 0.5 * h * k2, u)
                k4 = f(k, x + h * k3, u)
                x = x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
                elapsed += h
                if end - elapsed <= 1e-12 * (1.0 + end):
                    elapsed = end
                t = start + elapsed
                if elapsed >= end:
                    break
            mt.append(t), mx.append(x), mu.append(u)  # the pre-switch state, the last input held
            ts.append(np.array(mt)), xs.append(np.array(mx).T), us.append(np.array(mu).T)
            if k + 1 < self.system.num_modes:
                x = self.system.reset(k, x)
        return ddoc.Trajectory(ts, xs, us)


class Delegating(ddoc.Plant):
    def __init__(self, inner):
        super().__init__()
        self.inner = inner

    def run(self, x0, policy):
        return self.inner.run(x0, policy)


def solve(plant=None, method="alg1"):
    prob, _, _ = problem()
    return ddoc.Learner(prob).solve(x0=[0.0, 2.0], durations=[1.0, 1.0], plant=plant,
                                    method=method)


def assert_same(a, b, tol):
    assert (a.status, a.trials, a.iterations) == (b.status, b.trials, b.iterations)
    assert a.cost == pytest.approx(b.cost, rel=tol, abs=tol)
    np.testing.assert_allclose(a.T, b.T, rtol=0, atol=tol)
    np.testing.assert_allclose(a.cost_history, b.cost_history, rtol=tol, atol=tol)


def test_python_rk4_plant_equals_model_plant():
    _, system, bounds = problem()
    plant = Rk4Plant(system, bounds.duration_min, bounds.duration_max)
    mine, engine = solve(plant), solve()
    assert mine.status == "converged" and plant.runs == mine.trials + 1  # + the initial trial
    assert_same(mine, engine, 1e-12)


def test_python_rk4_plant_of_another_system_is_model_error():
    other = [a * 1.1 for a in A]
    _, system, bounds = problem(other)
    mine = solve(Rk4Plant(system, bounds.duration_min, bounds.duration_max))
    engine = solve(ddoc.LinearSystem(other, B))
    assert_same(mine, engine, 1e-12)
    assert abs(mine.cost - solve().cost) > 1e-3  # the plant's error shows
    mrl = solve(Rk4Plant(system, bounds.duration_min, bounds.duration_max), method="mrl")
    assert_same(mrl, solve(ddoc.LinearSystem(other, B), method="mrl"), 1e-12)


def test_plant_delegating_to_model_plant_is_identical():
    _, system, bounds = problem()
    mine, engine = solve(Delegating(ddoc.ModelPlant(system, bounds))), solve()
    assert_same(mine, engine, 0.0)


def test_plant_errors():
    class NoRun(ddoc.Plant):
        pass

    with pytest.raises(ValueError, match="a subclass must define run"):
        solve(NoRun())

    class WrongType(ddoc.Plant):
        def run(self, x0, policy):
            return [x0]

    with pytest.raises(ValueError, match="Plant.run returned list, expected a ddoc.Trajectory"):
        solve(WrongType())

    class Boom(Exception):
        pass

    class Raises(ddoc.Plant):
        def run(self, x0, policy):
            raise Boom("inside run")

    with pytest.raises(Boom, match="inside run"):
        solve(Raises())

    kept = []

    class Keeps(Delegating):
        def run(self, x0, policy):
            kept.append(policy)
            return super().run(x0, policy)

    _, system, bounds = problem()
    solve(Keeps(ddoc.ModelPlant(system, bounds)))
    with pytest.raises(ValueError, match="used outside the Plant.run it was given to"):
        kept[0].step(0, 0.0, [0.0, 2.0])
    with pytest.raises(ValueError, match="plant: expected None, a System or a Plant, got str"):
        solve("model")


def test_trajectory_constructor_errors():
    t, x, u = [np.array([0.0, 1.0])], [np.zeros((2, 2))], [np.zeros((1, 2))]
    traj = ddoc.Trajectory(t, x, u)
    assert list(traj.T) == [1.0] and list(traj.x0) == [0.0, 0.0]
    with pytest.raises(ValueError, match=r"x\[0\]: shape \(2, 3\), expected \(any, 2\)"):
        ddoc.Trajectory(t, [np.zeros((2, 3))], u)
    with pytest.raises(ValueError, match="t, x and u have 1, 2 and 1 modes"):
        ddoc.Trajectory(t, x * 2, u)
