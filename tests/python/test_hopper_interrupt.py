"""Ctrl-C during ddoc.run_hopper with a progress callback keeps the completed hops (issue 47).

Python runs its SIGINT handler in the next Python code it executes; with a progress callback that is
the callback, so the KeyboardInterrupt is raised inside it. run_hopper must end the run as on a
Ctrl-C between steps: ddoc.SolveInterrupted with the table of the hops done in .result.
"""
import math
import os
import pathlib
import signal
import threading

import pytest

import ddoc

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENARIO = str(ROOT / "models/scenarios/default.xml")

pytestmark = pytest.mark.skipif(not hasattr(ddoc, "run_hopper"),
                                reason="built without the MuJoCo application")


def _interrupted(**kwargs):
    """The SolveInterrupted of run_hopper(SCENARIO, **kwargs); a plain KeyboardInterrupt (which
    would end pytest) or none is a failure."""
    try:
        ddoc.run_hopper(SCENARIO, **kwargs)
    except ddoc.SolveInterrupted as e:
        return e
    except KeyboardInterrupt as e:
        pytest.fail(f"a plain {type(e).__name__} from the callback: the hops done are lost")
    pytest.fail("run_hopper was not interrupted")


def _check_partial(error, rows):
    table = error.result
    assert isinstance(error, KeyboardInterrupt)
    assert "interrupted after %d hops" % len(rows) in str(error)
    assert list(table["hop"]) == [r["hop"] for r in rows]
    for i, row in enumerate(rows):
        for name, value in row.items():
            assert value == table[name][i] or (math.isnan(value) and math.isnan(table[name][i])), (
                i, name)


def test_ctrl_c_in_the_callback_keeps_the_hops():
    # SIGINT sent to this process from inside the callback at hop 1: the handler raises
    # KeyboardInterrupt in the callback (signal.raise_signal runs it before returning).
    rows = []

    def progress(row):
        rows.append(row)
        if row["hop"] == 1:
            signal.raise_signal(signal.SIGINT)
        assert row["hop"] <= 1, "the run went on after Ctrl-C"

    error = _interrupted(method="ocfb", hops=6, log_every=0, progress=progress)
    assert [r["hop"] for r in rows] == [0, 1]
    _check_partial(error, rows)


def test_keyboard_interrupt_raised_by_the_callback_keeps_the_hops():
    rows = []

    def progress(row):
        rows.append(row)
        if row["hop"] == 2:
            raise KeyboardInterrupt

    error = _interrupted(method="ocfb", hops=6, log_every=0, progress=progress)
    _check_partial(error, rows)
    assert len(error.result["hop"]) == 3
    # The controller was detached: the next run runs.
    assert len(ddoc.run_hopper(SCENARIO, method="ocfb", hops=1, log_every=0)["hop"]) == 1


def test_ctrl_c_from_outside_with_a_do_nothing_callback():
    # The case: `progress=lambda row: None` and a Ctrl-C at any time. Wherever the signal
    # lands (in the callback or between steps), the result is SolveInterrupted with the hops done.
    hops = []
    timer = threading.Timer(1.0, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    try:
        error = _interrupted(method="ocfb", hops=5000, log_every=0,
                             progress=lambda row: hops.append(row["hop"]))
    finally:
        timer.cancel()
    table = error.result
    assert 0 < len(table["hop"]) < 5000
    assert list(table["hop"]) == list(range(len(table["hop"])))
    # A KeyboardInterrupt raised as the callback starts leaves that hop's row in the table only.
    assert list(table["hop"][:len(hops)]) == hops and len(table["hop"]) - len(hops) in (0, 1)
