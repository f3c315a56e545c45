"""The paper's 3-D scene: a human body of 11 ellipsoids about 1 m in front of an
11 x 17 planar array (7.5 mm, 20 GHz / 3 GHz).  Simulate, image with k-space
RPM, score each body part, optionally draw it.

Run: python examples/human_body_3d.py [--quick] [--png body.png]
(--quick keeps the head and the torso: 3 of the 11 parts.)
"""

import sys

import numpy as np
from scipy.spatial import cKDTree

from rpm_cl.cl import create_env
from rpm_cl.imaging import run_method
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import simulate
from rpm_cl.simulate.scene import HUMAN_BODY_PARTS, Scene, boundary_samples, get_preset


def main(quick=False, snr_db=20.0, seed=0, png=None):
    preset = get_preset("human-body")
    names = [name for name, _, _ in HUMAN_BODY_PARTS]
    parts = [0, 1, 2] if quick else list(range(len(names)))  # head, upper and lower torso
    scene = Scene(tuple(preset.scene.targets[i] for i in parts), "human-body")
    data = simulate(
        scene,
        preset.array,
        preset.waveform,
        preset.range_axis,
        snr_db,
        seed,
        boundary_spacing=preset.boundary_spacing,
        noise="receiver",
    )  # the paper's S/N
    result = run_method(
        "kspace-rpm",
        data,
        default_params(data, **preset.defaults),
        DeviceRPM(create_env(), "float32"),
    )
    points = result.image.points
    print(
        f"{len(result.rps)} RPs -> {len(points)} points in {1e3 * result.timings['total']:.0f} ms"
    )

    # per part: the points nearest that part, their median distance to its surface
    trees = [cKDTree(boundary_samples(t, 3e-3)) for t in scene.targets]
    dist = np.stack([tree.query(points)[0] for tree in trees], axis=1)
    nearest = np.argmin(dist, axis=1)
    per_part = {}
    for k, i in enumerate(parts):
        d = dist[nearest == k, k]
        per_part[names[i]] = (
            d.size,
            float(np.median(d)) if d.size else np.nan,
            float(np.mean(d <= 0.05)) if d.size else np.nan,
        )
        print(
            f"  {names[i]:16s} {d.size:5d} points, median {1e3 * per_part[names[i]][1]:5.1f} mm,"
            f" {100 * per_part[names[i]][2]:5.1f} % within 50 mm"
        )

    if png:
        import json
        import os
        import tempfile

        from rpm_cl.io.formats import save_result
        from rpm_cl.viz.view import view

        with tempfile.TemporaryDirectory() as tmp:
            out = os.path.join(tmp, "body.npz")
            save_result(out, result, {"scene": json.loads(data.truth.scene)})
            view(out, png)
        print(f"wrote {png}")
    return result, per_part


if __name__ == "__main__":
    png = sys.argv[sys.argv.index("--png") + 1] if "--png" in sys.argv else None
    main(quick="--quick" in sys.argv, png=png)
