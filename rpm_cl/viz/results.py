"""Image results of ``rpm-cl image`` read for the pictures
(:func:`load_result`): the points, their clusters, the antennas' RPs and the
true scene, each checked, so that an odd file gives one
:class:`rpm_cl.io.data.InputError` rather than a traceback from matplotlib or
pyvista.  Also the readers' helpers the image files share (:func:`_h5_meta`,
:func:`_oneline`, :func:`_is_real`).
"""

from __future__ import annotations

import json
import os
import zipfile

import numpy as np

from ..io.data import InputError


def load_result(path) -> dict:
    """Read an image result written by :func:`rpm_cl.io.formats.save_result`.

    Everything the pictures use is checked here, so that an odd file (edited by
    hand, or written by another tool) gives one :class:`InputError` rather than
    a traceback from matplotlib or pyvista.  Malformed true targets in
    ``meta["scene"]`` are rejected, not skipped: ``rpm-cl image`` always writes
    them whole, so one that is not means the file was altered, and drawing the
    rest would show a truth that is not the one the data were simulated from.

    Parameters
    ----------
    path : str or path-like
        A result ``.npz``, or ``.h5`` / ``.hdf5`` (the same names).

    Returns
    -------
    dict
        ``points`` (M, 2|3) float64, ``cluster`` (M,) int64, ``rp_x`` (K,)
        float64, ``rp_z`` (K,) float64 or None, ``meta`` (dict), ``scene``
        (dict, ``{}`` when absent) and ``targets`` (list of
        :class:`~rpm_cl.simulate.scene.PointTarget` / :class:`~rpm_cl.simulate.scene.Ellipsoid`
        built from ``scene``).

    Raises
    ------
    InputError
        The file is missing or unreadable, or a field has the wrong type or
        shape; the message names the field.
    """
    from ..io.formats import check_members

    path = os.fspath(path)
    if (
        os.path.isfile(path)
        and not os.path.splitext(path)[1].lower() in (".h5", ".hdf5")
        and not zipfile.is_zipfile(path)
    ):
        raise InputError(f"{path}: not an .npz result (not a zip archive)")
    check_members(path, ("points", "cluster", "rp_x", "rp_z", "meta"))
    try:
        if os.path.splitext(path)[1].lower() in (".h5", ".hdf5"):
            out, meta = _read_h5(path)
        else:
            out, meta = _read_npz(path)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except InputError:
        raise
    except KeyError as exc:
        raise InputError(f"{path}: not an rpm-cl image result (missing {exc})") from None
    except Exception as exc:  # noqa: BLE001 - any unreadable file is one line
        raise InputError(
            f"{path}: not a readable result file ({type(exc).__name__}: {_oneline(exc)})"
        ) from None
    _check_arrays(path, out)
    if not isinstance(meta, dict):
        raise InputError(f"{path}: meta must be a JSON object, got {type(meta).__name__}")
    scene = meta.get("scene") or {}
    if not isinstance(scene, dict):
        raise InputError(f"{path}: meta.scene must be a JSON object, got {type(scene).__name__}")
    out["meta"] = meta
    out["scene"] = scene
    out["targets"] = _targets(path, scene)
    return out


def _read_npz(path: str):
    """The fields :func:`load_result` uses, from an ``.npz`` result."""
    if os.path.isfile(path) and not zipfile.is_zipfile(path):
        raise InputError(f"{path}: not an .npz result (not a zip archive)")
    with np.load(path, allow_pickle=False) as npz:
        missing = [k for k in ("points", "cluster", "rp_x") if k not in npz.files]
        if missing:
            hint = (
                f"; it holds radar data: image it first (rpm-cl image {path} -o OUT.npz)"
                if {"signal", "spectrum"} & set(npz.files)
                else ""
            )
            raise InputError(f"{path}: not an rpm-cl image result (no {missing[0]!r}{hint})")
        out = {k: np.asarray(npz[k]) for k in ("points", "cluster", "rp_x")}
        out["rp_z"] = np.asarray(npz["rp_z"]) if "rp_z" in npz.files else None
        meta = json.loads(str(npz["meta"])) if "meta" in npz.files else {}
    return out, meta


