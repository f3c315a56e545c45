"""Where phase-rpm's points lie seen from their antennas, and how accurate
they are there: the measurement behind ``ImagingParams.reach_deg``.

For each scene and S/N: every point's angle from boresight at its main RP's
antenna (:func:`rpm_cl.rpm.methods.reach_angles`, with ``reach_deg = 90``, so
nothing is dropped), counted per angle band with how many lie within 50 mm
of the true boundary.

    python benchmarks/reach.py [--seeds 5]
"""

import argparse

import numpy as np

from rpm_cl.cl import create_env
from rpm_cl.imaging import run_method
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.methods import reach_angles
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import simulate_preset

BANDS = ((0, 45), (45, 60), (60, 70), (70, 75), (75, 90.1))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    args = ap.parse_args(argv)
    engine = DeviceRPM(create_env(), "float32")
    head = " ".join(f"{lo:>4g}-{hi:<4g}" for lo, hi in BANDS)
    print(f"{'scene':16s} {'S/N':>5s} {'points':>6s}   per angle band (deg): points (within 50 mm)")
    print(f"{'':30s}{head}")
    for name in ("paper-2d", "paper-2d-sparse", "human-body"):
        for snr in (None, 30.0, 20.0):
            counts = np.zeros((len(BANDS), 2), int)
            total = 0
            for seed in range(args.seeds if snr is not None else 1):
                data, _ = simulate_preset(name, snr, seed)
                params = default_params(data, reach_deg=90.0)
                res = run_method("phase-rpm", data, params, engine)
                ang = reach_angles(data.array, res.rps, res.image)
                b = data.truth.boundary
                err = np.array([np.min(np.linalg.norm(b - p, axis=1)) for p in res.image.points])
                total += ang.size
                for i, (lo, hi) in enumerate(BANDS):
                    m = (ang >= lo) & (ang < hi)
                    counts[i] += (int(m.sum()), int((err[m] <= 0.05).sum()))
            cells = " ".join(f"{n:>4d} ({g:>3d})" if n else f"{'.':>10s}" for n, g in counts)
            print(f"{name:16s} {('inf' if snr is None else f'{snr:g}'):>5s} {total:>6d}   {cells}")


if __name__ == "__main__":
    main()
