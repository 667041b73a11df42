"""tools/reproduce: the case list covers every scenario of Section V-D with every method (dry run),
options are passed on, and a full run against a stand-in CLI produces runs, plots and the table."""
import csv
import itertools
import os
import shlex
import stat
import unittest

from tools_test_util import HERE, PYTHON, ROOT, TempDirTest, run_tool

# Section V-D: exact model M=8 and M=12, inexact model vs robot M=8 and M=12, pushes with M=12.
SCENARIOS = ("exact_m8", "exact_m12", "inexact_m8", "inexact_m12", "push_m12")
METHODS = ("alg1", "ocfb", "mrl")


def parse(stdout):
    """Dry-run lines -> list of (scenario, method, out, hops or None, argv)."""
    cases = []
    for line in stdout.splitlines():
        if not line.strip() or line.startswith("#"):
            continue
        argv = shlex.split(line)
        opts = dict(zip(argv[2::2], argv[3::2]))
        scenario = os.path.splitext(os.path.basename(argv[1]))[0]
        cases.append((scenario, opts.get("--method"), opts.get("--out"), opts.get("--hops"), argv))
    return cases


class ReproduceDryRunTest(TempDirTest):
    def test_lists_every_scenario_and_method(self):
        out = os.path.join(self.tmp, "res")
        p = run_tool("reproduce", "--dry-run", "--out", out, "--build", os.path.join(self.tmp, "b"))
        self.assertEqual(p.returncode, 0, p.stderr)
        cases = parse(p.stdout)
        self.assertEqual(len(cases), 15)
        self.assertEqual({(s, m) for s, m, *_ in cases}, set(itertools.product(SCENARIOS, METHODS)))
        for scenario, method, run_out, hops, argv in cases:
            self.assertEqual(os.path.abspath(argv[0]),
                             os.path.join(self.tmp, "b", "bin", "ddoc-hopper"))
            self.assertEqual(os.path.abspath(argv[1]),
                             os.path.join(ROOT, "models", "scenarios", scenario + ".xml"))
            self.assertEqual(os.path.abspath(run_out), os.path.join(out, f"{scenario}_{method}"))
            self.assertIsNone(hops)
        self.assertEqual(len({c[2] for c in cases}), 15)  # one output directory per case

    def test_is_executable(self):
        import subprocess
        path = os.path.join(ROOT, "tools", "reproduce")
        self.assertTrue(os.access(path, os.X_OK), "tools/reproduce is not executable")
        p = subprocess.run([path, "--dry-run"], capture_output=True, text=True, timeout=60,
                           env=dict(os.environ, PYTHONDONTWRITEBYTECODE="1"))
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertEqual(len(parse(p.stdout)), 15)

    def test_hops_and_only(self):
        p = run_tool("reproduce", "--dry-run", "--hops", "7", "--only", "inexact_*,push_m12_alg1")
        self.assertEqual(p.returncode, 0, p.stderr)
        cases = parse(p.stdout)
        self.assertEqual({(s, m) for s, m, *_ in cases},
                         {(s, m) for s in ("inexact_m8", "inexact_m12") for m in METHODS}
                         | {("push_m12", "alg1")})
        self.assertTrue(all(h == "7" for *_, h, _ in cases))

    def test_offline_latency_is_passed_on_only_when_given(self):
        p = run_tool("reproduce", "--dry-run", "--offline-latency", "0", "--only", "exact_m8")
        self.assertEqual(p.returncode, 0, p.stderr)
        for *_, argv in parse(p.stdout):
            self.assertEqual(argv[argv.index("--offline-latency") + 1], "0.0")
        p = run_tool("reproduce", "--dry-run", "--only", "inexact_m8")
        self.assertTrue(all("--offline-latency" not in argv for *_, argv in parse(p.stdout)))

    def test_bad_options(self):
        p = run_tool("reproduce", "--dry-run", "--only", "no_such_case")
        self.assertEqual(p.returncode, 2)
        self.assertIn("matches none", p.stderr)
        p = run_tool("reproduce", "--dry-run", "--jobs", "0")
        self.assertEqual(p.returncode, 2)
        p = run_tool("reproduce", "--build", os.path.join(self.tmp, "nobuild"),
                     "--out", os.path.join(self.tmp, "res"))
        self.assertEqual(p.returncode, 2)
        self.assertIn("ddoc-hopper not found", p.stderr)


class ReproduceFakeCliTest(TempDirTest):
    """Runs reproduce against tests/tools/fake_ddoc_hopper.py (copies synthetic logs; ocfb falls on
    the inexact scenarios, exit 3)."""

    def test_runs_plots_and_table(self):
        bin_dir = os.path.join(self.tmp, "build", "bin")
        os.makedirs(bin_dir)
        cli = os.path.join(bin_dir, "ddoc-hopper")
        with open(cli, "w") as f:
            f.write(f'#!/bin/sh\nexec {PYTHON} {os.path.join(HERE, "fake_ddoc_hopper.py")} "$@"\n')
        os.chmod(cli, os.stat(cli).st_mode | stat.S_IXUSR)
        out = os.path.join(self.tmp, "res")
        p = run_tool("reproduce", "--build", os.path.join(self.tmp, "build"), "--out", out,
                     "--hops", "5", "--jobs", "2", "--only", "push_m12_*,inexact_m8_ocfb")
        self.assertEqual(p.returncode, 0, p.stdout + p.stderr)
        cases = ["inexact_m8_ocfb", "push_m12_alg1", "push_m12_ocfb", "push_m12_mrl"]
        for case in cases:
            with open(os.path.join(out, case, "argv.txt")) as f:
                argv = f.read().split()
            self.assertEqual(argv[argv.index("--hops") + 1], "5")
            self.assertTrue(os.path.isfile(os.path.join(out, "logs", case + ".log")))
        with open(os.path.join(out, "runs.csv")) as f:
            codes = {r["case"]: r["exit_code"] for r in csv.DictReader(f)}
        self.assertEqual(codes, {"inexact_m8_ocfb": "3", "push_m12_alg1": "0", "push_m12_ocfb": "3",
                                 "push_m12_mrl": "0"})
        for group in ("push_m12", "inexact_m8", "fig2_alg1"):
            self.assertTrue(os.path.isfile(os.path.join(out, "plots", group, "fig2.png")), group)
        with open(os.path.join(out, "results.md")) as f:
            rows = [l for l in f if l.startswith("| ") and not l.startswith("| scenario")]
        self.assertEqual(len(rows), 4)
        self.assertTrue(any(r.startswith("| push_m12 | ocfb | fell") for r in rows), rows)

    def test_failing_case_makes_exit_1(self):
        bin_dir = os.path.join(self.tmp, "build", "bin")
        os.makedirs(bin_dir)
        cli = os.path.join(bin_dir, "ddoc-hopper")
        with open(cli, "w") as f:
            f.write("#!/bin/sh\necho broken >&2\nexit 1\n")
        os.chmod(cli, os.stat(cli).st_mode | stat.S_IXUSR)
        out = os.path.join(self.tmp, "res")
        p = run_tool("reproduce", "--build", os.path.join(self.tmp, "build"), "--out", out,
                     "--only", "exact_m8_alg1")
        self.assertEqual(p.returncode, 1, p.stdout + p.stderr)
        with open(os.path.join(out, "results.md")) as f:
            text = f.read()
        self.assertIn("| exact_m8 | alg1 | no usable log", text)
        self.assertIn("exited with code 1", text)
        with open(os.path.join(out, "logs", "exact_m8_alg1.log")) as f:
            self.assertIn("broken", f.read())


if __name__ == "__main__":
    unittest.main()
