"""Benchmark the 2-D paper scenes: run time against error per method and stage.

Usage::

    python benchmarks/bench_2d.py [--repeats 50] [--device SPEC] [--precision float64]

Same as ``rpm-cl bench``; the target is each 2-D case imaged in
under 20 ms (the paper: 2 s), compile excluded.
"""

import sys

from rpm_cl.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", *sys.argv[1:]]))
