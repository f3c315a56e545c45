"""phase-rpm on sparse lines: near-field clusters' RPs on their fitted
spherical waves against their envelope ranges.

    python benchmarks/sparse_phase.py [--layouts 20] [--snr 30,20]

The scenes are ``benchmarks/sparse_layouts.py``'s random three-target layouts
on the paper's sparse array (21 antennas at 20 mm, 20 GHz, 0.2 GHz), each
with in-band noise (seed = layout).  Every layout is imaged twice by
phase-rpm: as it runs (``rpm_cl.extract.phase.spherical_ranges``: each
near-field cluster's RPs on ``|X - p|`` plus the envelope's weighted offset)
and with that step replaced by the identity (the envelope ranges the
near-field decomposition gives, as kspace-rpm uses them), and a third time
with the fitted wave but the search's direction kept where another alias's
range walk fits the envelope better (``_spherical_alias`` replaced by the
identity).  Printed per S/N:
the mean share of points within 50 mm of a target and the targets hit
(a point within 50 mm).  docs/decisions.md, "phase-rpm puts a near-field
cluster's RPs on its fitted spherical wave" and "The envelope's range walk
picks a near-field cluster's alias".
"""

import argparse

import numpy as np
from sparse_layouts import layout

from rpm_cl.cl import create_env
from rpm_cl.extract import phase
from rpm_cl.imaging import run_method
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import simulate
from rpm_cl.simulate.scene import PointTarget, Scene, get_preset


def envelope_ranges(data, rps, clusters, params=None):
    """The comparison: the near-field clusters' envelope ranges kept."""
    return rps, np.zeros(len(rps), bool)


def search_alias(xr, r_env, w, u, r, *rest):
    """The comparison: the near-field search's centre kept."""
    return u, r


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--layouts", type=int, default=20, help="random layouts (default 20)")
    ap.add_argument("--snr", default="30,20", help="in-band S/N list, dB (inf: noise-free)")
    args = ap.parse_args(argv)
    engine = DeviceRPM(create_env())
    pre = get_preset("paper-2d-sparse")
    snrs = [None if s.strip() == "inf" else float(s) for s in args.snr.split(",")]
    scenes = []
    for i in range(args.layouts):
        pts = layout(i)
        scene = Scene(tuple(PointTarget(tuple(p)) for p in pts), "layout")
        for snr in snrs:
            data = simulate(scene, pre.array, pre.waveform, pre.range_axis, snr, i, noise="in-band")
            scenes.append((snr, pts, data))
    fitted = phase.spherical_ranges
    print(f"{args.layouts} layouts of paper-2d-sparse, in-band noise, phase-rpm")
    print(f"{'S/N dB':>7} {'RPs':<28} {'mean <= 50 mm':>14} {'targets hit':>12}")
    alias = phase._spherical_alias
    for label, step, pick in (
        ("envelope ranges", envelope_ranges, alias),
        ("fitted wave, search's alias", fitted, search_alias),
        ("fitted wave", fitted, alias),
    ):
        phase.spherical_ranges, phase._spherical_alias = step, pick
        for snr in snrs:
            share, hit, total = [], 0, 0
            for s, pts, data in scenes:
                if s != snr:
                    continue
                res = run_method("phase-rpm", data, default_params(data, **pre.defaults), engine)
                p = res.image.points
                d = (
                    np.linalg.norm(p[:, None] - pts[None], axis=2)
                    if len(p)
                    else np.full((1, 3), 1.0)
                )
                share.append(np.mean(d.min(axis=1) <= 0.05))
                hit += int(np.sum(d.min(axis=0) <= 0.05))
                total += len(pts)
            print(
                f"{'inf' if snr is None else f'{snr:g}':>7} {label:<28} {np.mean(share):14.3f} {hit:>7d}/{total}"
            )
    phase.spherical_ranges, phase._spherical_alias = fitted, alias


if __name__ == "__main__":
    main()
