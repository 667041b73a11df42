"""The Python examples run (headless matplotlib backend) and produce their figure."""
import os
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_two_mode_lq_example(tmp_path):
    out = tmp_path / "two_mode_lq.png"
    env = dict(os.environ, MPLBACKEND="Agg")
    run = subprocess.run([sys.executable, str(ROOT / "examples/python/two_mode_lq.py"), str(out)],
                         env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert run.stdout.startswith("converged after"), run.stdout
    assert out.stat().st_size > 10000
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_hopper_methods_example(tmp_path):
    import ddoc
    if not hasattr(ddoc, "run_hopper"):
        import pytest
        pytest.skip("built without the MuJoCo application")
    out = tmp_path / "hopper_methods.png"
    env = dict(os.environ, MPLBACKEND="Agg")
    run = subprocess.run([sys.executable, str(ROOT / "examples/python/hopper_methods.py"),
                          str(out), "6"], env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert [line.split(":")[0] for line in lines] == ["alg1", "mrl", "ocfb"], run.stdout
    assert all("6 hops" in line for line in lines), run.stdout
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
