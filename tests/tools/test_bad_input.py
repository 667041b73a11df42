"""Bad input to plot_fig2.py and results_table.py: a clear error (exit 2) naming the file, the line
and the column or option that is wrong; never a traceback."""
import os
import unittest

from tools_test_util import PYTHON, TempDirTest, run_tool


def rewrite(path, fn):
    with open(path) as f:
        text = f.read()
    with open(path, "w") as f:
        f.write(fn(text))


def drop_column(text, name):
    """CSV text without column `name` (header and every row)."""
    lines = text.split("\n")
    j = lines[0].split(",").index(name)
    return "\n".join(",".join(c for k, c in enumerate(l.split(",")) if k != j) if l else l
                     for l in lines)


class BadInputTest(TempDirTest):
    TOOLS = (("plot_fig2.py", "--out"), ("results_table.py", "--out"))

    def both(self, run, *extra):
        """Run both tools on `run`; return their CompletedProcess objects."""
        out = []
        for tool, opt in self.TOOLS:
            dest = os.path.join(self.tmp, "out" if tool.startswith("plot") else "r.md")
            out.append(run_tool(tool, run, *extra, opt, dest))
        return out

    def assert_error(self, procs, *needles):
        for p in procs:
            self.assertEqual(p.returncode, 2, p.stdout + p.stderr)
            self.assertNotIn("Traceback", p.stderr)
            self.assertIn("error:", p.stderr)
            for n in needles:
                self.assertIn(n, p.stderr)

    def test_missing_hops_column_is_named(self):
        for col in ("T2", "du2", "step_length"):
            d = self.copy_run("exact_m8_alg1", f"run_{col}")
            rewrite(os.path.join(d, "hops.csv"), lambda t: drop_column(t, col))
            self.assert_error(self.both(d), "hops.csv", f"'{col}'")

    def test_missing_trajectory_column_is_named(self):
        d = self.copy_run("exact_m8_alg1")
        rewrite(os.path.join(d, "trajectory.csv"), lambda t: drop_column(t, "phi"))
        p = run_tool("plot_fig2.py", d, "--out", os.path.join(self.tmp, "o"))
        self.assert_error([p], "trajectory.csv", "'phi'")

    def test_renamed_column(self):
        d = self.copy_run("exact_m8_alg1")
        rewrite(os.path.join(d, "hops.csv"), lambda t: t.replace(",I4,", ",i4,", 1))
        self.assert_error(self.both(d), "'I4'")

    def test_empty_csv(self):
        d = self.copy_run("exact_m8_alg1")
        open(os.path.join(d, "hops.csv"), "w").close()
        self.assert_error(self.both(d), "hops.csv", "empty")

    def test_missing_directory_and_file(self):
        self.assert_error(self.both(os.path.join(self.tmp, "nope")), "does not exist")
        d = self.copy_run("exact_m8_alg1")
        os.remove(os.path.join(d, "hops.csv"))
        self.assert_error(self.both(d), "no hops.csv")

    def test_not_a_number_names_line_and_column(self):
        d = self.copy_run("exact_m8_alg1")
        rewrite(os.path.join(d, "hops.csv"),
                lambda t: t.replace("\n3,", "\nthree,", 1))
        self.assert_error(self.both(d), "hops.csv:5", "'hop'", "'three'")

    def test_wrong_field_count_in_the_middle(self):
        d = self.copy_run("exact_m8_alg1")

        def cut(t):
            lines = t.split("\n")
            lines[3] = ",".join(lines[3].split(",")[:-2])
            return "\n".join(lines)
        rewrite(os.path.join(d, "hops.csv"), cut)
        self.assert_error(self.both(d), "hops.csv:4", "16 fields, header has 18")

    def test_bad_options(self):
        d = self.copy_run("exact_m8_alg1")
        p = run_tool("plot_fig2.py", d, "--out", self.tmp, "--label", "a", "--label", "b")
        self.assert_error([p], "--label given 2 times for 1 run")
        p = run_tool("plot_fig2.py", d, "--out", self.tmp, "--motion-hops", "5")
        self.assert_error([p], "--motion-hops")
        p = run_tool("results_table.py", d, "--out", "-", "--delta-i", "0")
        self.assert_error([p], "--delta-i")

    def test_unreadable_summary_is_a_warning(self):
        d = self.copy_run("exact_m8_alg1")
        rewrite(os.path.join(d, "summary.json"), lambda t: t[: len(t) // 2])
        for p in self.both(d):
            self.assertEqual(p.returncode, 0, p.stderr)
            self.assertIn("summary.json: unreadable", p.stderr)

    def missing(self, module):
        """An environment whose interpreter cannot import `module`: a package of that name first on
        PYTHONPATH that fails to import the way an absent one does."""
        pkg = os.path.join(self.tmp, "blocked", module)
        os.makedirs(pkg)
        with open(os.path.join(pkg, "__init__.py"), "w") as f:
            f.write(f"raise ModuleNotFoundError(\"No module named '{module}'\", name='{module}')\n")
        return {"PYTHONPATH": os.path.join(self.tmp, "blocked")}

    def assert_names_the_missing_module(self, p, tool, module, package):
        self.assertNotEqual(p.returncode, 0, p.stdout + p.stderr)
        self.assertNotIn("Traceback", p.stderr)
        for needle in (f"{tool}:", PYTHON, f"'{module}'", package):
            self.assertIn(needle, p.stderr)

    def test_a_missing_numpy_names_the_interpreter_and_the_package(self):
        env = self.missing("numpy")
        for tool in ("plot_fig2.py", "results_table.py", "robustness_map", "mass_sweep",
                     "push_sweep"):
            p = run_tool(tool, "--help", env=env)
            self.assert_names_the_missing_module(p, tool, "numpy", "python3-numpy")

    def test_a_missing_matplotlib_names_the_interpreter_and_the_package(self):
        d = self.copy_run("exact_m8_alg1")
        p = run_tool("plot_fig2.py", d, "--out", self.tmp, env=self.missing("matplotlib"))
        self.assert_names_the_missing_module(p, "plot_fig2.py", "matplotlib", "python3-matplotlib")


if __name__ == "__main__":
    unittest.main()
