"""The `pip install .` backend's checks of a reused build tree (python/pip/ddoc_build_backend.py).

A tree given as DDOC_CMAKE_BUILD_DIR (or --config-settings build-dir=) that cannot make a package
for the running Python is rejected before anything is built, with a message that names the tree,
what is wrong and what to do. The whole install is ctest python.pip_install.
"""
import importlib.util
import pathlib
import sys
import sysconfig
import zipfile

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location(
    "ddoc_build_backend", ROOT / "python" / "pip" / "ddoc_build_backend.py")
backend = importlib.util.module_from_spec(spec)
spec.loader.exec_module(backend)

SUFFIX = sysconfig.get_config_var("EXT_SUFFIX")


def fake_tree(path, **cache):
    path.mkdir()
    lines = [f"{name}:{'INTERNAL' if name.startswith(('_', 'PYTHON_')) else 'STRING'}={value}"
             for name, value in cache.items()]
    (path / "CMakeCache.txt").write_text("\n".join(lines) + "\n")
    return str(path)


def build(tmp_path, build_dir):
    with pytest.raises(backend.BuildError) as info:
        backend.build_wheel(str(tmp_path), config_settings={"build-dir": build_dir})
    assert not list(tmp_path.glob("*.whl"))
    return str(info.value)


def test_a_tree_without_the_python_module(tmp_path):
    tree = fake_tree(tmp_path / "b", DDOC_PYTHON_INSTALL_DIR="lib/python3/dist-packages")
    assert build(tmp_path, tree) == (
        f"{tree} builds no Python module (DDOC_BUILD_PYTHON is off, or CMake found no pybind11 "
        "or Python headers: apt-get install python3-dev pybind11-dev python3-pybind11)")


def test_a_tree_for_another_python(tmp_path):
    tree = fake_tree(tmp_path / "b", PYTHON_MODULE_EXTENSION=".cpython-399-x86_64-linux-gnu.so",
                     _Python_EXECUTABLE="/opt/python3.99/bin/python3",
                     DDOC_PYTHON_INSTALL_DIR="lib/python3/dist-packages")
    message = build(tmp_path, tree)
    assert message.startswith(f"{tree} builds the module for /opt/python3.99/bin/python3 "
                              f"(_ddoc.cpython-399-x86_64-linux-gnu.so), not for {sys.executable} "
                              f"(_ddoc{SUFFIX})"), message
    assert message.endswith(f"-DPython_EXECUTABLE={sys.executable}"), message


def test_a_package_dir_of_another_depth(tmp_path):
    tree = fake_tree(tmp_path / "b", PYTHON_MODULE_EXTENSION=SUFFIX,
                     DDOC_PYTHON_INSTALL_DIR="python")
    message = build(tmp_path, tree)
    assert message.startswith(f"{tree}: DDOC_PYTHON_INSTALL_DIR is 'python', not as deep below "
                              "the prefix as this Python's 'lib/"), message
    assert "-DDDOC_PYTHON_INSTALL_DIR=lib/" in message, message


def test_a_directory_that_is_no_build_tree(tmp_path):
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "notes.txt").write_text("x")
    assert build(tmp_path, str(tmp_path / "src")) == (
        f"build dir {tmp_path / 'src'} is neither a CMake build tree (no CMakeCache.txt) nor an "
        "empty directory to configure one in")


def test_metadata(tmp_path):
    name = backend.prepare_metadata_for_build_wheel(str(tmp_path))
    version = backend._version()
    assert name == f"ddoc-{version}.dist-info"
    metadata = (tmp_path / name / "METADATA").read_text()
    assert f"Name: ddoc\nVersion: {version}\n" in metadata and "Requires-Dist: numpy\n" in metadata
    py = "cp%d%d" % sys.version_info[:2]
    assert f"Tag: {py}-{py}{sys.abiflags}-" in (tmp_path / name / "WHEEL").read_text()
    assert backend.get_requires_for_build_wheel() == []


def test_wheel_layout_and_record(tmp_path):
    # A staged prefix as `cmake --install --component ddoc_python` writes it.
    prefix = tmp_path / "prefix"
    package = prefix / "lib/python3/dist-packages/ddoc"
    package.mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (prefix / "bin").mkdir()
    (prefix / "bin/ddoc-hopper").write_text("#!/bin/sh\n")
    (prefix / "bin/ddoc-hopper").chmod(0o755)
    wheel = tmp_path / "x.whl"
    backend._write_wheel(str(wheel), str(prefix), "lib/python3/dist-packages")
    data = f"ddoc-{backend._version()}.data/data/"
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
        assert {"ddoc/__init__.py", data + "bin/ddoc-hopper"} <= names
        assert (z.getinfo(data + "bin/ddoc-hopper").external_attr >> 16) & 0o111
        record = z.read(f"ddoc-{backend._version()}.dist-info/RECORD").decode().splitlines()
    assert {line.split(",")[0] for line in record} == names
