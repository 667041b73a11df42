"""ddoc.run_hopper gives the numbers of the command line's hops.csv, character for character.

Both run models/scenarios/default.xml for 3 hops with each method: ddoc-hopper writes hops.csv,
ddoc.run_hopper returns the same columns as arrays, printed here with hops.csv's formats.
"""
import csv
import os
import pathlib
import subprocess

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
           ("alpha", "%.6g"), ("accepted", "%d"), ("du2", "%.9g"), ("dT2", "%.9g")]


@pytest.mark.parametrize("method", ["alg1", "mrl", "ocfb"])
def test_run_hopper_equals_cli_hops_csv(tmp_path, method):
    cli = BIN / "ddoc-hopper"
    if not cli.exists():
        pytest.skip(f"{cli} not built")
    out = tmp_path / "cli"
    run = subprocess.run([str(cli), SCENARIO, "--hops", "3", "--method", method, "--out", str(out)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    with open(out / "hops.csv") as f:
        rows = list(csv.DictReader(f))
    table = ddoc.run_hopper(SCENARIO, method=method, hops=3)
    assert table["method"] == method and not table["fell"]
    assert len(rows) == len(table["hop"]) == 3
    for i, row in enumerate(rows):
        for name, fmt in FORMATS:
            assert fmt % table[name][i] == row[name], (i, name, table[name][i], row[name])
        assert row["method"] == method


def test_run_hopper_bad_input():
    with pytest.raises(ValueError, match="method"):
        ddoc.run_hopper(SCENARIO, method="bogus", hops=1)
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
