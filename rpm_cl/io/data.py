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
"""

from __future__ import annotations

import decimal
import json
import numbers
import os
import tempfile
from dataclasses import dataclass, field

import numpy as np

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

#: Speed of light in vacuum, m/s (the propagation speed in air used throughout).
C0 = 299_792_458.0


#: Bounds of the largest signal amplitude accepted: a sum of all the samples
#: stays within float64 (at most SUM_MAX: the FFTs and the coherent sums add
#: up to every sample; powers are formed from amplitudes relative to the
#: largest), and the smallest peak keeps products with weights and windows
#: of 1e-8 normal numbers (float64's smallest normal is 2.2e-308).
SUM_MAX = 1e307
AMPLITUDE_MIN = 1e-300


class InputError(ValueError):
    """Malformed input; the message names the field and the problem."""


class DataWarning(UserWarning):
    """Input that loads but looks wrong (a unit, a sign convention or a
    setting); the message says what to change.  The command line prints it
    as one line ``rpm-cl: warning: ...`` on stderr."""


#: Lowest centre frequency accepted, Hz.  Below it the numbers are taken for
#: GHz or MHz values given without their factor and refused (every radar the
#: engine models, HF included, lies above).
FC_MIN = 1e6
#: Highest centre frequency accepted, Hz (10 THz: above the terahertz
#: imagers, below the infrared).  A larger number is no radar carrier but a
#: corrupt or mistyped value, and would size the k-space searches beyond any
#: memory (1e30 Hz: 1e22 directions).
FC_MAX = 1e13


def unit_hint(value_hz: float) -> str:
    """For a frequency below :data:`FC_MIN`: the unit its number looks like
    (``"GHz numbers (x 1e9)"`` below 1e3, else ``"MHz numbers (x 1e6)"``)."""
    return "GHz numbers (x 1e9)" if abs(value_hz) < 1e3 else "MHz numbers (x 1e6)"


#: The factors a frequency given in kHz, MHz or GHz numbers lacks.
_UNIT_FACTORS = (
    (1e3, "kHz numbers (x 1e3)"),
    (1e6, "MHz numbers (x 1e6)"),
    (1e9, "GHz numbers (x 1e9)"),
)


def scale_hint(value_hz: float, at_least_hz: float) -> str:
    """For a frequency (a bandwidth) that should be at least ``at_least_hz``:
    the unit its number looks like, the smallest factor that lifts it there
    (``"MHz numbers (x 1e6)"``), or ``"a unit other than Hz"``."""
    for k, name in _UNIT_FACTORS:
        if value_hz * k >= at_least_hz:
            return name
    return "a unit other than Hz"


def _real_kind(a) -> bool:
    """True for real numbers: integer or floating dtypes, not bool, complex,
    strings, dates or time spans (``np.timedelta64`` counts as an integer
    to ``np.issubdtype``)."""
    return np.asarray(a).dtype.kind in "iuf"


def _finite_scalar(name: str, value, positive: bool = True) -> float:
    if isinstance(value, (numbers.Real, decimal.Decimal)) and not isinstance(
        value, (bool, np.bool_)
    ):
        arr = np.asarray(float(value))  # int, float, numpy scalars, Fraction, Decimal
    else:
        arr = np.asarray(value)
        if not _real_kind(arr):
            raise InputError(f"{name} must be a real number, got dtype {arr.dtype}")
    try:
        v = float(arr.reshape(()))
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a real scalar, got {value!r}") from None
    if not np.isfinite(v):
        raise InputError(f"{name} must be finite, got {v}")
    if positive and v <= 0:
        raise InputError(f"{name} must be > 0, got {v}")
    return v


def _uniform_axis(name: str, values, min_len: int = 1, unit: str = "m") -> np.ndarray:
    a = np.asarray(values)
    if a.ndim != 1:
        raise InputError(f"{name} must be 1-D, got shape {a.shape}")
    if a.size < min_len:
        raise InputError(f"{name} must have at least {min_len} values, got {a.size}")
    if not _real_kind(a):
        raise InputError(f"{name} must be real numbers, got dtype {a.dtype}")
    # tolerance of the uniformity test: 1e-6 of the step, plus the rounding of
    # the stored values (float32 axes of measured data are common)
    eps = np.finfo(a.dtype).eps if np.issubdtype(a.dtype, np.floating) else 0.0
    a = a.astype(np.float64)
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name} contains NaN or Inf")
    if a.size >= 2:
        step = np.diff(a)
        if np.any(step <= 0):
            raise InputError(f"{name} must be strictly increasing")
        tol = 1e-6 * abs(step.mean()) + 8 * eps * float(np.max(np.abs(a))) + 1e-12
        if np.max(np.abs(step - step.mean())) > tol:
            raise InputError(
                f"{name} must be uniformly spaced (steps vary from "
                f"{step.min():.6g} to {step.max():.6g} {unit})"
            )
    a.setflags(write=False)
    return a


def carrier(fc) -> float:
    """``fc`` as a float, Hz, once it is finite and within :data:`FC_MIN` ..
    :data:`FC_MAX`; else :class:`InputError` naming the unit it looks like."""
    fc = _finite_scalar("fc", fc)
    if fc < FC_MIN:
        raise InputError(
            f"fc = {fc:g} Hz is below {FC_MIN:g} Hz: it looks like "
            f"{unit_hint(fc)}; give fc and bandwidth in Hz"
        )
    if fc > FC_MAX:
        raise InputError(
            f"fc = {fc:g} Hz is above {FC_MAX:g} Hz (10 THz): not a radar carrier; give fc in Hz"
        )
    return fc


@dataclass(frozen=True)
class Waveform:
    """Pulse-modulated transmit signal.

    Attributes
    ----------
    fc : float
        Centre frequency, Hz.
    bandwidth : float
        Bandwidth B, Hz; the nominal range resolution is ``c / (2 B)``.
    """

    fc: float
    bandwidth: float

    def __post_init__(self):
        fc = carrier(self.fc)
        bw = _finite_scalar("bandwidth", self.bandwidth)
        if bw >= 2 * fc:
            raise InputError(
                f"bandwidth ({bw:g} Hz) must be below 2*fc ({2 * fc:g} Hz): are "
                f"both in the same unit? give fc and bandwidth in Hz"
            )
        object.__setattr__(self, "fc", fc)
        object.__setattr__(self, "bandwidth", bw)

    @property
    def wavelength(self) -> float:
        """Centre wavelength, m."""
        return C0 / self.fc

    @property
    def kc(self) -> float:
        """Centre wavenumber ``2 pi fc / c``, rad/m."""
        return 2 * np.pi * self.fc / C0

    @property
    def range_resolution(self) -> float:
        """Nominal range resolution ``c / (2 B)``, m."""
        return C0 / (2 * self.bandwidth)


@dataclass(frozen=True)
class Array:
    """Monostatic antenna array on the y = 0 line or plane.

    Attributes
    ----------
    x : ndarray, shape (nx,)
        Uniform, strictly increasing x coordinates, m.
    z : ndarray, shape (nz,), or None
        Uniform, strictly increasing z coordinates for a planar array, m.
    """

    x: np.ndarray
    z: np.ndarray | None = None

    def __post_init__(self):
        object.__setattr__(self, "x", _uniform_axis("x", self.x, 2))
        if self.z is not None:
            object.__setattr__(self, "z", _uniform_axis("z", self.z, 2))

    @property
    def planar(self) -> bool:
        return self.z is not None

    @property
    def dim(self) -> int:
        """Dimension of the imaging problem: 2 (linear) or 3 (planar)."""
        return 3 if self.planar else 2

    @property
    def shape(self) -> tuple[int, ...]:
        return (self.x.size,) if self.z is None else (self.x.size, self.z.size)

    @property
    def n(self) -> int:
        """Number of antennas."""
        return int(np.prod(self.shape))

    @property
    def dx(self) -> float:
        return float(self.x[1] - self.x[0])

    @property
    def dz(self) -> float | None:
        return None if self.z is None else float(self.z[1] - self.z[0])

    def positions(self) -> np.ndarray:
        """Antenna positions, shape (n, dim), m, in ``signal``'s C order.

        2-D: ``(x, y=0)``; 3-D: ``(x, y=0, z)``.
        """
        if self.z is None:
            return np.stack([self.x, np.zeros_like(self.x)], axis=1)
        xx, zz = np.meshgrid(self.x, self.z, indexing="ij")
        return np.stack([xx.ravel(), np.zeros(xx.size), zz.ravel()], axis=1)


@dataclass(frozen=True)
class Truth:
    """True geometry of a simulated scene (for the metrics).

    Attributes
    ----------
    rp_antenna : ndarray of int, shape (K,), or None
        Flat antenna index (C order of the array) of each true RP; an
        integer dtype (floats, even integral ones, raise :class:`InputError`).
        None (with ``rp_range``) where the true RPs are unknown, e.g. measured
        data with a surveyed boundary only: Err_range is then unavailable.
    rp_range : ndarray, shape (K,), or None
        True range of each specular echo, m; None with ``rp_antenna``.
    boundary : ndarray, shape (P, dim)
        Dense samples of the true target boundary (the points themselves for
        point targets), m.
    scene : str
        JSON description of the scene.
    """

    rp_antenna: np.ndarray | None
    rp_range: np.ndarray | None
    boundary: np.ndarray
    scene: str = "{}"

    def __post_init__(self):
        if (self.rp_antenna is None) != (self.rp_range is None):
            raise InputError(
                "truth_rp_antenna and truth_rp_range go together: give both or neither"
            )
        if self.rp_antenna is not None:
            ant = np.asarray(self.rp_antenna)
            # indices are integers by type, as frame= and a result's cluster are:
            # a float (even 3.0) is refused rather than cast (3.5 became 3)
            if ant.size and not np.issubdtype(ant.dtype, np.integer):
                raise InputError(
                    f"truth_rp_antenna must be an integer array (antenna indices), "
                    f"got dtype {ant.dtype}"
                )
            object.__setattr__(self, "rp_antenna", ant.astype(np.int64).ravel())
        for name, v in (("truth_rp_range", self.rp_range), ("truth_boundary", self.boundary)):
            if v is not None and np.size(v) and not _real_kind(v):
                raise InputError(f"{name} must be real numbers, got dtype {np.asarray(v).dtype}")
        if self.rp_range is not None:
            object.__setattr__(self, "rp_range", np.asarray(self.rp_range, np.float64).ravel())
        b = np.asarray(self.boundary, np.float64)
        if b.ndim != 2 or b.shape[1] not in (2, 3):
            raise InputError(f"truth_boundary must have shape (P, 2|3), got {b.shape}")
        if not (
            np.all(np.isfinite(b)) and (self.rp_range is None or np.all(np.isfinite(self.rp_range)))
        ):
            raise InputError("truth_boundary or truth_rp_range contains NaN or Inf")
        object.__setattr__(self, "boundary", b)
        if self.has_rps and self.rp_antenna.shape != self.rp_range.shape:
            raise InputError("truth_rp_antenna and truth_rp_range differ in length")
        try:
            scene = json.loads(str(self.scene) or "{}")
        except ValueError:
            raise InputError("truth_scene must be a JSON object (the scene description)") from None
        if not isinstance(scene, dict):
            raise InputError("truth_scene must be a JSON object (the scene description)")

    @property
    def has_rps(self) -> bool:
        """True where the true RPs are known (Err_range can be computed)."""
        return self.rp_range is not None


#: A range resolution ``c / 2B`` more than BANDWIDTH_SPAN_WARN times the
#: range axis's span is warned about as a bandwidth in kHz numbers (the whole
#: axis within 1 % of one resolution cell), more than BANDWIDTH_SPAN_MAX
#: times refused as one in MHz or GHz numbers (as fc's are).  The searches
#: sized by the resolution are bounded by the axis, so such data cost what
#: the clean data do.  The frequency domain compares a given bandwidth with
#: its band by the same ratios.
BANDWIDTH_SPAN_WARN = 100.0
BANDWIDTH_SPAN_MAX = 1e4


def _bandwidth_line(bw: float, span: float, ratio: float) -> str:
    res = C0 / (2 * bw)
    return (
        f"bandwidth = {bw:g} Hz gives a range resolution c/2B = {res:g} m, over {ratio:g} "
        f"times the whole range axis ({span:g} m): it looks like "
        f"{scale_hint(bw, C0 / (2 * span))}; give fc and bandwidth in Hz"
    )


@dataclass(frozen=True)
class RadarData:
    """Range-compressed radar data, validated at construction.

    Attributes
    ----------
    signal : ndarray, complex, shape (nx, nr) or (nx, nz, nr)
        Baseband range profiles s(X[, Z], R); phase ``exp(-2j k_c R_t)`` at a
        target of range ``R_t``.
    array : Array
    range : ndarray, shape (nr,)
        Uniform range axis, m.
    waveform : Waveform
    truth : Truth, optional
    range_sidelobe_db : float, optional
        The strongest range sidelobe of the range compression that a k-space
        peak search can take for an echo (one beyond half a range
        resolution from its main lobe), dB relative to the main lobe, < 0;
        known for a spectrum compressed by :func:`rpm_cl.io.formats.range_compress`,
        None otherwise.  Imaging warns when a peak threshold lies below it.
    """

    signal: np.ndarray
    array: Array
    range: np.ndarray
    waveform: Waveform
    truth: Truth | None = field(default=None)
    range_sidelobe_db: float | None = field(default=None)

    def __post_init__(self):
        s = np.asarray(self.signal)
        if not np.iscomplexobj(s):
            raise InputError(
                f"signal must be complex baseband (complex64/complex128), got dtype {s.dtype}"
            )
        rng = _uniform_axis("range", self.range, 2)
        want = self.array.shape + (rng.size,)
        if s.shape != want:
            raise InputError(
                f"signal must have shape {want} (array {self.array.shape} x "
                f"range {rng.size}), got {s.shape}"
            )
        if not np.all(np.isfinite(s)):
            raise InputError("signal contains NaN or Inf")
        if rng[0] < 0:
            raise InputError(f"range must be >= 0, starts at {rng[0]:g} m")
        res = self.waveform.range_resolution
        dr = float(rng[1] - rng[0])
        if dr > res:
            raise InputError(
                f"range spacing {dr:g} m is coarser than the range resolution "
                f"c/2B = {res:g} m: range peaks cannot be located (range is "
                f"in m: millimetre numbers are 1000 times too large)"
            )
        span = float(rng[-1] - rng[0])
        if res > BANDWIDTH_SPAN_MAX * span:
            raise InputError(_bandwidth_line(self.waveform.bandwidth, span, BANDWIDTH_SPAN_MAX))
        if dr < 1e-9 * res:
            raise InputError(
                f"range spacing {dr:g} m is below 1e-9 of the range resolution {res:g} m"
            )
        t = self.truth
        if t is not None:
            if t.boundary.shape[1] != self.array.dim or len(t.boundary) == 0:
                raise InputError(
                    f"truth_boundary must have shape (P>0, {self.array.dim}) for "
                    f"this array, got {t.boundary.shape}"
                )
            if (
                t.has_rps
                and t.rp_antenna.size
                and (t.rp_antenna.min() < 0 or t.rp_antenna.max() >= self.array.n)
            ):
                raise InputError(f"truth_rp_antenna must index the {self.array.n} antennas")
        peak = float(np.max(np.abs(s))) if s.size else 0.0
        top = SUM_MAX / max(s.size, 1)
        if peak > 0 and not AMPLITUDE_MIN <= peak <= top:
            raise InputError(
                f"signal amplitudes up to {peak:.3g} are outside {AMPLITUDE_MIN:g} .. "
                f"{top:.3g} (for {s.size} samples: a sum of them all stays within "
                f"float64's range); scale the data"
            )
        # complex64 stays complex64 unless |s|^2 would leave float32's range
        # (1.2e-38 .. 3.4e38) on the way: then complex128, exactly
        keep64 = s.dtype == np.complex64 and (peak == 0 or 1e-15 <= peak <= 1e15)
        s = s.astype(np.complex64 if keep64 else np.complex128, copy=False)
        object.__setattr__(self, "signal", s)
        object.__setattr__(self, "range", rng)
        sl = self.range_sidelobe_db
        if sl is not None:
            sl = _finite_scalar("range_sidelobe_db", sl, positive=False)
            if sl >= 0:
                raise InputError(f"range_sidelobe_db must be < 0 dB, got {sl:g}")
            object.__setattr__(self, "range_sidelobe_db", sl)

    @property
    def dr(self) -> float:
        """Range sample spacing, m."""
        return float(self.range[1] - self.range[0])


#: The array pitch is taken for a unit mistake beyond these multiples of the
#: wavelength: above PITCH_MAX_WAVELENGTHS, x (z) in mm or cm read as m (a
#: 5 mm pitch is 333 wavelengths at 20 GHz in mm numbers, 33 in cm numbers;
#: the paper's sparse array has 1.3, a GPR line of 2 cm traces at 1.5 GHz
#: 0.1; an array with pitches of 20 wavelengths has grating lobes every 3
#: degrees, which no imager here can tell apart);
#: below 1 / PITCH_MIN_PER_WAVELENGTH, frequencies in kHz numbers (a 20 GHz
#: radar read as 20 MHz has a 15 m wavelength, 3000 of its 5 mm pitches).
PITCH_MAX_WAVELENGTHS = 20.0
PITCH_MIN_PER_WAVELENGTH = 300.0
#: An echo's range profile is as wide as the range resolution c / 2B: its
#: autocorrelation falls to half within about 0.6 of it (less for a rect
#: window).  Profiles correlated over more than ECHO_WIDTH_MAX resolutions
#: say the range axis is in cm numbers (mm numbers leave its gates coarser
#: than the resolution and are refused).
ECHO_WIDTH_MAX = 10.0


def check_plausible(data: RadarData) -> None:
    """Warn (:class:`DataWarning`) where the data's units look wrong.

    The array pitch against the wavelength ``c / fc``: more than
    :data:`PITCH_MAX_WAVELENGTHS` wavelengths suggests x (z) in mm or cm read as m;
    less than 1 / :data:`PITCH_MIN_PER_WAVELENGTH` of one suggests
    frequencies in kHz numbers; a range resolution over
    :data:`BANDWIDTH_SPAN_WARN` times the range axis's span, a bandwidth in
    kHz numbers.  (GHz and MHz numbers are refused by
    :class:`Waveform`; a range axis in mm by :class:`RadarData`.)
    """
    import warnings

    arr = data.array
    span = float(data.range[-1] - data.range[0])
    pitch = max(abs(arr.dx), abs(arr.dz or 0.0))
    lam = data.waveform.wavelength
    where = "x / z" if arr.planar else "x"
    if pitch > PITCH_MAX_WAVELENGTHS * lam:
        warnings.warn(
            f"the antenna pitch {pitch:g} m is {pitch / lam:.0f} wavelengths "
            f"({lam:.3g} m at fc = {data.waveform.fc:g} Hz): is {where} in mm or cm? "
            f"give {where} in m",
            DataWarning,
            stacklevel=3,
        )
    elif pitch < lam / PITCH_MIN_PER_WAVELENGTH:
        warnings.warn(
            f"the antenna pitch {pitch:g} m is 1/{lam / pitch:.0f} of the wavelength "
            f"({lam:.3g} m at fc = {data.waveform.fc:g} Hz): are the frequencies in "
            f"kHz numbers? give them in Hz (x 1e3)",
            DataWarning,
            stacklevel=3,
        )
    elif data.waveform.range_resolution > BANDWIDTH_SPAN_WARN * span:
        warnings.warn(
            _bandwidth_line(data.waveform.bandwidth, span, BANDWIDTH_SPAN_WARN),
            DataWarning,
            stacklevel=3,
        )
    width = echo_width(data)
    if width > ECHO_WIDTH_MAX * data.waveform.range_resolution:
        warnings.warn(
            f"the echoes are {width:.3g} m wide in range, "
            f"{width / data.waveform.range_resolution:.0f} times the range "
            f"resolution c/2B = {data.waveform.range_resolution:.3g} m: is range in cm "
            f"numbers? give it in m",
            DataWarning,
            stacklevel=3,
        )


def echo_width(data: RadarData) -> float:
    """The lag, m, at which the range profiles' autocorrelation (summed over
    the antennas) first falls to half its peak: about 0.6 range resolutions
    for echoes, a gate or so for white noise; 0 for all-zero data."""
    s = data.signal.reshape(-1, data.range.size)
    top = float(np.max(np.abs(s))) if s.size else 0.0
    if not top > 0:
        return 0.0
    n = data.range.size
    spec = np.fft.fft(s / top, 2 * n, axis=-1)  # relative: squares stay in range
    acf = np.abs(np.fft.ifft(np.sum(np.abs(spec) ** 2, axis=0))[:n])
    if not acf[0] > 0:
        return 0.0
    below = np.flatnonzero(acf < 0.5 * acf[0])
    return float((below[0] if below.size else n) * data.dr)


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


def _usual_mode(path) -> None:
    """Give a temporary file (mkstemp: 0600) the mode a plain open() would."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(path, 0o666 & ~umask)


