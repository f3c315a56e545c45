"""A GPR B-scan in a medium: the profiles, the DAS image and the RPM points side by side.

With no file, the scan is the full-wave gprMax fixture of five steel bars
0.15 m apart under 0.10-0.13 m of concrete (eps_r 6) and a deeper bar
(tests/data/gprmax_rebar, made by benchmarks/gprmax_rebar.py), converted
over 0.75-2.25 GHz *without* its target-free run, as a real B-scan comes:
the default background removal (``auto``) takes the antennas' coupling out.
A recorded scan is imaged the same way: convert it (``rpm-cl convert``, e.g.
a GSSI .dzt, with time zero at the window's start) and pass the .npz with
its permittivity (or ``--eps-r auto``: read from the bars' hyperbolas,
docs/model.md, "Media"), ``--time-zero auto`` (time zero at the direct wave's
envelope peak) and, where the traces' timing wanders (the engine warns),
``--align-traces``.

Three panels: |profile| per trace against depth (range / sqrt(eps_r)), the
DAS image in the medium (dB), and phase-rpm's points (over the bars' true
outlines where the scene is known).

Run: python examples/gpr_bscan.py [scan.npz --eps-r 6|auto [--time-zero auto|M] [--align-traces]]
[--png gpr.png]
"""

import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from rpm_cl import load_data
from rpm_cl.cl import create_env
from rpm_cl.imaging import run_method
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.params import default_params, is_auto

FIXTURE = Path(__file__).resolve().parent.parent / "tests" / "data" / "gprmax_rebar"


def fixture_scan(folder):
    """The rebar fixture as a scan file in ``folder`` (no background run);
    returns (path, bars (x, depth, radius) in m, eps_r)."""
    from rpm_cl.io import gprmax

    scene = json.loads((FIXTURE / "scene.json").read_text())
    path = Path(folder) / "rebar.npz"
    spec = gprmax.convert(
        FIXTURE / "targets_merged.h5", None, (0.75e9, 2.25e9), sidecar=FIXTURE / "scene.json"
    )
    gprmax.save_spectrum(path, spec)
    y = scene["scan"]["y"]
    bars = np.array([(c["centre"][0], y - c["centre"][1], c["radius"]) for c in scene["cylinders"]])
    return path, bars, scene["medium"]["eps_r"]


def main(path=None, eps_r=None, png=None, time_zero=0.0, align=False):
    """Image a B-scan; returns a dict with the result, the DAS image and,
    for the fixture, the bars and each point's distance to the nearest
    bar's outline (m).  ``eps_r``: a number, or "auto" (read from the data);
    ``time_zero``: m, or None for auto; ``align``: the traces aligned on
    the direct wave (docs/model.md, "Before imaging")."""
    with tempfile.TemporaryDirectory() as tmp:
        bars = None
        if path is None:
            path, bars, eps_r = fixture_scan(tmp)
        data = load_data(path)
    eps_r = eps_r if is_auto(eps_r) else float(eps_r or 1.0)
    engine = DeviceRPM(create_env())
    params = default_params(data, eps_r=eps_r, time_zero=time_zero, align_traces=align)
    eps_r = params.medium.eps_r
    rpm = run_method("phase-rpm", data, params, engine)
    das = run_method("das", data, params, engine)
    pts = rpm.image.points
    print(
        f"phase-rpm: {len(pts)} points in {rpm.timings['total'] * 1e3:.0f} ms; "
        f"DAS peaks: {len(das.image.points)}"
    )
    out = {"rpm": rpm, "das": das, "bars": bars}
    if bars is not None and len(pts):
        d = np.abs(
            np.hypot(pts[:, None, 0] - bars[None, :, 0], pts[:, None, 1] - bars[None, :, 1])
            - bars[None, :, 2]
        ).min(axis=1)
        out["distance"] = d
        print(f"{100 * np.mean(d <= 0.02):.0f} % of the points within 20 mm of a bar")
    if png:
        _picture(data, params, engine, rpm, bars, eps_r, png)
    return out


def _picture(data, params, engine, rpm, bars, eps_r, png):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from rpm_cl.baselines.das import DeviceDAS, Grid
    from rpm_cl.imaging import prepared

    seen, _ = prepared(data, params)
    x = seen.array.x
    p = rpm.image.points
    # the scan's width, down to half as deep again as the deepest point
    depth_max = max(0.3, 1.5 * float(p[:, 1].max())) if len(p) else 0.5
    grid = Grid(np.arange(x[0], x[-1], 0.004), np.arange(0.004, depth_max, 0.004))
    img = np.abs(DeviceDAS(engine.env).backproject(seen, grid, medium=params.medium))
    fig, ax = plt.subplots(1, 3, figsize=(14, 4.2), sharey=True)
    keep = seen.range / np.sqrt(eps_r) <= depth_max
    prof = np.abs(seen.signal[:, keep]).T
    ax[0].imshow(
        20 * np.log10(prof / prof.max() + 1e-6),
        extent=(x[0], x[-1], seen.range[keep][-1] / np.sqrt(eps_r), seen.range[0]),
        aspect="auto",
        vmin=-40,
        cmap="gray",
    )
    ax[0].set_title("|profile| (dB), background removed")
    ax[1].imshow(
        20 * np.log10(img.T / img.max() + 1e-6),
        extent=(grid.x[0], grid.x[-1], grid.y[-1], grid.y[0]),
        aspect="auto",
        vmin=-30,
        cmap="viridis",
    )
    ax[1].set_title(f"DAS in eps_r {eps_r:g} (dB)")
    ax[2].scatter(p[:, 0], p[:, 1], s=6, c="k", label=f"phase-rpm ({len(p)})")
    if bars is not None:
        t = np.linspace(0, 2 * np.pi, 60)
        for bx, by, r in bars:
            ax[2].plot(bx + r * np.cos(t), by + r * np.sin(t), "r-", lw=1)
    for a in ax:
        a.set_xlim(x[0], x[-1])
    ax[2].set_ylim(depth_max, 0)
    ax[2].set_title("RPM points (bars in red)")
    ax[2].legend(loc="lower right")
    for a in ax:
        a.set_xlabel("x (m)")
    ax[0].set_ylabel("depth (m)")
    fig.tight_layout()
    fig.savefig(png, dpi=90)
    print(f"wrote {png}")


if __name__ == "__main__":
    args = sys.argv[1:]
    png = args[args.index("--png") + 1] if "--png" in args else None
    eps = args[args.index("--eps-r") + 1] if "--eps-r" in args else None
    tz = args[args.index("--time-zero") + 1] if "--time-zero" in args else "0"
    files = [a for a in args if a.endswith((".npz", ".h5"))]
    main(
        files[0] if files else None,
        eps,
        png,
        None if tz == "auto" else float(tz),
        "--align-traces" in args,
    )
