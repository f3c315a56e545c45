"""The 3-D pairing limits against the exhaustive eq. 10 on the human body.

Usage::

    python benchmarks/exhaustive_3d.py [--snr 20] [--steps 0 1 2] [--cache FILE.npz]
                                       [--precision float32|float64]

Images the human body with the list argmax (each main RP paired with a list
of sub RPs: 12, 4 near + 8 spread, where steps follow; 24, 4 near + 20
spread, with ``--steps 0``) refined by ``--steps`` Newton / mean-shift
steps towards the exhaustive density's mode and the exhaustive argmax among
the candidates nearest to it (0: the list's argmax alone; the default
setting is marked), and exhaustively (every other-antenna RP of
the cluster: pair_cutoff inf, no neighbour cap, no mean shift), and prints the
times, the accuracy figures and, per main RP, the distance of each row's point
to the exhaustive one (share under 1 um, i.e. the same candidate, and
under 0.1 / 1 / 5 mm, median).  Minutes: the
exhaustive run scores ~17000 candidates per main RP; ``--cache`` keeps its
image in a file (with the S/N and precision it was made for) and reuses it.

Where a row's point is not the exhaustive one, the two may still be a tie:
both are candidates of eq. 10, and the kernels sum ~17000 Gaussians per
candidate in ``--precision``.  For those main RPs the script evaluates eq. 10
itself at both points in float64 NumPy, untruncated (every triplet of the
cluster, no cutoff: :func:`eq10_density`), and prints the largest relative
difference and how often the row's point scores higher.  A difference
within the rounding of such a sum in the kernels' precision
(:data:`TIE_REL`: 1e-5 for float32, 1e-12 for float64) is a tie, which the
rounding decides, not the search; a larger one is a point the search
missed (or a candidate the truncations of the refinement score differently).
"""

import argparse
import hashlib
import os
import time
from types import SimpleNamespace

import numpy as np

from rpm_cl.cl import create_env
from rpm_cl.extract.kspace import decompose
from rpm_cl.extract.rangepoints import rps_from_decomposition
from rpm_cl.imaging import run_method
from rpm_cl.metrics import summary
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.params import default_params
from rpm_cl.rpm.reference import _triplet
from rpm_cl.simulate import simulate_preset

#: The exhaustive eq. 10: every other-antenna RP of the cluster paired, no
#: neighbour cap, no mean shift.
EXHAUSTIVE = {"pair_cutoff": float("inf"), "max_neighbours": 4096, "meanshift_iters": 0}


def rps_digest(rps) -> str:
    """A digest of the RPs: an exhaustive image kept in a cache holds for
    these RPs only (a change to the decomposition or the RP extraction moves
    them).  A change to the RPM code itself is not seen: delete the cache then."""
    return hashlib.sha1(
        np.ascontiguousarray(
            np.stack([rps.range, rps.amp, rps.x, rps.z, rps.cluster.astype(float)])
        ).tobytes()
    ).hexdigest()


def exhaustive_image(data, pre, engine, snr, cache=None):
    """The exhaustive eq. 10 image of ``data`` (defaults of preset ``pre``),
    from ``cache`` when it holds the image of these RPs at this S/N and the
    engine's precision, else computed (minutes) and kept there.

    Returns
    -------
    image : SimpleNamespace
        ``rp_index`` (M,) and ``points`` (M, 3), m.
    sec : float
        Its run time, s (when it was computed).
    line : str
        Its accuracy figures.
    """
    snr = np.inf if snr is None else snr  # as kept in the cache
    precision = getattr(engine, "precision", "float64")
    params = default_params(data, **pre.defaults)
    rps = rps_from_decomposition(data, decompose(data, params.kspace), params.rp_threshold_db)
    key = rps_digest(rps)
    if cache and os.path.exists(cache):
        with np.load(cache) as f:
            # caches written before the precision was kept are float32's
            kept = str(f["precision"]) if "precision" in f else "float32"
            if float(f["snr"]) == snr and "rps" in f and str(f["rps"]) == key and kept == precision:
                return (
                    SimpleNamespace(rp_index=f["rp_index"], points=f["points"]),
                    float(f["sec"]),
                    f"{f['line']!s} (from {cache})",
                )
    params = default_params(data, **{**pre.defaults, **EXHAUSTIVE})
    t0 = time.perf_counter()
    res = run_method("kspace-rpm", data, params, engine)
    sec = time.perf_counter() - t0
    line = accuracy_line(res, data.truth)
    if cache:
        np.savez(
            cache,
            rp_index=res.image.rp_index,
            points=res.image.points,
            snr=snr,
            sec=sec,
            line=line,
            rps=key,
            precision=precision,
        )
    return res.image, sec, line


