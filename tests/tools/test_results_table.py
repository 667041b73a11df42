"""tools/results_table.py: one row per run with the right hop counts, status and convergence; and
the convergence test of Algorithm 1 (ddoc_results.converged_hop) on known sequences."""
import math
import os
import unittest

import numpy as np

from tools_test_util import RUNS, TempDirTest, run_dir, run_tool
import ddoc_results as dr


def table_rows(markdown):
    """Data rows of the first markdown table as lists of cell strings."""
    rows = [l for l in markdown.splitlines() if l.startswith("|")]
    return [[c.strip() for c in r.strip("|").split("|")] for r in rows[2:]]


class ResultsTableTest(TempDirTest):
    def test_one_row_per_run(self):
        out = os.path.join(self.tmp, "results.md")
        p = run_tool("results_table.py", *[run_dir(r) for r in RUNS], "--out", out)
        self.assertEqual(p.returncode, 0, p.stderr)
        with open(out) as f:
            text = f.read()
        self.assertEqual(text, p.stdout)  # also printed
        rows = table_rows(text)
        self.assertEqual(len(rows), len(RUNS))
        by = {(r[0], r[1]): r for r in rows}
        self.assertEqual(set(by), {("exact_m8", "alg1"), ("inexact_m8", "ocfb"), ("push_m12", "alg1")})
        # hops survived = complete rows of hops.csv (known by construction, see make_testdata.py)
        self.assertEqual(by[("exact_m8", "alg1")][3], "12")
        self.assertEqual(by[("inexact_m8", "ocfb")][3], "4")
        self.assertEqual(by[("push_m12", "alg1")][3], "15")
        self.assertEqual(by[("exact_m8", "alg1")][2], "ok")
        self.assertTrue(by[("inexact_m8", "ocfb")][2].startswith("fell in hop 4"))  # fall event
        self.assertIn("body touched the ground", by[("inexact_m8", "ocfb")][2])
        # convergence: computed for exact_m8 (summary has null), taken from summary for push_m12
        self.assertEqual(by[("exact_m8", "alg1")][-1], "9*")
        self.assertEqual(by[("push_m12", "alg1")][-1], "11")
        self.assertEqual(by[("inexact_m8", "ocfb")][-1], "not converged")
        # final cost = cost of the last complete hop, I4 at the converged hop
        run = dr.load_run(run_dir("exact_m8_alg1"))
        self.assertAlmostEqual(float(by[("exact_m8", "alg1")][4]), run.hops["cost"][-1], places=3)
        i4_conv = run.hops["I4"][list(run.hops["hop"]).index(9)]
        self.assertAlmostEqual(float(by[("exact_m8", "alg1")][5].split()[0]) / i4_conv, 1.0, places=2)
        # mean speed over all hops
        self.assertAlmostEqual(float(by[("exact_m8", "alg1")][6]), np.mean(run.hops["speed"]),
                               places=3)

    def test_status_shows_how_the_run_ended(self):
        import json
        import shutil
        ends = {"nonfinite_state": ("non-finite state: MuJoCo found a NaN, Inf or huge value in "
                                    "qacc at t = 1.5005 s", "non-finite state: MuJoCo found a NaN"),
                "interrupted": ("interrupted by SIGINT at t = 2.0 s", "interrupted: interrupted by"),
                "io_error": ("cannot write \"x\"", "io_error: cannot write"),
                "running": ("", "incomplete (summary.json says running"),
                "completed": ("", "ok")}
        for end, (message, status) in ends.items():
            run = os.path.join(self.tmp, end, "exact_m8_alg1")
            shutil.copytree(run_dir("exact_m8_alg1"), run)
            path = os.path.join(run, "summary.json")
            with open(path) as f:
                summary = json.load(f)
            summary.update(end=end, end_message=message)
            with open(path, "w") as f:
                json.dump(summary, f)
            p = run_tool("results_table.py", run, "--out", "-")
            self.assertEqual(p.returncode, 0, p.stderr)
            self.assertTrue(table_rows(p.stdout)[0][2].startswith(status),
                            (end, table_rows(p.stdout)[0][2]))

    def test_tail_and_eps_options(self):
        p = run_tool("results_table.py", run_dir("exact_m8_alg1"), "--out", "-", "--tail", "2",
                     "--eps", "1e-2", "--delta-i", "2")
        self.assertEqual(p.returncode, 0, p.stderr)
        row = table_rows(p.stdout)[0]
        run = dr.load_run(run_dir("exact_m8_alg1"))
        self.assertAlmostEqual(float(row[6]), np.mean(run.hops["speed"][-2:]), places=3)
        # 2.01 * 0.3**k <= 1e-2 first for k = 5, two in a row at k = 6
        self.assertEqual(row[-1], "6*")

    def test_keep_going_lists_unreadable_run(self):
        bad = os.path.join(self.tmp, "inexact_m12_mrl")
        os.makedirs(bad)
        with open(os.path.join(bad, "exit_code"), "w") as f:
            f.write("1\n")
        p = run_tool("results_table.py", run_dir("exact_m8_alg1"), bad, "--out", "-",
                     "--keep-going")
        self.assertEqual(p.returncode, 0, p.stderr)
        rows = table_rows(p.stdout)
        self.assertEqual(len(rows), 2)
        self.assertEqual(rows[1][:3], ["inexact_m12", "mrl", "no usable log"])
        self.assertIn("exited with code 1", p.stdout)
        # without --keep-going the same input is an error naming the directory
        p = run_tool("results_table.py", run_dir("exact_m8_alg1"), bad, "--out", "-")
        self.assertEqual(p.returncode, 2)
        self.assertIn("inexact_m12_mrl: no hops.csv", p.stderr)


class ConvergedHopTest(unittest.TestCase):
    @staticmethod
    def hops(d, accepted=None, dT2=None):
        n = len(d)
        return {"hop": np.arange(n, dtype=float), "du2": np.array(d, dtype=float),
                "dT2": np.zeros(n) if dT2 is None else np.array(dT2, dtype=float),
                "accepted": np.ones(n) if accepted is None else np.array(accepted, dtype=float)}

    def test_window_of_consecutive_iterations(self):
        h = self.hops([math.nan, 1.0, 0.5, 1e-4, 1e-4, 1.0, 1e-4, 1e-4, 1e-4, 1e-5])
        self.assertEqual(dr.converged_hop(h, eps=1e-3, delta_i=3), 8)
        self.assertEqual(dr.converged_hop(h, eps=1e-3, delta_i=2), 4)
        self.assertEqual(dr.converged_hop(h, eps=1e-3, delta_i=1), 3)
        self.assertIsNone(dr.converged_hop(h, eps=1e-3, delta_i=5))
        self.assertIsNone(dr.converged_hop(h, eps=1e-6, delta_i=1))

    def test_dT2_counts_and_rejected_trials_are_skipped(self):
        # dT2 alone pushes hop 2 over eps; the rejected trial at hop 4 neither counts nor breaks
        h = self.hops([math.nan, 1e-4, 1e-4, 1e-4, 9.0, 1e-4],
                      dT2=[0, 0, 5e-3, 0, 0, 0], accepted=[1, 1, 1, 1, 0, 1])
        self.assertEqual(dr.converged_hop(h, eps=1e-3, delta_i=2), 5)
        self.assertEqual(dr.converged_hop(h, eps=1e-3, delta_i=1), 1)
        self.assertIsNone(dr.converged_hop(h, eps=1e-3, delta_i=3))
        with self.assertRaises(ValueError):
            dr.converged_hop(h, eps=1e-3, delta_i=0)


if __name__ == "__main__":
    unittest.main()
