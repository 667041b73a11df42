"""The PEP 517 build backend of `pip install .` (pyproject.toml): the project's CMake builds and
installs the CMake component ddoc_python into a staging prefix, and this file packs that prefix into
a wheel. It uses the standard library only (build-system `requires = []`), so that pip installs
offline, with or without build isolation (docs/python.md, "pip install").

The staged package directory (DDOC_PYTHON_INSTALL_DIR below the prefix) becomes the wheel's root;
everything else the component installs (bin/ddoc-hopper, lib/libddoc_plugin.so, share/ddoc/) goes
into the wheel's data directory, which pip installs into the environment's prefix. The package finds
those through paths relative to itself (ddoc/_config.py, the module's RPATH), so the package
directory must sit as deep below the prefix as this Python's site-packages (3 levels:
lib/python3.X/site-packages).

Settings (pip's --config-settings KEY=VALUE, or the environment variable):
  build-dir   DDOC_CMAKE_BUILD_DIR  a CMake build tree to build and install from, kept; configured
                                    there first when it has no CMakeCache.txt. Unset: a temporary
                                    tree, configured from scratch and removed afterwards.
  cmake-args  DDOC_CMAKE_ARGS       extra configure arguments
                                    (e.g. -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
"""
import base64
import hashlib
import os
import re
import shlex
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
NAME = "ddoc"
COMPONENT = "ddoc_python"
TARGET = "ddoc_python_package"  # python/CMakeLists.txt: everything the component installs


class BuildError(RuntimeError):
    """A failed step of the build, with what to do about it."""


def _version():
    with open(os.path.join(ROOT, "CMakeLists.txt"), encoding="utf-8") as f:
        match = re.search(r"project\(\s*ddoc\s+VERSION\s+([0-9.]+)", f.read())
    if not match:
        raise BuildError("CMakeLists.txt: no `project(ddoc VERSION x.y.z)` to take the version "
                         "from")
    return match.group(1)


def _setting(config_settings, key, env):
    value = (config_settings or {}).get(key)
    return value if value else os.environ.get(env, "")


def _tag():
    if sys.implementation.name != "cpython":
        raise BuildError(f"the extension module needs CPython, not {sys.implementation.name}")
    python = f"cp{sys.version_info[0]}{sys.version_info[1]}"
    platform = sysconfig.get_platform().replace("-", "_").replace(".", "_")
    return f"{python}-{python}{sys.abiflags}-{platform}"


def _site_dir():
    """This Python's site-packages relative to the prefix pip installs data into."""
    return os.path.relpath(sysconfig.get_path("platlib"), sysconfig.get_path("data"))


def _dist_info():
    return f"{NAME}-{_version()}.dist-info"


def _metadata_files():
    metadata = (
        "Metadata-Version: 2.1\n"
        f"Name: {NAME}\n"
        f"Version: {_version()}\n"
        "Summary: Data-driven iterative optimal control of switched systems (Chen, Li & Braun, "
        "RA-L 2023): the C++ engine from Python\n"
        "License: Apache-2.0\n"
        f"Requires-Python: =={sys.version_info[0]}.{sys.version_info[1]}.*\n"
        "Requires-Dist: numpy\n")
    wheel = ("Wheel-Version: 1.0\n"
             "Generator: ddoc_build_backend\n"
             "Root-Is-Purelib: false\n"
             f"Tag: {_tag()}\n")
    return {"METADATA": metadata, "WHEEL": wheel}


def _run(command, what):
    print("ddoc_build_backend: " + " ".join(shlex.quote(c) for c in command), flush=True)
    if subprocess.call(command, stdout=sys.stderr) != 0:
        raise BuildError(f"{what} failed: {' '.join(command)}")


def _cache_value(build_dir, name):
    with open(os.path.join(build_dir, "CMakeCache.txt"), encoding="utf-8") as f:
        for line in f:
            if line.startswith(name + ":"):
                return line.split("=", 1)[1].strip()
    return ""


def _check_build_dir(build_dir):
    """The tree builds the module for this Python, with the package as deep below the prefix as
    this Python's site-packages; checked before building (the cache has the answers)."""
    suffix = _cache_value(build_dir, "PYTHON_MODULE_EXTENSION")
    if not suffix:
        raise BuildError(f"{build_dir} builds no Python module (DDOC_BUILD_PYTHON is off, or CMake "
                         "found no pybind11 or Python headers: apt-get install python3-dev "
                         "pybind11-dev python3-pybind11)")
    if suffix != sysconfig.get_config_var("EXT_SUFFIX"):
        built = _cache_value(build_dir, "_Python_EXECUTABLE") or "another Python"
        raise BuildError(f"{build_dir} builds the module for {built} (_ddoc{suffix}), not for "
                         f"{sys.executable} (_ddoc{sysconfig.get_config_var('EXT_SUFFIX')}); use "
                         "another build dir, or reconfigure this one with "
                         f"-DPython_EXECUTABLE={sys.executable}")
    package_dir = _cache_value(build_dir, "DDOC_PYTHON_INSTALL_DIR")
    if len(os.path.normpath(package_dir).split(os.sep)) != len(_site_dir().split(os.sep)):
        raise BuildError(
            f"{build_dir}: DDOC_PYTHON_INSTALL_DIR is {package_dir!r}, not as deep below the "
            f"prefix as this Python's {_site_dir()!r}, so the installed package would not find "
            "ddoc-hopper and its library; reconfigure with "
            f"-DDDOC_PYTHON_INSTALL_DIR={_site_dir()}")
    return package_dir