def temp_prefix(path) -> str:
    """Prefix of the temporary files written on the way to ``path``
    (``.tmp-<name>-``): hidden, and telling whose they are."""
    return f".tmp-{os.path.basename(os.fspath(path))}-"


def output_path(path):
    """Check an output path before anything is computed or written.

    Returns
    -------
    path : str
    folder : str
        Its (existing) folder, where temporary files go.

    Raises
    ------
    InputError
        The folder does not exist, or ``path`` is a folder.
    """
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise InputError(f"{path}: output folder {folder} does not exist")
    if os.path.isdir(path):
        raise InputError(f"{path}: is a folder, not a file")
    return path, folder


def _atomic_file(path, write, ext: str | None = None) -> None:
    """Call ``write(tmp_path)`` on a temporary file beside ``path``, then
    rename it over ``path``.

    An interrupted run never leaves a half-written ``path`` (nor the
    temporary file) behind.

    Raises
    ------
    InputError
        The folder does not exist or cannot be written.
    """
    path, folder = output_path(path)
    try:
        fd, tmp = tempfile.mkstemp(
            prefix=temp_prefix(path), suffix=ext or os.path.splitext(path)[1], dir=folder
        )
    except OSError as exc:
        raise InputError(f"{path}: cannot write ({exc.strerror})") from None
    os.close(fd)
    try:
        write(tmp)
        _usual_mode(tmp)
        os.replace(tmp, path)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError):
            text = exc.strerror or " ".join(str(exc).split())
            raise InputError(f"{path}: cannot write ({type(exc).__name__}: {text})") from None
        raise


