"""tools/robustness_map: the shards of a grid are a partition of it, merging shards gives the bytes of
an unsharded run, the Slurm array body runs the slice of its task, bad usage names what is wrong,
the summary counts what the CSV says, Ctrl-C keeps every case that ended before it; most with the
fake ddoc-hopper, one short run with the real one (DDOC_HOPPER, set by CMake)."""
import csv
import filecmp
import importlib.machinery
import importlib.util
import json
import math
import os
import signal
import subprocess
import threading
import time
import unittest
from unittest import mock

from tools_test_util import HERE, PYTHON, ROOT, TOOLS, TempDirTest, run_tool

HOPPER = os.environ.get("DDOC_HOPPER", "")
FAKE = os.path.join(HERE, "fake_ddoc_hopper.py")


def load_tool():
    loader = importlib.machinery.SourceFileLoader("robustness_map",
                                                  os.path.join(TOOLS, "robustness_map"))
    spec = importlib.util.spec_from_loader("robustness_map", loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


rm = load_tool()

# A small grid for the fake: 2 x 2 x 1 mass conditions and 1 x 1 x 2 x 2 pushes, 3 methods = 24 cases.
SMALL = ["--hops", "12", "--masses", "8,12", "--drags", "0,0.01", "--speeds", "0.5",
         "--robots", "12", "--durations", "0.1", "--forces", "-20,20", "--phases", "0,0.5",
         "--push-hop", "5", "--hopper", FAKE, "--jobs", "2"]


def read(path):
    with open(path, "rb") as f:
        return f.read()


def csv_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


class GridTest(unittest.TestCase):
    def grid(self, *args):
        return rm.grid_from_args(rm.run_parser().parse_args(rm.join_negative_values(list(args))))

    def test_the_default_grid_is_the_issues(self):
        names = [n for _, n, _ in rm.cases(self.grid())]
        mass = [n for n in names if n.startswith("mass_")]
        push = [n for n in names if n.startswith("push_")]
        self.assertEqual(len(mass), 7 * 3 * 3 * 3)         # 63 conditions x 3 methods
        self.assertEqual(len(push), 2 * 9 * 3 * 8 * 3)     # robots x forces x durations x phases
        self.assertEqual(len(set(names)), len(names))
        self.assertIn("mass_m13_cd0.02_v0.7_mrl", mass)
        self.assertIn("push_m8_d0.05_f-40_p0.875_ocfb", push)
        self.assertEqual(mass[:3], ["mass_m7_cd0_v0.3_alg1", "mass_m7_cd0_v0.3_ocfb",
                                    "mass_m7_cd0_v0.3_mrl"])

    def test_shards_partition_the_grid(self):
        full = rm.cases(self.grid())
        for n in (1, 2, 7, 16):
            with self.subTest(n=n):
                slices = [rm.shard_cases(full, (i, n)) for i in range(n)]
                union = [c for s in slices for c in s]
                self.assertEqual(len(union), len(full))                        # no overlap
                self.assertEqual(sorted(c[1] for c in union), sorted(c[1] for c in full))
                self.assertLessEqual(max(map(len, slices)) - min(map(len, slices)), 1)
        # Deterministic: the same slice twice, and slice 1/4 holds cases 1, 5, 9, ...
        self.assertEqual(rm.shard_cases(full, (1, 4)), rm.shard_cases(rm.cases(self.grid()), (1, 4)))
        self.assertEqual([c[1] for c in rm.shard_cases(full, (1, 4))][:2], [full[1][1], full[5][1]])

    def test_the_unmodelled_grid(self):
        # Issue 44: 2 robots x 6 kinds x 8 levels = 96 conditions, every method.
        cases = rm.cases(self.grid("--maps", "unmodelled"))
        names = [n for _, n, _ in cases]
        self.assertEqual(len(names), 2 * 6 * 8 * 3)
        self.assertEqual(len(set(names)), len(names))
        self.assertEqual(names[:4], ["unmod_m12_b_leg0.25_alg1", "unmod_m12_b_leg0.25_ocfb",
                                     "unmod_m12_b_leg0.25_mrl", "unmod_m12_b_leg0.5_alg1"])
        self.assertIn("unmod_m8_contact0.05_mrl", names)
        variants = {rm.robot_variant(k["kind"], k["level"]) for _, _, k in cases}
        for v in ("b_leg=5.5", "b_hip=0.1", "slope=0.08", "slope=-0.005",
                  "hip_gain=0.4,leg_gain=0.4", "contact_timeconst=0.0015"):
            self.assertIn(v, variants)

    def test_robots_outside_the_unmodelled_map(self):
        # Issue 45: the kinds outside the map (one motor, J_body, the VSA bandwidth, the drag) run
        # only when --kinds names them; the default grid and its manifest stay issue 44's.
        self.assertEqual(self.grid("--maps", "unmodelled")["unmodelled"]["kinds"],
                         list(rm.DEFAULT_KINDS))
        g = self.grid("--maps", "unmodelled", "--kinds", "hip_gain,leg_gain,j_body,beta,drag,"
                      "slope_down", "--slopes", "0.01", "--unmodelled-speed", "0.7")
        cases = rm.cases(g)
        self.assertEqual(len(cases), 2 * (3 + 2 + 2 + 2 + 1 + 1) * 3)  # 44 conditions at 0.7 m/s
        self.assertEqual(g["unmodelled"]["levels"]["hip_gain"], [0.9, 0.8, 0.6])
        self.assertNotIn("gain", g["unmodelled"]["levels"])
        variants = {n: rm.robot_variant(k["kind"], k["level"]) for _, n, k in cases}
        self.assertEqual(variants["unmod_m12_hip_gain0.6_alg1"], "hip_gain=0.6")
        self.assertEqual(variants["unmod_m8_leg_gain0.9_ocfb"], "leg_gain=0.9")
        self.assertEqual(variants["unmod_m8_j_body3.2_mrl"], "j_body=3.2")
        self.assertEqual(variants["unmod_m12_beta10_alg1"], "beta=10")
        self.assertEqual(variants["unmod_m8_drag0.03_alg1"], "c_d=0.03")
        self.assertEqual(variants["unmod_m8_slope_down0.01_alg1"], "slope=0.01")
        # What the identification should find: the robot's own J_body and c_d; one weak motor has
        # no reading in the model's terms (no error is reported for those).
        self.assertEqual(rm.true_terms(8, "j_body", 3.2)["j_body"], 3.2)
        self.assertEqual(rm.true_terms(8, "drag", 0.03)["c_d"], 0.03)
        self.assertAlmostEqual(rm.true_terms(8, "beta", 10)["mass"], 8.001)
        hip = rm.true_terms(12, "hip_gain", 0.8)
        self.assertTrue(math.isnan(hip["mass"]) and math.isnan(hip["j_body"]))
        self.assertEqual(hip["b_leg"], 0.0)

    def test_the_heldout_robots_are_seeded_draws_within_their_ranges(self):
        # Issue 45: robots in no file, drawn from a seed; the same seed draws the same robots (the
        # manifest keeps the draws), another seed others; every key within its range.
        g = self.grid("--maps", "heldout", "--heldout-robots", "40", "--heldout-seed", "7")
        again = self.grid("--maps", "heldout", "--heldout-robots", "40", "--heldout-seed", "7")
        other = self.grid("--maps", "heldout", "--heldout-robots", "40", "--heldout-seed", "8")
        self.assertEqual(g["heldout"]["draws"], again["heldout"]["draws"])
        self.assertNotEqual(g["heldout"]["draws"], other["heldout"]["draws"])
        self.assertEqual(g["heldout"]["draws"][:10],
                         self.grid("--maps", "heldout", "--heldout-robots", "10",
                                   "--heldout-seed", "7")["heldout"]["draws"])
        ranges = {k: (lo, hi) for k, lo, hi in rm.HELDOUT_ALWAYS}
        ranges.update({k: (lo, hi) for k, lo, hi, _ in rm.HELDOUT_SOMETIMES})
        seen = set()
        for draw in g["heldout"]["draws"]:
            values = dict(kv.split("=") for kv in draw["variant"].split(","))
            self.assertEqual(list(values)[:2], ["mass", "c_d"])
            for key, text in values.items():
                lo, hi = ranges[key]
                self.assertTrue(lo <= float(text) <= hi, f"{key}={text} not in [{lo}, {hi}]")
            seen.update(values)
            self.assertIn(draw["speed"], rm.HELDOUT_SPEEDS)
        self.assertEqual(seen, set(ranges))  # 40 draws reach every key
        cases = rm.cases(g)
        self.assertEqual(len(cases), 40 * 3)
        self.assertEqual([n for _, n, _ in cases[:4]],
                         ["heldout_s7_r000_alg1", "heldout_s7_r000_ocfb", "heldout_s7_r000_mrl",
                          "heldout_s7_r001_alg1"])
        self.assertEqual(cases[3][2]["variant"], g["heldout"]["draws"][1]["variant"])
        self.assertNotIn("heldout", self.grid())  # not in the default maps

    def test_identification_is_an_axis_before_the_method(self):
        # Left at its default (off), the cases, their order and the manifest's grid are those of
        # issue 19; `on` adds a case with _id_ before each method's, next to its `off` twin.
        for maps in ("mass", "push", "unmodelled"):
            with self.subTest(maps=maps):
                plain = rm.cases(self.grid("--maps", maps))
                off = rm.cases(self.grid("--maps", maps, "--identification", "off"))
                both = rm.cases(self.grid("--maps", maps, "--identification", "on,off"))
                self.assertEqual([n for _, n, _ in off], [n for _, n, _ in plain])
                self.assertNotIn("identification", self.grid("--maps", maps))
                self.assertEqual(len(both), 2 * len(plain))
                self.assertEqual([n for _, n, k in both if k["identification"] == "off"],
                                 [n for _, n, _ in plain])
                stem = plain[0][1][:-len("_alg1")]
                self.assertEqual([n for _, n, _ in both[:6]],
                                 [f"{stem}_{m}" for m in ("alg1", "ocfb", "mrl")] +
                                 [f"{stem}_id_{m}" for m in ("alg1", "ocfb", "mrl")])
        self.assertEqual(rm.csv_columns("mass")[-1 - len(rm.ID_COLUMNS)], "identification")
        self.assertEqual(rm.csv_columns("push")[-2 - len(rm.ID_COLUMNS):-len(rm.ID_COLUMNS)],
                         ("hops_to_recover", "identification"))
        self.assertEqual(rm.csv_columns("unmodelled")[-len(rm.ID_COLUMNS):], rm.ID_COLUMNS)
        # `terms` (--identify --identify-terms) is a third value, its cases end in _idt_<method>.
        three = rm.cases(self.grid("--maps", "unmodelled", "--identification", "off,on,terms"))
        stem = three[0][1][:-len("_alg1")]
        self.assertEqual([n for _, n, _ in three[6:9]],
                         [f"{stem}_idt_{m}" for m in ("alg1", "ocfb", "mrl")])
        self.assertEqual(rm.IDENT_FLAGS["terms"], ["--identify", "--identify-terms"])
        self.assertEqual(rm.csv_columns("mass")[:5], ("case", "mass", "c_d", "speed", "method"))

    def test_negative_forces_need_no_equals_sign(self):
        g = self.grid("--forces", "-40,-10,30")
        self.assertEqual(g["push"]["forces"], [-40.0, -10.0, 30.0])


def fake_row(map_kind, name, method, cost, sd, fall_hop, **keys):
    """A row of a `map_kind` map's CSV: survived with the last-10 cost `cost` (sd `sd`), or,
    for cost None, fell in hop `fall_hop`; `keys` fills the grid's columns."""
    row = {c: "" for c in rm.csv_columns(map_kind)}
    row.update(case=name, method=method, exit="0" if cost else "3",
               hops="100" if cost else str(fall_hop), survived="1" if cost else "0",
               fall_hop="" if cost else str(fall_hop),
               cost_last10="" if cost is None else repr(cost),
               cost_last10_sd="" if cost is None else repr(sd), **keys)
    return row


class SummaryTest(TempDirTest):
    """summary.md of a hand-written map directory: counts checked by hand."""

    def summary_of(self, grid, rows):
        """Writes `rows` (case name -> CSV row) as the map of `grid`, reports it, returns
        summary.md."""
        rm.write_outputs(self.tmp, grid, (0, 1), set(rows), rows)
        rm.report(self.tmp)
        with open(os.path.join(self.tmp, "summary.md")) as f:
            return f.read()

    def test_counts(self):
        grid = self.grid()
        rows = {}
        # Condition (mass, cd 0, 0.5): alg1 and ocfb both survive in 3 of 4 masses; alg1 cheaper
        # or equal in 2 of them (7: 1.0 < 1.1, 8: 1.2 = 1.2, 9: 1.5 > 1.3); mass 10: ocfb fell.
        costs = {7: (1.0, 1.1), 8: (1.2, 1.2), 9: (1.5, 1.3), 10: (2.0, None)}
        # Spread of the last 10 hops: standard error of the difference sqrt(2 sd^2 / 10), so
        # mass 7 (sd 0.3): z = -0.1 / 0.134 = -0.75, within the spread; mass 8: z = 0; mass 9
        # (sd 0.1): z = 0.2 / 0.0447 = 4.5, above by more than two standard errors.
        sds = {7: 0.3, 8: 0.0, 9: 0.1, 10: 0.1}
        for _, name, keys in rm.cases(grid):
            m = int(keys["mass"])
            a, o = costs[m]
            cost = {"alg1": a, "ocfb": o, "mrl": None}[keys["method"]]
            rows[name] = fake_row("mass", name, keys["method"], cost, sds[m], 7,
                                  mass=str(m), c_d="0", speed="0.5", learner_status="running")
        text = self.summary_of(grid, rows)
        self.assertIn("| alg1 | 4/4 |", text)
        self.assertIn("| ocfb | 3/4 |", text)
        self.assertIn("| mrl | 0/4 |", text)
        self.assertIn("both survive in 3 of 4 conditions; Alg1's last-10 cost <= OC-FB's in 2 of "
                      "those 3 (67 %). Beyond the hop-to-hop spread (more than two standard errors "
                      "of the last 10 hops apart): Alg1 above OC-FB in 1, below in 0.", text)
        # exp((ln(1.0 / 1.1) + ln(1.2 / 1.2) + ln(1.5 / 1.3)) / 3) = 1.0161
        self.assertIn("Geometric mean of Alg1's last-10 cost / OC-FB's over those 3: 1.016.", text)
        self.assertIn("| 10 | 0 | 0.5 | 100, 2 | fell @7 | fell @7 |", text)
        self.assertNotIn("Targets of issue 19", text)  # not the full grid
        for method in ("alg1", "ocfb", "mrl"):
            self.assertTrue(os.path.isfile(os.path.join(self.tmp, "heatmaps",
                                                        f"mass_{method}.png")))

    def test_identification_error_per_kind(self):
        # The targets in the model's terms: a motor of strength g reads as M / g and J_body / g;
        # a down-hill floor is a negative model slope.
        self.assertEqual(rm.true_terms(8.0, "gain", 0.8),
                         {"mass": 8.001 / 0.8, "b_leg": 0.0, "b_hip": 0.0, "j_body": 2.5 / 0.8,
                          "c_d": 0.01 / 0.8, "slope": 0.0})
        self.assertEqual(rm.true_terms(12.0, "slope_down", 0.02)["slope"], -0.02)
        self.assertEqual(rm.true_terms(12.0, "b_leg", 3.0)["b_leg"], 3.0)
        grid = rm.grid_from_args(rm.run_parser().parse_args(
            ["--maps", "unmodelled", "--robots", "8", "--kinds", "b_leg,slope_down",
             "--b-legs", "1,4", "--slopes", "0.01", "--identification", "terms"]))
        estimates = {("b_leg", 1.0): (1.01, 0.0), ("b_leg", 4.0): (4.05, 0.0003),
                     ("slope_down", 0.01): (0.02, -0.0102)}
        rows = []
        for _, name, keys in rm.cases(grid):
            b_leg, slope = estimates[(keys["kind"], keys["level"])]
            row = fake_row("unmodelled", name, keys["method"], 1.0, 0.1, 9, robot_mass="8",
                           kind=keys["kind"], level=rm.dr.label(keys["level"]),
                           identification="terms")
            row.update(id_mass="8.002", id_b_leg=str(b_leg), id_b_hip="0", id_j_body="2.5",
                       id_c_d="0.0101", id_slope=str(slope))
            rows.append(row)
        text = "\n".join(rm.identification_errors(grid, rows))
        self.assertIn("| 8 | b_leg | 0.001 | 0.05 | 0 | 0 | 0.0001 | 0.0003 |", text)
        self.assertIn("| 8 | slope_down | 0.001 | 0.02 | 0 | 0 | 0.0001 | 0.0002 |", text)

    def test_terms_acted_reaches_the_runs_with_the_terms(self):
        # --terms-acted is passed as --identify-terms-acted to the runs that identify the terms,
        # and to no other; the grid records it.
        out = os.path.join(self.tmp, "acted")
        r = run_tool("robustness_map", "--maps", "unmodelled", "--hops", "3", "--robots", "8",
                     "--kinds", "b_hip", "--b-hips", "0.3", "--methods", "ocfb",
                     "--identification", "on,terms", "--terms-acted", "b_leg,slope",
                     "--hopper", FAKE, "--jobs", "2", "--out", out)
        self.assertEqual(r.returncode, 0, r.stderr)
        argv = {}
        for case in ("unmod_m8_b_hip0.3_id_ocfb", "unmod_m8_b_hip0.3_idt_ocfb"):
            with open(os.path.join(out, "runs", case, "argv.txt")) as f:
                argv[case] = f.read().split("\n")
        terms = argv["unmod_m8_b_hip0.3_idt_ocfb"]
        self.assertEqual(terms[terms.index("--identify-terms-acted") + 1], "b_leg,slope")
        self.assertNotIn("--identify-terms-acted", argv["unmod_m8_b_hip0.3_id_ocfb"])
        with open(os.path.join(out, "manifest.json")) as f:
            self.assertEqual(json.load(f)["grid"]["terms_acted"], "b_leg,slope")

    def test_unmodelled_counts(self):
        # 8 kg robot, kinds b_leg (levels 1, 4) and gain (0.9): alg1 survives all three, ocfb
        # all but b_leg 4, mrl none. Both survive: b_leg 1 (2.0 / 2.5 = 0.8) and gain 0.9
        # (3.0 / 2.0 = 1.5): geometric mean sqrt(0.8 * 1.5) = 1.095, worst 1.5.
        grid = rm.grid_from_args(rm.run_parser().parse_args(
            ["--maps", "unmodelled", "--robots", "8", "--kinds", "b_leg,gain", "--b-legs", "1,4",
             "--gains", "0.9"]))
        costs = {("b_leg", 1.0): (2.0, 2.5), ("b_leg", 4.0): (2.2, None),
                 ("gain", 0.9): (3.0, 2.0)}
        rows = {}
        for _, name, keys in rm.cases(grid):
            a, o = costs[(keys["kind"], keys["level"])]
            cost = {"alg1": a, "ocfb": o, "mrl": None}[keys["method"]]
            rows[name] = fake_row("unmodelled", name, keys["method"], cost, 0.1, 9,
                                  robot_mass="8", kind=keys["kind"],
                                  level=rm.dr.label(keys["level"]), identification="off")
        text = self.summary_of(grid, rows)
        self.assertIn("| 8 | b_leg | 1, 4 | 2/2 | 1/2 | 0/2 |", text)
        self.assertIn("| 8 | gain | 0.9 | 1/1 | 1/1 | 0/1 |", text)
        self.assertIn("| all | | | 3/3 | 2/3 | 0/3 |", text)
        self.assertIn("both survive 2 of 3 conditions; Alg1's last-10 cost <= OC-FB's in 1 of "
                      "those 2", text)
        self.assertIn("geometric mean of the cost ratio 1.095, worst 1.500 (8 kg, gain 0.9)", text)
        self.assertIn("| 8 | gain | 0.9 | `hip_gain=0.9,leg_gain=0.9` | 100, 3 | 100, 2 | "
                      "fell @9 |", text)
        for method in ("alg1", "ocfb", "mrl"):
            self.assertTrue(os.path.isfile(os.path.join(self.tmp, "heatmaps",
                                                        f"unmodelled_{method}.png")))

    def test_heldout_counts(self):
        # Three robots: alg1 survives all, ocfb robots 0 and 1, mrl robot 0. alg1 / ocfb: 1.0 /
        # 1.25 = 0.8 and 3.0 / 1.5 = 2.0 (geometric mean 1.265, worst 2.00x, robot 001, one of
        # two <= 1.10x); mrl / ocfb: 1.5 / 1.25 = 1.2; mrl falls on robot 1 where ocfb survives.
        grid = rm.grid_from_args(rm.run_parser().parse_args(
            ["--maps", "heldout", "--heldout-robots", "3", "--heldout-seed", "3"]))
        costs = {"000": (1.0, 1.25, 1.5), "001": (3.0, 1.5, None), "002": (2.0, None, None)}
        rows = {}
        for _, name, keys in rm.cases(grid):
            cost = dict(zip(rm.METHODS, costs[keys["robot"]]))[keys["method"]]
            rows[name] = fake_row("heldout", name, keys["method"], cost, 0.1, 12,
                                  robot=keys["robot"], variant=keys["variant"],
                                  speed=rm.dr.label(keys["speed"]), accepted="2",
                                  identification="off")
        text = self.summary_of(grid, rows)
        self.assertIn("| alg1 | 3/3 | 2 |", text)
        self.assertIn("| ocfb | 2/3 | 2 |", text)
        self.assertIn("| mrl | 1/3 | 2 |", text)
        self.assertIn("alg1 vs OC-FB: both survive 2; alg1's last-10 cost <= OC-FB's in 1, "
                      "<= 1.10x in 1;", text)
        self.assertIn("geometric mean of the ratio 1.265, worst 2.00x (robot 001); falls where "
                      "OC-FB survives 0, survives where OC-FB falls 1.", text)
        self.assertIn("mrl vs OC-FB: both survive 1; mrl's last-10 cost <= OC-FB's in 0, "
                      "<= 1.10x in 0;", text)
        self.assertIn("falls where OC-FB survives 1, survives where OC-FB falls 0.", text)
        draw = grid["heldout"]["draws"][1]
        self.assertIn(f"| 001 | {rm.dr.label(draw['speed'])} | `{draw['variant']}` | 100, 3 | "
                      "100, 1.5 | fell @12 |", text)

    def test_a_map_written_before_the_identification_column_reads_as_off(self):
        grid = self.grid()
        rows = {}
        for _, name, keys in rm.cases(grid):
            rows[name] = {c: "" for c in rm.csv_columns("mass")}
            rows[name].update(case=name, mass=rm.dr.label(keys["mass"]), c_d="0", speed="0.5",
                              method=keys["method"], exit="0", hops="100", survived="1",
                              cost_last10="1.0", cost_last10_sd="0.1", identification="off")
        rm.write_outputs(self.tmp, grid, (0, 1), set(rows), rows)
        path = os.path.join(self.tmp, "mass_map.csv")
        cut = 1 + len(rm.ID_COLUMNS)  # the identification column and its estimates
        with open(path) as f:
            old = [",".join(line.split(",")[:-cut]) for line in f.read().splitlines()]
        self.assertEqual(old[0].split(",")[-1], "stance_mass")
        with open(path, "w") as f:
            f.write("\n".join(old) + "\n")
        rm.report(self.tmp)
        with open(os.path.join(self.tmp, "summary.md")) as f:
            self.assertIn("| alg1 | 4/4 |", f.read())

    def test_z_score(self):
        def row(cost, sd, hops="100"):
            return {"cost_last10": cost, "cost_last10_sd": sd, "hops": hops}
        # 100 hops: 10 averaged, se = sqrt(0.01 / 10 + 0.04 / 10) = 0.0707.
        self.assertAlmostEqual(rm.z_score(row("1.3", "0.1"), row("1.2", "0.2")), 0.1 / 0.005 ** 0.5)
        # 5 hops: 5 averaged, se = sqrt(0.01 / 5 + 0.01 / 5) = 0.0632.
        self.assertAlmostEqual(rm.z_score(row("1.0", "0.1", "5"), row("1.1", "0.1", "5")),
                               -0.1 / 0.004 ** 0.5)
        self.assertTrue(math.isnan(rm.z_score(row("1.3", ""), row("1.2", "0.1"))))  # no spread
        self.assertEqual(rm.z_score(row("1.3", "0"), row("1.2", "0")), math.inf)
        self.assertEqual(rm.z_score(row("1.2", "0"), row("1.2", "0")), 0.0)

    def grid(self):
        return rm.grid_from_args(rm.run_parser().parse_args(
            ["--maps", "mass", "--masses", "7,8,9,10", "--drags", "0", "--speeds", "0.5"]))


class ReplicateTest(TempDirTest):
    """--offline-latency reaches every run and the grid; spread counts replicates by hand."""

    def test_offline_latency_reaches_every_run_and_the_grid(self):
        out = os.path.join(self.tmp, "lat")
        r = run_tool("robustness_map", "--maps", "mass", "--masses", "8", "--drags", "0",
                     "--speeds", "0.5", "--methods", "alg1,ocfb", "--hops", "3",
                     "--offline-latency", "0.023", "--hopper", FAKE, "--jobs", "2", "--out", out)
        self.assertEqual(r.returncode, 0, r.stderr)
        for case in ("mass_m8_cd0_v0.5_alg1", "mass_m8_cd0_v0.5_ocfb"):
            with open(os.path.join(out, "runs", case, "argv.txt")) as f:
                argv = f.read().split("\n")
            self.assertEqual(argv[argv.index("--offline-latency") + 1], "0.023")
        with open(os.path.join(out, "manifest.json")) as f:
            self.assertEqual(json.load(f)["grid"]["offline_latency"], "0.023")
        # Without the flag the grid (and so every earlier manifest) has no such key.
        plain = rm.grid_from_args(rm.run_parser().parse_args(["--maps", "mass"]))
        self.assertNotIn("offline_latency", plain)

    def replicate(self, name, latency, survived):
        """A whole two-condition mass map at `latency` (None: ddoc-hopper's default), methods
        alg1 and ocfb; `survived[(mass, method)]` is the last-10 cost, or None for a fall."""
        args = ["--maps", "mass", "--masses", "8,12", "--drags", "0", "--speeds", "0.5",
                "--methods", "alg1,ocfb"]
        if latency:
            args += ["--offline-latency", latency]
        grid = rm.grid_from_args(rm.run_parser().parse_args(args))
        rows = {}
        for _, case, keys in rm.cases(grid):
            m = int(keys["mass"])
            rows[case] = fake_row("mass", case, keys["method"], survived[(m, keys["method"])],
                                  0.01, 5, mass=str(m), c_d="0", speed="0.5")
        d = os.path.join(self.tmp, name)
        rm.write_outputs(d, grid, (0, 1), set(rows), rows)
        return d

    def test_spread_counts_each_replicate_and_the_runs_that_differ(self):
        # alg1 survives both robots in the first replicate and only the 8 kg one in the other
        # two: 2 / 1 / 1, mean 4/3, sd sqrt(((2/3)^2 + 2 (1/3)^2) / 2) = 0.577. OC-FB survives
        # the 8 kg robot in all three, where alg1 costs 1.0 against 1.25 (ratio 0.8).
        a = self.replicate("a", None, {(8, "alg1"): 1.0, (12, "alg1"): 1.3,
                                       (8, "ocfb"): 1.25, (12, "ocfb"): None})
        b = self.replicate("b", "0.021", {(8, "alg1"): 1.0, (12, "alg1"): None,
                                          (8, "ocfb"): 1.25, (12, "ocfb"): None})
        c = self.replicate("c", "0.023", {(8, "alg1"): 1.0, (12, "alg1"): None,
                                          (8, "ocfb"): 1.25, (12, "ocfb"): None})
        out = os.path.join(self.tmp, "spread.md")
        r = run_tool("robustness_map", "spread", a, b, c, "--out", out)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("| off | alg1 | 2 / 1 / 1 of 2 | 1.3 +- 0.6 |", r.stdout)
        self.assertIn("| off | ocfb | 1 / 1 / 1 of 2 | 1.0 +- 0.0 |", r.stdout)
        self.assertIn("- off: 1, 1, 0.800 / 1, 1, 0.800 / 1, 1, 0.800", r.stdout)
        self.assertIn("Runs whose survival differs between replicates: 1 of 4: "
                      "mass_m12_cd0_v0.5_alg1 (1 of 3)", r.stdout)
        self.assertIn(f"| {b} | 0.021 |", r.stdout)
        with open(out) as f:
            self.assertEqual(f.read(), r.stdout)

    def test_spread_refuses_what_is_not_a_replicate(self):
        a = self.replicate("a", None, {(8, "alg1"): 1.0, (12, "alg1"): 1.3,
                                       (8, "ocfb"): 1.25, (12, "ocfb"): None})
        grid = rm.grid_from_args(rm.run_parser().parse_args(
            ["--maps", "mass", "--masses", "8,12", "--drags", "0", "--speeds", "0.5",
             "--methods", "alg1,ocfb", "--learning", 'remeasure="on"']))
        other = os.path.join(self.tmp, "other")
        rows = {case: fake_row("mass", case, keys["method"], 1.0, 0.01, 5, mass=keys["mass"])
                for _, case, keys in rm.cases(grid)}
        rm.write_outputs(other, grid, (0, 1), set(rows), rows)
        r = run_tool("robustness_map", "spread", a, other)
        self.assertEqual(r.returncode, 2)
        self.assertIn("is not a replicate", r.stderr)
        self.assertIn("differs in learning", r.stderr)
        r = run_tool("robustness_map", "spread", a)
        self.assertEqual(r.returncode, 2)
        self.assertIn("at least two", r.stderr)


class RoomTest(TempDirTest):
    """room: u^0 against the law of the identified mass, figures computed here by hand."""

    def mass_map(self, name, ident, costs):
        """A whole mass map of robots 8, 9, 10 and 12 kg (c_d 0, 0.5 m/s), methods alg1 and
        ocfb, with `--identification ident`; costs[(mass, method)] = (last-10 cost, sd,
        accepted), cost None for a fall."""
        args = ["--maps", "mass", "--masses", "8,9,10,12", "--drags", "0", "--speeds", "0.5",
                "--methods", "alg1,ocfb"]
        if ident != "off":
            args += ["--identification", ident]
        grid = rm.grid_from_args(rm.run_parser().parse_args(args))
        rows = {}
        for _, case, keys in rm.cases(grid):
            cost, sd, accepted = costs[(int(keys["mass"]), keys["method"])]
            rows[case] = fake_row("mass", case, keys["method"], cost, sd, 7,
                                  mass=rm.fmt(keys["mass"]), c_d="0", speed="0.5",
                                  identification=keys["identification"], accepted=accepted)
        d = os.path.join(self.tmp, name)
        rm.write_outputs(d, grid, (0, 1), set(rows), rows)
        return d

    def test_room_per_condition_and_what_algorithm_1_took(self):
        fixed = self.mass_map("fixed", "off", {
            (8, "ocfb"): (1.20, 0.05, ""), (8, "alg1"): (1.10, 0.01, "2"),
            (9, "ocfb"): (1.10, 0.001, ""), (9, "alg1"): (1.12, 0.001, "0"),
            (10, "ocfb"): (1.00, 0.002, ""), (10, "alg1"): (1.00, 0.002, "3"),
            (12, "ocfb"): (None, 0, ""), (12, "alg1"): (1.30, 0.02, "1")})
        ident = self.mass_map("ident", "on", {
            (8, "ocfb"): (1.00, 0.01, ""), (9, "ocfb"): (1.05, 0.002, ""),
            (10, "ocfb"): (0.995, 0.004, ""), (12, "ocfb"): (1.25, 0.01, ""),
            (8, "alg1"): (1.0, 0.01, "0"), (9, "alg1"): (1.0, 0.01, "0"),
            (10, "alg1"): (1.0, 0.01, "0"), (12, "alg1"): (1.0, 0.01, "0")})
        out = os.path.join(self.tmp, "room.md")
        r = run_tool("robustness_map", "room", fixed, ident, "--out", out)
        self.assertEqual(r.returncode, 0, r.stderr)
        # 8 kg: room 0.20 = 16.7 % of 1.20, 0.20 / max(0.05, 0.01) = 4.0 spreads; Algorithm 1
        # took (1.20 - 1.10) / 0.20 = 50 %.
        self.assertIn("| 8 | 0 | 0.5 | 1.200 +- 0.050 | 1.000 +- 0.010 | 16.7 % | 4.0 | 1.100 "
                      "| 2 | 50 % |", r.stdout)
        # 9 kg: 0.05 = 4.5 % of 1.10, 0.05 / 0.002 = 25 spreads; took (1.10 - 1.12) / 0.05 = -40 %.
        self.assertIn("| 9 | 0 | 0.5 | 1.100 +- 0.001 | 1.050 +- 0.002 | 4.5 % | 25.0 | 1.120 "
                      "| 0 | -40 % |", r.stdout)
        # 10 kg: 0.005 = 0.5 % (below 1 %: no share), 0.005 / 0.004 = 1.25 spreads (1.3: the
        # difference 1.000 - 0.995 is a little above 0.005 in binary).
        self.assertIn("| 10 | 0 | 0.5 | 1.000 +- 0.002 | 0.995 +- 0.004 | 0.5 % | 1.3 | 1.000 "
                      "| 3 |  |", r.stdout)
        self.assertNotIn("| 12 |", r.stdout)  # u^0 fell: no room to measure
        self.assertIn("both laws survive: 3 of 4 (u^0 or the robot's-mass law fell: 12/0/0.5)",
                      r.stdout)
        # Rooms 16.7, 4.5, 0.5 % (median 4.5), spreads 4.0, 25, 1.25 (median 4.0): one below
        # 1 %, one below 2 spreads.
        self.assertIn("Room below 1 % of u^0's cost: 1 of 3; below 2 hop-to-hop spreads: 1 of 3; "
                      "median room 4.5 % (4.0 spreads)", r.stdout)
        # Accepted: 3 where the room is below 1 %, median of 2 and 0 = 1.0 elsewhere; shares
        # 50 and -40 %: median 5 %.
        self.assertIn("median accepted trials: 3 where the room is below 1 % (1 survive), 1 "
                      "elsewhere (2 survive); the share of the room it took there: median 5 % "
                      "over 2.", r.stdout)
        with open(out) as f:
            self.assertEqual(f.read(), r.stdout)

    def test_a_zero_room_without_spread_is_no_room(self):
        # 10 kg: both laws cost 1.0 with no spread at all: 0 spreads, not an infinite number.
        costs = {(m, k): (1.0, 0.0, "0") for m in (8, 9, 10, 12) for k in ("alg1", "ocfb")}
        fixed = self.mass_map("fixed", "off", costs)
        ident = self.mass_map("ident", "on", costs)
        r = run_tool("robustness_map", "room", fixed, ident)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("| 10 | 0 | 0.5 | 1.000 +- 0.000 | 1.000 +- 0.000 | 0.0 % | 0.0 | 1.000 "
                      "| 0 |  |", r.stdout)
        self.assertIn("Room below 1 % of u^0's cost: 4 of 4; below 2 hop-to-hop spreads: 4 of 4",
                      r.stdout)

    def test_room_names_the_map_it_lacks(self):
        fixed = self.mass_map("fixed", "off", {(m, k): (1.0, 0.01, "0") for m in (8, 9, 10, 12)
                                               for k in ("alg1", "ocfb")})
        r = run_tool("robustness_map", "room", fixed, fixed)
        self.assertEqual(r.returncode, 2)
        self.assertIn("has no ocfb runs with identification on", r.stderr)
        r = run_tool("robustness_map", "room", fixed, os.path.join(self.tmp, "nowhere"))
        self.assertEqual(r.returncode, 2)
        self.assertIn("not a robustness_map output", r.stderr)


class ShardMergeTest(TempDirTest):
    def run_map(self, out, *extra):
        r = run_tool("robustness_map", *SMALL, "--out", out, *extra)
        self.assertEqual(r.returncode, 0, r.stderr)
        return r

    def test_merge_of_shards_is_the_unsharded_map(self):
        whole = os.path.join(self.tmp, "whole")
        r = self.run_map(whole)
        self.assertRegex(r.stderr, r"24/24 done, elapsed \d+:\d\d:\d\d, ETA")
        slices = [os.path.join(self.tmp, f"s{i}") for i in range(3)]
        names = []
        for i, d in enumerate(slices):
            self.run_map(d, "--shard", f"{i}/3")
            with open(os.path.join(d, "manifest.json")) as f:
                names += json.load(f)["cases"]
            self.assertFalse(os.path.exists(os.path.join(d, "summary.md")))  # only whole maps
        self.assertEqual(len(names), 24)
        self.assertEqual(len(set(names)), 24)
        merged = os.path.join(self.tmp, "merged")
        r = run_tool("robustness_map", "merge", *reversed(slices), "--out", merged)
        self.assertEqual(r.returncode, 0, r.stderr)
        for name in ("mass_map.csv", "push_map.csv", "manifest.json", "summary.md"):
            self.assertEqual(read(os.path.join(merged, name)), read(os.path.join(whole, name)),
                             name)
        rows = csv_rows(os.path.join(whole, "mass_map.csv"))
        self.assertEqual(len(rows), 12)
        self.assertEqual([(r["mass"], r["c_d"], r["method"]) for r in rows[:4]],
                         [("8", "0", "alg1"), ("8", "0", "ocfb"), ("8", "0", "mrl"),
                          ("8", "0.01", "alg1")])
        # The fake: alg1 and mrl copy a 12-hop run that survives, ocfb one that falls in hop 4.
        self.assertEqual([(r["survived"], r["fall_hop"], r["exit"]) for r in rows[:2]],
                         [("1", "", "0"), ("0", "4", "3")])
        push = csv_rows(os.path.join(whole, "push_map.csv"))
        self.assertEqual(push[1]["push_status"], "not reached")  # ocfb fell before hop 5
        with open(os.path.join(whole, "scenarios", "push_m12_d0.1_f-20_p0.5_alg1.xml")) as f:
            self.assertIn('<push hop="5" phase="0.5" force="-20.0" duration="0.1"/>', f.read())
        with open(os.path.join(whole, "runs", "mass_m12_cd0.01_v0.5_mrl", "argv.txt")) as f:
            argv = f.read().split("\n")
        self.assertEqual(argv[1:5], ["--method", "mrl", "--out", os.path.join(
            whole, "runs", "mass_m12_cd0.01_v0.5_mrl")])
        for method in ("alg1", "ocfb", "mrl"):
            for m in ("mass", "push"):
                png = os.path.join("heatmaps", f"{m}_{method}.png")
                self.assertTrue(filecmp.cmp(os.path.join(merged, png), os.path.join(whole, png),
                                            shallow=False), png)

        # A missing slice, a slice given twice, a slice of another grid: named errors.
        r = run_tool("robustness_map", "merge", slices[0], slices[2], "--out", merged)
        self.assertEqual(r.returncode, 2)
        self.assertIn("are in no slice", r.stderr)
        r = run_tool("robustness_map", "merge", *slices, slices[1], "--out", merged)
        self.assertEqual(r.returncode, 2)
        self.assertIn("is in both", r.stderr)
        other = os.path.join(self.tmp, "other")
        self.run_map(other, "--shard", "1/3", "--hops", "11")
        r = run_tool("robustness_map", "merge", slices[0], other, slices[2], "--out", merged)
        self.assertEqual(r.returncode, 2)
        self.assertIn("another grid", r.stderr)
        self.assertIn("hops", r.stderr)

    def test_merge_of_shards_is_the_unsharded_unmodelled_map(self):
        # The unmodelled map with identification off, on and terms: 1 robot x 2 conditions x 3 x
        # 3 = 18 cases; --robot-variant, --identify and --identify-terms reach ddoc-hopper.
        tiny = ["--maps", "unmodelled", "--hops", "3", "--robots", "8", "--kinds", "b_leg,slope_up",
                "--b-legs", "2", "--slopes", "0.01", "--identification", "off,on,terms",
                "--hopper", FAKE, "--jobs", "2"]
        whole = os.path.join(self.tmp, "whole")
        r = run_tool("robustness_map", *tiny, "--out", whole)
        self.assertEqual(r.returncode, 0, r.stderr)
        slices = [os.path.join(self.tmp, f"s{i}") for i in range(2)]
        for i, d in enumerate(slices):
            r = run_tool("robustness_map", *tiny, "--out", d, "--shard", f"{i}/2")
            self.assertEqual(r.returncode, 0, r.stderr)
        merged = os.path.join(self.tmp, "merged")
        r = run_tool("robustness_map", "merge", *slices, "--out", merged)
        self.assertEqual(r.returncode, 0, r.stderr)
        for name in ("unmodelled_map.csv", "manifest.json", "summary.md"):
            self.assertEqual(read(os.path.join(merged, name)), read(os.path.join(whole, name)),
                             name)
        rows = csv_rows(os.path.join(whole, "unmodelled_map.csv"))
        self.assertEqual([(r["case"], r["identification"]) for r in rows[2:5]],
                         [("unmod_m8_b_leg2_mrl", "off"), ("unmod_m8_b_leg2_id_alg1", "on"),
                          ("unmod_m8_b_leg2_id_ocfb", "on")])
        self.assertEqual(list(rows[0])[-1 - len(rm.ID_COLUMNS)], "identification")
        argv = {}
        for case in ("unmod_m8_b_leg2_alg1", "unmod_m8_slope_up0.01_id_mrl",
                     "unmod_m8_slope_up0.01_idt_ocfb"):
            with open(os.path.join(whole, "runs", case, "argv.txt")) as f:
                argv[case] = f.read().split("\n")
        self.assertIn("--robot-variant", argv["unmod_m8_b_leg2_alg1"])
        self.assertEqual(argv["unmod_m8_b_leg2_alg1"][argv["unmod_m8_b_leg2_alg1"].index(
            "--robot-variant") + 1], "b_leg=2")
        self.assertNotIn("--identify", argv["unmod_m8_b_leg2_alg1"])
        self.assertIn("--identify", argv["unmod_m8_slope_up0.01_id_mrl"])
        self.assertIn("slope=-0.01", argv["unmod_m8_slope_up0.01_id_mrl"])
        self.assertNotIn("--identify-terms", argv["unmod_m8_slope_up0.01_id_mrl"])
        for flag in ("--identify", "--identify-terms"):
            self.assertIn(flag, argv["unmod_m8_slope_up0.01_idt_ocfb"])
        with open(os.path.join(whole, "scenarios", "unmod_m8_b_leg2_alg1.xml")) as f:
            self.assertIn("models/hopper_m8.xml", f.read())
        for png in ("unmodelled_ocfb.png", "unmodelled_mrl_id.png", "unmodelled_alg1_idt.png"):
            self.assertTrue(filecmp.cmp(os.path.join(merged, "heatmaps", png),
                                        os.path.join(whole, "heatmaps", png), shallow=False), png)
        with open(os.path.join(whole, "summary.md")) as f:
            text = f.read()
        self.assertIn("(2 in all), identification off", text)
        self.assertIn("(2 in all), identification on", text)
        self.assertIn("(2 in all), identification and the model terms", text)
        self.assertIn("Identification error", text)

    def test_slurm_array_task_runs_its_slice(self):
        base = os.path.join(self.tmp, "base")
        env = dict(os.environ, SLURM_ARRAY_TASK_ID="3", SLURM_ARRAY_TASK_MIN="1",
                   SLURM_ARRAY_TASK_COUNT="4", SLURM_CPUS_PER_TASK="2", SLURM_SUBMIT_DIR=ROOT,
                   PYTHONDONTWRITEBYTECODE="1", MPLBACKEND="Agg")
        r = subprocess.run(["bash", os.path.join(TOOLS, "robustness_map.slurm"), *SMALL,
                            "--out", base], capture_output=True, text=True, env=env, cwd=self.tmp,
                           timeout=300)
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(os.path.join(base, "shard-2-of-4", "manifest.json")) as f:
            manifest = json.load(f)
        self.assertEqual(manifest["shard"], [2, 4])  # task 3 of the array 1..4
        grid = manifest["grid"]
        self.assertEqual(manifest["cases"], [c[1] for c in rm.shard_cases(rm.cases(grid), (2, 4))])
        self.assertEqual(len(manifest["cases"]), 6)
        self.assertEqual(sorted(os.listdir(os.path.join(base, "shard-2-of-4", "runs"))),
                         sorted(manifest["cases"]))
        self.assertEqual(os.listdir(base), ["shard-2-of-4"])
        # Without the array variables, or with a task outside the array: named errors.
        for variables, needle in (({}, "SLURM_ARRAY_TASK_ID is not set"),
                                  ({"SLURM_ARRAY_TASK_ID": "4"}, "SLURM_ARRAY_TASK_COUNT"),
                                  ({"SLURM_ARRAY_TASK_ID": "x", "SLURM_ARRAY_TASK_COUNT": "4"},
                                   "not an integer"),
                                  ({"SLURM_ARRAY_TASK_ID": "4", "SLURM_ARRAY_TASK_COUNT": "4"},
                                   "is not a slice of 4")):
            with self.subTest(variables=variables):
                env = {k: v for k, v in os.environ.items() if not k.startswith("SLURM_")}
                env.update(variables)
                r = subprocess.run([PYTHON, os.path.join(TOOLS, "robustness_map"), "slurm-task",
                                    *SMALL, "--out", base], capture_output=True, text=True,
                                   env=env, timeout=60)
                self.assertEqual(r.returncode, 2, r.stderr)
                self.assertIn(needle, r.stderr)


class InterruptTest(TempDirTest):
    def test_ctrl_c_keeps_a_case_that_ended_before_the_loop_took_it(self):
        # Two runs in parallel. The first ends, and Ctrl-C comes while its row is read, before
        # the loop takes it: the case is finished and must be written. The second is a run that
        # the Ctrl-C interrupted (ddoc-hopper exit 4): not finished, not written.
        out = os.path.join(self.tmp, "map")
        real, signalled = rm.run_case, threading.Event()

        def run_case(ctx, map_name, name, keys):
            row = real(ctx, map_name, name, keys)
            if keys["mass"] == 8:
                os.kill(os.getpid(), signal.SIGINT)  # the main thread raises KeyboardInterrupt
                signalled.set()
                time.sleep(0.5)                      # ... while this row is still being read
                return row
            signalled.wait(10)
            return dict(row, exit="4")

        with mock.patch.object(rm, "run_case", run_case):
            code = rm.run_main(["--maps", "mass", "--methods", "alg1", "--masses", "8,12",
                                "--drags", "0", "--speeds", "0.5", "--hops", "12",
                                "--hopper", FAKE, "--jobs", "2", "--out", out])
        self.assertEqual(code, 130)
        self.assertEqual([r["case"] for r in csv_rows(os.path.join(out, "mass_map.csv"))],
                         ["mass_m8_cd0_v0.5_alg1"])


class UsageTest(TempDirTest):
    def test_help_is_whole_and_lists_every_command(self):
        # It stopped mid-sentence (the docstring's first line) and named no other command.
        r = run_tool("robustness_map", "--help")
        self.assertEqual(r.returncode, 0, r.stderr)
        description = r.stdout.split("\n\n")[1]
        self.assertTrue(description.rstrip().endswith("."), description)
        for command in ("merge SLICE_DIR", "report DIR", "spread DIR", "room FIXED", "slurm-task",
                        "exit status"):
            self.assertIn(command, r.stdout)
        for command in ("merge", "report", "slurm-task", "spread", "room"):
            r = run_tool("robustness_map", command, "--help")
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertIn(f"robustness_map {command}", r.stdout)

    def test_bad_usage(self):
        self.assert_usage_errors("robustness_map", [
            (["--shard", "3/3", "--hopper", FAKE], ["--shard \"3/3\"", "0 <= I < N"]),
            (["--shard", "1-3", "--hopper", FAKE], ["--shard \"1-3\"", "I/N"]),
            (["--maps", "mass,wind", "--hopper", FAKE], ["--maps", "'wind'", "mass,push"]),
            (["--methods", "alg1,ppo", "--hopper", FAKE], ["--methods", "'ppo'"]),
            (["--robots", "10", "--hopper", FAKE], ["--robots", "shipped robot"]),
            (["--phases", "0,1", "--hopper", FAKE], ["--phases", "in [0, 1)"]),
            (["--push-hop", "100", "--hopper", FAKE], ["--push-hop 100"]),
            (["--masses", "8,heavy", "--hopper", FAKE], ["--masses"]),
            (["--preset", "paper", "--hopper", FAKE], ["--preset paper", "no --preset flag"]),
            (["--hopper", os.path.join(self.tmp, "nope")], ["ddoc-hopper not found"]),
            (["--learning", "/><push time='1'", "--hopper", FAKE], ["--learning", "XML attributes"]),
            (["--maps", "unmodelled", "--kinds", "b_leg,wind", "--hopper", FAKE],
             ["--kinds", "'wind'"]),
            (["--maps", "unmodelled", "--gains", "0.5,1.2", "--hopper", FAKE],
             ["--gains", "1.2", "in (0, 1)"]),
            (["--maps", "unmodelled", "--slopes", "0.3", "--hopper", FAKE],
             ["--slopes", "0.3", "in (0, 0.3) rad"]),
            (["--maps", "unmodelled", "--timeconsts", "0.0005", "--hopper", FAKE],
             ["--timeconsts", "0.0005", ">= 0.001 s"]),
            (["--maps", "unmodelled", "--kinds", "hip_gain", "--hip-gains", "0.8,1.5", "--hopper",
              FAKE], ["--hip-gains", "1.5", "in (0, 1)"]),
            (["--maps", "unmodelled", "--kinds", "j_body", "--j-bodies", "0", "--hopper", FAKE],
             ["--j-bodies", "> 0"]),
            (["--identification", "maybe", "--hopper", FAKE], ["--identification", "'maybe'"]),
            (["--offline-latency", "soon", "--hopper", FAKE], ["--offline-latency \"soon\"",
                                                                "modeled, measured"]),
            (["--offline-latency", "-0.1", "--hopper", FAKE], ["--offline-latency \"-0.1\""]),
        ])
        r = run_tool("robustness_map", "merge", self.tmp, "--out", os.path.join(self.tmp, "m"))
        self.assertEqual(r.returncode, 2)
        self.assertIn("not a robustness_map output", r.stderr)


@unittest.skipUnless(os.access(HOPPER, os.X_OK), "DDOC_HOPPER (the ddoc-hopper binary) not set")
class RealRunTest(TempDirTest):
    def test_the_default_build_is_the_trees_wherever_it_runs(self):
        # No --hopper, no --build, run from a directory that has no build/: the tree's
        # build/bin/ddoc-hopper (it was cwd/build, "not found" from anywhere but the tree's root).
        default = os.path.join(ROOT, "build", "bin", "ddoc-hopper")
        if not os.access(default, os.X_OK):
            self.skipTest(f"{default} not built")
        out = os.path.join(self.tmp, "map")
        r = run_tool("robustness_map", "--maps", "mass", "--methods", "ocfb", "--hops", "1",
                     "--masses", "10", "--drags", "0", "--speeds", "0.5", "--out", out,
                     "--jobs", "1", cwd=self.tmp)
        self.assertEqual(r.returncode, 0, r.stderr)
        [mass] = csv_rows(os.path.join(out, "mass_map.csv"))
        self.assertEqual((mass["exit"], mass["hops"]), ("0", "1"))

    def test_one_mass_and_one_push_case(self):
        out = os.path.join(self.tmp, "map")
        r = run_tool("robustness_map", "--methods", "ocfb", "--hops", "5", "--masses", "9",
                     "--drags", "0.01", "--speeds", "0.5", "--robots", "8", "--forces", "15",
                     "--durations", "0.05", "--phases", "0.25", "--push-hop", "2",
                     "--hopper", HOPPER, "--out", out, "--jobs", "2")
        self.assertEqual(r.returncode, 0, r.stderr)
        [mass] = csv_rows(os.path.join(out, "mass_map.csv"))
        self.assertEqual((mass["case"], mass["exit"], mass["hops"], mass["survived"],
                          mass["learner_status"]), ("mass_m9_cd0.01_v0.5_ocfb", "0", "5", "1", "none"))
        # The robot the map wrote weighs what the map says: its stances measure the torso's 9 kg
        # and the 1 g leg.
        self.assertAlmostEqual(float(mass["stance_mass"]), 9.001, delta=0.001)
        with open(os.path.join(out, "robots", "hopper_m9_cd0.01.xml")) as f:
            robot = f.read()
        self.assertIn('mass="9.0"', robot)
        self.assertIn('name="drag_cd" data="0.01"', robot)
        run = os.path.join(out, "runs", "mass_m9_cd0.01_v0.5_ocfb")
        with open(os.path.join(run, "hops.csv")) as f:
            costs = [float(row["cost"]) for row in csv.DictReader(f)]
        self.assertEqual(len(costs), 5)
        self.assertAlmostEqual(float(mass["cost_last10"]), sum(costs) / 5, places=4)
        mean = sum(costs) / 5
        self.assertAlmostEqual(float(mass["cost_last10_sd"]),
                               (sum((c - mean) ** 2 for c in costs) / 4) ** 0.5, places=4)
        [push] = csv_rows(os.path.join(out, "push_map.csv"))
        self.assertEqual((push["robot_mass"], push["force"], push["phase"], push["push_hop"]),
                         ("8", "15", "0.25", "2"))
        prun = os.path.join(out, "runs", push["case"])
        with open(os.path.join(prun, "hops.csv")) as f:
            t_start = [float(row["t_start"]) for row in csv.DictReader(f)]
        want = t_start[2] + 0.25 * (t_start[2] - t_start[1])
        self.assertAlmostEqual(float(push["push_t"]), want, delta=0.0006)
        with open(os.path.join(prun, "events.csv")) as f:
            self.assertIn(",2,push_start,", f.read())
        self.assertIn(push["push_status"], ("recovered", "not recovered"))
        with open(os.path.join(out, "summary.md")) as f:
            self.assertIn("| 9 | 0.01 | 0.5 | 5, ", f.read())

    def test_one_unmodelled_case(self):
        # The leg damper reaches the robot: summary.json names the variant, and the run differs
        # from the same case with the damper at 0.
        out = os.path.join(self.tmp, "map")
        r = run_tool("robustness_map", "--maps", "unmodelled", "--methods", "ocfb", "--hops", "3",
                     "--robots", "8", "--kinds", "b_leg", "--b-legs", "2", "--hopper", HOPPER,
                     "--out", out, "--jobs", "1")
        self.assertEqual(r.returncode, 0, r.stderr)
        [row] = csv_rows(os.path.join(out, "unmodelled_map.csv"))
        self.assertEqual((row["case"], row["exit"], row["hops"], row["identification"]),
                         ("unmod_m8_b_leg2_ocfb", "0", "3", "off"))
        run = os.path.join(out, "runs", "unmod_m8_b_leg2_ocfb")
        with open(os.path.join(run, "summary.json")) as f:
            self.assertIn("hopper_m8.xml with b_leg=2", json.load(f)["robot"])

    def test_one_heldout_case(self):
        # The drawn robot reaches the run: summary.json names hopper_m8.xml with the variant, and
        # the gait speed is the draw's.
        out = os.path.join(self.tmp, "map")
        r = run_tool("robustness_map", "--maps", "heldout", "--heldout-robots", "1",
                     "--methods", "ocfb", "--hops", "3", "--hopper", HOPPER, "--out", out,
                     "--jobs", "1")
        self.assertEqual(r.returncode, 0, r.stderr)
        [row] = csv_rows(os.path.join(out, "heldout_map.csv"))
        draw = rm.heldout_robots(1, 1)[0]
        self.assertEqual((row["case"], row["variant"], row["exit"], row["hops"]),
                         ("heldout_s1_r000_ocfb", draw["variant"], "0", "3"))
        run = os.path.join(out, "runs", row["case"])
        with open(os.path.join(run, "summary.json")) as f:
            robot = json.load(f)["robot"]
        self.assertIn("hopper_m8.xml with ", robot)
        for kv in draw["variant"].split(","):  # ddoc-hopper names the keys in its own order
            self.assertIn(kv, robot.split(" with ")[1].split(","))
        with open(os.path.join(out, "scenarios", row["case"] + ".xml")) as f:
            self.assertIn(f'<gait speed="{draw["speed"]!r}"/>', f.read())

    def test_learning_attributes_reach_every_run(self):
        # --learning (experiments): the <learning> element of every generated scenario, read by
        # ddoc-hopper; an unknown attribute is that run's
        # error (exit 2) and the map's exit 1.
        out = os.path.join(self.tmp, "map")
        common = ["--maps", "mass", "--methods", "alg1", "--masses", "8", "--drags", "0",
                  "--speeds", "0.5", "--hopper", HOPPER, "--jobs", "1"]
        r = run_tool("robustness_map", *common, "--hops", "3", "--out", out,
                     "--learning", 'remeasure="on" noise_margin="2"')
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(os.path.join(out, "scenarios", "mass_m8_cd0_v0.5_alg1.xml")) as f:
            self.assertIn('<learning remeasure="on" noise_margin="2"/>', f.read())
        with open(os.path.join(out, "manifest.json")) as f:
            self.assertEqual(json.load(f)["grid"]["learning"], 'remeasure="on" noise_margin="2"')
        bad = os.path.join(self.tmp, "bad")
        r = run_tool("robustness_map", *common, "--hops", "2", "--out", bad,
                     "--learning", 'remeasur="on"')
        self.assertEqual(r.returncode, 1)
        [row] = csv_rows(os.path.join(bad, "mass_map.csv"))
        self.assertEqual(row["exit"], "2")


if __name__ == "__main__":
    unittest.main()
