"""Benchmarks: run time against error for each method and scene.

Rules (so the numbers mean something on a shared, noisy machine): programs are
built and each kernel has run before timing (warm-up), every timed call ends
with its results on the host (the queue is finished), each figure is the median
of ``repeats`` runs, and the device name is printed with the table.
"""

from __future__ import annotations

import platform
import time

import numpy as np

from ..imaging import DEFAULT_METHOD, RPM_METHODS, timed_run
from ..metrics import err_rpm, summary
from ..rpm.params import default_params
from ..simulate.synth import simulate_preset
from .bench_roofline import TOLERANCES

__all__ = ["bench_case", "run_bench"]

#: (label, preset, S/N) of the benchmarked scenes.
SCENES = [
    ("points-5mm", "paper-2d", None),
    ("points-5mm", "paper-2d", 20.0),
    ("sparse-20mm", "paper-2d-sparse", None),
    ("human-body", "human-body", None),
    ("human-body", "human-body", 20.0),
]


def bench_case(engine, preset: str, snr, method: str, repeats: int = 20, seed: int = 0) -> dict:
    """Median stage timings and accuracy of one method on one scene.

    Returns
    -------
    dict
        ``total_ms`` and ``<stage>_ms`` (medians), ``rp10``, ``rpm50``,
        ``rpm100`` (fractions), ``within`` (``{tolerance m: fraction}`` of
        the points, for :data:`rpm_cl.cli.bench_roofline.TOLERANCES`),
        ``points``, ``rps``, ``clusters``, ``samples`` (complex input
        samples), ``dim``, and :func:`kernel_profile`'s keys.
    """
    data, pre = simulate_preset(preset, snr, seed, noise="receiver")
    params = default_params(data, **pre.defaults)
    res, _, stages = timed_run(method, data, params, engine, repeats)
    s = summary(res.rps, res.image, data.truth)
    e = err_rpm(res.image.points, data.truth)
    out = {f"{k}_ms": 1e3 * v for k, v in stages.items()}
    out.update(
        rp10=s["rp_within_10mm"] / max(1, s["rp_total"]),
        rpm50=s["rpm_within_50mm"] / max(1, s["rpm_total"]),
        rpm100=s["rpm_within_100mm"] / max(1, s["rpm_total"]),
        within={t: float(np.count_nonzero(e <= t)) / max(1, len(e)) for t in TOLERANCES},
        rps=len(res.rps),
        points=s["rpm_total"],
        clusters=len(set(res.rps.cluster.tolist())),
        samples=int(data.signal.size),
        dim=data.array.dim,
    )
    out.update(kernel_profile(engine, method, data, params))
    return out


#: Extra runs of :func:`kernel_profile`; each kernel's time is their median
#: (one run's time of the body's 3-9 ms scoring launch varied 2.8x on the
#: shared machine: 3.4-9.3 ms).
PROFILE_RUNS = 5


def kernel_profile(engine, method, data, params, runs: int = PROFILE_RUNS) -> dict:
    """``runs`` (>= 1) extra runs with each kernel waited for and timed
    (device engines); each kernel's time is the median over the runs.

    Returns ``<kernel>_ms`` for each key of the engine's ``kernel_times``
    (``intersect``, ``score``, ``argmax``, ``meanshift``, ``density``),
    ``kernel_evals`` and ``kernel_evals_per_s`` (Gaussian kernel evaluations
    the scoring kernel performs in one run, per second of its median time),
    ``kernel_work`` (the engine's ``kernel_work`` of one run),
    or ``{}`` for the NumPy reference.  The engine is left with its timing
    switch as it was and the last run's ``kernel_times``.
    """
    if runs < 1:
        raise ValueError(f"runs must be at least 1, got {runs}")
    if not hasattr(engine, "kernel_times"):
        return {}
    from ..imaging import run_method

    old = engine.timing
    engine.timing = True
    times = []
    try:
        for _ in range(runs):
            engine.kernel_times = dict.fromkeys(engine.kernel_times, 0.0)
            engine.kernel_evals = 0
            engine.kernel_work = dict.fromkeys(engine.kernel_work, 0)
            run_method(method, data, params, engine)
            times.append(dict(engine.kernel_times))
    finally:
        engine.timing = old
    kt = {k: float(np.median([t[k] for t in times])) for k in times[0]}
    out = {f"{k}_ms": 1e3 * v for k, v in kt.items()}
    out["kernel_evals"] = engine.kernel_evals  # the same every run
    out["kernel_work"] = dict(engine.kernel_work)
    out["kernel_evals_per_s"] = (
        engine.kernel_evals / kt["score"] if kt["score"] > 0 else float("nan")
    )
    return out


