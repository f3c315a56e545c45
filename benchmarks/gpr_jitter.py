"""Impulse GPR rebar lines with trigger jitter: bars found with and without
the per-trace alignment (``--align-traces``, ``rpm_cl/extract/alignment.py``).

Each line is written here as a GSSI ``.dzt`` file, sample by sample, from
Ricker pulses (not by the engine's simulator): a direct coupling six times
the strongest bar echo's amplitude over the bars and a late coupling
ring 0.4 of it 1.1 periods later, each bar an 8 mm cylinder whose echo
falls off with range, loss and a 40-degree beam, 16-bit quantisation and
white noise.  Every trace, coupling and echoes alike, arrives ``tau_i``
late, ``tau_i`` normal with the jitter as its rms (the sampler's trigger),
and its coupling's amplitude varies by 3 % rms.

- ``a``: 1.6 GHz, eps_r 7, twelve bars 0.2 m apart under 60 mm of cover,
  300 traces at 1 cm;
- ``b``: 2 GHz, eps_r 6, ten bars 0.25 m apart under a cover sloping from
  40 to 120 mm, 200 traces at 2 cm.

Each file is converted (``rpm_cl.io.dzt.convert``: time zero at the
window's start, the antenna's nominal band) and imaged in its medium with
time zero at the direct wave (``--time-zero``) and the default background
(the mean, as the coupling dominates): phase-rpm and the DAS peaks
(``das`` method), each without and with the alignment.  Columns: the bars
found (a point within 30 mm of a bar's top in x and in depth), the share
of points within 30 mm of a bar's boundary, the median distance, and the
rms of the offsets the alignment measured against the jitter's.

Usage::

    python benchmarks/gpr_jitter.py [--jitter-ps 0 20] [--lines a b] [--coupling-only]

``--coupling-only``: the direct coupling's pulse alone wanders (its ring
and the bars stay), as where the coupling, not the trigger, varies: there
the alignment moves the bars by the coupling's wander.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import warnings

import numpy as np

from rpm_cl.io.model import C0

LINES = {
    "a": {
        "fc": 1.6e9,
        "eps": 7.0,
        "nx": 300,
        "dx": 0.01,
        "window": 12e-9,
        "bars": [(0.40 + 0.2 * k, 0.060) for k in range(12)],
        "seed": 0,
        "noise": 0.01,
    },
    "b": {
        "fc": 2.0e9,
        "eps": 6.0,
        "nx": 200,
        "dx": 0.02,
        "window": 15e-9,
        "bars": [(0.70 + 0.25 * k, 0.040 + 0.080 * k / 9) for k in range(10)],
        "seed": 2,
        "noise": 0.02,
    },
}
SAMPLES = 512
N0 = 40.3  # the transmit instant, in samples
RADIUS = 0.008


def ricker(t, fc):
    a = (np.pi * fc * t) ** 2
    return (1 - 2 * a) * np.exp(-a)


def ringing(t, fc):
    """A ringing antenna's pulse: a cosine under an envelope that rises
    from a quarter period before the transmit instant and peaks 0.45
    periods after it."""
    ts = t + 0.25 / fc
    env = np.where(ts > 0, (ts * fc) ** 2 * np.exp(-ts * fc * 2.2), 0.0)
    return env * np.cos(2 * np.pi * fc * t) / 0.15


PULSES = {"ricker": ricker, "ringing": ringing}


def traces(line: dict, jitter: float, coupling_only: bool = False) -> tuple:
    """The line's traces (nx, SAMPLES), their delays (s) and x (m); with
    ``coupling_only`` the direct coupling's pulse alone is delayed."""
    rng = np.random.default_rng(line["seed"])
    fc, dt = line["fc"], line["window"] / SAMPLES
    t = (np.arange(SAMPLES) - N0) * dt
    x = np.arange(line["nx"]) * line["dx"]
    v = C0 / np.sqrt(line["eps"])
    pulse = PULSES[line.get("pulse", "ricker")]
    tau = jitter * rng.standard_normal(x.size)
    out = np.zeros((x.size, SAMPLES))
    for i, xi in enumerate(x):
        ti = t - (0.0 if coupling_only else tau[i])
        a = 6.0 * (1 + 0.03 * rng.standard_normal())
        out[i] = -a * pulse(t - tau[i], fc) + 0.4 * a * pulse(ti - 1.1 / fc, fc)
        for xb, cover in line["bars"]:
            r = np.hypot(xi - xb, cover + RADIUS) - RADIUS
            beam = np.exp(-((np.arctan2(abs(xi - xb), cover + RADIUS) / np.deg2rad(40)) ** 2))
            out[i] += 0.05 / r * beam * np.exp(-8 * r) * pulse(ti - 2 * r / v, fc)
    out += line["noise"] * rng.standard_normal(out.shape)
    gain = line.get("gain_db_per_ns", 0.0)  # a recorder's range gain, from time zero
    out *= 10 ** (gain * np.clip(t * 1e9, 0, None) / 20)
    return out, tau, x


