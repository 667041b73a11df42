"""ddoc.run_hopper gives the numbers of the command line's hops.csv and trajectory.csv, character for
character.

Both run models/scenarios/default.xml for 3 hops with each method (with a push given as numbers in
Python and as --push on the command line, and --preset paper): ddoc-hopper writes the CSVs,
ddoc.run_hopper returns the same columns as arrays, printed here with the CSVs' formats.
"""
import csv
import os
import pathlib
import subprocess

import numpy as np
import pytest

import ddoc

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENARIO = str(ROOT / "models/scenarios/default.xml")
BIN = pathlib.Path(os.environ.get("DDOC_BIN_DIR", ROOT / "build/bin"))

pytestmark = pytest.mark.skipif(not hasattr(ddoc, "run_hopper"),
                                reason="built without the MuJoCo application")

# hops.csv's columns and printf formats (src/app/run_log.cc, RunLog::WriteHop).
FORMATS = [("hop", "%d"), ("t_start", "%.6f"), ("t_end", "%.6f"), ("cost", "%.9g"),
           ("I1", "%.9g"), ("I2", "%.9g"), ("I3", "%.9g"), ("I4", "%.9g"), ("T1", "%.6f"),
           ("T2", "%.6f"), ("step_length", "%.6f"), ("speed", "%.6f"), ("apex", "%.6f"),
           ("alpha", "%.6g"), ("accepted", "%d"), ("du2", "%.9g"), ("dT2", "%.9g"),
           ("start_shift", "%.9g"), ("restarted", "%d"), ("remeasured", "%d"),
           ("learner_cost", "%.9g"), ("nominal_cost", "%.9g"), ("predicted", "%.9g"),
           ("optimality", "%.9g"), ("stance_mass", "%.6f"), ("reverted", "%d"),
           ("identified_mass", "%.6f"), ("model_mass", "%.6f"), ("latched", "%d")]


# trajectory.csv's columns and formats (RunLog::WriteSample): t, hop, phase, 14 coordinates and
# rates, 4 inputs, push.
TRAJECTORY_FORMATS = ["%.6f", "%d", "%d"] + ["%.7g"] * 18 + ["%.4g"]

# Per method, extra overrides given to both: a push by hop phase (a tuple in Python, a string on the
# command line), the paper preset.
EXTRA = {"alg1": ([(2, 0.25, 20.0, 0.1)], ["--push", "2@0.25,20,0.1"], ""),
         "mrl": ([], [], ""),
         "ocfb": ([(0.4, -15.0, 0.05)], ["--push", "0.4,-15,0.05", "--preset", "paper"], "paper")}


