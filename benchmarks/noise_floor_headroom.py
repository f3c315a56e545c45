"""What the k-space noise floor costs on the robustness benchmark's 2-D scenes.

    python benchmarks/noise_floor_headroom.py [--snrs 20 10] [--seeds 0 1 2]

The narrow-band 2-D scenes' range axes are two range resolutions long, so
the centre search estimates the noise power from the low tail of the
k-space map (``rpm_cl.extract.kspace._kspace_noise``), which reads high
where echoes fill most of the map.  Each scene is imaged by phase-rpm twice
per seed: with that estimate (the default), and with the true noise power
given (``noise_power``: the mean power per sample of the same noise
range-compressed alone).  A third run loads the spectrum as ``rpm-cl
image`` does, range-compressed over its whole unambiguous axis, and cuts it
to the same gates with ``max_range``: the noise power is then measured on
the whole axis before the cut (``rpm_cl.imaging.prepared``).  Targets hit
and the share of points within the scene's tolerance, seeds pooled, as
``rpm_cl.cli.robustness`` scores them; the gap is what a better estimate
could recover.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from rpm_cl.cl import create_env
from rpm_cl.cli import robustness as R
from rpm_cl.imaging import run_method
from rpm_cl.io.compress import range_compress
from rpm_cl.io.data import RadarData
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.params import default_params


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--snrs", type=float, nargs="+", default=[20.0, 10.0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    args = ap.parse_args(argv)
    eng = DeviceRPM(create_env())
    print(
        "scene  S/N  | noise power estimated        | noise power given"
        "            | whole axis, max_range"
    )
    for g in R.GEOMETRIES_2D:
        boundary = R.truth_boundary(g)
        for snr in args.snrs:
            acc = {key: [0, 0, 0.0, 0] for key in ("est", "true", "roi")}
            for seed in args.seeds:
                spec, f, _ = R.synthesize(g, snr, seed)
                data = R.radar_data(g, spec, f)
                noise = spec - R.synthesize(g, None, seed)[0]
                power = float(np.mean(np.abs(R.radar_data(g, noise, f).signal) ** 2))
                s, rng = range_compress(spec, f, data.waveform.fc, "hann")
                whole = RadarData(s, data.array, rng, data.waveform)
                runs = (
                    ("est", data, default_params(data)),
                    ("true", data, default_params(data, noise_power=power)),
                    ("roi", whole, default_params(whole, max_range=float(data.range[-1]))),
                )
                for key, d, params in runs:
                    res = run_method("phase-rpm", d, params, eng)
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
            print(f"{g.name:5s} {snr:4.0f} | {cells[0]:28s} | {cells[1]:28s} | {cells[2]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