def _atomic_write(path, write) -> None:
    """Call ``write(fh)`` on a binary file handle, atomically (see
    :func:`_atomic_file`)."""

    def to_file(tmp):
        with open(tmp, "wb") as fh:
            write(fh)

    _atomic_file(path, to_file)


def atomic_savez(path, **arrays) -> None:
    """Write an ``.npz`` atomically (see :func:`_atomic_write`)."""
    _atomic_write(path, lambda fh: np.savez(fh, **arrays))


def atomic_write_text(path, text: str) -> None:
    """Write a UTF-8 text file atomically (see :func:`_atomic_write`)."""
    _atomic_write(path, lambda fh: fh.write(text.encode("utf-8")))


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


def refuse_overwrite(path, inputs) -> None:
    """Raise :class:`InputError` when ``path`` is (or links to) one of ``inputs``
    (a command never writes over what it reads)."""
    out = os.path.realpath(os.fspath(path))
    for p in inputs:
        p = os.fspath(p)
        same = os.path.realpath(p) == out
        if not same and os.path.exists(path) and os.path.exists(p):
            same = os.path.samefile(p, path)
        if same:
            raise InputError(f"{path}: is also an input ({p}); write the output elsewhere")


#: A sample more than this many times the data's robust peak (the
#: SPIKE_COUNT-th largest magnitude) is taken for a corrupt one: no receiver
#: puts a handful of samples 40 dB above everything else, since a real echo
#: covers a range resolution (several gates, or every frequency sample) at
#: many antennas.  A flipped exponent bit (-3.6e64 in one sample) made a run
#: of 1.1 s take two minutes and 2992 clusters.
SPIKE_FACTOR = 100.0
#: How many of the largest samples may be spikes: the robust peak is the
#: magnitude ranked just below them (at least one in 10 000 samples).
SPIKE_COUNT = 16


