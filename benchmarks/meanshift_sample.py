"""Where the 3-D refinement moves points, and what skipping it where it does not costs.

    python benchmarks/meanshift_sample.py [--repeats 3]

For each scene: the human body (the engine's simulator, noise-free and 20
dB) and the robustness benchmark's three spheres (independently
synthesised, ``rpm_cl.cli.robustness.GEOMETRY_3D``) on 15 x 15 and, in
3 x 3 tiles, 64 x 64 arrays (noise-free and 10 dB in-band; a 45 x 45
array's 2 x 2 tiles give clusters of 484-529 RPs, one tile's over
``meanshift_max_rps``), imaged by phase-rpm:

- with every refined cluster stepped (``meanshift_sample = 0``), the median
  per cluster of the distance the steps move a point from the list's argmax,
  in units of sigma_r (the 10th, 50th and 90th percentile over clusters), and
  the clusters whose median lies below ``MS_SAMPLE_TOL``: over the clusters
  the sample is drawn from (at least ``4 * MS_SAMPLE_MIN`` main RPs) and
  their points with a list argmax (a step that finds no candidate leaves
  its point, a move of 0);
- with the default ``meanshift_sample`` and with 0: the points within the
  scene's tolerance, the median error (the body: Err_RPM against the true
  surface; spheres: distance to the nearest sphere's surface), how many
  points differ and by how much, and the engine's RPM-stage and total time
  (medians of ``--repeats`` runs after a warm-up, both in one process).
"""

from __future__ import annotations

import argparse
import statistics
import sys
from dataclasses import replace

import numpy as np

from rpm_cl.cl import create_env
from rpm_cl.cli import robustness as rb
from rpm_cl.heap import keep_freed_memory
from rpm_cl.imaging import run_method
from rpm_cl.metrics import err_rpm
from rpm_cl.rpm import DeviceRPM, pipeline
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate.synth import simulate_preset


def _scenes():
    for snr in (None, 20.0):
        data, pre = simulate_preset("human-body", snr, 0, noise="receiver")
        params = default_params(data, **pre.defaults)
        yield (
            f"human body, {'inf' if snr is None else f'{snr:g}'} dB",
            data,
            params,
            0.01,
            (lambda p, t=data.truth: err_rpm(p, t)),
        )
    for n in (15, 64):
        g = replace(rb.GEOMETRY_3D, x=(n, rb.GEOMETRY_3D.x[1]), z=(n, rb.GEOMETRY_3D.z[1]))
        spheres = np.asarray(g.targets, float)

        def err(p, s=spheres):
            d = np.abs(np.linalg.norm(p[:, None] - s[None, :, :3], axis=2) - s[:, 3])
            return d.min(axis=1) if len(p) else np.zeros(0)

        for snr in (None, 10.0):
            spec, f, _ = rb.synthesize(g, snr, 0)
            data = rb.loaded_data(g, spec, f)
            params = default_params(data, max_range=rb.region(g))
            label = f"spheres {n} x {n}, {'inf' if snr is None else f'{snr:g}'} dB"
            yield label, data, params, g.tol, err


def _moves(data, params, engine):
    """Per refined cluster, the median distance the steps move its points
    (every cluster stepped), in units of sigma_r."""
    seen = []
    inner = pipeline._meanshift

    def spy(parts, x, z, r, amp, start, count, p, eng):
        before = np.concatenate([q[2] for q in parts], axis=1).copy()
        out = inner(parts, x, z, r, amp, start, count, p, eng)
        move = np.linalg.norm(out[0][2] - before, axis=0)
        refined = pipeline._refined(count, p) & (count >= 4 * pipeline.MS_SAMPLE_MIN)
        valid = refined & (out[0][0] >= 0)
        seen.append([np.median(move[valid & (start == s)]) for s in np.unique(start[valid])])
        return out

    pipeline._meanshift = spy
    try:
        run_method(
            "phase-rpm", data, replace(params, rpm=replace(params.rpm, meanshift_sample=0)), engine
        )
    finally:
        pipeline._meanshift = inner
    return np.asarray(seen[-1] if seen else [], float) / params.rpm.sigma_r


def _run(data, params, engine, repeats):
    run_method("phase-rpm", data, params, engine)
    runs = [run_method("phase-rpm", data, params, engine) for _ in range(repeats)]
    med = {k: statistics.median(r.timings[k] for r in runs) for k in ("rpm", "total")}
    return runs[-1], med


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    keep_freed_memory()
    engine = DeviceRPM(create_env())
    print(
        "| scene | clusters refined | median move / sigma_r (p10, p50, p90) | below "
        "MS_SAMPLE_TOL | sample | within tol | median mm | points moved (max mm) | "
        "RPM ms | total ms |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for label, data, params, tol, err in _scenes():
        moves = _moves(data, params, engine)
        q = np.quantile(moves, [0.1, 0.5, 0.9]) if moves.size else [np.nan] * 3
        still = int(np.sum(moves < pipeline.MS_SAMPLE_TOL))
        res = {}
        for every in (params.rpm.meanshift_sample, 0):
            p = replace(params, rpm=replace(params.rpm, meanshift_sample=every))
            res[every] = _run(data, p, engine, args.repeats)
        ref = res[0][0].image
        for every, (r, med) in res.items():
            e = err(r.image.points)
            same = np.array_equal(r.image.rp_index, ref.rp_index)
            diff = np.linalg.norm(r.image.points - ref.points, axis=1) if same else None
            moved = (
                f"{int(np.sum(diff > 0))} ({1e3 * diff.max():.3f})"
                if diff is not None and diff.size
                else "-"
            )
            print(
                f"| {label} | {moves.size} | {q[0]:.4f}, {q[1]:.4f}, {q[2]:.4f} | {still} | "
                f"{every or 'off'} | {100 * np.mean(e <= tol):.1f} % | {1e3 * np.median(e):.3f} | "
                f"{moved} | {1e3 * med['rpm']:.0f} | {1e3 * med['total']:.0f} |",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
