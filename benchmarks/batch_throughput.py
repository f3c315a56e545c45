"""Batch throughput: frames/s of ``rpm-cl batch`` against the number of Dask
workers, and the per-frame time in a batch against a single ``rpm-cl image``
run (which pays interpreter start, OpenCL context creation and program build).

Usage::

    POCL_MAX_PTHREAD_COUNT=1 python benchmarks/batch_throughput.py [--frames 16]
        [--workers 1 2] [--scene paper-2d --scene human-body] [--das]

For each scene, K frames are simulated with different noise seeds (S/N 20 dB)
into a temporary folder, then imaged by :func:`rpm_cl.cli.batch.run_batch` on an
embedded LocalCluster of 1 and 2 workers (cluster start not counted; worker
setup, i.e. context and program build, counted in frames/s since every batch
pays it once per worker).  Columns:

- frames/s: frames done / wall time from submission to the last result;
- per frame: median time of one frame inside its worker (load, image, save);
- single run: median wall time of ``python -m rpm_cl.cli image`` on one frame,
  and of its in-process part (context + build + load + image + save), s.

Set POCL_MAX_PTHREAD_COUNT so that workers x threads fit the cores; the
median of ``--repeats`` batches is reported.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from rpm_cl.cli.batch import BatchConfig, run_batch
from rpm_cl.io.data import save_npz
from rpm_cl.simulate import simulate_preset

# DAS grids of --das: the 2-D image and the human body's y = 1 m section (3 mm)
DAS_GRIDS = {
    "paper-2d": "-0.3:0.3:0.005,0.3:0.6:0.005",
    "human-body": "-1:1:0.003,1.0:1.0:0.003,0:2:0.003",
}

_COLD = r"""
import json, sys, time
t0 = time.perf_counter()
from rpm_cl.cl import create_env
from rpm_cl.io.data import load_npz
from rpm_cl.imaging import run_method
from rpm_cl.io.formats import save_result
from rpm_cl.rpm.params import default_params
from rpm_cl.rpm import DeviceRPM
t1 = time.perf_counter()
env = create_env(); engine = DeviceRPM(env, "float32")
t2 = time.perf_counter()
data = load_npz(sys.argv[1])
save_result(sys.argv[2], run_method("kspace-rpm", data, default_params(data), engine))
t3 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "context_build": t2 - t1, "frame": t3 - t2}))
"""


def single_run(path: str, out: str, repeats: int) -> dict:
    """Median wall time of `rpm-cl image` in a fresh process, and its parts, s."""
    cli, parts = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "rpm_cl.cli", "image", path, "-o", out],
            check=True,
            capture_output=True,
        )
        cli.append(time.perf_counter() - t0)
        r = subprocess.run(
            [sys.executable, "-c", _COLD, path, out], check=True, capture_output=True, text=True
        )
        parts.append(json.loads(r.stdout.strip().splitlines()[-1]))
    med = {k: float(np.median([p[k] for p in parts])) for k in parts[0]}
    return {
        "cli_wall": float(np.median(cli)),
        **med,
        "in_process": med["context_build"] + med["frame"],
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=16, help="frames per scene (K)")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--scene", action="append", choices=sorted(DAS_GRIDS))
    ap.add_argument("--repeats", type=int, default=3, help="batches (and single runs) per row")
    ap.add_argument("--das", action="store_true", help="also a DAS image per frame")
    ap.add_argument("--json", help="write the rows here")
    args = ap.parse_args()
    scenes = args.scene or ["paper-2d", "human-body"]
    rows = []
    device = "?"
    for scene in scenes:
        with tempfile.TemporaryDirectory() as tmp:
            inp = os.path.join(tmp, "in")
            os.mkdir(inp)
            for seed in range(args.frames):
                save_npz(
                    os.path.join(inp, f"{scene}_{seed:04d}.npz"),
                    simulate_preset(scene, 20.0, seed, noise="receiver")[0],
                )
            single = single_run(
                os.path.join(inp, f"{scene}_0000.npz"),
                os.path.join(tmp, "single.npz"),
                args.repeats,
            )
            config = BatchConfig(das_grid=DAS_GRIDS[scene] if args.das else None)
            for w in args.workers:
                fps, per = [], []
                for rep in range(args.repeats):
                    s = run_batch(inp, os.path.join(tmp, f"out{w}_{rep}"), config, workers=w)
                    assert s.done == args.frames and not s.failed, s
                    fps.append(s.frames_per_s)
                    per.append(s.stage_median_s["total"])
                    device = ", ".join(s.device)
                rows.append(
                    {
                        "scene": scene,
                        "workers": w,
                        "frames": args.frames,
                        "frames_per_s": float(np.median(fps)),
                        "per_frame_s": float(np.median(per)),
                        "single": single,
                        "das": bool(args.das),
                    }
                )
    print(
        f"device: {device}; POCL_MAX_PTHREAD_COUNT={os.environ.get('POCL_MAX_PTHREAD_COUNT')}; "
        f"median of {args.repeats} batches{' with DAS' if args.das else ''}"
    )
    print(
        f"{'scene':11s} {'workers':>7s} {'frames':>6s} {'frames/s':>9s} "
        f"{'per frame in batch':>19s} {'single run (cli / in-process)':>30s} {'ratio':>6s}"
    )
    for r in rows:
        sg = r["single"]
        print(
            f"{r['scene']:11s} {r['workers']:7d} {r['frames']:6d} {r['frames_per_s']:9.2f} "
            f"{1e3 * r['per_frame_s']:16.1f} ms {1e3 * sg['cli_wall']:13.0f} / "
            f"{1e3 * sg['in_process']:7.0f} ms {sg['cli_wall'] / r['per_frame_s']:6.1f}x"
        )
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"device": device, "rows": rows}, fh, indent=2)


if __name__ == "__main__":
    main()
