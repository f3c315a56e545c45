"""Which decomposition images a sparse linear array: near-field or plane-wave.

Usage::

    python benchmarks/path_choice.py [--bandwidths 0.2,0.3,0.4,0.5,1,3] [--pitch-mm 20] [--antennas 21]
        [--method kspace-rpm|phase-rpm]

For one point target and one 50 mm circle at 0.8 m, 0 to 65 degrees off
broadside, S/N 20 dB (seed 0), images each scene through both decompositions
(``near_field=True`` and ``False``) and prints the RPs found, RP <= 10 mm and
RPM <= 50 mm, with the path the default (``near_field=None``,
:func:`rpm_cl.extract.nearfield.near_field_wanted`) takes and the aperture in range
resolutions.  The near-field model holds while the aperture is at most about
one range resolution; beyond, the plane-wave path's range-walk alignment
separates the aliases.
"""

import argparse
from dataclasses import replace

import numpy as np

from rpm_cl.cl import create_env
from rpm_cl.extract.nearfield import near_field_wanted
from rpm_cl.imaging import run_method
from rpm_cl.io.data import Array, Waveform
from rpm_cl.metrics import summary
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import simulate
from rpm_cl.simulate.scene import Ellipsoid, PointTarget, Scene


def figures(data, near_field, engine, method="kspace-rpm"):
    """(RPs, RP <= 10 mm share, RPM <= 50 mm share) with one decomposition."""
    p = default_params(data)
    p = replace(p, kspace=replace(p.kspace, near_field=near_field))
    res = run_method(method, data, p, engine)
    s = summary(res.rps, res.image, data.truth)
    return (
        s["rp_total"],
        s["rp_within_10mm"] / max(1, s["rp_total"]),
        s["rpm_within_50mm"] / max(1, s["rpm_total"]),
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bandwidths", default="0.2,0.3,0.4,0.5,1,3", help="GHz, comma-separated")
    ap.add_argument("--pitch-mm", type=float, default=20.0)
    ap.add_argument("--antennas", type=int, default=21)
    ap.add_argument("--fc-ghz", type=float, default=20.0)
    ap.add_argument(
        "--method",
        default="kspace-rpm",
        choices=("kspace-rpm", "phase-rpm"),
        help="the imaging method",
    )
    args = ap.parse_args()
    engine = DeviceRPM(create_env(), "float32")
    n, pitch = args.antennas, args.pitch_mm * 1e-3
    arr = Array((np.arange(n) - (n - 1) / 2) * pitch)
    print(
        f"{args.method}, {n} antennas at {args.pitch_mm:g} mm, {args.fc_ghz:g} GHz; "
        "columns: RPs found (true), RP<=10mm, RPM<=50mm"
    )
    print(
        f"{'GHz':>5} {'L/res':>5} {'default':>8} {'deg':>3} {'target':6}  {'near-field':>22}  {'plane-wave':>22}"
    )
    for b in (float(v) * 1e9 for v in args.bandwidths.split(",")):
        wf = Waveform(args.fc_ghz * 1e9, b)
        for deg in (0, 20, 35, 45, 55, 65):
            th = np.radians(deg)
            pos = (0.8 * np.sin(th), 0.8 * np.cos(th))
            for kind, tgt in (
                ("point", PointTarget(pos)),
                ("circle", Ellipsoid(pos, (0.05, 0.05))),
            ):
                data = simulate(
                    Scene((tgt,)), arr, wf, np.arange(0.3, 1.3, 2.5e-3), 20.0, 0, noise="receiver"
                )
                cols = []
                for nf in (True, False):
                    k, rp, rpm = figures(data, nf, engine, args.method)
                    cols.append(f"{k:3d} ({data.truth.rp_range.size}) {rp:4.0%} {rpm:4.0%}")
                path = "near" if near_field_wanted(data) else "plane"
                ratio = float(arr.x[-1] - arr.x[0]) / wf.range_resolution
                print(
                    f"{b / 1e9:5.2g} {ratio:5.2f} {path:>8} {deg:3d} {kind:6}  {cols[0]:>22}  {cols[1]:>22}",
                    flush=True,
                )


if __name__ == "__main__":
    main()