def write_dzt(path, tr: np.ndarray, line: dict) -> None:
    """``tr`` as a 16-bit GSSI file (benchmarks/readers_fixture.py's header)."""
    from readers_fixture import dzt_header

    q = np.round(tr / np.abs(tr).max() * 28000) + 0x8000
    q[:, 0] = np.arange(len(q)) % 65536
    q[:, 1] = 0
    antenna = f"{line['fc'] / 1e9:g} GHz"
    head = dzt_header(SAMPLES, 16, line["window"], 1.0 / line["dx"], antenna)
    with open(path, "wb") as fh:
        fh.write(head + q.astype("<u2").tobytes())


def as_loaded(tr: np.ndarray, line: dict):
    """The traces ``tr`` written as a GSSI file, converted (time zero at
    the window's start, the antenna's nominal band) and loaded, as
    ``rpm-cl convert`` then ``rpm-cl image`` take them."""
    from rpm_cl.io import dzt
    from rpm_cl.io.formats import load_data

    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "line.dzt")
        write_dzt(path, tr, line)
        np.savez(os.path.join(tmp, "line.npz"), **dzt.convert(path))
        return load_data(os.path.join(tmp, "line.npz"))


def score(points: np.ndarray, line: dict) -> tuple:
    bars = np.array(line["bars"])
    if not len(points):
        return 0, float("nan"), float("nan")
    found = sum(
        bool(np.any((np.abs(points[:, 0] - xb) <= 0.03) & (np.abs(points[:, 1] - c) <= 0.03)))
        for xb, c in bars
    )
    d = np.abs(
        np.hypot(
            points[:, None, 0] - bars[None, :, 0],
            points[:, None, 1] - (bars[None, :, 1] + RADIUS),
        )
        - RADIUS
    ).min(axis=1)
    return found, float(np.mean(d <= 0.03)), float(np.median(d))


def image_points(method: str, data, engine, **settings) -> tuple:
    """``method``'s points of ``data`` with ``default_params(data,
    **settings)``, the data warnings the lines draw by design silenced;
    returns (points (K, 2) m, the parameters)."""
    from rpm_cl.imaging import run_method
    from rpm_cl.io.data import DataWarning
    from rpm_cl.rpm.params import default_params

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataWarning)
        params = default_params(data, **settings)
        return run_method(method, data, params, engine).image.points, params


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jitter-ps", type=float, nargs="+", default=[0.0, 20.0])
    ap.add_argument("--lines", nargs="+", choices=sorted(LINES), default=sorted(LINES))
    ap.add_argument("--coupling-only", action="store_true")
    args = ap.parse_args(argv)

    from rpm_cl.cl import create_env
    from rpm_cl.extract.alignment import trace_shifts
    from rpm_cl.rpm import DeviceRPM

    engine = DeviceRPM(create_env())
    print(
        f"{'line':4s} {'jitter':>7s} {'method':9s} {'align':5s} {'bars':>6s} "
        f"{'<=30 mm':>8s} {'median':>9s} {'offsets rms':>12s}"
    )
    for name in args.lines:
        line = LINES[name]
        zero = N0 * line["window"] / SAMPLES * C0 / 2  # the direct wave's range, m
        for ps in args.jitter_ps:
            tr, tau, _ = traces(line, ps * 1e-12, args.coupling_only)
            data = as_loaded(tr, line)
            est = trace_shifts(data)
            rms = f"{1e3 * est.std():.2f}/{1e3 * tau.std() * C0 / 2:.2f} mm"
            for method in ("phase-rpm", "das"):
                for align in (False, True):
                    pts, _ = image_points(
                        method, data, engine, eps_r=line["eps"], time_zero=zero, align_traces=align
                    )
                    found, near, med = score(pts, line)
                    print(
                        f"{name:4s} {ps:5.0f}ps {method:9s} {'yes' if align else 'no':5s} "
                        f"{found:3d}/{len(line['bars']):<2d} {100 * near:7.1f}% "
                        f"{1e3 * med:6.1f} mm {rms:>12s}"
                    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
