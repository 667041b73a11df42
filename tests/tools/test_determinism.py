"""Determinism (issue 20): the same scenario run twice by the real ddoc-hopper (DDOC_HOPPER, set by
CMake) gives byte-identical hops.csv, events.csv and trajectory.csv, and summary.json identical but
for wall_time_s and offline_timing; tools/mass_sweep and tools/push_sweep give the same rows (and the same logs per
case) whatever --jobs."""
import filecmp
import json
import os
import subprocess
import unittest

from tools_test_util import ROOT, TempDirTest, push_scenario, run_tool

HOPPER = os.environ.get("DDOC_HOPPER", "")
LOGS = ("hops.csv", "events.csv", "trajectory.csv")


def summary_without_wall_time(run_dir, out=None):
    """summary.json without wall_time_s and offline_timing; paths under `out` (a sweep's --out) start with OUT."""
    with open(os.path.join(run_dir, "summary.json")) as f:
        text = f.read()
    if out:
        text = text.replace(json.dumps(out)[1:-1], "OUT")
    summary = json.loads(text)
    del summary["wall_time_s"]
    del summary["offline_timing"]  # wall time of the offline part
    return summary


def read(path):
    with open(path, "rb") as f:
        return f.read()


@unittest.skipUnless(os.access(HOPPER, os.X_OK), "DDOC_HOPPER (the ddoc-hopper binary) not set")
class DeterminismTest(TempDirTest):
    def assert_same_runs(self, a, b, out_a=None, out_b=None):
        for name in LOGS:
            self.assertTrue(filecmp.cmp(os.path.join(a, name), os.path.join(b, name),
                                        shallow=False), f"{name} differs: {a} vs {b}")
        self.assertEqual(summary_without_wall_time(a, out_a), summary_without_wall_time(b, out_b))

    def test_same_scenario_twice_is_byte_identical(self):
        # 5 hops of the default scenario: 3 warm-up hops on u^0, then 2 of Algorithm 1, so the
        # learner and the 20 ms offline latency are in it; a push too.
        scenario = os.path.join(ROOT, "models", "scenarios", "default.xml")
        runs = []
        for k in range(2):
            out = os.path.join(self.tmp, f"run{k}")
            r = subprocess.run([HOPPER, scenario, "--hops", "5", "--push", "1.2,15,0.05", "-q",
                                "--out", out], capture_output=True, text=True, timeout=600)
            self.assertEqual(r.returncode, 0, r.stderr)
            runs.append(out)
        with open(os.path.join(runs[0], "hops.csv")) as f:
            self.assertEqual(len(f.read().splitlines()), 6)  # header + 5 hops really ran
        self.assertIn(b"push_start", read(os.path.join(runs[0], "events.csv")))
        self.assert_same_runs(*runs)

    def sweep_twice(self, tool, args, jobs):
        outs = []
        for j in jobs:
            out = os.path.join(self.tmp, f"{tool}_jobs{j}")
            r = run_tool(tool, *args, "--hopper", HOPPER, "--jobs", str(j), "--out", out)
            self.assertEqual(r.returncode, 0, r.stderr)
            outs.append(out)
        a, b = outs
        for name in ("results.csv", "results.md"):
            self.assertEqual(read(os.path.join(a, name)), read(os.path.join(b, name)),
                             f"{tool} {name} differs between --jobs {jobs[0]} and {jobs[1]}")
        cases = sorted(os.listdir(os.path.join(a, "runs")))
        self.assertEqual(cases, sorted(os.listdir(os.path.join(b, "runs"))))
        self.assertGreaterEqual(len(cases), 2)
        for case in cases:
            self.assert_same_runs(os.path.join(a, "runs", case), os.path.join(b, "runs", case),
                                  a, b)

    def test_mass_sweep_rows_do_not_depend_on_jobs(self):
        self.sweep_twice("mass_sweep", ["--masses", "9,11", "--methods", "alg1",
                                        "--hops", "4"], (1, 3))

    def test_push_sweep_rows_do_not_depend_on_jobs(self):
        scenario = push_scenario(self.tmp)
        self.sweep_twice("push_sweep", ["--scenario", scenario, "--speeds", "0.5",
                                        "--durations", "0.02", "--offsets", "0,0.3",
                                        "--methods", "alg1"], (1, 2))


if __name__ == "__main__":
    unittest.main()
