"""tools/mass_sweep with the real ddoc-hopper (DDOC_HOPPER, set by CMake): generated robots load in
MuJoCo, runs are logged, the table names every case, speeds and terminal values multiply the
cases; bad usage exits 2 with a message."""
import csv
import os
import re
import unittest

from tools_test_util import TempDirTest, run_tool

HOPPER = os.environ.get("DDOC_HOPPER", "")


@unittest.skipUnless(os.access(HOPPER, os.X_OK), "DDOC_HOPPER (the ddoc-hopper binary) not set")
class MassSweepTest(TempDirTest):
    def test_two_short_runs(self):
        out = os.path.join(self.tmp, "sweep")
        r = run_tool("mass_sweep", "--masses", "11", "--methods", "ocfb", "--cyclic", "0,0.9",
                     "--hops", "2", "--hopper", HOPPER, "--out", out)
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(os.path.join(out, "robots", "hopper_m11.xml")) as f:
            robot = f.read()
        self.assertIn('mass="11.0"', robot)
        self.assertRegex(robot, r'name="drag_cd" data="0.01"')
        with open(os.path.join(out, "results.csv")) as f:
            rows = list(csv.DictReader(f))
        self.assertEqual([(r["method"], r["cyclic_value"]) for r in rows],
                         [("ocfb", "0.0"), ("ocfb", "0.9")])
        for row in rows:
            self.assertEqual(row["exit"], "0")
            self.assertEqual(row["hops"], "2")  # two hops really ran on the 11 kg robot
        with open(os.path.join(out, "runs", "m11_v0.5_ocfb_c0.9_time", "summary.json")) as f:
            self.assertIn('"hops": 2', f.read())
        with open(os.path.join(out, "results.md")) as f:
            table = f.read()
        self.assertTrue(re.search(r"\| 11 \| 2 \([0-9.]+\) \| 2 \([0-9.]+\) \|", table), table)
        self.assertIn("| survived 1/1 | survived 1/1 |", table)

    def test_speeds_and_terminal(self):
        out = os.path.join(self.tmp, "sweep")
        r = run_tool("mass_sweep", "--masses", "10", "--speeds", "0.4,0.5", "--methods", "alg1",
                     "--cyclic", "0", "--terminal", "time,event", "--hops", "3",
                     "--hopper", HOPPER, "--out", out, "--jobs", "4")
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(os.path.join(out, "results.csv")) as f:
            rows = list(csv.DictReader(f))
        self.assertEqual([(r["speed"], r["terminal"]) for r in rows],
                         [("0.4", "time"), ("0.4", "event"), ("0.5", "time"), ("0.5", "event")])
        for row in rows:
            self.assertEqual((row["mass"], row["method"], row["cyclic_value"], row["exit"],
                              row["hops"]), ("10.0", "alg1", "0.0", "0", "3"))
        with open(os.path.join(out, "scenarios", "m10_v0.4_alg1_c0_event.xml")) as f:
            scenario = f.read()
        self.assertIn('<gait speed="0.4"/>', scenario)
        self.assertIn('terminal="event"', scenario)
        self.assertTrue(os.path.isfile(os.path.join(out, "runs", "m10_v0.5_alg1_c0_time",
                                                    "summary.json")))
        with open(os.path.join(out, "results.md")) as f:
            table = f.read()
        self.assertIn("| speed [m/s] | robot mass [kg] | alg1 c=0 time | alg1 c=0 event |", table)
        self.assertTrue(re.search(r"\| 0\.5 \| 10 \| 3 \([0-9.]+\) \| 3 \([0-9.]+\) \|", table),
                        table)
        self.assertIn("| survived 2/2 | survived 2/2 |", table)

    def test_reference(self):
        out = os.path.join(self.tmp, "sweep")
        r = run_tool("mass_sweep", "--masses", "8", "--methods", "alg1", "--cyclic", "0",
                     "--reference", "own,gait", "--hops", "4", "--hopper", HOPPER, "--out", out)
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(os.path.join(out, "results.csv")) as f:
            rows = list(csv.DictReader(f))
        self.assertEqual([(r["reference"], r["exit"], r["hops"]) for r in rows],
                         [("own", "0", "4"), ("gait", "0", "4")])
        with open(os.path.join(out, "scenarios", "m8_v0.5_alg1_c0_time_gait.xml")) as f:
            self.assertIn('reference="gait"', f.read())
        with open(os.path.join(out, "scenarios", "m8_v0.5_alg1_c0_time.xml")) as f:
            self.assertIn('reference="own"', f.read())
        # The reference changes the learner's cost, so the two runs log different hops (hop 0
        # starts on the gait's state, where both references agree; on the 8 kg robot (36) then
        # judges hop 1 differently).
        logs = []
        for case in ("m8_v0.5_alg1_c0_time", "m8_v0.5_alg1_c0_time_gait"):
            with open(os.path.join(out, "runs", case, "hops.csv")) as f:
                logs.append(f.read())
        self.assertNotEqual(logs[0], logs[1])
        with open(os.path.join(out, "results.md")) as f:
            table = f.read()
        self.assertIn("| alg1 c=0 ref=own | alg1 c=0 ref=gait |", table)


class MassSweepUsageTest(TempDirTest):
    def test_bad_usage(self):
        self.assert_usage_errors("mass_sweep", [
            (["--methods", "foo"], ["foo"]),
            (["--cyclic", "2"], ["--cyclic"]),
            (["--terminal", "time,evnt"], ["--terminal", "evnt"]),
            (["--reference", "nominal"], ["--reference", "nominal"]),
            (["--speed", "fast"], ["fast"]),  # --speed: old alias
            (["--hopper", os.path.join(self.tmp, "nope")], ["ddoc-hopper not found"]),
        ])


if __name__ == "__main__":
    unittest.main()
