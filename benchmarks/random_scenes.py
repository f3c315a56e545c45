"""Random narrow-band 2-D scenes (rpm_cl.cli.robustness.random_geometry):
how often each method hits every target, on layouts nobody chose.

    python benchmarks/random_scenes.py [--scenes 30] [--first 1000] [--snr inf,30,20]

The robustness benchmark's four scenes were laid out by hand with their
targets 15-30 degrees apart; a user's scene need not be.  Each scene here is
drawn from the same envelope (20-24 GHz, 0.2-0.25 GHz, 21-31 antennas at 4-5
mm, three or four point targets at 0.35-0.5 m, at least 60 mm apart) with
its own seed, and imaged as the robustness benchmark images its scenes (a
spectrum file's compression, in-band noise, ``max_range`` the region).  Per
method and S/N: the points within 50 mm (pooled), targets hit, scenes with
every target hit; then the misses by how far the missed target's direction
lies from its nearest neighbour's, in aperture resolution cells
(:func:`rpm_cl.cli.robustness.direction_cells`): under one cell no method
that works on the aperture's k-space can tell the two apart.
"""

import argparse
import sys

import numpy as np

from rpm_cl import imaging
from rpm_cl.baselines.das import DeviceDAS
from rpm_cl.cl import create_env
from rpm_cl.cli import robustness as rb
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.params import default_params

#: (label, method, overrides)
METHODS = (
    ("phase-rpm", "phase-rpm", {}),
    ("phase-rpm, centres a quarter window apart", "phase-rpm", {"close_centres": False}),
    ("kspace-rpm", "kspace-rpm", {}),
)
#: Bins of the missed targets' direction gap, resolution cells.
CELL_BINS = (0.0, 1.0, 2.0, 4.0, np.inf)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=30, help="scenes drawn (default 30)")
    ap.add_argument("--first", type=int, default=1000, help="seed of the first scene")
    ap.add_argument("--snr", default="inf,30,20", help="in-band S/N list, dB (inf: noise-free)")
    args = ap.parse_args(argv)
    snrs = [None if s.strip() == "inf" else float(s) for s in args.snr.split(",")]
    env = create_env()
    engine, das = DeviceRPM(env), DeviceDAS(env)
    runs = [*METHODS, ("das peaks", "das", None)]
    labels = [r[0] for r in runs]
    tally = {}  # (snr, label) -> [within, points, hit, targets, scenes ok, missed cells]
    for seed in range(args.first, args.first + args.scenes):
        g = rb.random_geometry(seed)
        boundary = rb.truth_boundary(g)
        cells = rb.direction_cells(g)
        for snr in snrs:
            spec, f, _ = rb.synthesize(g, snr, seed)
            data = rb.loaded_data(g, spec, f)
            row = []
            for label, method, kw in runs:
                if kw is None:  # DAS: the peaks of its image, as the robustness benchmark
                    pts = rb._das_points(das, data, g)
                else:
                    params = default_params(data, max_range=rb.region(g), **kw)
                    pts = imaging.run_method(method, data, params, engine).image.points
                frac, _, _, n = rb._score(pts, g, boundary)
                hit = rb.hits(pts, g)
                t = tally.setdefault((snr, label), [0.0, 0, 0, 0, 0, []])
                t[0] += frac * n
                t[1] += n
                t[2] += int(hit.sum())
                t[3] += hit.size
                t[4] += bool(hit.all())
                t[5] += list(cells[~hit])
                row.append(f"{label} {100 * frac:.0f}% {hit.sum()}/{hit.size}")
            print(f"{g.name} S/N {snr}: " + " | ".join(row), flush=True)
    print()
    bins = [f"<{b:g}" for b in CELL_BINS[1:-1]] + [f">={CELL_BINS[-2]:g}"]
    print(
        "| S/N dB | method | within 50 mm | targets hit | scenes all hit | misses by gap "
        f"({', '.join(bins)} cells) |"
    )
    print("|---|---|---|---|---|---|")
    for snr in snrs:
        for label in labels:
            w, n, h, nt, ok, missed = tally[(snr, label)]
            counts = np.histogram(missed, CELL_BINS)[0] if missed else np.zeros(len(bins), int)
            print(
                f"| {'inf' if snr is None else f'{snr:g}'} | {label} | "
                f"{100 * w / max(n, 1):.1f} % | {h}/{nt} | {ok}/{args.scenes} | "
                f"{' / '.join(str(c) for c in counts)} |"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
