"""Shared helpers of the tests of the Python result tools (tools/*.py, tools/reproduce)."""
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
TOOLS = os.path.join(ROOT, "tools")
TESTDATA = os.path.join(TOOLS, "testdata")
RUNS = ("exact_m8_alg1", "inexact_m8_ocfb", "push_m12_alg1")  # the synthetic runs
PYTHON = "/usr/bin/python3"  # Debian's interpreter, the one with matplotlib

sys.path.insert(0, TOOLS)


def run_tool(*args, cwd=None, env=None):
    """Run a tool (path relative to tools/) with Debian's python; returns CompletedProcess.
    `env` adds to (or overrides) the environment."""
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1", MPLBACKEND="Agg", **(env or {}))
    script = os.path.join(TOOLS, args[0])
    return subprocess.run([PYTHON, script, *args[1:]], capture_output=True, text=True, env=env,
                          cwd=cwd, timeout=300)


def run_dir(name):
    return os.path.join(TESTDATA, name)


class TempDirTest(unittest.TestCase):
    """Gives each test a fresh temporary directory self.tmp (removed afterwards)."""

    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="ddoc_tools_test_")

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def copy_run(self, name, new_name=None):
        dst = os.path.join(self.tmp, new_name or name)
        shutil.copytree(run_dir(name), dst)
        return dst

    def assert_usage_errors(self, tool, cases):
        """Each case (args, needles): `tool args --out TMP` exits 2 and its stderr holds every
        needle (the message names what is wrong)."""
        for args, needles in cases:
            with self.subTest(args=args):
                r = run_tool(tool, *args, "--out", self.tmp)
                self.assertEqual(r.returncode, 2, r.stderr)
                for needle in needles:
                    self.assertIn(needle, r.stderr)


def push_scenario(tmp, with_push=True):
    """A short scenario: the 12 kg robot under the extended settings, one small early push."""
    path = os.path.join(tmp, "short_push.xml")
    robot = os.path.join(ROOT, "models", "hopper_m12.xml")
    push = '<push time="1.0" force="10" duration="0.05"/>' if with_push else ""
    with open(path, "w") as f:
        f.write(f"""<ddoc_scenario name="short_push">
  <robot mjcf="{robot}"/>
  <model M="10" c_d="0"/>
  <method name="alg1"/>
  <duration hops="4"/>
  {push}
  <learning terminal="event" cyclic_value="0.99" reference="gait"/>
  <gait speed="0.5"/>
</ddoc_scenario>
""")
    return path
