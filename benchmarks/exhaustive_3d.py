"""The 3-D pairing limits against the exhaustive eq. 10 on the human body.

Usage::

    python benchmarks/exhaustive_3d.py [--snr 20] [--steps 0 1 2] [--cache FILE.npz]

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
image in a file (with the S/N it was made for) and reuses it.
"""

import argparse
import hashlib
import os
import time
from types import SimpleNamespace

import numpy as np

from rpm_cl.cl import create_env
from rpm_cl.imaging import default_params, run_method
from rpm_cl.kspace import decompose
from rpm_cl.metrics import summary
from rpm_cl.rangepoints import rps_from_decomposition
from rpm_cl.rpm import DeviceRPM
from rpm_cl.simulate import simulate_preset

#: The exhaustive eq. 10: every other-antenna RP of the cluster paired, no
#: neighbour cap, no mean shift.
EXHAUSTIVE = {"pair_cutoff": float("inf"), "max_neighbours": 4096, "meanshift_iters": 0}


def rps_digest(rps) -> str:
    """A digest of the RPs: an exhaustive image kept in a cache holds for
    these RPs only (a change to the decomposition or the RP extraction moves
    them).  A change to the RPM code itself is not seen: delete the cache then."""
    return hashlib.sha1(np.ascontiguousarray(np.stack(
        [rps.range, rps.amp, rps.x, rps.z, rps.cluster.astype(float)])).tobytes()).hexdigest()


def exhaustive_image(data, pre, engine, snr, cache=None):
    """The exhaustive eq. 10 image of ``data`` (defaults of preset ``pre``),
    from ``cache`` when it holds the image of these RPs at this S/N, else
    computed (minutes) and kept there.

    Returns
    -------
    image : SimpleNamespace
        ``rp_index`` (M,) and ``points`` (M, 3), m.
    sec : float
        Its run time, s (when it was computed).
    line : str
        Its accuracy figures.
    """
    snr = np.inf if snr is None else snr   # as kept in the cache
    params = default_params(data, **pre.defaults)
    rps = rps_from_decomposition(data, decompose(data, params.kspace), params.rp_threshold_db)
    key = rps_digest(rps)
    if cache and os.path.exists(cache):
        with np.load(cache) as f:
            if float(f["snr"]) == snr and "rps" in f and str(f["rps"]) == key:
                return (SimpleNamespace(rp_index=f["rp_index"], points=f["points"]),
                        float(f["sec"]), f"{f['line']!s} (from {cache})")
    params = default_params(data, **{**pre.defaults, **EXHAUSTIVE})
    t0 = time.perf_counter()
    res = run_method("kspace-rpm", data, params, engine)
    sec = time.perf_counter() - t0
    line = accuracy_line(res, data.truth)
    if cache:
        np.savez(cache, rp_index=res.image.rp_index, points=res.image.points,
                 snr=snr, sec=sec, line=line, rps=key)
    return res.image, sec, line


def accuracy_line(res, truth) -> str:
    s = summary(res.rps, res.image, truth)
    m = max(1, s["rpm_total"])
    return (f"{s['rpm_total']} points, RPM<=50 {s['rpm_within_50mm'] / m:.1%}, "
            f"RPM<=10 {s['rpm_within_10mm'] / m:.1%}")


def distances(a, b):
    """Per main RP imaged by both images, the distance of a's point to b's, m."""
    _, ia, ib = np.intersect1d(a.rp_index, b.rp_index, return_indices=True)
    return np.linalg.norm(a.points[ia] - b.points[ib], axis=1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--snr", type=float, default=None)
    ap.add_argument("--steps", type=int, nargs="+", default=[0, 1, 2],
                    help="mean-shift steps of the rows besides the exhaustive one")
    ap.add_argument("--cache", help="npz file that keeps the exhaustive image")
    args = ap.parse_args()
    engine = DeviceRPM(create_env(), "float32")
    data, pre = simulate_preset("human-body", args.snr, 0)
    out = {}
    default_steps = default_params(data, **pre.defaults).rpm.meanshift_iters
    rows = tuple((f"{k} steps" + (" (default)" if k == default_steps else ""),
                  {"meanshift_iters": k}) for k in args.steps)
    for name, extra in rows:
        params = default_params(data, **{**pre.defaults, **extra})
        run_method("kspace-rpm", data, params, engine)
        t0 = time.perf_counter()
        res = run_method("kspace-rpm", data, params, engine)
        sec = time.perf_counter() - t0
        print(f"{name:18s}: {sec:8.2f} s, {accuracy_line(res, data.truth)}", flush=True)
        out[name] = res.image
    b, sec, line = exhaustive_image(data, pre, engine, args.snr, args.cache)
    print(f"{'exhaustive':18s}: {sec:8.2f} s, {line}", flush=True)
    for name, _ in rows:
        d = distances(out[name], b)
        print(f"{name:18s} to exhaustive, per main RP imaged by both ({d.size}): "
              f"same point (< 1 um) {np.mean(d < 1e-6):.1%}, "
              f"< 0.1 mm {np.mean(d < 1e-4):.1%}, < 1 mm {np.mean(d < 1e-3):.1%}, "
              f"< 5 mm {np.mean(d < 5e-3):.1%}, median {1e3 * np.median(d):.2f} mm")


if __name__ == "__main__":
    main()
