"""Writers of the output files by format: arrays as HDF5
(:func:`_h5_write_arrays`), a pyvista dataset as VTK XML (:func:`_vtk_write`),
an image result's arrays (:func:`result_arrays`) and its point cloud as PLY or
VTP.  Each writes to the temporary file it is given; the atomic rename is the
caller's."""

from __future__ import annotations

import errno
import io
import json

import numpy as np

from .checks import InputError
from .filetypes import _h5py


def _h5_write_arrays(tmp: str, arrays: dict) -> None:
    """The arrays as an HDF5 file at ``tmp``, built in memory and written by
    Python: a full disk then raises OSError (HDF5 writing to a full disk
    itself crashed the process).  The price: the file is held in memory
    once more while written (a 1 GB array peaked at 2.2 GB against 1.1 GB)."""
    h5py = _h5py()
    bio = io.BytesIO()
    with h5py.File(bio, "w") as f:
        for k, v in arrays.items():
            v = np.asarray(v)
            if v.dtype.kind == "U":  # JSON strings: UTF-8 string datasets
                f.create_dataset(k, data=str(v), dtype=h5py.string_dtype("utf-8"))
            else:
                f.create_dataset(k, data=v)
    with open(tmp, "wb") as fh:
        fh.write(bio.getbuffer())


def _vtk_write(dataset, tmp: str, in_memory: bool = False) -> None:
    """A pyvista dataset as binary VTK XML at ``tmp`` (``.vtp`` PolyData,
    ``.vti`` ImageData).

    VTK only prints a failed write and leaves a truncated file, or crashes
    (a full disk part-way through a point cloud: a segmentation fault).
    Here its messages are kept off stderr and its error code raises OSError;
    with ``in_memory`` VTK writes a string that Python then writes, so a
    full disk is an OSError and never reaches VTK (point clouds; volumes
    are written by VTK directly, after :func:`rpm_cl.baselines.das.check_disk`)."""
    from vtkmodules.vtkCommonCore import vtkObject
    from vtkmodules.vtkCommonMisc import vtkErrorCode
    from vtkmodules.vtkIOXML import vtkXMLImageDataWriter, vtkXMLPolyDataWriter

    writer = (vtkXMLPolyDataWriter if tmp.endswith(".vtp") else vtkXMLImageDataWriter)()
    writer.SetInputData(dataset)
    writer.SetDataModeToBinary()
    if in_memory:
        writer.WriteToOutputStringOn()
    else:
        writer.SetFileName(tmp)
    shown = vtkObject.GetGlobalWarningDisplay()
    vtkObject.GlobalWarningDisplayOff()
    try:
        ok = writer.Write()
    finally:
        vtkObject.SetGlobalWarningDisplay(shown)
    code = writer.GetErrorCode()
    if not ok or code:
        full = code == vtkErrorCode.OutOfDiskSpaceError
        raise OSError(
            errno.ENOSPC if full else errno.EIO,
            "No space left on device"
            if full
            else f"VTK: {vtkErrorCode.GetStringFromErrorCode(code) or 'write failed'}",
        )
    if in_memory:
        with open(tmp, "wb") as fh:
            fh.write(writer.GetOutputString().encode("latin-1"))


def result_arrays(result, meta: dict | None = None) -> dict:
    """The arrays of an image result, by name (the ``.npz`` / HDF5 content).

    ``points`` (M, 2|3) m, ``cluster``, ``score``, ``rp_index`` (M,), the RPs
    ``rp_x`` (``rp_z``), ``rp_range``, ``rp_amp``, ``rp_cluster``,
    ``rp_antenna`` (K,), and ``meta``: a JSON string (method, stage timings,
    and ``meta``: version, device, parameters ...).
    """
    rps, img = result.rps, result.image
    out = {
        "points": img.points,
        "cluster": img.cluster,
        "score": img.score,
        "rp_index": img.rp_index,
        "rp_x": rps.x,
        "rp_range": rps.range,
        "rp_amp": rps.amp,
        "rp_cluster": rps.cluster,
        "rp_antenna": rps.antenna,
    }
    if rps.z is not None:
        out["rp_z"] = rps.z
    if img.multipath is not None:
        out["multipath"] = img.multipath
    info = {"method": result.method, "timings": result.timings, **(meta or {})}
    out["meta"] = np.array(json.dumps(info, default=str))
    return out


def _points3(points: np.ndarray) -> np.ndarray:
    p = np.asarray(points, np.float64)
    if p.shape[1] == 2:  # (x, y) of a linear array: the z = 0 plane
        p = np.column_stack([p, np.zeros(len(p))])
    return np.ascontiguousarray(p)


def _write_ply(tmp: str, arrays: dict) -> None:
    """Binary little-endian PLY: vertices x, y, z (double), cluster (int),
    score (double); the meta JSON as a comment line."""
    pts = _points3(arrays["points"])
    rec = np.zeros(
        len(pts), [("x", "<f8"), ("y", "<f8"), ("z", "<f8"), ("cluster", "<i4"), ("score", "<f8")]
    )
    rec["x"], rec["y"], rec["z"] = pts.T
    rec["cluster"] = arrays["cluster"]
    rec["score"] = arrays["score"]
    meta = " ".join(str(arrays["meta"]).split())
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"comment rpm-cl {meta}\n"
        f"element vertex {len(pts)}\n"
        "property double x\nproperty double y\nproperty double z\n"
        "property int cluster\nproperty double score\nend_header\n"
    )
    with open(tmp, "wb") as fh:
        fh.write(header.encode("utf-8"))
        fh.write(rec.tobytes())


def _pyvista():
    try:
        import pyvista as pv
    except ImportError:
        raise InputError(
            "VTK outputs (.vtp, .vti) need pyvista: pip install 'rpm-cl[view]'"
        ) from None
    return pv


def _write_vtp(tmp: str, arrays: dict) -> None:
    pv = _pyvista()
    cloud = pv.PolyData(_points3(arrays["points"]))
    cloud.point_data["cluster"] = np.asarray(arrays["cluster"], np.int64)
    cloud.point_data["score"] = np.asarray(arrays["score"], np.float64)
    cloud.field_data["meta"] = [str(arrays["meta"])]
    _vtk_write(cloud, tmp, in_memory=True)
