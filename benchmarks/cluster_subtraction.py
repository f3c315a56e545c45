"""phase-rpm against a variant that refines each cluster on the data with the
other clusters' echoes taken out, on random narrow-band 2-D scenes.

    python benchmarks/cluster_subtraction.py [--scenes 30] [--first 1000] [--snr inf,30,20] [--passes 2]

Where two targets lie a few aperture cells apart in direction, each one's
k-space window also holds the other's echo, and the phase of a cluster's
samples is that of their sum.  The variant models every refined RP as an
echo of its own, ``sample * exp(-j 4 pi (f - f_c) R / c)`` at its antenna,
subtracts the other clusters' echoes from the frequency samples and the
profiles, decomposes again, takes the cluster nearest the old centre (within
half a window in k and a range resolution in R), refines its ranges by
phase, and repeats ``--passes`` times (a SAGE-like cycle).  The scenes,
noise and scoring are those of ``benchmarks/random_scenes.py``: points
within 50 mm (pooled), targets hit, scenes with every target hit, and the
imaging time of both.  docs/decisions.md ("Each cluster's phase is read from
the data as decomposed") keeps the figures.
"""

import argparse
import sys
import time
from dataclasses import replace

import numpy as np

from rpm_cl import imaging
from rpm_cl.cl import create_env
from rpm_cl.cli import robustness as rb
from rpm_cl.extract.kspace import decompose
from rpm_cl.extract.phase import phase_ranges
from rpm_cl.extract.rangepoints import RangePoints, rps_from_decomposition
from rpm_cl.io.compress import range_compress
from rpm_cl.io.model import C0
from rpm_cl.io.radar import Spectrum
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm import methods as M
from rpm_cl.rpm.params import default_params


def _echoes(data, rps, refined):
    """Per cluster, the frequency samples of its refined RPs as lone echoes,
    shape (nx, nf)."""
    f, fc = data.spectrum.frequency, data.waveform.fc
    out = {}
    for m in np.unique(rps.cluster):
        y = np.zeros(data.spectrum.values.shape, complex)
        for i in np.nonzero((rps.cluster == m) & refined)[0]:
            y[rps.antenna[i]] += rps.sample[i] * np.exp(-4j * np.pi * (f - fc) * rps.range[i] / C0)
        out[int(m)] = y
    return out


def _profiles(data, y):
    """``y`` compressed as the scenes are (Hann), on the data's gates."""
    s, rng = range_compress(y, data.spectrum.frequency, data.waveform.fc, "hann")
    return s[..., np.rint((data.range - rng[0]) / (rng[1] - rng[0])).astype(int)]


def _subtracted(data, ks, params, env, dec, rps, refined, passes):
    kp = 2 * np.pi / data.array.dx
    res = data.waveform.range_resolution
    for _ in range(passes):
        echo = _echoes(data, rps, refined)
        prof = {m: _profiles(data, y) for m, y in echo.items()}
        parts = []
        for m, c in enumerate(dec.clusters):
            old = rps.cluster == m
            others = [j for j in echo if j != m]
            best = None
            if others:
                y = data.spectrum.values - sum(echo[j] for j in others)
                s = data.signal - sum(prof[j] for j in others)
                dm = replace(data, signal=s, spectrum=Spectrum(y, data.spectrum.frequency))
                d2 = decompose(dm, ks, env)
                near = [
                    c2
                    for c2 in d2.clusters
                    if abs((c2.k[0] - c.k[0] + kp / 2) % kp - kp / 2) <= ks.window_x / 2
                    and abs(c2.r_centre - c.r_centre) <= res
                ]
                if near:
                    best = max(near, key=lambda c2: c2.peak)
            if best is None:
                parts.append(
                    (
                        rps.antenna[old],
                        rps.range[old],
                        rps.amp[old],
                        rps.sample[old],
                        refined[old],
                        m,
                    )
                )
                continue
            r1 = rps_from_decomposition(dm, replace(d2, clusters=(best,)), params.rp_threshold_db)
            r1, ref1 = phase_ranges(dm, r1, np.array([best.k]))
            parts.append((r1.antenna, r1.range, r1.amp, r1.sample, ref1, m))
        ant = np.concatenate([p[0] for p in parts]).astype(np.int64)
        rps = RangePoints(
            ant,
            data.array.x[ant],
            None,
            np.concatenate([p[1] for p in parts]),
            np.concatenate([p[2] for p in parts]),
            np.concatenate([np.full(len(p[1]), p[5]) for p in parts]).astype(np.int64),
            np.concatenate([p[3] for p in parts]),
        )
        refined = np.concatenate([p[4] for p in parts])
    return rps


