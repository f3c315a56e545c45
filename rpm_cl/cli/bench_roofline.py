"""The roofline and equal-accuracy tables of ``rpm-cl bench``.

Roofline: each stage's time, its work in its own unit, its rate, and that
rate against this machine's measured limits (:mod:`rpm_cl.cli.limits`):
FLOP/s over the peak for arithmetic kernels, bytes/s over the memory
bandwidth for stages that stream data.  The operations and bytes per unit
come from :func:`stage_models`, counted from the kernels' sources.

Equal accuracy: RPM (every method of the family) and DAS (the scene's grid
at the steps of :data:`DAS_COARSENING`) each give operating points
(fraction of points within a tolerance of the true boundary, time); for
each tolerance, the fraction both reach is the lower of their best, and
each side's time is the least time at which it reaches that fraction.
"""

from __future__ import annotations

import time

import numpy as np

__all__ = [
    "DAS_COARSENING",
    "TOLERANCES",
    "equal_accuracy",
    "roofline_rows",
    "roofline_table",
    "stage_models",
]

#: Steps of the DAS grids of the equal-accuracy comparison, as multiples of
#: the step of the scene's DAS grid (``rpm_cl.cli.reproduce.DAS_GRIDS``):
#: the 2-D image's 1 mm, and the body's whole 2 m volume (not its section,
#: which images one plane of the surface RPM finds whole) from 12 mm up,
#: 1 s of back-projection or less (its 3 mm grid takes minutes).
DAS_COARSENING = {"image": (1, 2, 4, 8), "volume": (4, 8, 16)}
#: Tolerances of the equal-accuracy comparison, m (the paper's 50 mm and a
#: tighter 20 mm).
TOLERANCES = (0.05, 0.02)


def stage_models(dim: int, precision: str) -> dict:
    """Work model of each stage: ``{stage: (unit, FLOP per unit, bytes per unit)}``.

    FLOP counts are the floating-point additions, subtractions and
    multiplications of one unit's straight-line code, a multiply-add 2
    (comparisons, selects and integer operations not counted):

    - ``score`` (one Gaussian evaluation, kernels/score.cl): the DIM
      differences, the squared distance (2 DIM - 1), its scaling (1),
      ``vexp2_neg`` (rounding 3, ``ln 2`` 1, a Horner polynomial of degree 7
      for float32 / 12 for float64 as multiply-adds, the power of two 1) and
      the weighted sum (2): 30 / 40 in 3-D, 27 / 37 in 2-D.  Its inputs
      are read from cache (each row is reused by every candidate of the
      row), so the bytes do not bound it.
    - ``intersect`` (one candidate slot): bytes written, the candidate
      (DIM reals), its weight (1 real) and its validity (1 byte); the
      arithmetic (a few square roots and an exponential per slot) is
      not the limit of a kernel that writes every slot.
    - ``das`` (one back-projection, kernels/das.cl with the polynomial
      sine and cosine): the distance (3-D 3, 2-D 2), the square root (1),
      the fractional row (4), the interpolation (4), the phase (2), the
      sine and cosine (24, degree 12 / 11) and the accumulation (8):
      46 / 45.  Its gathered rows (16 or 32 bytes) come from cache.
    - ``decompose`` (one input sample): the bytes of the complex input
      read once, a lower bound of the host's memory traffic.
    """
    real = 8 if precision == "float64" else 4
    deg = 12 if precision == "float64" else 7
    exp2 = 3 + 1 + 2 * deg + 1
    score = dim + (2 * dim - 1) + 1 + exp2 + 2
    das = (3 if dim == 3 else 2) + 1 + 4 + 4 + 2 + 24 + 8
    return {
        "score": ("evaluation", score, 0),
        "intersect": ("slot", 0, dim * real + real + 1),
        "das": ("back-projection", das, 0),
        "decompose": ("sample", 0, 2 * real),
    }


def roofline_rows(stages: dict, limits, dim: int) -> list[dict]:
    """Rows of the roofline table from measured ``stages``.

    Parameters
    ----------
    stages : dict
        ``{stage: (seconds, units of work, unit name)}``; stages without a
        model in :func:`stage_models` get a rate in their unit and no ratio.
    limits : MachineLimits
    dim : int
        2 or 3 (the models' counts depend on it).

    Returns
    -------
    list of dict
        ``stage``, ``ms``, ``work``, ``unit``, ``rate`` (units/s),
        ``gflops``, ``peak`` (fraction of peak FLOP/s), ``gbps``, ``bw``
        (fraction of the bandwidth); NaN where the model has no count.
    """
    models = stage_models(dim, limits.precision)
    rows = []
    for stage, (sec, work, unit) in stages.items():
        _, flop, nbytes = models.get(stage, (unit, 0, 0))
        rate = work / sec if sec > 0 else float("nan")
        f = flop * rate if flop else float("nan")
        b = nbytes * rate if nbytes else float("nan")
        rows.append(
            {
                "stage": stage,
                "ms": 1e3 * sec,
                "work": work,
                "unit": unit,
                "rate": rate,
                "gflops": f / 1e9,
                "peak": f / limits.flops,
                "gbps": b / 1e9,
                "bw": b / limits.bandwidth,
            }
        )
    return rows