def bench_das(
    das, preset: str, snr, repeats: int = 3, seed: int = 0, volume: bool = False, data=None
):
    """DAS rows of one scene: one dict per grid of
    :data:`rpm_cl.cli.reproduce.DAS_GRIDS` (the volume only with ``volume``),
    on ``data`` (default: the preset simulated at ``snr`` and ``seed``).

    Each dict: ``label``, ``total_ms`` (median of ``repeats``; the volume runs
    once), ``bp`` and ``bp_per_s`` (back-projections, voxels x antennas, and
    per second), ``dim`` (the grid's),
    ``rpm50``, ``rpm100`` (fractions of the image's points within 50 / 100 mm
    of the true boundary), ``points``.
    """
    from ..baselines.das import parse_grid
    from ..metrics import cumulative, err_rpm
    from .reproduce import DAS_GRIDS, das_points

    if data is None:
        data, _ = simulate_preset(preset, snr, seed, noise="receiver")
    out = []
    for label, text, kind in DAS_GRIDS.get(preset, []):
        if kind == "volume" and not volume:
            continue
        grid = parse_grid(text)
        times = []
        for _ in range(1 if kind == "volume" else repeats):
            pts, sec = das_points(das, data, grid, kind)
            times.append(sec)
        sec = float(np.median(times))
        e = err_rpm(pts, data.truth)
        n = max(1, len(e))
        out.append(
            {
                "label": label,
                "total_ms": 1e3 * sec,
                "points": len(e),
                "bp_per_s": grid.size * data.array.n / sec,
                "bp": grid.size * data.array.n,
                "dim": grid.dim,
                "rpm50": cumulative(e, 0.05)[0] / n,
                "rpm100": cumulative(e, 0.10)[0] / n,
            }
        )
    return out


def bench_rma(preset: str, snr, repeats: int = 3, seed: int = 0):
    """RMA row of a linear-array scene (None for planar ones): ``total_ms``
    (median), ``rpm50``, ``rpm100`` of the image's peaks, ``points``, ``label``."""
    from ..metrics import cumulative, err_rpm
    from .reproduce import RMA_IMAGES, rma_points

    if preset not in RMA_IMAGES:
        return None
    label, y0, y1 = RMA_IMAGES[preset]
    data, _ = simulate_preset(preset, snr, seed, noise="receiver")
    times = []
    for _ in range(repeats):
        pts, sec, shape = rma_points(data, y0, y1)
        times.append(sec)
    e = err_rpm(pts, data.truth)
    n = max(1, len(e))
    return {
        "label": f"{label}, {shape[0]} x {shape[1]} px",
        "total_ms": 1e3 * float(np.median(times)),
        "points": len(e),
        "rpm50": cumulative(e, 0.05)[0] / n,
        "rpm100": cumulative(e, 0.10)[0] / n,
    }