def _build_and_stage(build_dir, cmake_args, prefix):
    """Configures (if needed) and builds `build_dir`, installs the component into `prefix`;
    returns the package directory below the prefix."""
    if not os.path.exists(os.path.join(build_dir, "CMakeCache.txt")):
        if os.path.exists(build_dir) and (not os.path.isdir(build_dir) or os.listdir(build_dir)):
            raise BuildError(f"build dir {build_dir} is neither a CMake build tree (no "
                             "CMakeCache.txt) nor an empty directory to configure one in")
        _run(["cmake", "-S", ROOT, "-B", build_dir, "-DCMAKE_BUILD_TYPE=Release",
              f"-DPython_EXECUTABLE={sys.executable}", f"-DDDOC_PYTHON_INSTALL_DIR={_site_dir()}",
              "-DDDOC_BUILD_TESTS=OFF", "-DDDOC_BUILD_BENCH=OFF"] + shlex.split(cmake_args),
             "configuring with CMake")
    package_dir = _check_build_dir(build_dir)
    parallel = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL") or str(os.cpu_count() or 1)
    _run(["cmake", "--build", build_dir, "--target", TARGET, "--parallel", parallel], "building")
    _run(["cmake", "--install", build_dir, "--prefix", prefix, "--component", COMPONENT],
         "cmake --install")
    return package_dir


def _record_line(path, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{path},sha256={digest},{len(data)}"


def _write_wheel(wheel_path, prefix, package_dir):
    data_dir = f"{NAME}-{_version()}.data/data/"
    records = []
    with zipfile.ZipFile(wheel_path, "w", zipfile.ZIP_DEFLATED) as wheel:
        def add(arcname, data, mode=0o644):
            info = zipfile.ZipInfo(arcname, date_time=(1980, 1, 1, 0, 0, 0))
            info.external_attr = (0o100000 | mode) << 16
            info.compress_type = zipfile.ZIP_DEFLATED
            wheel.writestr(info, data)
            records.append(_record_line(arcname, data))

        package_root = os.path.join(prefix, package_dir)
        for directory, dirs, files in os.walk(prefix):
            dirs.sort()
            for name in sorted(files):
                path = os.path.join(directory, name)  # a symlink is packed as a copy
                rel = os.path.relpath(path, prefix).replace(os.sep, "/")
                if os.path.commonpath([path, package_root]) == package_root:
                    arcname = os.path.relpath(path, package_root).replace(os.sep, "/")
                else:
                    arcname = data_dir + rel
                with open(path, "rb") as f:
                    add(arcname, f.read(), os.stat(path).st_mode & 0o777)
        for name, text in _metadata_files().items():
            add(f"{_dist_info()}/{name}", text.encode())
        records.append(f"{_dist_info()}/RECORD,,")
        wheel.writestr(f"{_dist_info()}/RECORD", "\n".join(records) + "\n")


def get_requires_for_build_wheel(config_settings=None):
    """Nothing: the backend uses the standard library and the system's CMake and pybind11."""
    return []


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):
    """Writes ddoc-VERSION.dist-info (METADATA, WHEEL) without building."""
    directory = os.path.join(metadata_directory, _dist_info())
    os.makedirs(directory, exist_ok=True)
    for name, text in _metadata_files().items():
        with open(os.path.join(directory, name), "w", encoding="utf-8") as f:
            f.write(text)
    return _dist_info()


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    """Builds with CMake, stages the ddoc_python component, packs it; returns the wheel's name."""
    stage = tempfile.mkdtemp(prefix="ddoc-wheel-")
    try:
        build_dir = _setting(config_settings, "build-dir", "DDOC_CMAKE_BUILD_DIR")
        build_dir = os.path.abspath(build_dir) if build_dir else os.path.join(stage, "build")
        prefix = os.path.join(stage, "prefix")
        package_dir = _build_and_stage(
            build_dir, _setting(config_settings, "cmake-args", "DDOC_CMAKE_ARGS"), prefix)
        wheel_name = f"{NAME}-{_version()}-{_tag()}.whl"
        _write_wheel(os.path.join(wheel_directory, wheel_name), prefix, package_dir)
        return wheel_name
    finally:
        shutil.rmtree(stage, ignore_errors=True)