def drop_spikes(values: np.ndarray, name: str) -> np.ndarray:
    """``values`` with corrupt samples (:data:`SPIKE_FACTOR`) replaced and a
    :class:`DataWarning` naming how many; the same array where there are none.

    A corrupt sample becomes the mean of its sound neighbours along the last
    axis (range gates, or frequency samples: both oversample what they hold,
    so the mean is close to what was there; zero left a notch in an echo
    that moved its points), or zero where it has none.

    Parameters
    ----------
    values : ndarray, complex, any shape
        Samples (``signal`` or ``spectrum``); non-finite ones are left for
        :class:`RadarData` to refuse.
    name : str
        The dataset's name, for the warning.
    """
    import warnings

    mag = np.abs(values).astype(np.float64).ravel()  # the threshold may exceed float32
    if not np.all(np.isfinite(mag)):
        return values
    m = max(SPIKE_COUNT, mag.size // 10_000)
    if mag.size <= m:
        return values
    robust = float(np.partition(mag, mag.size - m - 1)[mag.size - m - 1])
    bad = mag > SPIKE_FACTOR * robust
    if robust <= 0 or not bad.any():
        return values
    out = np.array(values, copy=True)
    flat = out.reshape(-1, out.shape[-1])
    bad = bad.reshape(flat.shape)
    rows, cols = np.nonzero(bad)
    sound = np.zeros(len(rows))
    total = np.zeros(len(rows), flat.dtype)
    for step in (-1, 1):
        nb = cols + step
        ok = (nb >= 0) & (nb < flat.shape[1])
        ok[ok] &= ~bad[rows[ok], nb[ok]]
        total[ok] += flat[rows[ok], nb[ok]]
        sound += ok
    flat[rows, cols] = np.where(sound > 0, total / np.maximum(sound, 1), 0)
    warnings.warn(
        f"{name}: {len(rows)} sample(s) more than {SPIKE_FACTOR:g} times the "
        f"data's robust peak ({robust:.3g}) look corrupt and were replaced by their "
        f"neighbours' mean",
        DataWarning,
        stacklevel=2,
    )
    return out
