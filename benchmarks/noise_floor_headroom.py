"""What the k-space noise floor costs on the robustness benchmark's 2-D scenes.

    python benchmarks/noise_floor_headroom.py [--snrs 20 10] [--seeds 0 1 2]

The narrow-band 2-D scenes' range axes are two range resolutions long, so
the centre search estimates the noise power from the low tail of the
k-space map (``rpm_cl.extract.kspace._kspace_noise``), which reads high
where echoes fill most of the map.  Each scene is imaged by phase-rpm twice
per seed: with that estimate (the default), and with the true noise power
given (``noise_power``: the mean power per sample of the same noise
range-compressed alone).  Targets hit and the share of points within the
scene's tolerance, seeds pooled, as ``rpm_cl.cli.robustness`` scores them;
the gap is what a better estimate could recover.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from rpm_cl.cl import create_env
from rpm_cl.cli import robustness as R
from rpm_cl.imaging import run_method
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.params import default_params


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--snrs", type=float, nargs="+", default=[20.0, 10.0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    args = ap.parse_args(argv)
    eng = DeviceRPM(create_env())
    print("scene  S/N  | noise power estimated        | noise power given")
    for g in R.GEOMETRIES_2D:
        boundary = R.truth_boundary(g)
        for snr in args.snrs:
            acc = {"est": [0, 0, 0.0, 0], "true": [0, 0, 0.0, 0]}
            for seed in args.seeds:
                spec, f, _ = R.synthesize(g, snr, seed)
                data = R.radar_data(g, spec, f)
                noise = spec - R.synthesize(g, None, seed)[0]
                power = float(np.mean(np.abs(R.radar_data(g, noise, f).signal) ** 2))
                for key, kw in (("est", {}), ("true", {"noise_power": power})):
                    res = run_method("phase-rpm", data, default_params(data, **kw), eng)
                    frac, _, hit, n = R._score(res.image.points, g, boundary)
                    a = acc[key]
                    a[0] += hit
                    a[1] += len(g.targets)
                    a[2] += frac * n
                    a[3] += n
            cells = [
                f"hit {a[0]:2d}/{a[1]:2d}, {a[2] / max(a[3], 1):6.1%} within tol"
                for a in acc.values()
            ]
            print(f"{g.name:5s} {snr:4.0f} | {cells[0]:28s} | {cells[1]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
