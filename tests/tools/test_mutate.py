"""tools/mutate: every mutant of the list still applies to the tree (each snippet is found exactly
once), names are unique, --list and --only select what they say. No build: the mutation run itself
(minutes per mutant) is not part of the suite."""
import os
import re
import subprocess
import unittest

from tools_test_util import PYTHON, ROOT, run_tool

MUTATE = os.path.join(ROOT, "tools", "mutate")


def listed_names(stdout):
    return [line.split()[0] for line in stdout.splitlines()
            if line.strip() and not line.startswith(" ")]


def load_mutate():
    """tools/mutate as a module (it has no .py suffix)."""
    import importlib.machinery
    import importlib.util
    loader = importlib.machinery.SourceFileLoader("mutate_under_test", MUTATE)
    spec = importlib.util.spec_from_loader("mutate_under_test", loader)
    mod = importlib.util.module_from_spec(spec)
    loader.exec_module(mod)
    return mod


class MutateCheckTest(unittest.TestCase):
    def test_every_mutant_applies_to_the_tree(self):
        p = run_tool("mutate", "--check")
        self.assertEqual(p.returncode, 0, p.stderr)
        m = re.search(r"(\d+)/(\d+) mutants apply", p.stdout)
        self.assertIsNotNone(m, p.stdout)
        self.assertEqual(m.group(1), m.group(2))
        self.assertGreaterEqual(int(m.group(2)), 25)

    def test_list_names_are_unique_and_cover_the_areas(self):
        p = run_tool("mutate", "--list")
        self.assertEqual(p.returncode, 0, p.stderr)
        names = listed_names(p.stdout)
        self.assertEqual(len(names), len(set(names)))
        self.assertGreaterEqual(len(names), 25)
        files = set(re.findall(r"^\S+\s+(\S+)", p.stdout, re.M))
        for f in ("src/core/backward_pass.cc", "src/core/online_controller.cc",
                  "src/core/learner.cc", "src/core/box_qp.cc", "src/core/cost.cc",
                  "src/core/switching_time_update.cc", "src/core/time_normalization.cc",
                  "src/mujoco/contact_phase.cc", "plugin/hopper_controller.cc"):
            self.assertIn(f, files)
        # The breakages of issue 23 are in the list.
        for n in ("oc_no_state_feedback", "bp_jump_no_GtPG", "bp_jump_no_phiz",
                  "ln_predicted_any_decrease"):
            self.assertIn(n, names)
        # The breakages of issue 47 (section 5) that passed the whole suite are in the list.
        for n in ("hm_stance_leg_servo_underdamped", "hm_stance_hip_servo_underdamped",
                  "hm_flight_leg_servo_underdamped", "hm_flight_hip_servo_underdamped",
                  "oc_output_not_clamped", "td_remeasure_replays_nominal",
                  "ln_start_shift_no_reference", "bp_no_upper_bound_tolerance"):
            self.assertIn(n, names)

    def test_only_selects_in_the_given_order(self):
        p = run_tool("mutate", "--list", "--only", "oc_no_state_feedback,bp_jump_*")
        self.assertEqual(p.returncode, 0, p.stderr)
        names = listed_names(p.stdout)
        self.assertEqual(names[0], "oc_no_state_feedback")
        self.assertTrue(all(n.startswith("bp_jump_") for n in names[1:]))
        self.assertGreater(len(names), 2)
        bad = run_tool("mutate", "--list", "--only", "no_such_mutant")
        self.assertNotEqual(bad.returncode, 0)

    def test_check_fails_when_a_snippet_is_missing(self):
        # The check must be able to fail: one snippet changed so that it is no longer in the tree.
        mod = load_mutate()
        self.assertEqual(mod.check(mod.MUTANTS), [])
        broken = mod.MUTANTS[0]._replace(original=mod.MUTANTS[0].original + " /* not there */")
        problems = mod.check([broken] + mod.MUTANTS[1:])
        self.assertEqual(len(problems), 1)
        self.assertIn(broken.name, problems[0])
        twice = mod.MUTANTS[1]._replace(original=";")  # occurs many times
        self.assertTrue(any("times" in x for x in mod.check([twice])))
        dup = mod.check([mod.MUTANTS[2], mod.MUTANTS[2]])
        self.assertTrue(any("duplicate" in x for x in dup))

    def test_reads_failed_tests_from_ctest_output(self):
        mod = load_mutate()
        out = ("50% tests passed, 3 tests failed out of 6\n\nThe following tests FAILED:\n"
               "\t 32 - core.BackwardPassJump.PAndGains (Failed)\n"
               "\t 80 - core.A/B.C/4-byte object <00-00 00-00> (Timeout)\n"
               "\t 97 - core.Suite/E.R/exp0  # GetParam() = \"exp0\" (Failed)\n"
               "Errors while running CTest\n")
        self.assertEqual(mod.failed_tests(out),
                         [("core.BackwardPassJump.PAndGains", "Failed"),
                          ("core.A/B.C/4-byte object <00-00 00-00>", "Timeout"),
                          ("core.Suite/E.R/exp0", "Failed")])
        self.assertEqual(mod.failed_tests("100% tests passed, 0 tests failed out of 6\n"), [])

    def test_is_executable(self):
        self.assertTrue(os.access(MUTATE, os.X_OK), "tools/mutate is not executable")
        p = subprocess.run([MUTATE, "--check"], capture_output=True, text=True, timeout=60,
                           env=dict(os.environ, PYTHONDONTWRITEBYTECODE="1"))
        self.assertEqual(p.returncode, 0, p.stderr)


if __name__ == "__main__":
    unittest.main()
