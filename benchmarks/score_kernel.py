"""Gaussian evaluations per second of the scoring kernel alone .

Times ``score_candidates`` (kernels/score.cl, float32, DIM 3) on synthetic
candidates shaped like the human body's (n main RPs x slots per row), kernel
time only (inputs already on the device), and checks its scores against a
float64 NumPy evaluation.  ``--source`` times another version of score.cl
beside the current one in the same run, e.g. the one before a change::

    git show REV:kernels/score.cl > /tmp/score_old.cl
    python benchmarks/score_kernel.py --source /tmp/score_old.cl

Usage::

    python benchmarks/score_kernel.py [--n 2000] [--slots 280] [--repeats 5] [--source FILE]
"""

import argparse
import time
from importlib import resources

import numpy as np
import pyopencl as cl

from rpm_cl.cl import create_env


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=2000)
    ap.add_argument("--slots", type=int, default=280, help="candidates per main RP (multiple of 8)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--source", help="another score.cl to time beside the current one")
    args = ap.parse_args()
    env = create_env()
    ctx, q = env.context, env.queue
    kdir = resources.files("rpm_cl.kernels")
    sources = {"current": kdir.joinpath("score.cl").read_text()}
    if args.source:
        with open(args.source) as f:
            sources[args.source] = f.read()
    n, maxc = args.n, args.slots
    rng = np.random.default_rng(0)
    cand = rng.normal(0, 0.05, (3, n, maxc)).astype(np.float32)
    w = rng.uniform(0, 1, (n, maxc)).astype(np.float32)
    valid = (rng.uniform(size=(n, maxc)) < 0.95).astype(np.int8)
    mf = cl.mem_flags
    bufs = [cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a) for a in (cand, w, valid)]
    out_buf = cl.Buffer(ctx, mf.WRITE_ONLY, n * maxc * 4)
    sigma = 0.05
    l2 = np.float32(np.log2(np.e) / (2 * sigma * sigma))
    c = cand.astype(np.float64)
    d2 = sum((c[k][:, None, :] - c[k][:, :, None]) ** 2 for k in range(3))
    ref = (w.astype(np.float64)[:, None, :] * np.exp(-d2 / (2 * sigma * sigma))).sum(-1)
    ref[valid == 0] = -1
    evals = int(valid.sum()) * maxc
    print(
        f"device: {env.device.name}; {n} main RPs x {maxc} slots, DIM 3, float32; "
        f"best of {args.repeats} after a warm-up"
    )
    for rep in range(2):
        for name, src in sources.items():
            k = (
                cl.Program(ctx, src)
                .build(options=["-DREAL=float", "-DDIM=3", "-I", str(kdir)])
                .score_candidates
            )
            kargs = (q, (maxc, n), None, *bufs, np.int32(n), np.int32(maxc), l2, out_buf)
            k(*kargs).wait()
            best = np.inf
            for _ in range(args.repeats):
                t = time.perf_counter()
                k(*kargs).wait()
                best = min(best, time.perf_counter() - t)
            got = np.empty((n, maxc), np.float32)
            cl.enqueue_copy(q, got, out_buf)
            err = float(np.max(np.abs(got - ref) / np.maximum(np.abs(ref), 1e-30)))
            print(
                f"{name:24s} {best * 1e3:7.1f} ms  {evals / best:.3g} evaluations/s  "
                f"max relative error {err:.1e}"
            )


if __name__ == "__main__":
    main()
