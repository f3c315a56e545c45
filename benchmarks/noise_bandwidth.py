"""How the noisy 2-D figures depend on the noise bandwidth of the S/N definition.

The paper defines S/N as peak instantaneous signal power over average noise
power but does not state the sampling rate its simulated received signal (and
so its white noise) had.  This script re-runs the paper-2d case at one S/N for
several receiver sample rates ``receiver_fs`` (noise white over that band) and
prints the paper's three figures for each (the ``"receiver"`` noise model of
:mod:`rpm_cl.simulate`, whose default rate c/(2 dr) = 60 GHz reproduces the
tables), and a last row with the ``"in-band"`` model, where the S/N is that of
the range profiles after the matched filter (as a receiver whose noise
bandwidth is the signal's, ``receiver_fs = 2 B``, gives).

Usage::

    python benchmarks/noise_bandwidth.py [--snr 10] [--trials 20] [--engine reference|opencl]
"""

import argparse

import numpy as np

from rpm_cl.imaging import run_method
from rpm_cl.metrics import summary
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import simulate
from rpm_cl.simulate.scene import get_preset


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--snr", type=float, default=10.0)
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--engine", choices=("reference", "opencl"), default="reference")
    ap.add_argument("--rates-ghz", default="60,120,240,600")
    args = ap.parse_args()
    if args.engine == "opencl":
        from rpm_cl.cl import create_env
        from rpm_cl.rpm import DeviceRPM

        engine = DeviceRPM(create_env())
    else:
        from rpm_cl.rpm import reference as engine
    pre = get_preset("paper-2d")
    print(f"paper-2d, S/N {args.snr:g} dB, {args.trials} noise realisations, engine {args.engine}")
    print(f"{'receiver_fs':>12s} {'RP<=10mm':>9s} {'RPM<=50mm':>10s} {'RPM<=100mm':>11s}")
    rows = [
        (f"{float(g):9.0f} GHz", {"noise": "receiver", "receiver_fs": float(g) * 1e9})
        for g in args.rates_ghz.split(",")
    ] + [(f"{'in-band':>13s}", {"noise": "in-band"})]
    for label, model in rows:
        tot = np.zeros(5)
        for seed in range(args.trials):
            data = simulate(
                pre.scene, pre.array, pre.waveform, pre.range_axis, args.snr, seed, **model
            )
            res = run_method("kspace-rpm", data, default_params(data, **pre.defaults), engine)
            s = summary(res.rps, res.image, data.truth)
            tot += [
                s["rp_within_10mm"],
                s["rp_total"],
                s["rpm_within_50mm"],
                s["rpm_within_100mm"],
                s["rpm_total"],
            ]
        print(f"{label} {tot[0] / tot[1]:9.0%} {tot[2] / tot[4]:10.0%} {tot[3] / tot[4]:11.0%}")


if __name__ == "__main__":
    main()
