"""How far phase-rpm's range constant (the coherent level) lies from the truth.

    python benchmarks/phase_level.py [--scenes 2d-a 2d-d] [--snrs 30 20] [--seeds 10]

phase-rpm places each echo's track by its phase walk (exact up to one
constant) and takes the constant from the coherent sum of the range profiles
along the walk (``rpm_cl.extract.phase._coherent_level``).  On the
robustness benchmark's narrow-band 2-D scenes every error of a point is
radial, one constant per track, so this constant decides whether a target is
hit.  For each track the constant's error is measured against the target
whose true ranges fit the track's walk best: on the scene as synthesised,
and on each of its targets alone at the same noise power per sample.  The
scene's S/N is its compressed peak over the mean noise power, and targets in
one range cell add up in that peak: alone, each echo meets the same noise
with its own amplitude.  The RMS gap between the two columns is what the
other echoes cost; the single-target column against the Cramer-Rao bound of
the range (``crb``) is what the estimator costs.  ``from the samples``: the
same scene with its frequency samples beside the profiles (as ``rpm-cl
image`` loads a spectrum file), whose coherent sums are formed from them
(``rpm_cl.extract.phase.LEVEL_WINDOW``).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace

import numpy as np

from rpm_cl.cli import robustness as R
from rpm_cl.extract import phase as PH
from rpm_cl.extract.kspace import decompose
from rpm_cl.extract.rangepoints import rps_from_decomposition
from rpm_cl.io.data import Spectrum
from rpm_cl.rpm.params import default_params


def _errors(
    g, snr: float, seed: int, sigma2: float | None = None, samples: bool = False
) -> list[float]:
    """Level error of every track of ``g`` at one noise seed, m.  ``sigma2``
    fixes the noise power per frequency sample (default: from ``snr``);
    ``samples`` hands the engine the frequency samples too."""
    targets = np.asarray(g.targets)
    spec, f, s2 = R.synthesize(g, snr, seed)
    if sigma2 is not None:  # the same noise, scaled to the given power
        clean = R.synthesize(g, None, seed)[0]
        spec = clean + (spec - clean) * np.sqrt(sigma2 / s2)
    data = R.radar_data(g, spec, f)
    if samples:  # as a spectrum file loads: the samples beside the profiles
        data = replace(data, spectrum=Spectrum(spec, f))
    params = default_params(data)
    dec = decompose(data, params.kspace)
    rps = rps_from_decomposition(data, dec, params.rp_threshold_db)
    out = []
    level = PH._coherent_level

    def spy(data_, antenna, grid, r_fit):
        c = level(data_, antenna, grid, r_fit)
        pos = np.column_stack([data_.array.x[antenna], np.zeros(len(antenna))])
        off = np.linalg.norm(pos[:, None] - targets[None], axis=2) - r_fit[:, None]
        j = int(np.argmin(np.std(off, axis=0)))
        out.append(c - float(np.mean(off[:, j])))
        return c

    PH._coherent_level = spy
    try:
        PH.phase_ranges(data, rps, np.array([c.k for c in dec.clusters]))
    finally:
        PH._coherent_level = level
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="+", default=["2d-a", "2d-d"])
    ap.add_argument("--snrs", type=float, nargs="+", default=[30.0, 20.0])
    ap.add_argument("--seeds", type=int, default=10)
    args = ap.parse_args(argv)
    print(
        "scene  S/N | tracks  RMS in scene  max     | alone: RMS   max     "
        "| from the samples: RMS  max     | CRB range, one antenna"
    )
    for name in args.scenes:
        g = next(x for x in R.GEOMETRIES_2D if x.name == name)
        for snr in args.snrs:
            scene, alone, samples = [], [], []
            for seed in range(args.seeds):
                scene += _errors(g, snr, seed)
                samples += _errors(g, snr, seed, samples=True)
                s2 = R.synthesize(g, snr, seed)[2]
                for t in g.targets:
                    alone += _errors(replace(g, targets=(t,)), snr, seed, sigma2=s2)
            e, a, y = (np.abs(v) * 1e3 for v in (scene, alone, samples))
            crb = R.crb(g, R.synthesize(g, snr, 0)[2])[0] * 1e3
            print(
                f"{name:5s} {snr:4.0f} | {e.size:6d}  {np.sqrt(np.mean(e**2)):7.1f} mm  "
                f"{e.max():5.1f} mm | {np.sqrt(np.mean(a**2)):7.1f} mm  {a.max():5.1f} mm | "
                f"{np.sqrt(np.mean(y**2)):16.1f} mm  {y.max():5.1f} mm | {crb:.1f} mm"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
