"""Solving from Python: settings attributes, model error plants, progress, Ctrl-C, nominal."""
import os
import signal
import threading

import numpy as np
import pytest

import ddoc
from standard_pose import pose


def two_mode_problem(gain=1.0):
    A = [np.array([[0.6, 1.2], [-0.8, 3.4]]), np.array([[4.0, 3.0], [-1.0, 0.0]])]
    B = [gain * np.array([[1.0], [1.0]]), gain * np.array([[2.0], [-1.0]])]
    system = ddoc.LinearSystem(A, B)
    cost = ddoc.QuadraticCost(Q=[np.diag([0.0, 1.0])] * 2, R=[np.eye(1)] * 2,
                              S=[np.zeros((2, 2)), np.eye(2)],
                              r=[np.array([0.0, 2.0])] * 2, s=[np.zeros(2), np.array([4.0, 2.0])])
    bounds = ddoc.Bounds(u_min=[-np.inf], u_max=[np.inf], duration_min=[0.01, 0.01],
                         duration_max=[2.0, 2.0])
    bounds.fix_final_time(2.0)
    return ddoc.Problem(system, cost, bounds), system


def test_settings_presets_and_attributes():
    default, paper = ddoc.LearnerSettings(), ddoc.LearnerSettings.paper()
    assert ddoc.LearnerSettings.preset("default").acceptance == default.acceptance
    assert paper.acceptance == ddoc.Acceptance.SUFFICIENT_DECREASE
    assert default.acceptance == ddoc.Acceptance.PREDICTED_DECREASE
    assert paper.step_convergence and not default.step_convergence
    default.max_trials = 3
    default.backward.box_aware = False
    assert default.max_trials == 3 and not default.backward.box_aware
    assert paper.backward.equation == ddoc.BackwardEquation.LYAPUNOV
    assert ddoc.LearnerSettings().backward.equation == ddoc.BackwardEquation.RICCATI
    default.switching.max_duration_step = 0.05
    default.controller.warm_start = False
    assert default.switching.max_duration_step == 0.05 and not default.controller.warm_start
    assert default.curvature_scale_min == 1.0 / 16
    default.curvature_scale_min = 0.5
    assert default.curvature_scale_min == 0.5


def test_max_trials_and_progress():
    problem, _ = two_mode_problem()
    settings = ddoc.LearnerSettings()
    settings.max_trials = 3
    seen = []
    r = ddoc.Learner(problem, settings).solve([0.0, 2.0], [1.0, 1.0], progress=seen.append)
    assert r.status == "max_trials" and r.trials == 3
    assert [s["trial"] for s in seen] == [1, 2, 3]
    assert len(r.cost_history) == r.iterations + 1


def test_model_error_plant_alg1_and_mrl():
    """Learning on a plant with 20 % more input gain than the model.

    The direction comes from the wrong model's derivatives, so the learner stops near, not at,
    the plant's optimum (here 2 %; the line search ends it): the measured cost must fall from
    the initial trial's to within 5 % of the optimum of the plant (solved with the exact model).
    """
    problem, _ = two_mode_problem()
    true_problem, true_system = two_mode_problem(gain=1.2)
    exact = ddoc.Learner(true_problem).solve([0.0, 2.0], [1.0, 1.0])
    assert exact.status == "converged"
    for method in ("alg1", "mrl"):
        r = ddoc.Learner(problem).solve([0.0, 2.0], [1.0, 1.0], plant=true_system, method=method)
        assert r.status in ("converged", "line_search_failed"), (method, r)
        assert r.cost < 1.05 * exact.cost, (method, r.cost, exact.cost)
        assert r.cost < 1e-3 * r.cost_history[0]
    # The plant is really different: the model's own optimum costs more on it.
    model_only = ddoc.Learner(problem).solve([0.0, 2.0], [1.0, 1.0])
    assert abs(model_only.cost - exact.cost) > 0.1 * exact.cost


