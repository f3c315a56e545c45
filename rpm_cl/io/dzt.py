"""GSSI ``.dzt`` (impulse GPR B-scans) -> the engine's frequency-domain input.

The header is parsed here, from GSSI's published description of the DZT
file (the ``tagRFHeader`` structure of the SIR-3000 / SIR-4000 manuals);
readgssi on PyPI reads the same files but is AGPL-3, which this MIT package
cannot depend on.

Layout
------
The file starts with one 1024-byte header per channel (little-endian; byte
offsets)::

    0   u16  rh_tag       0x00FF documented (0xFnFF older); real files carry
                          others (0x0700), so it is not checked
    2   u16  rh_data      offset to the data: 1024 * rh_data bytes when
                          rh_data < 1024, else 1024 * rh_nchan
    4   u16  rh_nsamp     samples per scan (per channel)
    6   u16  rh_bits      bits per sample: 8, 16 (unsigned) or 32 (signed)
    8   u16  rh_zero      binary offset of unsigned samples (0x80, 0x8000)
    10  f32  rhf_sps      scans per second
    14  f32  rhf_spm      scans per metre (0: time-triggered, no distance)
    18  f32  rhf_mpm      metres per mark
    22  f32  rhf_position position, ns
    26  f32  rhf_range    time window of a scan, ns
    30  u16  rh_npass
    32  u32  rhb_cdt, 36 u32 rhb_mdt   creation / modification dates
    40  u16  rh_rgain, rh_nrgain, rh_text, rh_ntext, rh_proc, rh_nproc
    52  u16  rh_nchan     channels
    54  f32  rhf_epsr     relative permittivity entered in the survey
    58  f32  rhf_top, 62 f32 rhf_depth
    98  char rh_antname[14]   antenna model, NUL-padded
    114 char rh_name[12]
    126 u16  rh_chksum

The data are scans of ``rh_nchan`` traces of ``rh_nsamp`` samples each
(channel after channel), scan after scan, to the end of the file.  The first
two samples of every trace hold the system's scan header words (marks), not
echoes: they are set to the third sample's value.

Conversion
----------
Sample ``n`` of a trace lies at ``t_n = (n - n0) dt``, ``dt = rhf_range /
rh_nsamp``, ``n0`` the time zero (``time_zero``, samples, may be
fractional; default 0, the window's first sample).  Samples before time
zero are set to 0 (the transmitter's direct coupling there would otherwise
wrap to the end of the range axis).  Each trace loses its mean (the binary
offset's remainder), and with ``subtract_mean`` the mean trace of the scan
(the direct coupling and every horizontal band).  Then::

    X(f_k) = sum_n x_n exp(-j 2 pi f_k t_n) dt,   f_k = k / (2 N dt)

(NumPy's FFT sign, the record of ``N`` samples zero-padded to ``2 N`` so that
the range axis holds twice the record and nothing wraps), keeping the
``f_k`` within the band.  A real trace ``a p(t - tau)`` becomes
``a P(f) exp(-j 2 pi f tau)``: with ``R = c tau / 2`` in air that is
``a P(f) exp(-j 4 pi f R / c)``, the schema's echo, times the spectrum
``P(f)`` of the antenna's pulse, which stays in (it is not known for a real
antenna; a pulse centred on its own time zero has a real ``P``).  ``R`` is
the range in air; under ground it is ``sqrt(eps_r)`` times the depth.

Positions: scan ``i`` at ``x = i / rhf_spm`` m, or ``i dx`` with ``dx``.
Band: given, else the antenna's nominal band, ``0.5 .. 1.5`` times its centre
frequency (the usual -3 dB width of an impulse GPR antenna), when the
antenna name says it (a frequency with its unit, or a GSSI model number of
:data:`ANTENNA_MHZ`).
"""

from __future__ import annotations

import math
import os
import re
import struct
import warnings
from dataclasses import dataclass

import numpy as np

from .data import DataWarning, InputError
from .traces import MAX_SAMPLES, line_arrays

