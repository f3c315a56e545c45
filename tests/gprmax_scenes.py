"""What the gprMax fixture tests share: a fixture converted to the engine's
input, and its cylinders in the engine's frame."""

import json
from pathlib import Path

import numpy as np

from rpm_cl.io import gprmax as G
from rpm_cl.io.formats import load_data

DATA = Path(__file__).parent / "data"


def scene(name: str) -> dict:
    """``tests/data/NAME/scene.json``."""
    return json.loads((DATA / name / "scene.json").read_text())


def converted(name: str, band, folder: Path, background: bool = True):
    """The fixture converted over ``band`` (Hz) with (or without) its
    background run, saved in ``folder`` and loaded."""
    d = DATA / name
    path = Path(folder) / f"{name}.npz"
    bg = d / "background_merged.h5" if background else None
    G.save_spectrum(path, G.convert(d / "targets_merged.h5", bg, band, sidecar=d / "scene.json"))
    return load_data(path)


def cylinders(doc: dict) -> np.ndarray:
    """(x, y, radius) of each cylinder in the engine's frame (y down from
    the antennas), m, shape (n, 3)."""
    ys = doc["scan"]["y"]
    return np.array([(c["centre"][0], ys - c["centre"][1], c["radius"]) for c in doc["cylinders"]])


def to_boundary(points, cyl: np.ndarray) -> np.ndarray:
    """Distance (points, cylinders) of each point to each cylinder's
    surface, m."""
    p = np.asarray(points, np.float64).reshape(-1, 2)
    return np.abs(
        np.hypot(p[:, None, 0] - cyl[None, :, 0], p[:, None, 1] - cyl[None, :, 1]) - cyl[None, :, 2]
    )
