"""The 3-D pairing limits against the exhaustive eq. 10 on the human body.

Usage::

    python benchmarks/exhaustive_3d.py [--snr 20]

Images the human body with the defaults (each main RP paired with its nearest
24 sub RPs within 2 sigma_D) and exhaustively (every other-antenna RP of the
cluster: pair_cutoff inf, no neighbour cap), and prints both times, the
accuracy figures and the share of main RPs given the same point (within
0.1 mm).  Minutes: the exhaustive run scores ~17000 candidates per main RP.
"""

import argparse
import time

import numpy as np

from rpm_cl.cl import create_env
from rpm_cl.imaging import default_params, run_method
from rpm_cl.metrics import summary
from rpm_cl.rpm import DeviceRPM
from rpm_cl.simulate import simulate_preset


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--snr", type=float, default=None)
    args = ap.parse_args()
    engine = DeviceRPM(create_env(), "float32")
    data, pre = simulate_preset("human-body", args.snr, 0)
    out = {}
    for name, extra in (("default", {}), ("exhaustive", {"pair_cutoff": float("inf"),
                                                         "max_neighbours": 4096})):
        params = default_params(data, **{**pre.defaults, **extra})
        run_method("kspace-rpm", data, params, engine) if name == "default" else None
        t0 = time.perf_counter()
        res = run_method("kspace-rpm", data, params, engine)
        sec = time.perf_counter() - t0
        s = summary(res.rps, res.image, data.truth)
        m = max(1, s["rpm_total"])
        print(f"{name:10s}: {sec:8.2f} s, {s['rpm_total']} points, RPM<=50 "
              f"{s['rpm_within_50mm'] / m:.1%}, RPM<=10 {s['rpm_within_10mm'] / m:.1%}", flush=True)
        out[name] = res.image
    a, b = out["default"], out["exhaustive"]
    common, ia, ib = np.intersect1d(a.rp_index, b.rp_index, return_indices=True)
    d = np.linalg.norm(a.points[ia] - b.points[ib], axis=1)
    print(f"same point (< 0.1 mm) for {np.sum(d < 1e-4)} of {len(common)} main RPs imaged by both; "
          f"median distance of the others {1e3 * np.median(d[d >= 1e-4]) if np.any(d >= 1e-4) else 0:.1f} mm")


if __name__ == "__main__":
    main()