def test_initial_input_callable_and_nominal_arrays():
    problem, _ = two_mode_problem()
    calls = []

    def u0(k, tau, x):
        calls.append(k)
        return [0.1 * tau]
    learner = ddoc.Learner(problem)
    r = learner.solve([0.0, 2.0], [1.0, 1.0], u0=u0)
    assert calls and r.status == "converged"
    nominal = learner.nominal
    assert len(nominal.modes) == 2
    for k, mode in enumerate(nominal.modes):
        assert mode.x.shape == (2, mode.t.size) and mode.u.shape == (1, mode.t.size)
        assert abs(mode.t[-1] - nominal.T[k]) < 1e-12
    np.testing.assert_array_equal(nominal.T, r.T)


def test_ctrl_c_keeps_partial_result():
    """SIGINT while C++ runs trials (GIL released) raises SolveInterrupted between trials."""
    problem, _, _, _ = pose("lqr")
    settings = ddoc.LearnerSettings()
    settings.alpha_initial = 1e-3  # tiny steps: thousands of trials, seconds of work
    settings.max_trials = 100000
    timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt) as info:
            ddoc.Learner(problem, settings).solve([1.0, 0.0], [4.0])
    finally:
        timer.cancel()
    assert isinstance(info.value, ddoc.SolveInterrupted)
    partial = info.value.result
    assert partial.interrupted
    assert 0 < partial.trials < settings.max_trials
    assert len(partial.cost_history) == partial.iterations + 1
    assert partial.cost <= partial.cost_history[0]


def test_ctrl_c_during_a_python_model_keeps_partial_result():
    """SIGINT while a CallbackSystem's model is simulated (the GIL held for the run, issue 46):
    the KeyboardInterrupt raised in a flow call ends the solve as SolveInterrupted."""
    import ddoc_testing
    from standard_pose import exp1_python_cost, exp1_system, suite_bounds
    d = ddoc_testing.data("exp1")
    problem = ddoc.Problem(exp1_system("batch"), exp1_python_cost(d, "batch"),
                           suite_bounds(3, [-np.inf], [np.inf], d["final_time"]))
    settings = ddoc.LearnerSettings()
    settings.alpha_initial = 1e-4  # tiny steps: hundreds of trials of ~10 ms
    settings.max_trials = 100000
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(ddoc.SolveInterrupted) as info:
            ddoc.Learner(problem, settings).solve(d["x0"], d["initial_durations"])
    finally:
        timer.cancel()
    assert info.value.result.interrupted and 0 < info.value.result.trials < settings.max_trials


def test_keyboard_interrupt_from_a_callback_keeps_partial_result():
    """A KeyboardInterrupt raised in Python during the solve (here: the progress callback)."""
    problem, _ = two_mode_problem()

    def progress(info):
        if info["trial"] == 3:
            raise KeyboardInterrupt
    with pytest.raises(ddoc.SolveInterrupted) as info:
        ddoc.Learner(problem).solve([0.0, 2.0], [1.0, 1.0], progress=progress)
    assert info.value.result.trials == 3 and info.value.result.interrupted


def test_gil_is_released_during_a_cpp_solve():
    """Another Python thread runs while a matrix-given problem is solved in C++.

    The thread sleeps 1 ms and stamps the time, again and again (little CPU, so a loaded
    machine does not starve it). Each stamp needs the GIL: held by a C++ trial (~0.1 s here),
    the thread could stamp only between trials, about once per trial; released, it stamps
    every few ms. Checked to fail with the release removed from Learner.solve.
    """
    import time
    problem, _, _, _ = pose("sto9_linear")
    settings = ddoc.LearnerSettings()
    settings.max_trials = 5
    settings.max_samples = 200000
    stamps = []
    stop = threading.Event()

    def stamp():
        while not stop.is_set():
            time.sleep(0.001)
            stamps.append(time.perf_counter())
    thread = threading.Thread(target=stamp)
    thread.start()
    try:
        time.sleep(0.01)
        start = time.perf_counter()
        r = ddoc.Learner(problem, settings).solve([1.0, 1.0], np.full(9, 1.0 / 9), dt=1e-5)
        end = time.perf_counter()
    finally:
        stop.set()
        thread.join()
    during = sum(1 for t in stamps if start <= t < end)
    trials = r.trials + 1
    assert during > 5 * trials, (during, trials, end - start)
