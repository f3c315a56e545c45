"""The three spheres on larger half-wavelength planar arrays: points on and
off the spheres with the alias reach rule and without it.

    python benchmarks/planar_aliases.py [--sizes 45 64]

The robustness benchmark's 3-D scene (``rpm_cl.cli.robustness.GEOMETRY_3D``:
three spheres at 0.55-0.7 m, 20 GHz / 3 GHz, noise-free) on n x n antennas
at 7.5 mm, half a wavelength at 20 GHz: every cluster's k has a visible
alias one unit of u away, and the alignment tells them apart
(``rpm_cl.extract.kspace_align``).  For phase-rpm and kspace-rpm, the image
points, those within 20 mm of a sphere's surface and those beyond, with the
reach rule (``ALIAS_REACH``, the default) and without it (``inf``).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace

import numpy as np

from rpm_cl.cl import create_env
from rpm_cl.cli import robustness as R
from rpm_cl.extract import kspace_align as KA
from rpm_cl.imaging import run_method
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.params import default_params


def _distance(points: np.ndarray) -> np.ndarray:
    d = np.full(len(points), np.inf)
    for cx, cy, cz, rho in R.GEOMETRY_3D.targets:
        d = np.minimum(d, np.abs(np.linalg.norm(points - [cx, cy, cz], axis=1) - rho))
    return d


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[45, 64])
    args = ap.parse_args(argv)
    engine = DeviceRPM(create_env())
    default = KA.ALIAS_REACH
    print("array    method       alias reach  points  <= 20 mm  > 20 mm")
    for n in args.sizes:
        g = replace(R.GEOMETRY_3D, x=(n, 7.5e-3), z=(n, 7.5e-3))
        spec, f, _ = R.synthesize(g, None, 0)
        data = R.radar_data(g, spec, f)
        params = default_params(data)
        for method in ("phase-rpm", "kspace-rpm"):
            for reach in (default, np.inf):
                KA.ALIAS_REACH = reach
                try:
                    pts = run_method(method, data, params, engine).image.points
                finally:
                    KA.ALIAS_REACH = default
                near = int(np.sum(_distance(pts) <= 0.02))
                print(
                    f"{n:3d}x{n:<3d}  {method:11s}  {reach:11g}  {len(pts):6d}  {near:8d}  "
                    f"{len(pts) - near:7d}"
                )
    return 0


if __name__ == "__main__":
    sys.exit(main())