def cli_run(tmp_path, args):
    cli = BIN / "ddoc-hopper"
    if not cli.exists():
        pytest.skip(f"{cli} not built")
    out = tmp_path / "cli"
    run = subprocess.run([str(cli), SCENARIO, *args, "--out", str(out)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    return out


@pytest.mark.parametrize("method", ["alg1", "mrl", "ocfb"])
def test_run_hopper_equals_cli_hops_and_trajectory_csv(tmp_path, method):
    pushes, push_args, preset = EXTRA[method]
    out = cli_run(tmp_path, ["--hops", "3", "--method", method, *push_args])
    with open(out / "hops.csv") as f:
        rows = list(csv.DictReader(f))
    table = ddoc.run_hopper(SCENARIO, method=method, hops=3, pushes=pushes, preset=preset)
    assert table["method"] == method and not table["fell"]
    assert len(rows) == len(table["hop"]) == 3
    for i, row in enumerate(rows):
        for name, fmt in FORMATS:
            assert fmt % table[name][i] == row[name], (i, name, table[name][i], row[name])
        assert row["method"] == method
    with open(out / "trajectory.csv") as f:
        lines = f.read().splitlines()
    trajectory = table["trajectory"]
    assert lines[0].split(",") == list(trajectory)  # the same columns in the same order
    assert len(lines) - 1 == len(trajectory["t"]) > 1000
    columns = list(trajectory.values())
    for i, line in enumerate(lines[1:]):
        mine = ",".join(fmt % c[i] for fmt, c in zip(TRAJECTORY_FORMATS, columns))
        assert mine == line, (i, mine, line)
    if pushes:  # the push acted
        assert max(abs(trajectory["push"])) > 0


def test_run_hopper_pushes_as_numbers_equal_strings():
    kw = dict(method="ocfb", hops=3, log_every=0)
    numbers = ddoc.run_hopper(SCENARIO, pushes=[(0.3, 25.0, 0.1), (2, 0.5, -10.0, 0.05)], **kw)
    strings = ddoc.run_hopper(SCENARIO, pushes=["0.3,25,0.1", "2@0.5,-10,0.05"], **kw)
    plain = ddoc.run_hopper(SCENARIO, **kw)
    for name, _ in FORMATS:  # NaN (the learner's columns of OC-FB hops) equals NaN here
        np.testing.assert_array_equal(numbers[name], strings[name], err_msg=name)
    assert list(numbers["cost"]) != list(plain["cost"])  # the pushes changed the run
    assert len(numbers["trajectory"]["t"]) == 0  # log_every=0: no trajectory


def test_run_hopper_law_cache(tmp_path):
    # The first run solves u^0 and stores it, the second loads it: the same table.
    kw = dict(method="alg1", hops=2, log_every=0, law_cache=str(tmp_path / "laws"))
    first = ddoc.run_hopper(SCENARIO, **kw)
    second = ddoc.run_hopper(SCENARIO, **kw)
    laws = list((tmp_path / "laws").glob("u0-*.law"))
    assert len(laws) == 1
    assert first["initial_law"] == "stored " + str(laws[0])
    assert second["initial_law"] == "loaded " + str(laws[0])
    for name, _ in FORMATS:
        np.testing.assert_array_equal(first[name], second[name], err_msg=name)


def test_run_hopper_substep_events():
    # --substep-events: each hop starts where the previous one ended (at the located takeoff);
    # at the step (default) one step (0.5 ms) after it, and T1 on the step grid.
    kw = dict(method="ocfb", hops=3, log_every=0)
    step = ddoc.run_hopper(SCENARIO, **kw)
    inside = ddoc.run_hopper(SCENARIO, substep_events=True, **kw)
    np.testing.assert_allclose(step["t_start"][1:] - step["t_end"][:-1], 0.0005, atol=1e-9)
    np.testing.assert_array_equal(inside["t_start"][1:], inside["t_end"][:-1])
    np.testing.assert_allclose(step["T1"] / 0.0005, np.round(step["T1"] / 0.0005), atol=1e-6)
    assert np.all(np.abs(inside["T1"] / 0.0005 - np.round(inside["T1"] / 0.0005)) > 1e-3)


def test_run_hopper_identify():
    # identify=True (--identify): u^0 is solved again on the 8 kg robot's mass after the first
    # stance; the model_mass column says from which hop on; identify=False is the plain run.
    kw = dict(method="ocfb", hops=8, log_every=0)
    plain = ddoc.run_hopper(SCENARIO, **kw)
    off = ddoc.run_hopper(SCENARIO, identify=False, preset="identified", **kw)
    on = ddoc.run_hopper(SCENARIO, identify=True, **kw)
    np.testing.assert_array_equal(plain["cost"], off["cost"])
    assert plain["resolves"] == [] and off["resolves"] == []
    assert len(on["resolves"]) == 1
    r = on["resolves"][0]
    assert r["hop"] == 0 and abs(r["mass"] - 8.001) < 0.01
    took_over = r["took_over_hop"]
    assert 0 < took_over < 8
    np.testing.assert_array_equal(on["model_mass"][:took_over], 10.0)
    np.testing.assert_array_equal(on["model_mass"][took_over:], r["mass"])
    np.testing.assert_allclose(on["identified_mass"], 8.001, atol=0.01)


def test_run_hopper_identify_terms():
    # identify_terms=True (--identify-terms) on the 8 kg robot (c_d 0.01) with the 10 kg drag-free
    # model: u^0 is re-solved on the drag after the first hop, the mass stays the model's (that
    # is identify=True); no dampers, level floor, the body's inertia as the model's.
    kw = dict(method="ocfb", hops=3, log_every=0)
    plain = ddoc.run_hopper(SCENARIO, **kw)
    off = ddoc.run_hopper(SCENARIO, identify_terms=False, **kw)
    np.testing.assert_array_equal(plain["cost"], off["cost"])
    assert off["resolves"] == []
    on = ddoc.run_hopper(SCENARIO, identify_terms=True, **kw)
    assert len(on["resolves"]) == 1
    r = on["resolves"][0]
    assert r["hop"] == 0 and abs(r["c_d"] - 0.01) < 2e-4 and r["mass"] == 10.0
    assert r["b_leg"] == 0.0 and r["b_hip"] == 0.0 and r["slope"] == 0.0
    assert r["j_body"] == 2.5
    both = ddoc.run_hopper(SCENARIO, identify=True, identify_terms=True, **kw)
    assert abs(both["resolves"][0]["mass"] - 8.001) < 0.01
    # identify_terms_acted: the drag left out re-solves nothing; a bad list names the term.
    no_drag = ddoc.run_hopper(SCENARIO, identify_terms=True, identify_terms_acted="b_leg,slope",
                              **kw)
    assert no_drag["resolves"] == []
    np.testing.assert_array_equal(no_drag["cost"], plain["cost"])
    with pytest.raises(ValueError, match='identify_terms_acted: .*unknown term "drag"'):
        ddoc.run_hopper(SCENARIO, identify_terms=True, identify_terms_acted="drag", **kw)


def test_run_hopper_log_every():
    every = ddoc.run_hopper(SCENARIO, method="ocfb", hops=1)["trajectory"]
    tenth = ddoc.run_hopper(SCENARIO, method="ocfb", hops=1, log_every=10)["trajectory"]
    assert len(tenth["t"]) == len(every["t"]) // 10
    assert list(tenth["x"]) == list(every["x"][9::10][:len(tenth["x"])])


def test_run_hopper_progress_rows_and_exception():
    rows = []
    table = ddoc.run_hopper(SCENARIO, method="alg1", hops=3, log_every=0, progress=rows.append)
    assert [r["hop"] for r in rows] == [0, 1, 2]
    for i, row in enumerate(rows):
        assert set(row) == {name for name in table if name not in (
            "trajectory", "method", "fell", "fall_reason", "sim_time", "frames", "initial_law",
            "resolves")}
        for name, value in row.items():
            assert value == table[name][i], (i, name)

    class Stop(Exception):
        pass

    def stop_at_second(row):
        if row["hop"] == 1:
            raise Stop("from the callback")

    with pytest.raises(Stop, match="from the callback"):
        ddoc.run_hopper(SCENARIO, method="alg1", hops=5, progress=stop_at_second)
    # The controller was detached: the next run runs.
    assert len(ddoc.run_hopper(SCENARIO, method="ocfb", hops=1, log_every=0)["hop"]) == 1


def test_run_hopper_render(tmp_path):
    frames = tmp_path / "frames"
    if not ddoc.HAVE_RENDER:
        with pytest.raises(ValueError, match="render"):
            ddoc.run_hopper(SCENARIO, hops=1, render_dir=str(frames))
        return
    table = ddoc.run_hopper(SCENARIO, method="ocfb", hops=1, render_dir=str(frames), width=96,
                            height=64, fps=20, log_every=0)
    files = sorted(frames.glob("frame_*.png"))
    assert table["frames"] == len(files)
    # One frame per 1/fps of simulated time, the first at t = 0 (FrameRecorder's clock).
    assert len(files) == int(table["sim_time"] * 20 + 1e-9) + 1
    assert files[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ValueError, match="width"):
        ddoc.run_hopper(SCENARIO, hops=1, render_dir=str(frames), width=-5)


def test_run_hopper_bad_input():
    with pytest.raises(ValueError, match="method"):
        ddoc.run_hopper(SCENARIO, method="bogus", hops=1)
    with pytest.raises(ValueError, match="preset \"bogus\": expected default, paper or identified"):
        ddoc.run_hopper(SCENARIO, preset="bogus", hops=1)
    with pytest.raises(ValueError, match=r"pushes\[1\]: expected \(time, force, duration\) or "
                       r"\(hop, phase, force, duration\), got a sequence of length 2"):
        ddoc.run_hopper(SCENARIO, pushes=[(0.1, 1.0, 0.1), (1.0, 2.0)], hops=1)
    with pytest.raises(ValueError, match=r"pushes\[0\]\[1\]: expected a number, got 'a'"):
        ddoc.run_hopper(SCENARIO, pushes=[(0.1, "a", 0.1)], hops=1)
    with pytest.raises(ValueError, match=r"pushes\[0\]: .*duration > 0"):
        ddoc.run_hopper(SCENARIO, pushes=[(0.1, 5.0, -0.1)], hops=1)
    with pytest.raises(ValueError, match=r'pushes\[0\]: --push "1@1.5,5.0,0.1": hop must be an '
                       r"integer >= 1, phase in \[0, 1\)"):
        ddoc.run_hopper(SCENARIO, pushes=[(1, 1.5, 5.0, 0.1)], hops=1)
    with pytest.raises(ValueError, match="log_every must be >= 0, got -1"):
        ddoc.run_hopper(SCENARIO, hops=1, log_every=-1)
    with pytest.raises(ValueError, match="progress: expected a callable"):
        ddoc.run_hopper(SCENARIO, hops=1, progress=3)
    with pytest.raises(ValueError, match="no_such_file.xml"):
        ddoc.run_hopper(str(ROOT / "no_such_file.xml"), hops=1)


def test_run_hopper_ctrl_c_keeps_partial_table():
    import signal
    import threading
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(ddoc.SolveInterrupted) as info:
            ddoc.run_hopper(SCENARIO, method="ocfb", hops=5000)
    finally:
        timer.cancel()
    table = info.value.result
    assert 0 < len(table["hop"]) < 5000
    assert list(table["hop"]) == list(range(len(table["hop"])))


def test_run_hopper_non_finite_state_raises_run_failed(tmp_path, monkeypatch):
    # A 1e300 N push makes MuJoCo's qacc huge; MuJoCo warns and resets the state. The run must end
    # there (ddoc-hopper's exit 6), with the hops before it, not go on from the reset pose.
    monkeypatch.chdir(tmp_path)
    with pytest.warns(RuntimeWarning, match="MuJoCo warning: Nan, Inf or huge value in QACC"):
        with pytest.raises(ddoc.RunFailed, match="non-finite state: MuJoCo found a NaN, Inf or "
                                                 "huge value in qacc at t = 1.5005 s") as info:
            ddoc.run_hopper(SCENARIO, hops=20, pushes=["1.5,1e300,0.05"], log_every=0)
    assert info.value.end == "nonfinite_state"
    table = info.value.result
    assert len(table["hop"]) >= 1 and list(table["hop"]) == list(range(len(table["hop"])))
    # sim_time is the last finite state's (the message's t), not the reset's 0.0005 s.
    assert table["t_end"][-1] <= 1.5 and table["sim_time"] == pytest.approx(1.5005, abs=1e-9)
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


def test_run_hopper_measured_latency():
    # offline_latency="measured": a law never takes effect sooner than its offline part took on
    # this computer, and never sooner than the 0.02 s floor; the modeled default, never sooner
    # than the model's time for its passes' steps; a fixed one reports its offline times too.
    table = ddoc.run_hopper(SCENARIO, hops=5, offline_latency="measured", log_every=0)
    offline, latency = table["offline_ms"], table["latency_ms"]
    learned = np.isfinite(latency)
    assert learned.any()
    assert np.all(latency[learned] >= offline[learned])
    assert np.all(latency[learned] >= 20.0)
    modeled = ddoc.run_hopper(SCENARIO, hops=5, log_every=0)
    learned = np.isfinite(modeled["latency_ms"])
    model_ms = 1.0 + 3.6e-3 * modeled["offline_steps"][learned]
    assert np.allclose(modeled["latency_ms"][learned], np.maximum(20.0, model_ms), rtol=1e-12)
    assert modeled["offline_steps"][0] > 1000  # hop 0 initializes the learner: a pass
    fixed = ddoc.run_hopper(SCENARIO, hops=5, log_every=0, offline_latency=0.02)
    assert np.all(fixed["latency_ms"][np.isfinite(fixed["latency_ms"])] == 20.0)
    assert np.nanmax(fixed["offline_ms"]) > 0
    with pytest.raises(ValueError,
                       match=r'offline_latency "soon": expected a number of s, "modeled" or "measured"'):
        ddoc.run_hopper(SCENARIO, hops=1, offline_latency="soon")
    with pytest.raises(ValueError, match=r"^offline_latency: expected a number of s"):
        ddoc.run_hopper(SCENARIO, hops=1, offline_latency=[1])
