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
          ("sparse-20mm", "paper-2d-sparse", None), ("human-body", "human-body", None),
          ("human-body", "human-body", 20.0)]


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
    out = {f"{k}_ms": 1e3 * v for k, v in stages.items()}
    out.update(
        rp10=s["rp_within_10mm"] / max(1, s["rp_total"]),
        rpm50=s["rpm_within_50mm"] / max(1, s["rpm_total"]),
        rpm100=s["rpm_within_100mm"] / max(1, s["rpm_total"]),
        rps=len(res.rps), points=s["rpm_total"], clusters=len(set(res.rps.cluster.tolist())),
    )
    out.update(kernel_profile(engine, method, data, params))
    return out


def kernel_profile(engine, method, data, params) -> dict:
    """One extra run with each kernel waited for and timed (device engines).

    Returns ``intersect_ms``, ``score_ms``, ``argmax_ms`` and
    ``kernel_evals_per_s`` (Gaussian kernel evaluations the scoring kernel
    performed, per second of scoring), or ``{}`` for the NumPy reference.
    """
    if not hasattr(engine, "kernel_times"):
        return {}
    from .imaging import run_method

    old = engine.timing
    engine.timing = True
    engine.kernel_times = dict.fromkeys(engine.kernel_times, 0.0)
    engine.kernel_evals = 0
    try:
        run_method(method, data, params, engine)
    finally:
        engine.timing = old
    kt = engine.kernel_times
    out = {f"{k}_ms": 1e3 * v for k, v in kt.items()}
    out["kernel_evals"] = engine.kernel_evals
    out["kernel_evals_per_s"] = engine.kernel_evals / kt["score"] if kt["score"] > 0 else float("nan")
    return out


def run_bench(engine, env, repeats: int = 20, scenes=None) -> str:
    """All methods on :data:`SCENES` (or the labels in ``scenes``); the table as text."""
    chosen = [sc for sc in SCENES if scenes is None or sc[0] in scenes]
    lines = [f"device: {env.name} | precision: {getattr(engine, 'precision', 'float64')} | "
             f"host: {platform.processor() or platform.machine()} | "
             f"median of {repeats} runs after warm-up",
             f"{'case':12s} {'S/N':>4s} {'method':11s} {'total':>8s} {'decomp':>7s} "
             f"{'RPs':>6s} {'RPM':>7s} {'isect':>6s} {'score':>7s} {'RP<=10mm':>9s} "
             f"{'RPM<=50':>8s} {'RPM<=100':>9s} {'kernel evals/s':>15s}"]
    t0 = time.perf_counter()
    for label, preset, snr in chosen:
        for method in METHODS:
            b = bench_case(engine, preset, snr, method, repeats)
            lines.append(
                f"{label:12s} {'inf' if snr is None else f'{snr:g}':>4s} {method:11s} "
                f"{b['total_ms']:8.2f} {b.get('decompose_ms', 0.0):7.2f} "
                f"{b.get('range_points_ms', 0.0):6.2f} {b['rpm_ms']:7.2f} "
                f"{b.get('intersect_ms', float('nan')):6.2f} {b.get('score_ms', float('nan')):7.2f} "
                f"{b['rp10']:9.0%} {b['rpm50']:8.0%} {b['rpm100']:9.0%} "
                f"{b.get('kernel_evals_per_s', float('nan')):15.3g}")
    lines.append(f"(wall time of the benchmark: {time.perf_counter() - t0:.1f} s.  Times in ms: "
                 "total, decomp(osition), RPs (extraction) and RPM are stage medians; isect and "
                 "score are the intersection and scoring kernels of one extra run with each "
                 "kernel waited for; kernel evals/s = Gaussian evaluations of the scoring "
                 "kernel per second of it)")
    return "\n".join(lines)
