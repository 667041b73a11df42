#!/usr/bin/python3
"""Markdown results table from ddoc-hopper run directories. See `results_table.py --help`.

    /usr/bin/python3 tools/results_table.py RUN_DIR [RUN_DIR...] [--out results.md]
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ddoc_results import table_main  # noqa: E402

if __name__ == "__main__":
    sys.exit(table_main())
