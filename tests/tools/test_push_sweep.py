"""ddoc_results.push_recovery on hand-made runs whose answer is counted by hand, and tools/push_sweep
with the real ddoc-hopper (DDOC_HOPPER, set by CMake): generated scenarios, logged runs, the table;
bad usage exits 2 with a message."""
import csv
import json
import os
import unittest

from tools_test_util import TempDirTest, push_scenario, run_tool

import ddoc_results as dr

HOPPER = os.environ.get("DDOC_HOPPER", "")
PERIOD = 0.5  # s per hop of the hand-made runs


def write_run(path, costs, push_hops, fell=False, scheduled=None):
    """A run directory with one hop per cost (hop k spans [k, k+1) * PERIOD) and a push starting
    0.1 s into each hop of push_hops. fell: a fall event right after the last hop. scheduled:
    the pushes of summary.json (default: the logged ones)."""
    os.makedirs(path)
    with open(os.path.join(path, "hops.csv"), "w") as f:
        f.write(",".join(dr.HOPS_COLUMNS) + "\n")
        for k, c in enumerate(costs):
            f.write(f"{k},{k * PERIOD},{(k + 1) * PERIOD},{c},0,0,0,0,0.2,0.5,0.3,0.5,0.8,1,0,0,0,"
                    f"alg1\n")
    pushes = [(h * PERIOD + 0.1, -20.0 if i == 0 else 25.0) for i, h in enumerate(push_hops)]
    with open(os.path.join(path, "events.csv"), "w") as f:
        f.write(",".join(dr.EVENTS_COLUMNS) + "\n")
        for t, _ in pushes:
            f.write(f"{t},{int(t / PERIOD)},push_start,0,0.8,0.5,0\n"
                    f"{t + 0.1},{int(t / PERIOD)},push_end,0,0.8,0.5,0\n")
        if fell:
            f.write(f"{len(costs) * PERIOD + 0.2},{len(costs)},fall,0,0.3,0.5,0\n")
    summary = {"scenario": "push_test", "method": "alg1", "hops": len(costs), "fell": fell,
               "pushes": [{"t": t, "force": F, "duration": 0.1}
                          for t, F in (scheduled if scheduled is not None else pushes)]}
    with open(os.path.join(path, "summary.json"), "w") as f:
        json.dump(summary, f)
    return dr.load_run(path)


# Pushes in hops 5 and 12. Push 1: baseline median(hops 0-4) = 1; hops 7-11 are all <= 1.1 and
# hop 6 is not, so back in 7 - 5 = 2 hops. Push 2: baseline median(hops 7-11) = 1; hops 14-16
# <= 1.1, hop 13 (1.2) is not: back in 14 - 12 = 2 hops (3 hops logged there, the minimum).
COSTS = [1, 1, 1, 1, 1, 9, 3, 1.05, 1.0, 1.02, 1.0, 1.0, 8, 1.2, 1.0, 1.0, 1.0]


class PushRecoveryTest(TempDirTest):
    def recovery(self, name, costs, push_hops, **kw):
        tolerance = kw.pop("tolerance", dr.RECOVERY_TOLERANCE)
        run = write_run(os.path.join(self.tmp, name), costs, push_hops, **kw)
        return [(r.hop, r.status, r.hops_to_recover) for r in dr.push_recovery(run, tolerance)]

    def test_recovered_counts_hops_from_the_push_hop(self):
        self.assertEqual(self.recovery("a", COSTS, [5, 12]),
                         [(5, "recovered", 2), (12, "recovered", 2)])

    def test_tolerance_widens_what_counts_as_the_cycle(self):
        # 1.2 <= 1.25: push 2 is back in hop 13; 3 > 1.25 still keeps push 1 at 2 hops.
        self.assertEqual(self.recovery("b", COSTS, [5, 12], tolerance=0.25),
                         [(5, "recovered", 2), (12, "recovered", 1)])

    def test_too_few_good_hops_is_not_recovered(self):
        # Only 2 good hops (15, 16) after push 2: fewer than RECOVERY_MIN_HOPS.
        costs = COSTS[:14] + [1.5, 1.0, 1.0]
        self.assertEqual(self.recovery("c", costs, [5, 12])[1], (12, "not recovered", None))

    def test_a_late_bad_hop_undoes_recovery(self):
        costs = COSTS[:11] + [2.0] + COSTS[12:]  # hop 11, just before push 2, is off the cycle
        self.assertEqual(self.recovery("d", costs, [5, 12])[0], (5, "not recovered", None))

    def test_fall_after_the_second_push(self):
        self.assertEqual(self.recovery("e", COSTS[:14], [5, 12], fell=True),
                         [(5, "recovered", 2), (12, "fell", None)])

    def test_push_after_the_fall_was_not_reached(self):
        # The robot falls after hop 9; the second push (scheduled at 6.1 s) never happened.
        self.assertEqual(self.recovery("f", COSTS[:10], [5], fell=True,
                                       scheduled=[(2.6, -20.0), (6.1, 25.0)]),
                         [(5, "fell", None), (None, "not reached", None)])