def accuracy_line(res, truth) -> str:
    s = summary(res.rps, res.image, truth)
    m = max(1, s["rpm_total"])
    return (
        f"{s['rpm_total']} points, RPM<=50 {s['rpm_within_50mm'] / m:.1%}, "
        f"RPM<=10 {s['rpm_within_10mm'] / m:.1%}"
    )


def distances(a, b):
    """Per main RP imaged by both images, the distance of a's point to b's, m."""
    _, ia, ib = np.intersect1d(a.rp_index, b.rp_index, return_indices=True)
    return np.linalg.norm(a.points[ia] - b.points[ib], axis=1)


def eq10_density(rps, rp_index, points, sigma_d, sigma_r):
    """The exhaustive eq. 10 density of main RPs at given points, float64,
    untruncated: every valid triplet (i, j, k), j < k, of the main RP's
    cluster (the maths of kernels/triplet.h, :func:`rpm_cl.rpm.reference._triplet`),
    weighted by g of eq. 11, each with the Gaussian kernel of width sigma_r.

    Parameters
    ----------
    rps : RangePoints
        The RPs (3-D).
    rp_index : ndarray, shape (M,)
        Main RPs, indices into ``rps``.
    points : ndarray, shape (M, 3)
        One point per main RP, (x, y, z), m.
    sigma_d, sigma_r : float
        sigma_D of eq. 11 and sigma_r of eq. 10, m.

    Returns
    -------
    ndarray, shape (M,)
        The density (amplitudes as in ``rps``: compare ratios).
    """
    x, z, r = (np.asarray(v, np.float64) for v in (rps.x, rps.z, rps.range))
    amp, cluster = np.asarray(rps.amp, np.float64), np.asarray(rps.cluster)
    out = np.empty(len(rp_index))
    for q, (i, p) in enumerate(zip(rp_index, np.asarray(points, np.float64))):
        members = np.flatnonzero(cluster == cluster[i])
        js, ks = np.triu_indices(members.size, 1)
        px, py, pz, ok, g, _ = _triplet(x, z, r, amp, i, members[js], members[ks], sigma_d)
        c = np.stack([px[ok] + x[i], py[ok], pz[ok] + z[i]], axis=1)
        out[q] = g[ok] @ np.exp(-np.sum((c - p) ** 2, axis=1) / (2.0 * sigma_r**2))
    return out


#: Two candidates of eq. 10 whose float64 densities differ by less than this
#: (relative) are a tie for kernels of that precision: about the rounding of
#: a sum of a body main RP's ~17000 Gaussians, sqrt(17000) * 2**-24 = 7.8e-6
#: in float32 and sqrt(17000) * 2**-53 = 1.4e-14 in float64.
TIE_REL = {"float32": 1e-5, "float64": 1e-12}


