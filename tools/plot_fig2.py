#!/usr/bin/python3
"""Fig. 2 panels from ddoc-hopper run directories. See `plot_fig2.py --help` and ddoc_results.py.

    /usr/bin/python3 tools/plot_fig2.py RUN_DIR [RUN_DIR...] --out DIR [--label TEXT ...]
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ddoc_results import plot_main  # noqa: E402

if __name__ == "__main__":
    sys.exit(plot_main())
