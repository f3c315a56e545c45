"""Reproduce the paper's tables: ``rpm-cl reproduce paper-2d``.

Each row images one case with one method at one S/N.  Noisy rows are pooled
over ``trials`` noise realisations (seeds ``seed``, ``seed+1``, ...): counts are
summed, so ``rp_total`` is the number of RPs over all trials.  ``seconds`` is
the median imaging time per trial from s(X, R) to points; programs are built
and every kernel has run once before the clock starts (compile excluded).
The scenes are simulated with the ``"receiver"`` noise model
(:mod:`rpm_cl.simulate`), the one the tables' S/N figures are reproduced with.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from ..baselines.peaks import image_peaks
from ..imaging import RPM_METHODS, timed_run
from ..io.data import InputError
from ..metrics import pct, summary
from ..rpm.params import default_params
from ..simulate.synth import simulate_preset

__all__ = [
    "CASES",
    "PAPER",
    "ReproRow",
    "format_markdown",
    "format_table",
    "pct",
    "reproduce",
    "update_markdown",
    "write_json",
]

#: The paper's figures (Tables I, II, IV, V and Section V-A4), as fractions;
#: ``*_n`` are the paper's counts of accurate RPs / points where it gives them.
PAPER = {
    ("points-5mm", "kspace-rpm", None): {"rp10": 0.94, "rpm50": 0.67, "rpm100": 1.00},
    ("points-5mm", "kspace-rpm", 20.0): {"rp10": 0.95, "rpm50": 0.71, "rpm100": 0.97},
    ("points-5mm", "kspace-rpm", 10.0): {"rp10": 0.95, "rpm50": 0.50, "rpm100": 0.94},
    ("points-5mm", "kspace-rpm", 0.0): {"rp10": 0.90, "rpm50": 0.35, "rpm100": 0.61},
    ("sparse-20mm", "kspace-rpm", None): {"rp10": 0.87, "rpm50": 0.94},
    ("points-5mm", "capon-rpm", None): {"rp10": 0.98, "rpm50": 0.61, "rpm100": 0.96},
    ("points-5mm", "capon-rpm", 20.0): {"rp10": 0.0, "rpm50": 0.0, "rpm100": 0.0},
    ("points-5mm", "capon-rpm", 10.0): {"rp10": 0.0, "rpm50": 0.0, "rpm100": 0.0},
    ("points-5mm", "capon-rpm", 0.0): {"rp10": 0.0, "rpm50": 0.0, "rpm100": 0.0},
    ("human-body", "capon-rpm", None): {"rp10": 1.00, "rpm50": 0.99, "rp10_n": 678, "rpm50_n": 341},
    ("human-body", "capon-rpm", 20.0): {"rp10": 0.026, "rpm50": 0.0, "rp10_n": 16, "rpm50_n": 0},
    ("human-body", "kspace-rpm", None): {
        "rp10": 0.98,
        "rpm50": 0.95,
        "rp10_n": 2248,
        "rpm50_n": 1155,
    },
    ("human-body", "kspace-rpm", 20.0): {
        "rp10": 0.98,
        "rpm50": 0.95,
        "rp10_n": 2253,
        "rpm50_n": 1170,
    },
}

#: Cases of each reproduction: name -> (preset, S/N list).
CASES = {
    "paper-2d": {
        "points-5mm": ("paper-2d", [None, 20.0, 10.0, 0.0]),
        "sparse-20mm": ("paper-2d-sparse", [None]),
    },
    "paper-3d": {
        "human-body": ("human-body", [None, 20.0]),
    },
}


@dataclass(frozen=True)
class ReproRow:
    """One row of the reproduction (the JSON schema of ``--json``)."""

    case: str
    method: str
    snr_db: float | None
    trials: int
    rp_total: int
    rp_within_10mm: int
    rpm_total: int
    rpm_within_50mm: int
    rpm_within_100mm: int
    seconds: float
    grid: str = ""

    def as_dict(self) -> dict:
        return dict(self.__dict__)


#: Coherent (DAS) rows per preset: (label, grid "x0:x1:dx,y0:y1:dy[,z0:z1:dz]", kind).
#: kind "image": 2-D image, a point at every local maximum of |I| (over 5 x 5
#: pixels) above -10 dB of the image maximum, i.e. the targets the image shows;
#: "section": a 3-D slice at one y, every pixel above -6 dB is a
#: point; "volume": a point per (x, z) column at the y of its maximum (above
#: -10 dB), the volume reduced chunk by chunk, never held.
DAS_GRIDS = {
    "paper-2d": [("image 1 mm", "-0.3:0.3:0.001,0.2:0.7:0.001", "image")],
    "paper-2d-sparse": [("image 1 mm", "-0.3:0.3:0.001,0.2:0.7:0.001", "image")],
    "human-body": [
        ("section y=1 m, 3 mm", "-1:1:0.003,1.0:1.0:0.003,0:2:0.003", "section"),
        ("volume 2x2x2 m, 3 mm", "-1:1:0.003,0:2:0.003,0:2:0.003", "volume"),
    ],
}


def das_points(das, data, grid, kind: str, progress=False):
    """Run the DAS kernel on ``grid`` and turn the image into points (m);
    ``progress`` (the volume's bar) as in :func:`rpm_cl.progress.callback`.

    Returns
    -------
    points : ndarray, shape (M, dim)
    seconds : float
        Wall time of the back-projection (the kernel warm).
    """
    import time

    if kind == "volume":
        nx, ny, nz = grid.shape
        best = np.zeros((nx, nz), np.float32)
        best_y = np.zeros((nx, nz), np.int64)

        def reduce(row0, chunk):  # rows are (x, y) pairs in C order
            rows = row0 + np.arange(chunk.shape[0])
            ix, iy = rows // ny, rows % ny
            mag = np.abs(chunk)
            for x in np.unique(ix):
                sel = ix == x
                m = mag[sel]
                k = np.argmax(m, axis=0)
                v = m[k, np.arange(nz)]
                better = v > best[x]
                best[x] = np.where(better, v, best[x])
                best_y[x] = np.where(better, iy[sel][k], best_y[x])

        from ..progress import callback

        with callback(progress, desc="das volume", unit="voxel") as cb:
            t0 = time.perf_counter()
            das.backproject(data, grid, reduce=reduce, progress=cb)
            sec = time.perf_counter() - t0
        keep = np.nonzero(best >= best.max() * 10 ** (-10 / 20)) if best.max() > 0 else ([], [])
        pts = np.stack([grid.x[keep[0]], grid.y[best_y[keep]], grid.z[keep[1]]], axis=1)
        return pts, sec
    # warm-up (the kernel's first call builds its invoker) on one row of the
    # grid: the same kernel, none of the image's cost
    from ..baselines.das import Grid

    das.backproject(data, Grid(grid.x[:1], grid.y[:1], None if grid.z is None else grid.z))
    t0 = time.perf_counter()
    img = das.backproject(data, grid)
    sec = time.perf_counter() - t0
    if kind == "image":
        return image_peaks(img, grid.axes, threshold_db=-10.0, size=5)[0], sec
    mag = np.abs(img)
    idx = np.nonzero(mag >= mag.max() * 10 ** (-6 / 20))
    return np.stack([grid.axes[a][idx[a]] for a in range(grid.dim)], axis=1), sec


#: RMA rows (linear arrays): preset -> (label, y_min, y_max) of the image.
RMA_IMAGES = {
    "paper-2d": ("image y 0.2-0.7 m", 0.2, 0.7),
    "paper-2d-sparse": ("image y 0.2-0.7 m", 0.2, 0.7),
}


def rma_points(data, y_min: float, y_max: float):
    """RMA image (:func:`rpm_cl.baselines.rma.rma_image`, x pixel 1/4 of the pitch) and
    its peak points; returns (points (M, 2), seconds, image shape)."""
    import time

    from ..baselines.rma import rma_image

    rma_image(data, upsample_x=4, y_min=y_min, y_max=y_max)  # warm-up
    t0 = time.perf_counter()
    img, x, y = rma_image(data, upsample_x=4, y_min=y_min, y_max=y_max)
    sec = time.perf_counter() - t0
    return image_peaks(img, (x, y), threshold_db=-10.0, size=5)[0], sec, img.shape


def _image_row(case, method, snr, datasets, label, image) -> ReproRow:
    """One coherent imager's row: ``image(data)`` -> (points, seconds) on
    every dataset, the points scored against the truth and pooled, the
    median time."""
    from ..metrics import cumulative, err_rpm

    tot = dict.fromkeys(("rpm_total", "rpm_within_50mm", "rpm_within_100mm"), 0)
    times = []
    for data, _ in datasets:
        pts, sec = image(data)
        times.append(sec)
        e = err_rpm(pts, data.truth)
        tot["rpm_total"] += len(e)
        tot["rpm_within_50mm"] += cumulative(e, 0.05)[0]
        tot["rpm_within_100mm"] += cumulative(e, 0.10)[0]
    return ReproRow(
        case, method, snr, len(datasets), 0, 0, seconds=float(np.median(times)), grid=label, **tot
    )


def _rma_rows(case, preset_name, snr, datasets, progress):
    if preset_name not in RMA_IMAGES:
        return []
    label, y0, y1 = RMA_IMAGES[preset_name]
    if progress:
        progress(f"{case} rma S/N={'inf' if snr is None else snr}")
    return [_image_row(case, "rma", snr, datasets, label, lambda d: rma_points(d, y0, y1)[:2])]


def _coherent_rows(case, preset_name, snr, datasets, das, skip_volume, progress, bar=False):
    from ..baselines.das import parse_grid

    rows = []
    for label, text, kind in DAS_GRIDS.get(preset_name, []):
        if kind == "volume" and (skip_volume or snr is not None):
            continue  # the volume once, noise-free (minutes on a CPU)
        if progress:
            progress(f"{case} das ({label}) S/N={'inf' if snr is None else snr}")
        grid = parse_grid(text)
        rows.append(
            _image_row(
                case,
                "das",
                snr,
                datasets,
                label,
                lambda d, g=grid, k=kind: das_points(das, d, g, k, bar),
            )
        )
    return rows


def reproduce(
    name: str,
    engine,
    methods=None,
    trials: int = 10,
    seed: int = 0,
    progress=None,
    das=None,
    skip_volume: bool = False,
    rma: bool = True,
    bar: bool | None = False,
) -> list[ReproRow]:
    """Run every case of reproduction ``name`` with every method.

    Parameters
    ----------
    name : str
        A key of :data:`CASES`.
    engine : object
        RPM engine (:class:`rpm_cl.rpm.DeviceRPM` or the reference module).
    methods : list of str, optional
        Default: the RPM family, :data:`rpm_cl.imaging.RPM_METHODS`.
    trials : int
        Noise realisations per noisy row (noise-free rows use 1).
    seed : int
        First noise seed.
    progress : callable, optional
        Called with a short text before each row.
    das : rpm_cl.baselines.das.DeviceDAS, optional
        Adds the coherent rows of :data:`DAS_GRIDS` (``"method": "das"``).
    skip_volume : bool
        Leave out the full-volume DAS row (minutes on a CPU).
    rma : bool
        Add the RMA rows of :data:`RMA_IMAGES` (linear arrays).
    bar : bool or None
        Progress bars on stderr (rows x trials; the DAS volume):
        False none (default), None on a terminal, True always
        (:func:`rpm_cl.progress.progress`).
    """
    if name not in CASES:
        raise InputError(f"unknown reproduction {name!r}; choose from {', '.join(CASES)}")
    if trials < 1:
        raise InputError(f"trials must be >= 1, got {trials}")
    from ..progress import progress as progress_bar

    methods = list(methods or RPM_METHODS)
    rows = []
    # one step per (scene, S/N, trial): simulation and every method on it
    steps = sum(1 if snr is None else trials for _, snrs in CASES[name].values() for snr in snrs)
    pbar = progress_bar(total=steps * (len(methods) + 1), desc=name, enabled=bar, unit="run")
    for case, (preset_name, snrs) in CASES[name].items():
        for snr in snrs:
            n_trials = 1 if snr is None else trials
            datasets = []
            for t in range(n_trials):
                datasets.append(simulate_preset(preset_name, snr, seed + t, noise="receiver"))
                pbar.update()
            for method in methods:
                if progress:
                    progress(f"{case} {method} S/N={'inf' if snr is None else snr}")
                pbar.set_postfix_str(f"{case} {method} S/N={'inf' if snr is None else snr}")
                tot = {
                    "rp_total": 0,
                    "rp_within_10mm": 0,
                    "rpm_total": 0,
                    "rpm_within_50mm": 0,
                    "rpm_within_100mm": 0,
                }
                times = []
                for data, preset in datasets:
                    pbar.update()
                    params = default_params(data, **preset.defaults)
                    res, seconds, _ = timed_run(method, data, params, engine)
                    times.append(seconds)
                    s = summary(res.rps, res.image, data.truth)
                    for k in tot:
                        tot[k] += s[k]
                rows.append(
                    ReproRow(case, method, snr, n_trials, seconds=float(np.median(times)), **tot)
                )
            if das is not None:
                rows += _coherent_rows(
                    case, preset_name, snr, datasets, das, skip_volume, progress, bar
                )
            if rma:
                rows += _rma_rows(case, preset_name, snr, datasets, progress)
    pbar.close()
    return rows


def format_table(rows: list[ReproRow]) -> str:
    """The rows as a text table with the paper's figures beside ours."""
    head = (
        f"{'case':12s} {'method':11s} {'S/N':>5s} {'RP<=10mm':>20s} {'RPM<=50mm':>20s} "
        f"{'RPM<=100mm':>20s} {'ms':>9s}   paper (RP10/RPM50/RPM100) | grid"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        snr = "inf" if r.snr_db is None else f"{r.snr_db:g}"
        ref_s = _paper_cell(r)
        lines.append(
            f"{r.case:12s} {r.method:11s} {snr:>5s} {pct(r.rp_within_10mm, r.rp_total):>20s} "
            f"{pct(r.rpm_within_50mm, r.rpm_total):>20s} "
            f"{pct(r.rpm_within_100mm, r.rpm_total):>20s} {1e3 * r.seconds:9.2f}   {ref_s}"
            + (f" | {r.grid}" if r.grid else "")
        )
    return "\n".join(lines)


def _paper_cell(r: ReproRow) -> str:
    ref = PAPER.get((r.case, r.method, r.snr_db))
    if ref is None:
        return ""
    return " / ".join(
        (f"{100 * ref[k]:.0f}%" + (f" ({ref[k + '_n']})" if k + "_n" in ref else ""))
        if k in ref
        else "-"
        for k in ("rp10", "rpm50", "rpm100")
    )


#: The columns of :func:`format_markdown`'s table.
MARKDOWN_COLUMNS = (
    "case",
    "method",
    "S/N (dB)",
    "RP <= 10 mm",
    "RPM <= 50 mm",
    "RPM <= 100 mm",
    "ms",
    "paper (RP / RPM 50 / RPM 100)",
    "grid",
)


def format_markdown(name: str, rows: list[ReproRow], meta: dict) -> str:
    """The rows as a Markdown section ``## name``: how they were made (the
    command, device, precision, trials), then one table row per
    :class:`ReproRow` with the paper's figures beside ours."""
    cmd = meta.get("command") or f"rpm-cl reproduce {name} --markdown docs/results.md"
    lines = [
        f"## {name}",
        "",
        (
            f"`{cmd}` on {meta['device']} ({meta['precision']}), rpm-cl {meta['version']}; "
            f"noisy rows pooled over {meta['trials']} noise realisations (seeds from "
            f"{meta['seed']}). Each cell: the fraction of RPs within 10 mm of a true RP "
            "(Err_range) or of image points within 50 / 100 mm of the boundary (Err_RPM), "
            "with the counts; `ms`: median imaging time per trial, compile excluded."
        ),
        "",
        "| " + " | ".join(MARKDOWN_COLUMNS) + " |",
        "|" + "|".join("---" for _ in MARKDOWN_COLUMNS) + "|",
    ]
    for r in rows:
        cells = [
            r.case,
            r.method,
            "inf" if r.snr_db is None else f"{r.snr_db:g}",
            pct(r.rp_within_10mm, r.rp_total),
            pct(r.rpm_within_50mm, r.rpm_total),
            pct(r.rpm_within_100mm, r.rpm_total),
            f"{1e3 * r.seconds:.2f}",
            _paper_cell(r),
            r.grid,
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


#: The head of a results file that :func:`update_markdown` creates.
MARKDOWN_HEAD = (
    "# Results\n\n"
    "The paper's tables reproduced on the engine's own simulator, one section per "
    "`rpm-cl reproduce` case, each written by the command it names (`--markdown`); "
    "regenerate a section by running that command again.\n"
)


def update_markdown(path, name: str, section: str) -> None:
    """Write ``section`` (:func:`format_markdown`) into the Markdown file
    ``path``, replacing that case's section if there is one, else appending
    it (a new file starts with :data:`MARKDOWN_HEAD`); atomically."""
    import os

    from ..io.data import atomic_write_text

    text = MARKDOWN_HEAD
    if os.path.exists(path):
        with open(path, encoding="utf-8") as f:
            text = f.read()
    parts = text.split("\n## ")
    head, sections = parts[0], parts[1:]
    title = section.split("\n", 1)[0][3:]
    body = section[3:].rstrip("\n") + "\n"
    kept = [s if s.split("\n", 1)[0] != title else body for s in sections]
    if body not in kept:
        kept.append(body)
    out = head.rstrip("\n") + "\n" + "".join("\n## " + s.rstrip("\n") + "\n" for s in kept)
    atomic_write_text(path, out)


def write_json(path, rows: list[ReproRow], meta: dict) -> None:
    """Write ``{"rows": [...], "meta": {...}}`` atomically."""
    from ..io.data import atomic_write_text

    atomic_write_text(
        path, json.dumps({"rows": [r.as_dict() for r in rows], "meta": meta}, indent=2)
    )