def exhaustive_ties(res, exh, params):
    """Per main RP imaged by both, whether ``res``'s point is the exhaustive
    one (within 1 um), and where it is not, eq. 10 in float64 at both points
    (:func:`eq10_density`).

    Returns
    -------
    same : ndarray of bool, shape (K,)
        The same point, for the K main RPs imaged by both.
    rel : ndarray, shape (K - same.sum(),)
        ``(f_exh - f_row) / f_exh`` where the points differ (negative: the
        row's point is the higher); NaN where ``f_exh`` is 0.  A tie where
        ``|rel| < TIE_REL[precision]``.
    """
    common, ia, ib = np.intersect1d(res.image.rp_index, exh.rp_index, return_indices=True)
    differ = np.linalg.norm(res.image.points[ia] - exh.points[ib], axis=1) > 1e-6
    sd, sr = params.rpm.sigma_x, params.rpm.sigma_r
    f_row = eq10_density(res.rps, common[differ], res.image.points[ia[differ]], sd, sr)
    f_exh = eq10_density(res.rps, common[differ], exh.points[ib[differ]], sd, sr)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(f_exh > 0, (f_exh - f_row) / f_exh, np.nan)
    return ~differ, rel


def same_or_tied(same, rel, precision) -> float:
    """Share of the main RPs imaged by both that are the exhaustive point or
    tie with it (:func:`exhaustive_ties`); NaN when none is imaged by both."""
    if same.size == 0:
        return float("nan")
    return float(same.sum() + np.sum(np.abs(rel) < TIE_REL[precision])) / same.size


def tie_line(res, exh, params, precision) -> str:
    """:func:`exhaustive_ties` as a line of text."""
    same, rel = exhaustive_ties(res, exh, params)
    if same.size == 0:
        return "no main RP imaged by both"
    if rel.size == 0:
        return "every point the exhaustive one"
    return (
        f"{rel.size} points not the exhaustive one; eq. 10 in float64 there: "
        f"|f_exh - f_row| / f_exh at most {np.nanmax(np.abs(rel)):.2g} (median "
        f"{np.nanmedian(np.abs(rel)):.2g}), the row's point higher in {np.mean(rel < 0):.0%}; "
        f"the same point or a tie (within {TIE_REL[precision]:g}): "
        f"{round(same_or_tied(same, rel, precision) * same.size)} of {same.size}"
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--snr", type=float, default=None)
    ap.add_argument(
        "--steps",
        type=int,
        nargs="+",
        default=[0, 1, 2],
        help="mean-shift steps of the rows besides the exhaustive one",
    )
    ap.add_argument("--cache", help="npz file that keeps the exhaustive image")
    ap.add_argument(
        "--precision",
        choices=("float32", "float64"),
        default="float32",
        help="kernel precision of every row and of the exhaustive image",
    )
    args = ap.parse_args()
    engine = DeviceRPM(create_env(), args.precision)
    data, pre = simulate_preset("human-body", args.snr, 0, noise="receiver")
    out = {}
    default_steps = default_params(data, **pre.defaults).rpm.meanshift_iters
    rows = tuple(
        (f"{k} steps" + (" (default)" if k == default_steps else ""), {"meanshift_iters": k})
        for k in args.steps
    )
    for name, extra in rows:
        params = default_params(data, **{**pre.defaults, **extra})
        run_method("kspace-rpm", data, params, engine)
        t0 = time.perf_counter()
        res = run_method("kspace-rpm", data, params, engine)
        sec = time.perf_counter() - t0
        print(f"{name:18s}: {sec:8.2f} s, {accuracy_line(res, data.truth)}", flush=True)
        out[name] = (res, params)
    b, sec, line = exhaustive_image(data, pre, engine, args.snr, args.cache)
    print(f"{'exhaustive':18s}: {sec:8.2f} s, {line}", flush=True)
    for name, _ in rows:
        res, params = out[name]
        d = distances(res.image, b)
        print(
            f"{name:18s} to exhaustive, per main RP imaged by both ({d.size}): "
            f"same point (< 1 um) {np.mean(d < 1e-6):.1%}, "
            f"< 0.1 mm {np.mean(d < 1e-4):.1%}, < 1 mm {np.mean(d < 1e-3):.1%}, "
            f"< 5 mm {np.mean(d < 5e-3):.1%}, median {1e3 * np.median(d):.2f} mm"
        )
        if params.rpm.meanshift_iters > 0:
            print(f"{'':18s}   {tie_line(res, b, params, args.precision)}")


if __name__ == "__main__":
    main()
