"""Image the gprMax rebar fixture in its medium: points on the bars, bars found.

The fixture (``tests/data/gprmax_rebar``, made by
``benchmarks/gprmax_rebar.py``) is a 2-D TM FDTD B-scan inside a dielectric
of relative permittivity 6: five PEC bars 0.15 m apart under 0.10-0.13 m
and a deeper one, 61 antennas at 12 mm.  Converted over 0.75-2.25 GHz
(``rpm_cl.io.gprmax.convert``) and imaged with ``eps_r = 6``: phase-rpm
with its defaults, without the coherence test (``coherence=False``) and
without the double-bounce filter (``multipath="flag"``, flagged points
kept), kspace-rpm, and the ``das`` method (peaks of the DAS image in the
medium on its default grid, ``rpm_cl.baselines.imagers``).

Columns: image points; the share within 20 mm and 30 mm of a bar's
boundary; the median distance; the bars found (a point within 30 mm of the
bar's boundary), of 6, by number (1-5 the shallow bars left to right, 6
the deep one).

Usage::

    python benchmarks/gprmax_rebar_image.py
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import numpy as np

from rpm_cl.io import gprmax as G
from rpm_cl.io.formats import load_data

DATA = Path(__file__).resolve().parent.parent / "tests" / "data" / "gprmax_rebar"
BAND = (0.75e9, 2.25e9)


def main():
    from rpm_cl.cl import create_env
    from rpm_cl.imaging import run_method
    from rpm_cl.rpm import DeviceRPM
    from rpm_cl.rpm.params import default_params

    scene = json.loads((DATA / "scene.json").read_text())
    ys = scene["scan"]["y"]
    bars = np.array(
        [(c["centre"][0], ys - c["centre"][1], c["radius"]) for c in scene["cylinders"]]
    )
    eps_r = scene["medium"]["eps_r"]
    env = create_env()
    engine = DeviceRPM(env)
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "scan.npz")
        G.save_spectrum(
            path,
            G.convert(
                DATA / "targets_merged.h5",
                DATA / "background_merged.h5",
                BAND,
                sidecar=DATA / "scene.json",
            ),
        )
        data = load_data(path)
    runs = [
        ("phase-rpm", {}),
        ("phase-rpm", {"coherence": False}),
        ("phase-rpm", {"multipath": "flag"}),
        ("kspace-rpm", {}),
    ]
    print(
        f"gprMax rebar fixture: {data.array.x.size} antennas, eps_r {eps_r:g}, "
        f"{BAND[0] / 1e9:g}-{BAND[1] / 1e9:g} GHz; device {env.name}"
    )
    print(
        f"{'method':11s} {'setting':20s} {'points':>6s} {'<=20 mm':>8s} {'<=30 mm':>8s} "
        f"{'median':>9s}  bars found"
    )
    rows = []
    for name, over in runs:
        pts = run_method(name, data, default_params(data, eps_r=eps_r, **over), engine)
        rows.append((name, ", ".join(f"{k}={v}" for k, v in over.items()) or "-", pts.image.points))
    pts = run_method("das", data, default_params(data, eps_r=eps_r), engine).image.points
    rows.append(("das", "-", pts))
    for name, setting, p in rows:
        d = np.abs(
            np.hypot(p[:, None, 0] - bars[None, :, 0], p[:, None, 1] - bars[None, :, 1])
            - bars[None, :, 2]
        )
        best = d.min(axis=1) if len(p) else np.zeros(0)
        found = [str(i + 1) for i in range(len(bars)) if len(p) and d[:, i].min() <= 0.03]
        med = f"{1e3 * np.median(best):.1f} mm" if len(p) else "-"
        print(
            f"{name:11s} {setting:20s} {len(p):6d} {100 * np.mean(best <= 0.02):7.1f}% "
            f"{100 * np.mean(best <= 0.03):7.1f}% {med:>9s}  {len(found)}/{len(bars)} "
            f"{' '.join(found)}"
        )


if __name__ == "__main__":
    main()
