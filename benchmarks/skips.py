"""What each skip saves, and what it costs in accuracy .

Usage::

    python benchmarks/skips.py [--repeats 5] [--device SPEC]

For each scene, the median time of the k-space RPM image with the skips on
(the defaults) and off, with the number of clusters, RPs and points and the
accuracy figures of the paper tables for both, all measured in one run:

- range gates that cannot hold a k-space centre (``KSpaceParams.skip_gates``)
  and the noise floor (``KSpaceParams.noise_pfa``), on the human body, one
  ellipsoid in front of the same array, noise only and an all-zero input;
- 2-D pairing within ``pair_cutoff_2d * sigma_x`` on a 1 m linear array;
- how much a sigma_r cutoff in the scoring could save: the fraction of the
  human body's candidate pairs (per main RP) within 3, 4 and 5 sigma_r.
"""

import argparse
import dataclasses
import time

import numpy as np

from rpm_cl.cl import create_env
from rpm_cl.imaging import run_method
from rpm_cl.io.data import Array, RadarData, Waveform
from rpm_cl.metrics import summary
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.neighbours import neighbour_lists
from rpm_cl.rpm.params import default_params
from rpm_cl.rpm.pipeline import _prepare, pair_windows, rpm_image
from rpm_cl.simulate import simulate, simulate_preset
from rpm_cl.simulate.scene import Ellipsoid, PointTarget, Scene, get_preset


def _median_time(fn, repeats, stage=None):
    """(last output, median seconds[, median of its timings[stage]])."""
    fn()  # warm-up
    times, stages = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
        if stage:
            stages.append(out.timings[stage])
    if stage:
        return out, float(np.median(times)), float(np.median(stages))
    return out, float(np.median(times))


def _figures(rps, image, truth):
    if truth is None:
        return "-"
    s = summary(rps, image, truth)
    return (
        f"RP<=10mm {s['rp_within_10mm']}/{s['rp_total']}, "
        f"RPM<=50mm {s['rpm_within_50mm']}/{s['rpm_total']}"
    )


def _scenes():
    preset = get_preset("human-body")
    body, _ = simulate_preset("human-body", 20.0, 0, noise="receiver")
    clean, _ = simulate_preset("human-body", None, 0)
    one = simulate(
        Scene((Ellipsoid((0.0, 1.1, 1.0), (0.08, 0.05, 0.1)),), "one"),
        preset.array,
        preset.waveform,
        preset.range_axis,
        20.0,
        0,
        boundary_spacing=3e-3,
        noise="receiver",
    )
    noise = dataclasses.replace(body, signal=body.signal - clean.signal, truth=None)
    zero = RadarData(np.zeros_like(body.signal), preset.array, preset.range_axis, preset.waveform)
    return preset, [
        ("human body, 20 dB", body),
        ("one ellipsoid, 20 dB", one),
        ("noise only (20 dB level)", noise),
        ("all zero", zero),
    ]


def gate_skips(engine, repeats):
    preset, scenes = _scenes()
    print("## Range-gate skip and noise floor (human-body array, 11 x 17)\n")
    print("| scene | skips | ms (median) | decomposition ms | clusters | RPs | points | accuracy |")
    print("|---|---|---:|---:|---:|---:|---:|---|")
    for label, data in scenes:
        params = default_params(data, **preset.defaults)
        off = dataclasses.replace(
            params, kspace=dataclasses.replace(params.kspace, skip_gates=False, noise_pfa=None)
        )
        for name, p in (("on (default)", params), ("off", off)):
            res, sec, dec = _median_time(
                lambda d=data, q=p: run_method("kspace-rpm", d, q, engine), repeats, "decompose"
            )
            print(
                f"| {label} | {name} | {1e3 * sec:.1f} | {1e3 * dec:.1f} | "
                f"{len(set(res.rps.cluster.tolist()))} | {len(res.rps)} | "
                f"{len(res.image.points)} | {_figures(res.rps, res.image, data.truth)} |"
            )
    print()


def pair_cutoff_2d(engine, repeats):
    arr = Array((np.arange(201) - 100) * 5e-3)
    scene = Scene((PointTarget((-0.1, 0.45)), PointTarget((0.15, 0.5))), "long")
    data = simulate(
        scene, arr, Waveform(20e9, 0.2e9), np.arange(0.0, 1.5, 2.5e-3), 30.0, 0, noise="receiver"
    )
    params = default_params(data, sigma_x=0.05, sigma_r=0.05)
    rps = run_method("kspace-rpm", data, params, engine).rps
    print("## 2-D pairing cutoff: 201 antennas at 5 mm, sigma_x = 50 mm, 2 points, 30 dB\n")
    print("| pair_cutoff_2d | largest window (RPs) | RPM ms (median) | accuracy |")
    print("|---:|---:|---:|---|")
    for cut in (2.0, 3.0, 4.0, np.inf):
        p = dataclasses.replace(params.rpm, pair_cutoff_2d=cut)
        idx, _, _, s, c = _prepare(rps, p)
        width = int(pair_windows(np.asarray(rps.x)[idx], s, c, cut * p.sigma_x)[1].max())
        img, sec = _median_time(lambda q=p: rpm_image(rps, q, engine), repeats)
        print(
            f"| {cut:g}{' (default)' if cut == 4.0 else ''} | {width} | {1e3 * sec:.1f} | "
            f"{_figures(rps, img, data.truth)} |"
        )
    print()


def score_cutoff(engine):
    data, preset = simulate_preset("human-body", 20.0, 0, noise="receiver")
    params = default_params(data, **preset.defaults)
    rps = run_method("kspace-rpm", data, params, engine).rps
    p = params.rpm
    idx, amp, _, start, count = _prepare(rps, p)
    x, z, r = (np.asarray(v, np.float64)[idx] for v in (rps.x, rps.z, rps.range))
    nbr, nnbr = neighbour_lists(
        x,
        z,
        np.asarray(rps.antenna)[idx],
        start,
        count,
        p.pair_cutoff * p.sigma_x,
        p.max_neighbours,
        p.near_neighbours,
    )
    cand, _, valid = engine.intersect_spheres(x, z, r, amp, nbr, nnbr, p.sigma_x)
    within = {3: 0, 4: 0, 5: 0}
    pairs = 0
    for i in range(x.size):
        v = valid[i].astype(bool)
        c = cand[:, i, v].T.astype(np.float64)
        d2 = np.sum((c[:, None, :] - c[None, :, :]) ** 2, axis=-1)
        pairs += d2.size
        for k in within:
            within[k] += int(np.sum(d2 <= (k * p.sigma_r) ** 2))
    print("## Scoring: candidate pairs within k sigma_r (human body, 20 dB)\n")
    print(
        f"{pairs} candidate pairs over {x.size} main RPs (sigma_r = {1e3 * p.sigma_r:g} mm); "
        "a cutoff at k sigma_r could skip at most the rest:\n"
    )
    print("| k | pairs within | could skip |")
    print("|---:|---:|---:|")
    for k, n in within.items():
        print(f"| {k} | {100 * n / pairs:.1f} % | {100 * (1 - n / pairs):.1f} % |")
    print()


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--device")
    args = ap.parse_args()
    env = create_env(args.device)
    engine = DeviceRPM(env, "float32")
    print(f"device: {env.name}, float32, median of {args.repeats}\n")
    gate_skips(engine, args.repeats)
    pair_cutoff_2d(engine, args.repeats)
    score_cutoff(engine)


if __name__ == "__main__":
    main()
