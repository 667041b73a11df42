"""`import ddoc` from an interpreter that cannot use the module says why (issue 47).

A venv without the system's site packages has no NumPy (as a pyenv or venv Python first on PATH):
the ImportError names NumPy, the running interpreter and the Python the module was built for,
instead of pybind11's bare `ImportError: initialization failed`. A module file built for another
Python version is named with both versions.
"""
import os
import pathlib
import shutil
import subprocess
import sys
import sysconfig

import ddoc
from ddoc import _config

PACKAGE = pathlib.Path(ddoc.__file__).resolve().parent


def _import(python, path, cwd):
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    env["PYTHONPATH"] = str(path)
    return subprocess.run([str(python), "-c", "import ddoc"], cwd=cwd, env=env, text=True,
                          capture_output=True, timeout=120)


def test_import_without_numpy_names_numpy_and_both_pythons(tmp_path):
    venv = tmp_path / "venv"  # no --system-site-packages: Debian's NumPy is not visible
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    python = venv / "bin" / "python"
    assert subprocess.run([str(python), "-c", "import numpy"], capture_output=True).returncode
    out = _import(python, PACKAGE.parent, tmp_path)
    assert out.returncode != 0
    last = out.stderr.strip().splitlines()[-1]
    assert last.startswith("ImportError: ddoc needs NumPy, which the running interpreter "
                           f"{python} (Python "), out.stderr
    assert f"built for {_config.PYTHON} (Python {_config.PYTHON_VERSION})" in last, last
    assert "No module named 'numpy'" in last, last
    assert "initialization failed" not in out.stderr


def test_module_built_for_another_python_names_both(tmp_path):
    # The package with its module renamed as one built for CPython 3.99: this interpreter cannot
    # load it (before, `No module named 'ddoc._ddoc'`).
    package = tmp_path / "ddoc"
    shutil.copytree(PACKAGE, package, ignore=shutil.ignore_patterns("_ddoc*.so", "__pycache__"))
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    other = "_ddoc" + suffix.replace("-%d%d-" % sys.version_info[:2], "-399-")
    assert other != "_ddoc" + suffix
    os.symlink(PACKAGE / ("_ddoc" + suffix), package / other)
    out = _import(sys.executable, tmp_path, tmp_path)
    assert out.returncode != 0
    last = out.stderr.strip().splitlines()[-1]
    assert last.startswith(f"ImportError: ddoc's extension module {other} was built for "), last
    assert f"the running interpreter {sys.executable} (Python " in last, last
    assert f"-DPython_EXECUTABLE={sys.executable}" in last, last
