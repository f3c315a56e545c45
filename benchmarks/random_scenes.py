"""Random narrow-band 2-D scenes (rpm_cl.cli.robustness.random_geometry):
how often each method hits every target, on layouts nobody chose.

    python benchmarks/random_scenes.py [--scenes 30] [--first 1000] [--snr inf,30,20]
        [--envelope paper|wide]

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

``--envelope wide`` draws from a far wider envelope instead
(:func:`wide_geometry`): carriers of 10-77 GHz, bands of 0.25-4 GHz,
16-128 antennas at a quarter to two wavelengths, one to six point targets
at 0.2-3 m within +-40 degrees, the frequency step keeping the unambiguous
range over twice the farthest echo; DAS then images a grid fitted to the
scene (:func:`das_peaks`).
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


def wide_geometry(seed: int, min_separation: float = 0.06) -> rb.Geometry:
    """A 2-D scene drawn from the wide envelope (module notes), named
    ``w<seed>``: targets at least ``min_separation`` (m) apart."""
    rng = np.random.default_rng(seed)
    fc = float(rng.choice([10e9, 24e9, 60e9, 77e9]))
    band = float(rng.choice([0.25e9, 1e9, 4e9]))
    nx = int(rng.choice([16, 24, 32, 48, 64, 96, 128]))
    pitch = float(rng.choice([0.25, 0.5, 0.75, 1.0, 1.5, 2.0])) * 299792458.0 / fc
    nt = int(rng.integers(1, 7))
    for _ in range(10_000):
        rs, ang = rng.uniform(0.2, 3.0, nt), np.radians(rng.uniform(-40, 40, nt))
        pts = np.stack([rs * np.sin(ang), rs * np.cos(ang)], axis=1)
        gap = np.linalg.norm(pts[:, None] - pts[None], axis=2) + np.eye(nt)
        if gap.min() >= min_separation:
            break
    x = (np.arange(nx) - (nx - 1) / 2) * pitch
    far = float(np.max(np.hypot(x[:, None] - pts[None, :, 0], pts[None, :, 1])))
    # frequency step: an unambiguous range c / (2 df) over twice the farthest echo
    nf = max(32, int(np.ceil(4 * far * band / 299792458.0)))
    return rb.Geometry(f"w{seed}", fc, band, nf, (nx, pitch), None, tuple(map(tuple, pts)))


def das_peaks(das, data, g: rb.Geometry) -> np.ndarray:
    """DAS's peaks on a grid fitted to a wide-envelope scene: +-1.25 times the
    farthest target's range across, 0.1 m to that range down, in steps of a
    four-hundredth of it (at least 2 mm); peaks as the robustness benchmark
    takes them (within 10 dB of the maximum, 5 x 5 local maxima)."""
    from rpm_cl.baselines.das import Grid
    from rpm_cl.baselines.peaks import image_peaks

    far = 1.25 * float(np.max(np.hypot(*np.asarray(g.targets).T)))
    step = max(2e-3, far / 400)
    grid = Grid(np.arange(-far, far, step), np.arange(0.1, far, step))
    return image_peaks(das.backproject(data, grid), grid.axes, threshold_db=-10.0, size=5)[0]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=30, help="scenes drawn (default 30)")
    ap.add_argument("--first", type=int, default=1000, help="seed of the first scene")
    ap.add_argument("--snr", default="inf,30,20", help="in-band S/N list, dB (inf: noise-free)")
    ap.add_argument(
        "--envelope",
        default="paper",
        choices=("paper", "wide"),
        help="the robustness benchmark's envelope (default) or the wide one",
    )
    args = ap.parse_args(argv)
    snrs = [None if s.strip() == "inf" else float(s) for s in args.snr.split(",")]
    draw, peaks = (
        (rb.random_geometry, rb._das_points)
        if args.envelope == "paper"
        else (wide_geometry, das_peaks)
    )
    env = create_env()
    engine, das = DeviceRPM(env), DeviceDAS(env)
    runs = [*METHODS, ("das peaks", "das", None)]
    labels = [r[0] for r in runs]
    tally = {}  # (snr, label) -> [within, points, hit, targets, scenes ok, missed cells]
    for seed in range(args.first, args.first + args.scenes):
        g = draw(seed)
        boundary = rb.truth_boundary(g)
        cells = rb.direction_cells(g)
        for snr in snrs:
            spec, f, _ = rb.synthesize(g, snr, seed)
            data = rb.loaded_data(g, spec, f)
            row = []
            for label, method, kw in runs:
                if kw is None:  # DAS: the peaks of its image, as the robustness benchmark
                    pts = peaks(das, data, g)
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