def run_bench(
    engine,
    env,
    repeats: int = 20,
    scenes=None,
    das=None,
    volume: bool = False,
    bar: bool | None = False,
    limits=None,
) -> str:
    """All methods on :data:`SCENES` (or the labels in ``scenes``); the table as text.

    With ``das`` (a :class:`rpm_cl.baselines.das.DeviceDAS`), the DAS rows of each scene
    follow, with their back-projections per second; ``volume`` adds the
    human body's full 2 m x 2 m x 2 m volume at 3 mm (minutes).  ``bar``: a
    progress bar over scenes x methods on stderr (False none, the default;
    None on a terminal; True always; :func:`rpm_cl.progress.progress`).
    With ``limits`` (:func:`rpm_cl.cli.limits.measure_limits`), the roofline
    table of the default method's stages and DAS follows, and with ``das``
    too, RPM against DAS at equal accuracy
    (:mod:`rpm_cl.cli.bench_roofline`).
    """
    from ..progress import progress
    from .bench_roofline import (
        das_sweep,
        equal_accuracy,
        equal_accuracy_lines,
        roofline_rows,
        roofline_table,
    )

    chosen = [sc for sc in SCENES if scenes is None or sc[0] in scenes]
    pbar = progress(
        total=len(chosen) * (len(RPM_METHODS) + 1 + (das is not None)),
        desc="bench",
        enabled=bar,
        unit="row",
    )
    lines = [
        (
            f"device: {env.name} | precision: {getattr(engine, 'precision', 'float64')} | "
            f"host: {platform.processor() or platform.machine()} | "
            f"median of {repeats} runs after warm-up"
        ),
        (
            f"{'case':12s} {'S/N':>4s} {'method':11s} {'total':>8s} {'decomp':>7s} "
            f"{'RPs':>6s} {'RPM':>7s} {'isect':>6s} {'score':>7s} {'RP<=10mm':>9s} "
            f"{'RPM<=50':>8s} {'RPM<=100':>9s} {'kernel evals/s':>15s}"
        ),
    ]
    roof, equal = [], []
    t0 = time.perf_counter()
    for label, preset, snr in chosen:
        case = f"{label} {'inf' if snr is None else f'{snr:g}'}"
        rpm_ops = []
        for method in RPM_METHODS:
            pbar.set_postfix_str(f"{label} {method}")
            b = bench_case(engine, preset, snr, method, repeats)
            pbar.update()
            rpm_ops.append({"label": method, "ms": b["total_ms"], "within": b["within"]})
            if limits is not None and method == DEFAULT_METHOD:
                roof.append((case, method, roofline_rows(_stages(b), limits, b["dim"])))
            lines.append(
                f"{label:12s} {'inf' if snr is None else f'{snr:g}':>4s} {method:11s} "
                f"{b['total_ms']:8.2f} {b.get('decompose_ms', 0.0):7.2f} "
                f"{b.get('range_points_ms', 0.0):6.2f} {b['rpm_ms']:7.2f} "
                f"{b.get('intersect_ms', float('nan')):6.2f} {b.get('score_ms', float('nan')):7.2f} "
                f"{b['rp10']:9.0%} {b['rpm50']:8.0%} {b['rpm100']:9.0%} "
                f"{b.get('kernel_evals_per_s', float('nan')):15.3g}"
            )
        rma = bench_rma(preset, snr, max(1, min(repeats, 5)))
        pbar.update()
        if rma is not None:
            lines.append(
                f"{label:12s} {'inf' if snr is None else f'{snr:g}':>4s} {'rma':11s} "
                f"{rma['total_ms']:8.1f} {'':7s} {'':6s} {'':7s} {'':6s} {'':7s} {'-':>9s} "
                f"{rma['rpm50']:8.0%} {rma['rpm100']:9.0%} {'':17s}  "
                f"({rma['label']}, {rma['points']} points)"
            )
        if das is not None:
            pbar.set_postfix_str(f"{label} das")
            data, _ = simulate_preset(preset, snr, 0, noise="receiver")
            rows_das = bench_das(
                das, preset, snr, max(1, min(repeats, 5)), volume=volume, data=data
            )
            pbar.update()
            if limits is not None and rows_das:
                d = rows_das[0]
                sec = d["bp"] / d["bp_per_s"]
                roof.append(
                    (case, "das", roofline_rows({"das": (sec, d["bp"], "bp")}, limits, d["dim"]))
                )
                ops = das_sweep(das, data, preset, max(1, min(repeats, 3)))
                equal += equal_accuracy_lines(case, equal_accuracy(rpm_ops, ops))
            for b in rows_das:
                lines.append(
                    f"{label:12s} {'inf' if snr is None else f'{snr:g}':>4s} {'das':11s} "
                    f"{b['total_ms']:8.1f} {'':7s} {'':6s} {'':7s} {'':6s} {'':7s} {'-':>9s} "
                    f"{b['rpm50']:8.0%} {b['rpm100']:9.0%} {b['bp_per_s']:12.3g} bp/s  "
                    f"({b['label']}, {b['points']} points)"
                )
    pbar.close()
    lines.append(
        f"(wall time of the benchmark: {time.perf_counter() - t0:.1f} s.  Times in ms: "
        "total, decomp(osition), RPs (extraction) and RPM are stage medians; isect and "
        f"score are the intersection and scoring kernels, medians of {PROFILE_RUNS} extra runs "
        "with each kernel waited for; kernel evals/s = Gaussian evaluations of the scoring "
        "kernel per second of it; das rows: back-projections (voxels x antennas) per "
        "second, points = the image's peaks, or its -6 dB pixels for a section)"
    )
    if roof:
        lines += ["", *roofline_table(roof, limits)]
        lines.append(
            "(stage times are medians (kernels: waited for, as isect and score above); "
            "FLOP and bytes per unit: rpm_cl.cli.bench_roofline.stage_models; '-': no "
            "model, the rate in its unit only)"
        )
    if equal:
        lines += [
            "",
            (
                "RPM against DAS at equal accuracy (fraction of points within the tolerance "
                "of the true boundary; each side's least time reaching the fraction both reach; "
                f"RPM: {', '.join(RPM_METHODS)}; DAS: its grids of "
                "rpm_cl.cli.bench_roofline.DAS_COARSENING, back-projection and point picking; "
                "the fraction says how many points are right, not how much of the boundary "
                "they cover):"
            ),
            *equal,
        ]
    return "\n".join(lines)


def _stages(b: dict) -> dict:
    """``{stage: (seconds, work, unit)}`` of one :func:`bench_case` result."""
    work = b.get("kernel_work", {})
    out = {
        "decompose": (b.get("decompose_ms", 0.0) / 1e3, b["samples"], "sample"),
        "range_pts": (b.get("range_points_ms", 0.0) / 1e3, b["rps"], "RP"),
        "rpm": (b["rpm_ms"] / 1e3, b["rps"], "RP"),
    }
    if "intersect_ms" in b:
        out["intersect"] = (b["intersect_ms"] / 1e3, work.get("intersect", 0), "slot")
        out["score"] = (b["score_ms"] / 1e3, b["kernel_evals"], "evaluation")
        for k in ("meanshift", "density"):
            if work.get(k):
                out[k] = (b[f"{k}_ms"] / 1e3, work[k], "main RP")
    return {k: v for k, v in out.items() if v[0] > 0}