@unittest.skipUnless(os.access(HOPPER, os.X_OK), "DDOC_HOPPER (the ddoc-hopper binary) not set")
class PushSweepTest(TempDirTest):
    def test_speeds_durations_and_offsets(self):
        out = os.path.join(self.tmp, "sweep")
        r = run_tool("push_sweep", "--scenario", push_scenario(self.tmp), "--speeds", "0.4,0.5",
                     "--durations", "0.02", "--offsets", "0,0.3", "--methods", "ocfb",
                     "--hopper", HOPPER, "--out", out)
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(os.path.join(out, "results.csv")) as f:
            rows = list(csv.DictReader(f))
        self.assertEqual([(r["speed"], r["duration"], r["offset"], r["method"], r["exit"],
                           r["hops"]) for r in rows],
                         [("0.4", "0.02", "0.0", "ocfb", "0", "4"),
                          ("0.4", "0.02", "0.3", "ocfb", "0", "4"),
                          ("0.5", "0.02", "0.0", "ocfb", "0", "4"),
                          ("0.5", "0.02", "0.3", "ocfb", "0", "4")])
        for row in rows:
            self.assertEqual(row["push1_force"], "10")
            self.assertIn(row["push1_status"], ("recovered", "not recovered"))
        with open(os.path.join(out, "scenarios", "v0.4_d0.02_o0_ocfb.xml")) as f:
            scenario = f.read()
        self.assertIn('speed="0.4"', scenario)
        self.assertIn('duration="0.02"', scenario)
        self.assertIn('cyclic_value="0.99"', scenario)  # the scenario's settings are kept
        with open(os.path.join(out, "runs", "v0.5_d0.02_o0_ocfb", "events.csv")) as f:
            events = f.read()
        self.assertIn("push_start", events)  # the push really happened
        for offset in (0, 0.3):
            with open(os.path.join(out, "runs", f"v0.5_d0.02_o{offset:g}_ocfb",
                                   "summary.json")) as f:
                pushes = json.load(f)["pushes"]
            self.assertEqual([(p["t"], p["force"], p["duration"]) for p in pushes],
                             [(1.0 + offset, 10.0, 0.02)])
        with open(os.path.join(out, "results.md")) as f:
            table = f.read()
        self.assertIn("| speed [m/s] | push duration [s] | time offset [s] | ocfb |", table)
        self.assertRegex(table, r"\| 0\.5 \| 0\.02 \| 0\.3 \| 4: (\d+|no) \|")


class PushSweepUsageTest(TempDirTest):
    def test_bad_usage(self):
        no_push = push_scenario(self.tmp, with_push=False)
        self.assert_usage_errors("push_sweep", [
            (["--scenario", no_push, "--hopper", HOPPER or "/bin/true"], ["has no <push>"]),
            (["--durations", "0.1,-1"], ["--durations"]),
            (["--offsets", "later"], ["--offsets"]),
            (["--methods", "alg2"], ["alg2"]),
            (["--scenario", os.path.join(self.tmp, "missing.xml")], ["missing.xml"]),
            (["--hopper", os.path.join(self.tmp, "nope")], ["ddoc-hopper not found"]),
        ])


if __name__ == "__main__":
    unittest.main()
