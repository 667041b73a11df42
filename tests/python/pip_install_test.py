"""`pip install .` from the checkout into a fresh venv, offline (ctest python.pip_install).

Usage: pip_install_test.py SOURCE_DIR WORK_DIR [BUILD_DIR]

Makes WORK_DIR/venv (`python -m venv --system-site-packages`: Debian's NumPy), runs the venv's
`pip install --no-index --no-cache-dir SOURCE_DIR` (with pip's build isolation: the in-tree backend
needs nothing from an index) with TMPDIR inside WORK_DIR, then install_check.py with the venv's
Python from an empty directory and no PYTHONPATH: import ddoc from the venv, one solve, run_hopper,
robustness_map with the installed ddoc-hopper. Then `pip uninstall` removes every installed file.
BUILD_DIR (DDOC_CMAKE_BUILD_DIR) reuses a built tree; without it the backend configures and builds
from scratch in TMPDIR. Not a pytest file (its name does not start with test_).
"""
import os
import pathlib
import shutil
import subprocess
import sys
import time


def run(command, **kwargs):
    print("+", " ".join(str(c) for c in command), flush=True)
    done = subprocess.run([str(c) for c in command], text=True, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, **kwargs)
    print(done.stdout, flush=True)
    if done.returncode != 0:
        sys.exit(f"failed ({done.returncode}): {' '.join(str(c) for c in command)}")
    return done.stdout


def main():
    source, work = pathlib.Path(sys.argv[1]).resolve(), pathlib.Path(sys.argv[2]).resolve()
    build = sys.argv[3] if len(sys.argv) > 3 else ""
    shutil.rmtree(work, ignore_errors=True)
    (work / "tmp").mkdir(parents=True)
    (work / "cwd").mkdir()
    venv = work / "venv"
    run([sys.executable, "-m", "venv", "--system-site-packages", venv])
    python = venv / "bin" / "python"
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "DDOC_CMAKE_BUILD_DIR", "PIP_INDEX_URL", "VIRTUAL_ENV")}
    env["TMPDIR"] = str(work / "tmp")
    env["PIP_DISABLE_PIP_VERSION_CHECK"] = "1"
    if build:
        env["DDOC_CMAKE_BUILD_DIR"] = build
    start = time.monotonic()
    run([python, "-m", "pip", "install", "--no-index", "--no-cache-dir", source], env=env,
        cwd=work / "cwd")
    print(f"pip install: {time.monotonic() - start:.1f} s")
    check = pathlib.Path(__file__).with_name("install_check.py")
    run([python, check, venv], env=env, cwd=work / "cwd")
    # The wheel's RECORD lists every file: uninstall leaves none of ddoc's behind.
    run([python, "-m", "pip", "uninstall", "-y", "ddoc"], env=env, cwd=work / "cwd")
    left = [p for p in venv.rglob("*") if "ddoc" in p.name and not p.is_dir()]
    assert not left, f"left after pip uninstall: {left}"
    out = subprocess.run([python, "-c", "import ddoc"], cwd=work / "cwd", env=env, text=True,
                         capture_output=True)
    assert out.returncode != 0, "ddoc still imports after pip uninstall"
    print("pip install / import / uninstall: ok")


if __name__ == "__main__":
    main()
