"""The sidecar JSON of a gprMax scan (:func:`read_sidecar`, :class:`Sidecar`):
the source waveform, the antenna positions, the objects' geometry and the
material they lie in."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass

import numpy as np

from .checks import InputError
from .gprmax_waveform import SourceWaveform

#: Largest sidecar JSON read, bytes.
MAX_SIDECAR = 16 << 20


@dataclass(frozen=True)
class Sidecar:
    """What a sidecar JSON tells about a scan (all optional).

    Attributes
    ----------
    waveform : SourceWaveform or None
        ``{"waveform": {"type": "ricker", "frequency": 3e9, "amplitude": 1}}``.
    scan_x : ndarray, shape (nx,) or None
        ``{"scan": {"x": [...]}}``: antenna x per trace, m, in trace order.
    scan_y : float or None
        ``{"scan": {"y": ...}}``: the scan line, m.
    cylinders : tuple of (cx, cy, r)
        ``{"cylinders": [{"centre": [cx, cy], "radius": r}, ...]}``, m.
    polygons : tuple of ndarray (k, 2)
        ``{"plates": [{"corners": [[x, y], ...]}, ...]}``: convex outlines, m.
    eps_r : float or None
        ``{"medium": {"eps_r": 6.0, ...}}``: the relative permittivity of
        the material the objects lie in; None: free space.
    surface_y : float or None
        ``{"medium": {"surface_y": y}}``: gprMax's y of the flat surface of
        a half-space of that material (the antennas on the other side of it,
        in air), m; None with ``eps_r``: a homogeneous medium.
    """

    waveform: SourceWaveform | None = None
    scan_x: np.ndarray | None = None
    scan_y: float | None = None
    cylinders: tuple = ()
    polygons: tuple = ()
    eps_r: float | None = None
    surface_y: float | None = None

    def medium(self, y_scan: float | None = None):
        """The :class:`rpm_cl.io.medium.Medium` of the sidecar in the engine's
        frame (the antenna height ``|surface_y - y_scan|``), None in free
        space."""
        from .medium import Medium

        if self.eps_r is None:
            return None
        y = self.scan_y if y_scan is None else y_scan
        if self.surface_y is None or y is None:
            return Medium(self.eps_r)
        return Medium(self.eps_r, abs(self.surface_y - y))


def _numbers(value, shape_ok, what: str, path: str) -> np.ndarray:
    try:
        a = np.asarray(value, np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{path}: {what} must be numbers") from None
    if not shape_ok(a.shape) or not np.all(np.isfinite(a)):
        raise InputError(
            f"{path}: {what} must be finite numbers of the right shape, got shape {a.shape}"
        )
    return a


def read_sidecar(path) -> Sidecar:
    """Read a sidecar JSON (the fixture's ``scene.json`` is one).

    Raises
    ------
    InputError
        Unreadable, larger than :data:`MAX_SIDECAR`, not a JSON object, or a
        known key of the wrong form (unknown keys are ignored).
    """
    path = os.fspath(path)
    doc = _read_json(path)
    wave = _sidecar_waveform(doc, path)
    sx, sy = _scan_line(doc, path)
    cyl = _cylinders(doc, path)
    polys = _plates(doc, path)
    eps_r, surface = _sidecar_medium(doc, path)
    return Sidecar(wave, sx, sy, tuple(cyl), tuple(polys), eps_r, surface)


def _read_json(path: str) -> dict:
    """The JSON object of the sidecar at ``path``."""
    try:
        size = os.path.getsize(path)
        if size > MAX_SIDECAR:
            raise InputError(f"{path}: {size} bytes; a sidecar is at most {MAX_SIDECAR}")
        with open(path, encoding="utf-8") as fh:
            doc = json.load(fh)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        text = " ".join(str(exc).split())
        raise InputError(f"{path}: not a readable JSON file ({text})") from None
    if not isinstance(doc, dict):
        raise InputError(f"{path}: must be a JSON object")
    return doc


def _sidecar_waveform(doc: dict, path: str) -> SourceWaveform | None:
    """``"waveform"``, where given."""
    wave = None
    if "waveform" in doc:
        w = doc["waveform"]
        if not isinstance(w, dict) or "type" not in w or "frequency" not in w:
            raise InputError(f'{path}: waveform must be {{"type": ..., "frequency": Hz}}')
        try:
            wave = SourceWaveform(str(w["type"]), w["frequency"], w.get("amplitude", 1.0))
        except InputError as exc:
            raise InputError(f"{path}: {exc}") from None
    return wave


def _scan_line(doc: dict, path: str) -> tuple:
    """``"scan"``: antenna x per trace and the line's y, m (None where not given)."""
    scan = doc.get("scan", {})
    if not isinstance(scan, dict):
        raise InputError(f"{path}: scan must be an object")
    sx = (
        _numbers(scan["x"], lambda s: len(s) == 1 and s[0] >= 2, "scan.x", path)
        if "x" in scan
        else None
    )
    sy = float(_numbers(scan["y"], lambda s: s == (), "scan.y", path)) if "y" in scan else None
    return sx, sy


def _cylinders(doc: dict, path: str) -> list:
    """``"cylinders"``: (cx, cy, r), m."""
    cyl = []
    for c in _list(doc, "cylinders", path):
        if not isinstance(c, dict) or "centre" not in c or "radius" not in c:
            raise InputError(f'{path}: a cylinder must be {{"centre": [x, y], "radius": r}}')
        cx, cy = _numbers(c["centre"], lambda s: s == (2,), "a cylinder centre", path)
        r = float(_numbers(c["radius"], lambda s: s == (), "a cylinder radius", path))
        if r <= 0:
            raise InputError(f"{path}: a cylinder radius must be > 0, got {r:g}")
        cyl.append((float(cx), float(cy), r))
    return cyl


def _plates(doc: dict, path: str) -> list:
    """``"plates"``: corners (k, 2), m."""
    polys = []
    for p in _list(doc, "plates", path):
        if not isinstance(p, dict) or "corners" not in p:
            raise InputError(f'{path}: a plate must be {{"corners": [[x, y], ...]}}')
        polys.append(
            _numbers(
                p["corners"],
                lambda s: len(s) == 2 and 3 <= s[0] <= 1000 and s[1] == 2,
                "plate corners",
                path,
            )
        )
    return polys


def _sidecar_medium(doc: dict, path: str) -> tuple:
    """``"medium"``: (eps_r, surface_y), None where not given."""
    eps_r = surface = None
    if "medium" in doc:
        med = doc["medium"]
        if not isinstance(med, dict) or "eps_r" not in med:
            raise InputError(f'{path}: medium must be {{"eps_r": ..., "surface_y": m}}')
        eps_r = float(_numbers(med["eps_r"], lambda s: s == (), "medium.eps_r", path))
        if "surface_y" in med:
            surface = float(_numbers(med["surface_y"], lambda s: s == (), "medium.surface_y", path))
        from .medium import Medium

        try:
            Medium(eps_r)
        except InputError as exc:
            raise InputError(f"{path}: medium: {exc}") from None
    return eps_r, surface


def _list(doc, key, path):
    v = doc.get(key, [])
    if not isinstance(v, list) or len(v) > 10_000:
        raise InputError(f"{path}: {key} must be a list (of at most 10000)")
    return v