__all__ = [
    "ANTENNA_MHZ",
    "HEADER_SIZE",
    "MAX_SAMPLES",
    "DztHeader",
    "convert",
    "nominal_band",
    "read_header",
    "read_traces",
]

#: Bytes of one channel's header.
HEADER_SIZE = 1024
#: Most channels a file may declare.
MAX_CHANNELS = 16
#: Centre frequencies of GSSI antenna models, MHz, by the model number that
#: starts ``rh_antname`` (GSSI's product names).
ANTENNA_MHZ = {
    "3101": 900,
    "3207": 100,
    "5100": 1500,
    "5103": 400,
    "5106": 200,
    "50270": 270,
    "50400": 400,
    "51600": 1600,
    "52600": 2600,
    "62000": 2000,
}

_FIELDS = struct.Struct("<HHHHHfffff")  # offsets 0 .. 30
_NCHAN = struct.Struct("<Hf")  # offsets 52, 54


#: Scans per metre a header may give without ``--dx``: a trace every 100 m
#: to one every 10 um (a corrupt or unset field reads as 1e-30 or 1e30).
SPM_MIN, SPM_MAX = 0.01, 1e5


@dataclass(frozen=True)
class DztHeader:
    """The fields of a DZT header the conversion uses.

    Attributes
    ----------
    tag : int
        ``rh_tag``.
    data_offset : int
        Bytes before the first scan.
    samples : int
        Samples per trace, ``rh_nsamp``.
    bits : int
        8, 16 or 32.
    zero : int
        Binary offset of unsigned (8, 16-bit) samples, ``rh_zero``.
    scans_per_second, scans_per_metre : float
        ``rhf_sps``, ``rhf_spm`` (0 for a time-triggered survey).
    position : float
        ``rhf_position``, s.
    window : float
        The time window of a trace, ``rhf_range``, s.
    channels : int
        ``rh_nchan``.
    epsr : float
        ``rhf_epsr``.
    antennas : tuple of str
        ``rh_antname`` of each channel's header.
    """

    tag: int
    data_offset: int
    samples: int
    bits: int
    zero: int
    scans_per_second: float
    scans_per_metre: float
    position: float
    window: float
    channels: int
    epsr: float
    antennas: tuple

    def __post_init__(self):
        # rh_tag is not checked: GSSI documents 0x00FF (0xFnFF in older
        # files), but a SIR-3000 400 MHz survey (GPRPy's example
        # FILE____032.DZT) carries 0x0700 and reads correctly; the fields
        # below and the file's size judge a stranger's file instead
        if not 1 <= self.channels <= MAX_CHANNELS:
            raise InputError(
                f"rh_nchan {self.channels}: a DZT file holds 1 .. {MAX_CHANNELS} channels"
            )
        if self.bits not in (8, 16, 32):
            raise InputError(f"rh_bits {self.bits}: samples of 8, 16 or 32 bits are read")
        if self.samples < 3:
            raise InputError(
                f"rh_nsamp {self.samples}: a trace needs at least 3 samples (the "
                f"first two are header words)"
            )
        if self.data_offset < HEADER_SIZE * self.channels:
            raise InputError(
                f"data offset {self.data_offset} bytes lies inside the "
                f"{self.channels} channel header(s)"
            )
        if not (math.isfinite(self.window) and self.window > 0):
            raise InputError(f"rhf_range {self.window * 1e9:g} ns: the time window must be > 0")
        if not (math.isfinite(self.scans_per_metre) and self.scans_per_metre >= 0):
            raise InputError(f"rhf_spm {self.scans_per_metre:g}: scans per metre must be >= 0")

    @property
    def dt(self) -> float:
        """Sample interval, s."""
        return self.window / self.samples

    @property
    def scan_bytes(self) -> int:
        """Bytes of one scan (every channel)."""
        return self.channels * self.samples * self.bits // 8


