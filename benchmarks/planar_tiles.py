"""Large planar arrays decomposed whole and in tiles (phase-rpm).

    python benchmarks/planar_tiles.py [--sizes 45 64] [--snr inf,20,10] [--tile-per-range 0.3]

The robustness benchmark's 3-D scene (three spheres 0.55-0.7 m away, 20 GHz
/ 3 GHz, 96 frequencies, 7.5 mm pitch; ``rpm_cl.cli.robustness.GEOMETRY_3D``)
on n x n planar arrays, with in-band noise (seed 0), loaded as a spectrum
file is and imaged with ``max_range`` the scene's region, by phase-rpm with
``segments`` off (the array decomposed whole) and on (in tiles where
:func:`rpm_cl.extract.segments.segment_plan` cuts it).  Per run: the tiles,
RPs per antenna (each antenna sees each sphere once), points, the share within
20 mm of a sphere's surface, the median distance and the engine's total time.
``--tile-per-range`` sets :data:`rpm_cl.extract.segments.TILE_PER_RANGE`
for a sweep; ``--no-whole`` leaves out the whole decompositions; ``--overlap half``
cuts planar tiles as a line's segments are, overlapping by half
(:func:`rpm_cl.extract.segments._cuts`), instead of the fewest tiles that
cover each axis.  ``--scene one`` / ``two`` image other spheres instead:
one of 50 mm off axis at 0.6 m, or one of 30 mm at 0.45 m and one of 100
mm at 0.9 m (same waveform and pitch); ``--seed`` the noise's.
"""

import argparse
import sys
from dataclasses import replace

import numpy as np

from rpm_cl.cl import create_env
from rpm_cl.cli import robustness as rb
from rpm_cl.extract import segments
from rpm_cl.heap import keep_freed_memory
from rpm_cl.imaging import prepared, run_method
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.methods import phase_plan
from rpm_cl.rpm.params import default_params

#: Spheres (x, y, z, radius), m, of ``--scene``.
SCENES = {
    "three": rb.GEOMETRY_3D.targets,
    "one": ((0.07, 0.6, -0.05, 0.05),),
    "two": ((-0.06, 0.45, 0.04, 0.03), (0.05, 0.9, -0.03, 0.1)),
}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[45, 64])
    ap.add_argument("--snr", default="inf,20,10", help="in-band S/N list, dB (inf: noise-free)")
    ap.add_argument("--tile-per-range", type=float, default=segments.TILE_PER_RANGE)
    ap.add_argument("--no-whole", action="store_true", help="the tiled runs only")
    ap.add_argument("--scene", choices=sorted(SCENES), default="three")
    ap.add_argument("--seed", type=int, default=0, help="noise seed")
    ap.add_argument(
        "--overlap",
        choices=("fewest", "half"),
        default="fewest",
        help="planar tiles: the fewest that cover each axis (the engine's), or "
        "overlapping by half as a line's segments",
    )
    args = ap.parse_args(argv)
    segments.TILE_PER_RANGE = args.tile_per_range
    if args.overlap == "half":
        segments._tiles = segments._cuts
    snrs = [None if s.strip() == "inf" else float(s) for s in args.snr.split(",")]
    keep_freed_memory()
    engine = DeviceRPM(create_env())
    print(
        f"TILE_PER_RANGE = {segments.TILE_PER_RANGE:g}, planar tiles: {args.overlap}, "
        f"scene {args.scene}, seed {args.seed}"
    )
    print(
        "| array | S/N dB | decomposed | tiles | RPs per antenna | points | within 20 mm "
        "| median mm | engine s |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for n in args.sizes:
        g = replace(
            rb.GEOMETRY_3D,
            x=(n, rb.GEOMETRY_3D.x[1]),
            z=(n, rb.GEOMETRY_3D.z[1]),
            targets=SCENES[args.scene],
        )
        spheres = np.asarray(g.targets, float)
        for snr in snrs:
            spec, f, _ = rb.synthesize(g, snr, args.seed)
            data = rb.loaded_data(g, spec, f)
            for tiled in (True,) if args.no_whole else (False, True):
                params = default_params(data, max_range=rb.region(g), segments=tiled)
                # the plan phase_rpm makes, of the data as run_method prepares them
                plan = phase_plan(*prepared(data, params))
                res = run_method("phase-rpm", data, params, engine)
                p = res.image.points
                # distance to the nearest sphere's surface, m
                d = np.abs(
                    np.linalg.norm(p[:, None] - spheres[None, :, :3], axis=2) - spheres[:, 3]
                )
                d = d.min(axis=1) if len(p) else np.zeros(0)
                frac, med, pts = float(np.mean(d <= 0.02)), float(np.median(d)), len(p)
                print(
                    f"| {n} x {n} | {'inf' if snr is None else f'{snr:g}'} | "
                    f"{'in tiles' if tiled else 'whole'} | {len(plan) if plan else '-'} | "
                    f"{len(res.rps) / data.array.n:.2f} | {pts} | {100 * frac:.1f} % | "
                    f"{1e3 * med:.2f} | {res.timings['total']:.1f} |",
                    flush=True,
                )
    return 0


if __name__ == "__main__":
    sys.exit(main())
