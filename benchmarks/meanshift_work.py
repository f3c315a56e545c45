"""The work of the 3-D refinement (mean shift and density): pairs per pass.

    python benchmarks/meanshift_work.py [--preset human-body] [--snr DB]

For each main RP the refinement kernels (kernels/meanshift.cl) sweep every
pair (j, k) of its cluster's sub RPs with j "near" (within MS_PAIR_CUTOFF
sigma_D of the main antenna) and k > j, after dropping sub RPs whose sphere
passes farther than MS_CUTOFF sigma_r from the point: this script counts
them at each main RP's output point (the mean shift's last pass) with the
kernel's own rules, and the 8-wide vector iterations they take.  Divided
by the measured ``meanshift`` / ``density`` kernel times of ``rpm-cl
bench`` it gives the pairs per second the kernels reach.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from rpm_cl.cl import create_env
from rpm_cl.imaging import run_method
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.params import default_params
from rpm_cl.rpm.reference import MS_CUTOFF, MS_PAIR_CUTOFF
from rpm_cl.simulate.synth import simulate_preset


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="human-body")
    ap.add_argument("--snr", type=float, default=None)
    ap.add_argument("--method", default="kspace-rpm")
    args = ap.parse_args(argv)
    data, pre = simulate_preset(args.preset, args.snr, 0, noise="receiver")
    params = default_params(data, **pre.defaults)
    res = run_method(args.method, data, params, DeviceRPM(create_env()))
    rps, img, p = res.rps, res.image, params.rpm
    x, z, r, cl = (np.asarray(v) for v in (rps.x, rps.z, rps.range, rps.cluster))
    far2 = (MS_PAIR_CUTOFF * p.sigma_x) ** 2
    cut = MS_CUTOFF * p.sigma_r
    pairs = vectors = 0
    kept, near = [], []
    for k, i in enumerate(img.rp_index):
        members = np.flatnonzero(cl == cl[i])
        if members.size > p.meanshift_max_rps:
            continue  # not refined
        ax, az = x[members] - x[i], z[members] - z[i]
        n2 = ax**2 + az**2
        q = img.points[k] - np.array([x[i], 0.0, z[i]])
        d = np.sqrt((q[0] - ax) ** 2 + q[1] ** 2 + (q[2] - az) ** 2)
        keep = (n2 > 0) & (np.abs(d - r[members]) <= cut)
        m, mn = int(keep.sum()), int((keep & (n2 <= far2)).sum())
        kept.append(m)
        near.append(mn)
        j = np.arange(mn)
        pairs += int(np.sum(m - j - 1))
        vectors += int(np.sum((m + 7) // 8 - (j + 1) // 8))
    print(
        f"{args.preset} ({args.method}): {len(kept)} main RPs refined; sigma_r "
        f"{1e3 * p.sigma_r:.1f} mm, sigma_D {1e3 * p.sigma_x:.2f} mm; sub RPs kept per main RP "
        f"median {np.median(kept):.0f} (largest {max(kept)}), near median {np.median(near):.0f}"
    )
    print(f"per pass: {pairs:.4g} pairs, {vectors:.4g} vector iterations of 8 lanes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
