"""tools/plot_fig2.py on the synthetic runs of tools/testdata: the PNGs exist and are real images;
the log reader handles a run that fell with cut-off last lines, and finds the pushes."""
import math
import os
import struct
import unittest

from tools_test_util import RUNS, TempDirTest, run_dir, run_tool
import ddoc_results as dr

EXPECTED_PNGS = ("fig2a_motion.png", "fig2b_speed.png", "fig2c_cost.png", "fig2d_period.png",
                 "fig2e_step_length.png", "fig2.png")


def png_size(path):
    """(width, height) from the PNG header; fails the test's assertion if not a PNG."""
    with open(path, "rb") as f:
        head = f.read(24)
    if head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        return None
    return struct.unpack(">II", head[16:24])


class PlotFig2Test(TempDirTest):
    def check_pngs(self, out):
        for name in EXPECTED_PNGS:
            path = os.path.join(out, name)
            self.assertTrue(os.path.isfile(path), f"{name} not written")
            self.assertGreater(os.path.getsize(path), 5000, f"{name} is suspiciously small")
            size = png_size(path)
            self.assertIsNotNone(size, f"{name} is not a PNG")
            self.assertGreater(min(size), 200, f"{name} has size {size}")

    def test_all_runs_overlaid(self):
        out = os.path.join(self.tmp, "plots")
        p = run_tool("plot_fig2.py", *[run_dir(r) for r in RUNS], "--out", out)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.check_pngs(out)
        # it prints the files it wrote, one per line
        self.assertEqual(sorted(os.path.basename(l) for l in p.stdout.split()),
                         sorted(EXPECTED_PNGS))
        # the cut-off last lines of the run that fell are reported, not fatal
        self.assertIn("incomplete last line", p.stderr)

    def test_options_labels_snapshots_range(self):
        out = os.path.join(self.tmp, "plots")
        p = run_tool("plot_fig2.py", run_dir(RUNS[0]), run_dir(RUNS[2]), "--out", out,
                     "--label", "first", "--label", "second", "--snap-every", "7",
                     "--motion-hops", "0:3", "--motion-runs", "1")
        self.assertEqual(p.returncode, 0, p.stderr)
        self.check_pngs(out)

    def test_run_without_trajectory_still_plots(self):
        d = self.copy_run(RUNS[0])
        os.remove(os.path.join(d, "trajectory.csv"))
        os.remove(os.path.join(d, "events.csv"))
        out = os.path.join(self.tmp, "plots")
        p = run_tool("plot_fig2.py", d, "--out", out)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("trajectory.csv: missing", p.stderr)
        self.check_pngs(out)


class ReaderTest(TempDirTest):
    def test_fallen_run_drops_cut_off_lines(self):
        run = dr.load_run(run_dir("inexact_m8_ocfb"), need_trajectory=True)
        # hops.csv: header + 4 complete rows + a cut-off 5th line (see make_testdata.py)
        with open(os.path.join(run.path, "hops.csv")) as f:
            text = f.read()
        self.assertFalse(text.endswith("\n"))
        self.assertEqual(len(run.hops), text.count("\n") - 1)
        self.assertEqual(len(run.hops), 4)
        self.assertEqual(list(run.hops["hop"]), [0, 1, 2, 3])
        # the trajectory keeps every complete line and drops the cut-off one
        with open(os.path.join(run.path, "trajectory.csv")) as f:
            ttext = f.read()
        self.assertEqual(len(run.trajectory), ttext.count("\n") - 1)
        self.assertTrue(run.fell)
        self.assertEqual(run.method, "ocfb")
        self.assertEqual(run.scenario, "inexact_m8")

    def test_pushes_from_events(self):
        run = dr.load_run(run_dir("push_m12_alg1"), need_trajectory=True)
        ps = dr.pushes(run)
        self.assertEqual(len(ps), 2)
        (a0, a1, fa), (b0, b1, fb) = ps
        self.assertAlmostEqual(a0, 3.0)
        self.assertAlmostEqual(a1 - a0, 0.2, places=6)
        self.assertAlmostEqual(b0, 6.0)
        self.assertEqual((fa, fb), (-20.0, 25.0))  # read from the trajectory's push column
        # the same pushes from summary.json when events.csv is absent
        d = self.copy_run("push_m12_alg1")
        os.remove(os.path.join(d, "events.csv"))
        ps2 = dr.pushes(dr.load_run(d))
        self.assertEqual([(round(a, 6), round(b, 6), f) for a, b, f in ps2],
                         [(3.0, 3.2, -20.0), (6.0, 6.2, 25.0)])

    def test_time_to_hop(self):
        run = dr.load_run(run_dir("exact_m8_alg1"))
        h = run.hops
        t_mid = 0.5 * (h["t_start"][3] + h["t_end"][3])
        self.assertAlmostEqual(dr.time_to_hop(run, t_mid), 3.5)
        self.assertAlmostEqual(dr.time_to_hop(run, h["t_start"][0]), 0.0)
        self.assertEqual(dr.time_to_hop(run, h["t_end"][-1] + 1.0), h["hop"][-1] + 1)

    def test_empty_field_is_nan(self):
        path = os.path.join(self.tmp, "x.csv")
        with open(path, "w") as f:
            f.write("t,hop,type\n0.5,,touchdown\n")
        t = dr.read_csv(path, ("t", "hop", "type"))
        self.assertTrue(math.isnan(t["hop"][0]))
        self.assertEqual(t["type"], ["touchdown"])


if __name__ == "__main__":
    unittest.main()