def _fmt(v, spec):
    return "-" if not np.isfinite(v) else format(v, spec)


def roofline_table(blocks, limits) -> list[str]:
    """Lines of the roofline table: ``blocks`` are ``(case, method, rows)``."""
    lines = [
        limits.describe(),
        (
            f"{'case':18s} {'method':11s} {'stage':10s} {'ms':>8s} {'work':>10s} "
            f"{'unit':16s} {'rate /s':>9s} {'GFLOP/s':>8s} {'% peak':>7s} {'GB/s':>6s} {'% bw':>6s}"
        ),
    ]
    for case, method, rows in blocks:
        for r in rows:
            lines.append(
                f"{case:18s} {method:11s} {r['stage']:10s} {r['ms']:8.2f} {r['work']:10.3g} "
                f"{r['unit']:16s} {_fmt(r['rate'], '9.3g')} {_fmt(r['gflops'], '8.1f')} "
                f"{_fmt(100 * r['peak'], '7.1f')} {_fmt(r['gbps'], '6.2f')} "
                f"{_fmt(100 * r['bw'], '6.1f')}"
            )
    return lines


def das_sweep(das, data, preset: str, repeats: int = 3) -> list[dict]:
    """DAS operating points of one scene (``data``, simulated from
    ``preset``): the preset's DAS grid at each step of :data:`DAS_COARSENING`.

    Returns
    -------
    list of dict
        ``label``, ``ms`` (median wall time of back-projection and point
        picking), and ``within`` ``{tolerance: fraction of the points}``.
    """
    from ..baselines.das import Grid, parse_grid
    from ..metrics import err_rpm
    from .reproduce import DAS_GRIDS, das_points

    out = []
    for label, text, kind in DAS_GRIDS.get(preset, []):
        if kind not in DAS_COARSENING:
            continue
        fine = parse_grid(text)
        step = float(fine.x[1] - fine.x[0])
        for m in DAS_COARSENING[kind]:
            grid = Grid(fine.x[::m], fine.y[::m], None if fine.z is None else fine.z[::m])
            times = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                pts, _ = das_points(das, data, grid, kind)
                times.append(time.perf_counter() - t0)
            e = err_rpm(pts, data.truth)
            n = max(1, len(e))
            out.append(
                {
                    "label": f"das {kind} {1e3 * step * m:g} mm",
                    "ms": 1e3 * float(np.median(times)),
                    "within": {t: float(np.count_nonzero(e <= t)) / n for t in TOLERANCES},
                }
            )
    return out


def equal_accuracy(rpm_points: list[dict], das_points: list[dict]) -> list[dict]:
    """For each tolerance: the fraction both sides reach (the lower of their
    best) and the least time at which each reaches it.

    Parameters
    ----------
    rpm_points, das_points : list of dict
        Operating points: ``label``, ``ms``, ``within`` ``{tolerance: fraction}``.

    Returns
    -------
    list of dict
        ``tol`` (m), ``fraction``, ``rpm`` and ``das`` (the fastest point
        reaching it), ``ratio`` (RPM time / DAS time).
    """
    out = []
    if not rpm_points or not das_points:
        return out
    for tol in TOLERANCES:
        frac = min(
            max(p["within"][tol] for p in rpm_points), max(p["within"][tol] for p in das_points)
        )

        def fastest(points, frac=frac, tol=tol):
            return min((p for p in points if p["within"][tol] >= frac), key=lambda p: p["ms"])

        r, d = fastest(rpm_points), fastest(das_points)
        out.append({"tol": tol, "fraction": frac, "rpm": r, "das": d, "ratio": r["ms"] / d["ms"]})
    return out


def equal_accuracy_lines(case: str, rows: list[dict]) -> list[str]:
    """Lines of the equal-accuracy table for one case."""
    return [
        f"{case:18s} <= {1e3 * q['tol']:2.0f} mm  both reach {q['fraction']:6.1%}:  RPM "
        f"{q['rpm']['ms']:8.2f} ms ({q['rpm']['label']}), DAS {q['das']['ms']:8.2f} ms "
        f"({q['das']['label']}), RPM / DAS = {q['ratio']:.3g}"
        for q in rows
    ]
