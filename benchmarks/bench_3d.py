"""Benchmark the 3-D human-body scene: time of each stage and kernel throughput.

Usage::

    python benchmarks/bench_3d.py [--repeats 20] [--device SPEC] [--precision float64]

Prints, for S/N inf and 20 dB, the median time from s(X, Z, R) to points and of
each stage (FFT decomposition, RP extraction, RPM), the intersection and
scoring kernels' times, and the Gaussian kernel evaluations per second of the
scoring kernel.  The target: the whole image in under 0.5 s on a 2-core
CPU through PoCL (the paper: 20 s on a 14-core Xeon).  Same as
``rpm-cl bench --scene human-body``.
"""

import sys

from rpm_cl.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", "--scene", "human-body", *sys.argv[1:]]))
