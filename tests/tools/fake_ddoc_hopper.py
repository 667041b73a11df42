#!/usr/bin/python3
"""Stand-in for build/bin/ddoc-hopper in the tests of tools/reproduce.

    fake_ddoc_hopper.py <scenario.xml> --method <alg1|ocfb|mrl> --out DIR [--hops N]

Copies a synthetic run from tools/testdata into DIR with scenario/method set from the arguments and
exits like the real CLI: 0 ok, 3 the robot fell (ocfb on an inexact scenario), 2 bad input.
It also writes DIR/argv.txt so a test can check what it was called with.
"""
import json
import os
import shutil
import sys

TESTDATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools", "testdata")


def main(argv):
    if len(argv) < 1 or not argv[0].endswith(".xml"):
        print("usage: ddoc-hopper <scenario.xml> --method M --out DIR [--hops N]", file=sys.stderr)
        return 2
    args = dict(zip(argv[1::2], argv[2::2]))
    method, out = args.get("--method"), args.get("--out")
    if method not in ("alg1", "ocfb", "mrl") or not out:
        print(f"bad --method {method!r} or missing --out", file=sys.stderr)
        return 2
    if not os.path.isfile(argv[0]):
        print(f"{argv[0]}: no such scenario file", file=sys.stderr)
        return 2
    scenario = os.path.splitext(os.path.basename(argv[0]))[0]
    fell = method == "ocfb" and not scenario.startswith("exact")
    src = "inexact_m8_ocfb" if fell else ("push_m12_alg1" if scenario.startswith("push")
                                          else "exact_m8_alg1")
    os.makedirs(out, exist_ok=True)
    for name in ("hops.csv", "trajectory.csv", "events.csv", "summary.json"):
        shutil.copy(os.path.join(TESTDATA, src, name), os.path.join(out, name))
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    summary.update(scenario=scenario, method=method)
    with open(os.path.join(out, "summary.json"), "w") as f:
        json.dump(summary, f)
    with open(os.path.join(out, "argv.txt"), "w") as f:
        f.write("\n".join(argv) + "\n")
    print(f"fake ddoc-hopper: {scenario} {method} -> {'fell' if fell else 'ok'}")
    return 3 if fell else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
