"""Checked before the extension module ddoc._ddoc loads: the running interpreter can import NumPy
and load the module's file. Otherwise an ImportError that names what is missing, the running
interpreter and the Python the module was built for (without this check, a Python without NumPy
got pybind11's bare `ImportError: initialization failed`)."""
import glob
import importlib.machinery
import os
import sys


def built_for():
    """The Python the extension module was built for, as CMake found it (ddoc/_config.py)."""
    try:
        from ._config import PYTHON, PYTHON_VERSION
    except ImportError:
        return "an unknown Python (ddoc/_config.py is missing)"
    return f"{PYTHON} (Python {PYTHON_VERSION})"


def running():
    """The running interpreter and its version."""
    return f"{sys.executable} (Python {'.'.join(str(v) for v in sys.version_info[:3])})"


def check_interpreter():
    """Raises ImportError naming NumPy or the module's file, this interpreter and the built one."""
    try:
        import numpy  # noqa: F401  (the module's arrays are NumPy arrays)
    except ImportError as e:
        raise ImportError(
            f"ddoc needs NumPy, which the running interpreter {running()} cannot import ({e}); "
            f"ddoc's extension module was built for {built_for()}. Run ddoc with that Python, or "
            f"make NumPy importable here (`{sys.executable} -m pip install numpy`, or a venv made "
            f"with --system-site-packages to use the system's NumPy).") from e
    here = os.path.dirname(os.path.abspath(__file__))
    files = sorted(os.path.basename(f) for f in glob.glob(os.path.join(here, "_ddoc*.so")))
    suffixes = importlib.machinery.EXTENSION_SUFFIXES
    if files and not any(f[len("_ddoc"):] in suffixes for f in files):
        raise ImportError(
            f"ddoc's extension module {', '.join(files)} was built for {built_for()}; the running "
            f"interpreter {running()} loads only _ddoc{{{', '.join(suffixes)}}}. Run ddoc with "
            f"that Python, or rebuild it for this one (cmake -DPython_EXECUTABLE={sys.executable}, "
            f"or `{sys.executable} -m pip install .` from the checkout).")
