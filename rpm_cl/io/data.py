"""Radar data model: waveform, array, range profiles, truth; ``.npz`` I/O.

Everything is SI: metres, hertz, seconds.  Antennas are monostatic and lie at
``(x, 0)`` for a linear array (2-D problem) or ``(x, 0, z)`` for a planar one
(3-D problem); targets are at ``y > 0``.

Input contract (``.npz``)
-------------------------
``signal``
    complex, ``(nx, nr)`` linear or ``(nx, nz, nr)`` planar: range-compressed
    baseband profiles whose phase at a target of range ``R_t`` is
    ``exp(-1j * 2 * k_c * R_t)``, ``k_c = 2 pi fc / c``.
``x`` ``(nx,)`` and, planar only, ``z`` ``(nz,)``
    uniform, strictly increasing antenna coordinates, m.
``range`` ``(nr,)``
    uniform, strictly increasing range axis, m.
``fc``, ``bandwidth``
    scalars, Hz.
``truth_*`` (optional)
    the true geometry, see :class:`Truth`: ``truth_boundary`` (with it, the
    optional ``truth_rp_antenna`` and ``truth_rp_range``, both or neither,
    and ``truth_scene``).

Where the parts live
--------------------
:mod:`.checks` (InputError, DataWarning, value checks), :mod:`.model`
(Waveform, Array, Truth, C0), :mod:`.radar` (RadarData), :mod:`.plausible`
(unit warnings), :mod:`.spikes` (corrupt samples), :mod:`.atomic` (output
paths and atomic writes); their names are importable from here too.  This
module holds the ``.npz`` reading and writing of the contract.
"""

from __future__ import annotations

import os

import numpy as np

from .atomic import (  # noqa: F401 - importable from here
    _atomic_file,
    _atomic_write,
    _usual_mode,
    atomic_savez,
    atomic_write_text,
    output_path,
    refuse_overwrite,
    temp_prefix,
)
from .checks import (  # noqa: F401 - importable from here
    _UNIT_FACTORS,
    FC_MAX,
    FC_MIN,
    DataWarning,
    InputError,
    _finite_scalar,
    _real_kind,
    _uniform_axis,
    carrier,
    scale_hint,
    unit_hint,
)
from .model import C0, Array, Truth, Waveform
from .plausible import (  # noqa: F401 - importable from here
    ECHO_WIDTH_MAX,
    PITCH_MAX_WAVELENGTHS,
    PITCH_MIN_PER_WAVELENGTH,
    check_plausible,
    echo_width,
)
from .radar import (  # noqa: F401 - importable from here
    AMPLITUDE_MIN,
    BANDWIDTH_SPAN_MAX,
    BANDWIDTH_SPAN_WARN,
    SUM_MAX,
    RadarData,
    Spectrum,
    _bandwidth_line,
)
from .spikes import SPIKE_COUNT, SPIKE_FACTOR, drop_spikes  # noqa: F401 - importable from here

__all__ = [
    "C0",
    "FC_MAX",
    "FC_MIN",
    "Array",
    "DataWarning",
    "InputError",
    "RadarData",
    "Truth",
    "Waveform",
    "atomic_savez",
    "atomic_write_text",
    "carrier",
    "check_plausible",
    "drop_spikes",
    "load_npz",
    "refuse_overwrite",
    "save_npz",
    "scale_hint",
    "temp_prefix",
    "unit_hint",
]


def _read(npz, key, name):
    if key not in npz.files:
        raise InputError(f"{name}: missing key {key!r}")
    return npz[key]


def load_npz(path) -> RadarData:
    """Read and validate an ``.npz`` following the input contract.

    Raises
    ------
    InputError
        Unreadable file, missing key, bad shape, dtype or values.
    """
    path = os.fspath(path)
    try:
        npz = np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except Exception as exc:  # noqa: BLE001 - zipfile.BadZipFile, ValueError, OSError, EOFError ...
        raise InputError(
            f"{path}: not a readable .npz file ({type(exc).__name__}: {exc})"
        ) from None
    with npz:
        try:
            z = npz["z"] if "z" in npz.files else None
            array = Array(_read(npz, "x", path), z)
            waveform = Waveform(_read(npz, "fc", path), _read(npz, "bandwidth", path))
            truth = None
            if "truth_boundary" in npz.files:
                scene = str(npz["truth_scene"]) if "truth_scene" in npz.files else "{}"
                truth = Truth(
                    npz["truth_rp_antenna"] if "truth_rp_antenna" in npz.files else None,
                    npz["truth_rp_range"] if "truth_rp_range" in npz.files else None,
                    npz["truth_boundary"],
                    scene,
                )
            data = RadarData(
                _read(npz, "signal", path), array, _read(npz, "range", path), waveform, truth
            )
            check_plausible(data)
            return data
        except InputError as exc:
            msg = str(exc)
            raise InputError(msg if msg.startswith(path) else f"{path}: {msg}") from None
        except Exception as exc:  # noqa: BLE001 - truncated member inside a valid zip, bad pickle ...
            raise InputError(f"{path}: cannot read ({type(exc).__name__}: {exc})") from None


def data_arrays(data: RadarData) -> dict:
    """The input contract's arrays of ``data`` (and its truth, if any), by name."""
    out = {
        "signal": data.signal,
        "x": data.array.x,
        "range": data.range,
        "fc": np.float64(data.waveform.fc),
        "bandwidth": np.float64(data.waveform.bandwidth),
    }
    if data.array.z is not None:
        out["z"] = data.array.z
    if data.truth is not None:
        if data.truth.has_rps:
            out.update(truth_rp_antenna=data.truth.rp_antenna, truth_rp_range=data.truth.rp_range)
        out.update(truth_boundary=data.truth.boundary, truth_scene=np.array(data.truth.scene))
    return out


def save_npz(path, data: RadarData) -> None:
    """Write ``data`` (and its truth, if any) following the input contract."""
    atomic_savez(path, **data_arrays(data))