def _check_arrays(path: str, out: dict) -> None:
    """Check the arrays of a result read by :func:`load_result` (``points``,
    ``cluster``, ``rp_x``, ``rp_z``) and convert them to float64 / int64 in
    place; InputError names the first wrong one."""
    pts = out["points"]
    if (
        pts.ndim != 2
        or pts.shape[1] not in (2, 3)
        or not _is_real(pts)
        or not np.all(np.isfinite(pts))
    ):
        raise InputError(f"{path}: points must be a finite (M, 2) or (M, 3) array")
    out["points"] = pts.astype(np.float64)
    m = len(pts)
    cl = out["cluster"]
    if cl.shape != (m,) or not (np.issubdtype(cl.dtype, np.integer) or cl.dtype == bool):
        raise InputError(
            f"{path}: cluster must be an integer array of shape ({m},) like "
            f"points, got {cl.dtype} {cl.shape}"
        )
    out["cluster"] = cl.astype(np.int64)
    for key in ("rp_x", "rp_z"):
        a = out[key]
        if a is None:
            continue
        if a.ndim != 1 or not _is_real(a) or not np.all(np.isfinite(a)):
            raise InputError(f"{path}: {key} must be a finite 1-D array, got {a.dtype} {a.shape}")
        out[key] = a.astype(np.float64)
    if out["rp_z"] is not None and out["rp_z"].shape != out["rp_x"].shape:
        raise InputError(
            f"{path}: rp_x and rp_z must have the same length, got "
            f"{out['rp_x'].size} and {out['rp_z'].size}"
        )


def _read_h5(path: str):
    """The fields :func:`load_result` uses, from an HDF5 result
    (:func:`rpm_cl.io.formats.save_result`: the ``.npz`` names as root datasets)."""
    import h5py

    if not os.path.exists(path):
        raise FileNotFoundError(path)
    with h5py.File(path, "r") as f:
        for k in ("points", "cluster", "rp_x"):
            if k not in f:
                raise KeyError(k)
        out = {k: np.asarray(f[k][()]) for k in ("points", "cluster", "rp_x")}
        out["rp_z"] = np.asarray(f["rp_z"][()]) if "rp_z" in f else None
        meta = _h5_meta(f)
    return out, meta


def _h5_meta(f) -> object:
    """The ``meta`` JSON string dataset of an open HDF5 file, parsed ({} when absent)."""
    meta = f["meta"][()] if "meta" in f else b"{}"
    if isinstance(meta, np.ndarray) and meta.ndim == 0:
        meta = meta.item()
    return json.loads(meta.decode("utf-8") if isinstance(meta, bytes) else str(meta))


def _oneline(exc: BaseException) -> str:
    """An OS error as one line: its strerror, else its text with newlines folded."""
    return getattr(exc, "strerror", None) or " ".join(str(exc).split()) or type(exc).__name__


def _is_real(a: np.ndarray) -> bool:
    return np.issubdtype(a.dtype, np.integer) or np.issubdtype(a.dtype, np.floating)


def _targets(path: str, scene: dict) -> list:
    """The true targets of ``scene`` as scene objects; InputError names a bad one."""
    from ..simulate.scene import Ellipsoid, PointTarget

    targets = scene.get("targets", [])
    if not isinstance(targets, list):
        raise InputError(f"{path}: meta.scene.targets must be a list, got {type(targets).__name__}")
    need = {"point": ("position",), "ellipsoid": ("center", "semi_axes")}
    out = []
    for i, t in enumerate(targets):
        where = f"{path}: meta.scene.targets[{i}]"
        if not isinstance(t, dict):
            raise InputError(f"{where} must be a JSON object, got {type(t).__name__}")
        kind = t.get("type")
        if kind not in need:
            raise InputError(f"{where}: unknown type {kind!r} (expected 'point' or 'ellipsoid')")
        missing = [k for k in need[kind] if k not in t]
        if missing:
            raise InputError(f"{where}: the {kind} target has no {' or '.join(missing)}")
        try:
            if kind == "point":
                out.append(PointTarget(t["position"]))
            else:
                out.append(Ellipsoid(t["center"], t["semi_axes"], t.get("angles", (0.0,))))
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None
        except (TypeError, ValueError) as exc:
            raise InputError(f"{where}: not numeric ({_oneline(exc)})") from None
    return out