def subtracted_rpm(data, params, engine, passes):
    """phase-rpm's steps (one segment: the scenes' lines are short) with the
    clusters refined on the data without the others' echoes; the points."""
    ks = replace(params.kspace, close_centres=True)
    env = engine.env
    dec = decompose(data, ks, env)
    rps = rps_from_decomposition(data, dec, params.rp_threshold_db)
    if not dec.near_field and dec.clusters:
        rps, refined = phase_ranges(data, rps, np.array([c.k for c in dec.clusters]))
        if len(dec.clusters) > 1:
            rps = _subtracted(data, ks, params, env, dec, rps, refined, passes)
    image = M._rpm(rps, params, engine)
    image = M.in_reach(data.array, rps, image, params.reach_deg)
    image = M.coherent(data, rps, image, params)
    return M._multipath(data, rps, image, params.multipath, params.medium).points


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=30, help="scenes drawn (default 30)")
    ap.add_argument("--first", type=int, default=1000, help="seed of the first scene")
    ap.add_argument("--snr", default="inf,30,20", help="in-band S/N list, dB (inf: noise-free)")
    ap.add_argument("--passes", type=int, default=2, help="subtraction passes (default 2)")
    args = ap.parse_args(argv)
    snrs = [None if s.strip() == "inf" else float(s) for s in args.snr.split(",")]
    engine = DeviceRPM(create_env())
    labels = ("phase-rpm", f"others subtracted, {args.passes} passes")
    tally = {}  # (snr, label) -> [within, points, hit, targets, scenes ok, seconds]
    for seed in range(args.first, args.first + args.scenes):
        g = rb.random_geometry(seed)
        boundary = rb.truth_boundary(g)
        for snr in snrs:
            spec, f, _ = rb.synthesize(g, snr, seed)
            raw = rb.loaded_data(g, spec, f)
            params = default_params(raw, max_range=rb.region(g))
            data, prepared = imaging.prepared(raw, params)  # as run_method prepares them
            for label in labels:
                t0 = time.perf_counter()
                if label == "phase-rpm":
                    pts = imaging.run_method("phase-rpm", raw, params, engine).image.points
                else:
                    pts = subtracted_rpm(data, prepared, engine, args.passes)
                sec = time.perf_counter() - t0
                frac, _, _, n = rb._score(pts, g, boundary)
                hit = rb.hits(pts, g)
                t = tally.setdefault((snr, label), [0.0, 0, 0, 0, 0, 0.0])
                t[0] += frac * n
                t[1] += n
                t[2] += int(hit.sum())
                t[3] += hit.size
                t[4] += bool(hit.all())
                t[5] += sec
        print(f"scene {seed} done", flush=True)
    print()
    print("| S/N dB | method | within 50 mm | targets hit | scenes all hit | seconds |")
    print("|---|---|---|---|---|---|")
    for snr in snrs:
        for label in labels:
            w, n, h, nt, ok, sec = tally[(snr, label)]
            print(
                f"| {'inf' if snr is None else f'{snr:g}'} | {label} | "
                f"{100 * w / max(n, 1):.1f} % | {h}/{nt} | {ok}/{args.scenes} | {sec:.1f} |"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
