"""Benchmarks: run time against error for each method and scene.

Rules (so the numbers mean something on a shared, noisy machine): programs are
built and each kernel has run before timing (warm-up), every timed call ends
with its results on the host (the queue is finished), each figure is the median
of ``repeats`` runs, and the device name is printed with the table.
"""

from __future__ import annotations

import platform
import time


from .imaging import METHODS, default_params, timed_run
from .metrics import summary
from .simulate import simulate_preset

__all__ = ["bench_case", "run_bench"]

#: (label, preset, S/N) of the benchmarked scenes.
SCENES = [("points-5mm", "paper-2d", None), ("points-5mm", "paper-2d", 20.0),
          ("sparse-20mm", "paper-2d-sparse", None)]


def bench_case(engine, preset: str, snr, method: str, repeats: int = 20, seed: int = 0) -> dict:
    """Median stage timings and accuracy of one method on one scene.

    Returns
    -------
    dict
        ``total_ms`` and ``<stage>_ms`` (medians), ``rp10``, ``rpm50``,
        ``rpm100`` (fractions), ``points``, ``rps``, ``pairs_per_s`` (circle
        pairs intersected per second in the RPM step), ``kernel_evals_per_s``
        (Gaussian kernel evaluations per second in the RPM step).
    """
    data, pre = simulate_preset(preset, snr, seed)
    params = default_params(data, **pre.defaults)
    res, _, stages = timed_run(method, data, params, engine, repeats)
    s = summary(res.rps, res.image, data.truth)
    _, counts = res.rps.cluster_bounds()
    # RPM work: every main RP pairs with its cluster (n*maxc slots) and every
    # slot is scored against every slot of its row.
    maxc = int(counts.max()) if counts.size else 0
    n = len(res.rps)
    rpm_s = stages["rpm"]
    out = {f"{k}_ms": 1e3 * v for k, v in stages.items()}
    out.update(
        rp10=s["rp_within_10mm"] / max(1, s["rp_total"]),
        rpm50=s["rpm_within_50mm"] / max(1, s["rpm_total"]),
        rpm100=s["rpm_within_100mm"] / max(1, s["rpm_total"]),
        rps=n, points=s["rpm_total"],
        pairs_per_s=n * maxc / rpm_s if rpm_s > 0 else float("nan"),
        kernel_evals_per_s=n * maxc * maxc / rpm_s if rpm_s > 0 else float("nan"),
    )
    return out


def run_bench(engine, env, repeats: int = 20) -> str:
    """All methods on :data:`SCENES`; returns the table as text."""
    lines = [f"device: {env.name} | precision: {getattr(engine, 'precision', 'float64')} | "
             f"host: {platform.processor() or platform.machine()} | "
             f"median of {repeats} runs after warm-up",
             f"{'case':12s} {'S/N':>4s} {'method':11s} {'total ms':>9s} {'decomp':>7s} "
             f"{'RPs':>6s} {'RPM ms':>7s} {'RP<=10mm':>9s} {'RPM<=50':>8s} {'RPM<=100':>9s} "
             f"{'kernel evals/s':>15s}"]
    t0 = time.perf_counter()
    for label, preset, snr in SCENES:
        for method in METHODS:
            b = bench_case(engine, preset, snr, method, repeats)
            lines.append(
                f"{label:12s} {'inf' if snr is None else f'{snr:g}':>4s} {method:11s} "
                f"{b['total_ms']:9.2f} {b.get('decompose_ms', 0.0):7.2f} "
                f"{b.get('range_points_ms', 0.0):6.2f} {b['rpm_ms']:7.2f} {b['rp10']:9.0%} "
                f"{b['rpm50']:8.0%} {b['rpm100']:9.0%} {b['kernel_evals_per_s']:15.3g}")
    lines.append(f"(wall time of the benchmark: {time.perf_counter() - t0:.1f} s; "
                 f"columns decomp, RPs, RPM ms are stage medians in ms)")
    return "\n".join(lines)
