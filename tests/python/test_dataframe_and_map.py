"""ddoc.to_dataframe with and without pandas (both paths by monkeypatching the import), and
ddoc.robustness_map on a tiny slice: its tables equal the CSVs the tool wrote; Ctrl-C keeps the
finished cases."""
import csv
import math
import os
import pathlib
import signal
import sys
import threading
import types

import numpy as np
import pytest

import ddoc

ROOT = pathlib.Path(__file__).resolve().parents[2]
BIN = pathlib.Path(os.environ.get("DDOC_BIN_DIR", ROOT / "build/bin"))
TABLE = {"hop": np.array([0, 1]), "cost": np.array([3.0, 2.5]), "method": "alg1", "fell": False,
         "trajectory": {"t": np.zeros(3)}}


def test_to_dataframe_without_pandas(monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)  # `import pandas` raises ImportError
    with pytest.raises(ImportError, match="ddoc.to_dataframe needs pandas, which is not installed"):
        ddoc.to_dataframe(TABLE)


def test_to_dataframe_with_a_stand_in_pandas(monkeypatch):
    class DataFrame:
        def __init__(self, columns):
            self.columns, self.attrs = columns, {}

    monkeypatch.setitem(sys.modules, "pandas", types.SimpleNamespace(DataFrame=DataFrame))
    frame = ddoc.to_dataframe(TABLE)
    assert list(frame.columns) == ["hop", "cost"]
    assert frame.columns["cost"] is TABLE["cost"]
    assert frame.attrs == {"method": "alg1", "fell": False}


def test_to_dataframe_with_pandas():
    pandas = pytest.importorskip("pandas")
    frame = ddoc.to_dataframe(TABLE)
    assert isinstance(frame, pandas.DataFrame) and list(frame["cost"]) == [3.0, 2.5]


def hopper_or_skip():
    hopper = BIN / "ddoc-hopper"
    if not hopper.exists():
        pytest.skip(f"{hopper} not built")
    return str(hopper)


def assert_table_equals_csv(table, path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows, path
    assert list(table) == list(rows[0])
    for name, column in table.items():
        assert len(column) == len(rows)
        for value, row in zip(column, rows):
            text = row[name]
            if column.dtype.kind == "U":
                assert value == text, (name, value, text)
            elif text == "":
                assert math.isnan(value), (name, value)
            else:
                assert value == float(text) and type(value.item())(text) == value, (name, text)


def test_robustness_map_tiny_slice_equals_its_csv(tmp_path):
    hopper = hopper_or_skip()
    out = tmp_path / "map"
    tables = ddoc.robustness_map(str(out), maps="mass", methods="ocfb", hops=3, masses=[8],
                                 drags=[0], speeds=[0.5], jobs=1, hopper=hopper)
    assert list(tables) == ["mass"]
    mass = tables["mass"]
    assert_table_equals_csv(mass, out / "mass_map.csv")
    assert list(mass["method"]) == ["ocfb"] and list(mass["mass"]) == [8]
    assert list(mass["exit"]) == [0] and list(mass["hops"]) == [3]
    assert list(mass["survived"]) == [1]


def test_robustness_map_as_frame(tmp_path, monkeypatch):
    hopper = hopper_or_skip()
    frames = []

    class DataFrame:
        def __init__(self, columns):
            self.columns, self.attrs = columns, {}
            frames.append(self)

    monkeypatch.setitem(sys.modules, "pandas", types.SimpleNamespace(DataFrame=DataFrame))
    tables = ddoc.robustness_map(str(tmp_path / "map"), maps=["mass"], methods=["ocfb"], hops=2,
                                 masses=[9], drags=[0.01], speeds=[0.5], jobs=1, hopper=hopper,
                                 as_frame=True)
    assert tables["mass"] is frames[0]
    assert list(tables["mass"].columns["mass"]) == [9]


def test_robustness_map_bad_option(tmp_path):
    hopper = hopper_or_skip()
    with pytest.raises(ValueError, match="--masses"):
        ddoc.robustness_map(str(tmp_path / "m"), maps="mass", masses=["heavy"], hopper=hopper)
    with pytest.raises(FileNotFoundError, match="no_such_tool"):
        ddoc.robustness_map(str(tmp_path / "m"), tool=str(tmp_path / "no_such_tool"))


def test_robustness_map_ctrl_c_keeps_the_finished_cases(tmp_path):
    hopper = hopper_or_skip()
    out = tmp_path / "map"
    runs = out / "runs"

    def interrupt_after_the_first_case():  # the tool writes runs/<case>/ddoc-hopper.log at its end
        while not (runs.exists() and any((d / "ddoc-hopper.log").exists() for d in runs.iterdir())):
            if stop.wait(0.05):
                return
        os.kill(os.getpid(), signal.SIGINT)

    stop = threading.Event()
    watcher = threading.Thread(target=interrupt_after_the_first_case)
    watcher.start()
    try:
        with pytest.raises(ddoc.SolveInterrupted, match="interrupted after") as info:
            ddoc.robustness_map(str(out), maps="mass", methods="ocfb", hops=40,
                                masses=[8, 9, 10], drags=[0], speeds=[0.5], jobs=1, hopper=hopper)
    finally:
        stop.set()
        watcher.join()
    mass = info.value.result["mass"]
    assert 1 <= len(mass["case"]) < 3
    assert list(mass["hops"]) == [40] * len(mass["case"])  # finished cases only
    assert_table_equals_csv(mass, out / "mass_map.csv")
    # No case was started after the interrupt.
    assert len(list(runs.iterdir())) <= len(mass["case"]) + 1
