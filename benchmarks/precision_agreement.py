"""float32 against float64 kernels: the share of main RPs given the same point.

Usage::

    python benchmarks/precision_agreement.py [--seeds 5]

For each paper scene (2-D points, the human body) at S/N inf and 20 dB over
``--seeds`` noise realisations, both precisions image the same RPs; a main RP
"agrees" when both choose points within 0.1 mm of each other (a float32
near-tie between two candidates can pick the other one).
"""

import argparse

import numpy as np

from rpm_cl.cl import create_env
from rpm_cl.imaging import run_method
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import simulate_preset


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    args = ap.parse_args()
    env = create_env()
    d32, d64 = DeviceRPM(env, "float32"), DeviceRPM(env, "float64")
    print(f"device: {env.name}")
    print(
        f"{'scene':12s} {'S/N':>4s} {'main RPs':>9s} {'same point':>11s} {'fraction':>9s} "
        f"{'max shift of the others':>24s}"
    )
    for preset in ("paper-2d", "human-body"):
        for snr in (None, 20.0):
            n = same = 0
            worst = 0.0
            for seed in range(args.seeds if snr is not None else 1):
                data, pre = simulate_preset(preset, snr, seed, noise="receiver")
                params = default_params(data, **pre.defaults)
                a = run_method("kspace-rpm", data, params, d32).image
                b = run_method("kspace-rpm", data, params, d64).image
                common, ia, ib = np.intersect1d(a.rp_index, b.rp_index, return_indices=True)
                d = np.linalg.norm(a.points[ia] - b.points[ib], axis=1)
                n += len(common) + len(np.setxor1d(a.rp_index, b.rp_index))
                same += int(np.sum(d < 1e-4))
                if np.any(d >= 1e-4):
                    worst = max(worst, float(d[d >= 1e-4].max()))
            snr_s = "inf" if snr is None else f"{snr:g}"
            print(
                f"{preset:12s} {snr_s:>4s} {n:9d} {same:11d} {same / max(1, n):9.4f} "
                f"{1e3 * worst:21.1f} mm"
            )


if __name__ == "__main__":
    main()