def read_header(path) -> DztHeader:
    """Parse the header(s) of a DZT file (the module docstring's layout).

    Raises
    ------
    InputError
        Shorter than its headers, a sample size other than 8/16/32 bits,
        fewer than 3 samples, a data offset inside
        the headers or beyond the file, a non-positive time window.
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise InputError(f"{path}: no such file")
    size = os.path.getsize(path)
    if size < HEADER_SIZE:
        raise InputError(f"{path}: {size} bytes, shorter than a DZT header ({HEADER_SIZE})")
    with open(path, "rb") as fh:
        head = fh.read(HEADER_SIZE)
        tag, rh_data, nsamp, bits, zero, sps, spm, _mpm, pos, rng = _FIELDS.unpack_from(head, 0)
        nchan, epsr = _NCHAN.unpack_from(head, 52)
        try:
            if not 1 <= nchan <= MAX_CHANNELS:
                raise InputError(f"rh_nchan {nchan}: a DZT file holds 1 .. {MAX_CHANNELS} channels")
            if size < HEADER_SIZE * nchan:
                raise InputError(f"{size} bytes, shorter than its {nchan} channel headers")
            names = [_antenna(head)]
            for k in range(1, nchan):
                fh.seek(HEADER_SIZE * k)
                names.append(_antenna(fh.read(HEADER_SIZE)))
            offset = HEADER_SIZE * rh_data if rh_data < HEADER_SIZE else HEADER_SIZE * nchan
            hdr = DztHeader(
                tag,
                offset,
                nsamp,
                bits,
                zero,
                float(sps),
                float(spm),
                float(pos) * 1e-9,
                float(rng) * 1e-9,
                nchan,
                float(epsr),
                tuple(names),
            )
        except InputError as exc:
            raise InputError(f"{path}: {exc}") from None
    if hdr.data_offset > size:
        raise InputError(
            f"{path}: the data start at byte {hdr.data_offset}, beyond the file's {size} bytes"
        )
    return hdr


def _antenna(head: bytes) -> str:
    return head[98:112].split(b"\0", 1)[0].decode("ascii", "replace").strip()


def nominal_band(antenna: str) -> tuple | None:
    """``(0.5 fc, 1.5 fc)`` Hz for an antenna name that says its centre
    frequency ``fc`` (``"400MHz"``, ``"1.6 GHz"``, or a model number of
    :data:`ANTENNA_MHZ` at its start); None otherwise."""
    m = re.search(r"(\d+(?:\.\d+)?)\s*([MG])HZ", antenna.upper())
    if m:
        fc = float(m.group(1)) * (1e6 if m.group(2) == "M" else 1e9)
    else:
        m = re.match(r"\d+", antenna.strip())
        if not m or m.group(0) not in ANTENNA_MHZ:
            return None
        fc = ANTENNA_MHZ[m.group(0)] * 1e6
    return 0.5 * fc, 1.5 * fc


def read_traces(path, channel: int = 0) -> tuple:
    """The traces of one channel, in sample units with the binary offset removed.

    Parameters
    ----------
    path : str or path-like
    channel : int
        From 0.

    Returns
    -------
    header : DztHeader
    traces : ndarray, float64, shape (scans, samples)
        ``value - rh_zero`` for 8- and 16-bit (unsigned) samples, the value
        for 32-bit (signed) ones; the first two samples set to the third.

    Warns
    -----
    DataWarning
        The data end in a part of a scan (a cut-off recording): it is dropped.
    """
    path = os.fspath(path)
    hdr = read_header(path)
    if (
        isinstance(channel, bool)
        or not isinstance(channel, (int, np.integer))
        or not 0 <= channel < hdr.channels
    ):
        raise InputError(
            f"{path}: channel {channel!r}; the file holds {hdr.channels} (0 .. {hdr.channels - 1})"
        )
    size = os.path.getsize(path)
    n_scans, rest = divmod(size - hdr.data_offset, hdr.scan_bytes)
    if n_scans * hdr.channels * hdr.samples > MAX_SAMPLES:
        raise InputError(
            f"{path}: {n_scans} scans of {hdr.channels} x {hdr.samples} samples, "
            f"more than {MAX_SAMPLES}"
        )
    if n_scans < 2:
        raise InputError(
            f"{path}: {n_scans} scans of {hdr.scan_bytes} bytes after the header; "
            f"a B-scan needs at least 2"
        )
    if rest:
        warnings.warn(
            f"{path}: the data end {rest} bytes into scan {n_scans} (of "
            f"{hdr.scan_bytes} bytes); that part scan is dropped",
            DataWarning,
            stacklevel=2,
        )
    dtype = {8: "<u1", 16: "<u2", 32: "<i4"}[hdr.bits]
    with open(path, "rb") as fh:
        fh.seek(hdr.data_offset)
        buf = fh.read(n_scans * hdr.scan_bytes)
    if len(buf) != n_scans * hdr.scan_bytes:
        raise InputError(f"{path}: the file changed while read")
    raw = np.frombuffer(buf, dtype).reshape(n_scans, hdr.channels, hdr.samples)[:, channel]
    tr = raw.astype(np.float64)
    if hdr.bits < 32:
        tr -= hdr.zero
    tr[:, :2] = tr[:, 2:3]
    return hdr, tr


def convert(
    path,
    band=None,
    dx: float | None = None,
    time_zero: float = 0.0,
    channel: int = 0,
    subtract_mean: bool = False,
) -> dict:
    """A DZT B-scan -> ``spectrum``, ``frequency``, ``x`` (the module docstring).

    Parameters
    ----------
    path : str or path-like
        The ``.dzt`` file.
    band : (float, float), optional
        ``f0 < f1``, Hz, at most the Nyquist frequency ``1 / (2 dt)``;
        default the antenna's nominal band (:func:`nominal_band`).
    dx : float, optional
        Scan spacing, m; default ``1 / rhf_spm`` (required for a
        time-triggered survey, ``rhf_spm = 0``).
    time_zero : float
        The sample of time zero (the transmit instant), >= 0, may be
        fractional.
    channel : int
        Channel, from 0.
    subtract_mean : bool
        Subtract the mean trace (direct coupling, ground bounce, every
        horizontal band).

    Returns
    -------
    dict
        ``spectrum`` complex128 ``(scans, nf)`` (sample units x s),
        ``frequency`` ``(nf,)`` Hz, ``x`` ``(scans,)`` m from 0,
        ``record_range`` the range the record covers after time zero, m
        (``(N - n0) dt c / 2``: the gates beyond it, the zero padding's,
        are dropped on loading).

    Raises
    ------
    InputError
        The header's (:func:`read_header`), no band given nor known from the
        antenna, a band beyond the Nyquist frequency or with fewer than 2
        samples, no distance (``rhf_spm = 0`` and no ``dx``), a time zero
        outside the trace.
    """
    path = os.fspath(path)
    hdr, tr = read_traces(path, channel)
    antenna = hdr.antennas[channel]
    if band is None:
        band = nominal_band(antenna)
        if band is None:
            raise InputError(
                f"{path}: no band given and none known for antenna "
                f"{antenna or '(unnamed)'!r}: give --band F0:F1 (Hz)"
            )

    def spacing():
        if hdr.scans_per_metre == 0:
            raise InputError(
                f"{path}: a time-triggered survey (0 scans per metre): give the "
                f"scan spacing (--dx M)"
            )
        if not SPM_MIN <= hdr.scans_per_metre <= SPM_MAX:
            raise InputError(
                f"{path}: the header's {hdr.scans_per_metre:g} scans per metre (a "
                f"{1.0 / hdr.scans_per_metre:.3g} m trace spacing) is no survey's: give the "
                f"scan spacing (--dx M)"
            )
        return 1.0 / hdr.scans_per_metre

    return line_arrays(
        path, tr, hdr.dt, band, spacing if dx is None else dx, time_zero, subtract_mean
    )
