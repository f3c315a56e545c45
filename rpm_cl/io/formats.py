"""File formats in and out: ``.npz`` and HDF5 inputs, results by extension.

Inputs (:func:`load_data`, :func:`frame_count`)
-----------------------------------------------
One schema, two containers: the names of the ``.npz`` input contract
(:mod:`rpm_cl.io.data`) are members of an ``.npz`` or datasets at the root of an
HDF5 file (``.h5`` / ``.hdf5``; scalars as 0-d datasets, ``truth_scene`` as a
string dataset).  Either

- **time domain**: ``signal`` (nx[, nz], nr) complex with its ``range`` (nr,)
  axis, ``fc`` and ``bandwidth``; or
- **frequency domain** (stepped-frequency or dechirped FMCW samples):
  ``spectrum`` (nx[, nz], nf) complex with its ``frequency`` (nf,) axis, Hz
  (uniform, strictly increasing, > 0); ``fc`` and ``bandwidth`` optional.
  :func:`range_compress` turns it into the time-domain form.

``signal`` / ``spectrum`` may carry one leading frame axis (a *stack*,
``(n_frames, nx[, nz], n)``); ``frame=i`` reads frame ``i`` only (an HDF5
hyperslab; for an ``.npz`` the frame's bytes of the member).

Range compression of a spectrum
-------------------------------
With ``f_n = f_0 + n df`` (n = 0 .. nf-1), a window ``w_n`` and ``fc``::

    s(R) = sum_n w_n Y(f_n) exp(+j 4 pi (f_n - fc) R / c) / sum_n w_n

so a lone echo ``Y(f) = a exp(-j 4 pi f R_t / c)`` peaks at ``|s(R_t)| = a``
with phase ``exp(-j 2 k_c R_t)``, ``k_c = 2 pi fc / c``: the time-domain
contract.  It is evaluated by an inverse FFT zero-padded to
``N = next_fast_len(RANGE_OVERSAMPLE * nf)`` points: range gates of
``dr = c / (2 df N)`` (at most 1/:data:`RANGE_OVERSAMPLE` of the resolution
``c / (2 nf df)`` of the whole band) over the unambiguous range
``[0, c / (2 df))``; echoes beyond it alias.

When omitted, ``fc = (f_0 + f_last) / 2`` (the band centre) and ``bandwidth``
= the full width at half amplitude of the window over the band,
``nf df`` times the fraction of the window above half its peak (rect:
``nf df``; hann: ``nf df / 2``): the engine's ``bandwidth`` is that width (the
simulator's ``P(f) = cos^2(pi f / 2B)``, a Hann window over ``2B``, has it).

Outputs by extension (:func:`save_result`, :func:`save_data`, :func:`write_volume`)
-----------------------------------------------------------------------------------
Image results: ``.npz``, ``.h5`` (same arrays; ``meta`` a JSON string
dataset), ``.ply`` and ``.vtp`` point clouds with per-point ``cluster`` and
``score``.  Radar data (``rpm-cl simulate``): ``.npz``, ``.h5``.  DAS images:
``.npz``, ``.h5`` (chunked), ``.vti`` (VTK ImageData).  Every file is written
to a temporary file beside the target and renamed.

Where the code lives
--------------------
:mod:`.load` (reading), :mod:`.compress` (range compression),
:mod:`.sources` (``.npz`` and HDF5 members from their headers),
:mod:`.filetypes` (extensions), :mod:`.writers` and :mod:`.volumes`
(writing); their names are importable from here too.  This module holds
:func:`save_data` and :func:`save_result`, which find their writers
(``_h5_write_arrays``, ``_write_ply``, ``_write_vtp``) in this module.
"""

from __future__ import annotations

import os

from .atomic import _atomic_file, atomic_savez
from .compress import (  # noqa: F401 - importable from here
    CONJUGATE_FAR_SHARE,
    RANGE_OVERSAMPLE,
    RANGE_WINDOWS,
    WRAP_ABOVE_MEDIAN,
    WRAP_EDGE,
    WRAP_LEVEL,
    _frequency_axis,
    range_compress,
    range_sidelobe_db,
    window_bandwidth,
)
from .data import data_arrays
from .filetypes import (
    _H5_EXT,
    DATA_EXTENSIONS,
    RESULT_EXTENSIONS,
    VOLUME_EXTENSIONS,
    _need_ext,
    check_output,
)
from .load import BESIDE_READ_BYTES, frame_count, load_data  # noqa: F401 - importable from here
from .radar import RadarData
from .sources import (  # noqa: F401 - importable from here
    NPY_HEADER_MAX,
    TEXT_MAX_BYTES,
    TEXT_MAX_ITEMS,
    _guarded,
    _H5Source,
    _NpzSource,
    check_members,
)
from .volumes import write_volume
from .writers import (  # noqa: F401 - importable from here
    _h5_write_arrays,
    _pyvista,
    _vtk_write,
    _write_ply,
    _write_vtp,
    result_arrays,
)

__all__ = [
    "DATA_EXTENSIONS",
    "RANGE_OVERSAMPLE",
    "RANGE_WINDOWS",
    "RESULT_EXTENSIONS",
    "VOLUME_EXTENSIONS",
    "check_members",
    "check_output",
    "frame_count",
    "load_data",
    "range_compress",
    "range_sidelobe_db",
    "result_arrays",
    "save_data",
    "save_result",
    "window_bandwidth",
    "write_volume",
]


def save_data(path, data: RadarData) -> None:
    """Write radar data (time domain, with its truth) as ``.npz`` or HDF5.

    Parameters
    ----------
    path : str or path-like
        ``.npz``, ``.h5`` or ``.hdf5``; the same names either way.
    data : RadarData
    """
    from .data import save_npz

    path = os.fspath(path)
    ext = _need_ext(path, DATA_EXTENSIONS, "data output")
    if ext == ".npz":
        save_npz(path, data)
        return
    out = data_arrays(data)
    _atomic_file(path, lambda tmp: _h5_write_arrays(tmp, out))


def save_result(path, result, meta: dict | None = None) -> None:
    """Write an image result; the format follows the extension.

    - ``.npz``: :func:`result_arrays` (the same file as
      :func:`rpm_cl.io.formats.save_result`);
    - ``.h5`` / ``.hdf5``: the same names as root datasets, ``meta`` a UTF-8
      string dataset;
    - ``.ply``: a binary point cloud, vertex properties ``x y z`` (m; z = 0
      for 2-D results), ``cluster``, ``score``, and the meta JSON as a comment;
    - ``.vtp``: a VTK PolyData point cloud with point arrays ``cluster`` and
      ``score`` and the field ``meta`` (needs pyvista).

    The RPs are kept by ``.npz`` and HDF5 only.

    Parameters
    ----------
    path : str or path-like
    result : rpm_cl.result.ImageResult
    meta : dict, optional
        Run metadata (version, device, parameters ...), stored as JSON.

    Raises
    ------
    InputError
        Unknown extension (the message lists the supported ones), the
        folder is missing or not writable, pyvista missing for ``.vtp``.
    """
    path = os.fspath(path)
    ext = _need_ext(path, RESULT_EXTENSIONS, "result")
    arrays = result_arrays(result, meta)
    if ext == ".npz":
        atomic_savez(path, **arrays)
    elif ext in _H5_EXT:
        _atomic_file(path, lambda tmp: _h5_write_arrays(tmp, arrays))
    elif ext == ".ply":
        _atomic_file(path, lambda tmp: _write_ply(tmp, arrays))
    else:
        _pyvista()  # fail before anything is written
        _atomic_file(path, lambda tmp: _write_vtp(tmp, arrays))
