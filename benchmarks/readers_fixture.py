"""Synthetic recordings for the readers of ``rpm-cl convert``: ``tests/data/readers/``.

No real capture can be downloaded here, so each file is built byte by byte
to its documented layout (the layouts are in the readers' docstrings:
``rpm_cl/io/mapped.py``, ``rpm_cl/io/dzt.py``, ``rpm_cl/io/dca1000.py``), with one
point target at a known place, so that the tests know where its echo must
land:

- ``targets.mat`` (MATLAB v7: compressed v5, ``scipy.io.savemat``) and
  ``targets_v73.mat`` (MATLAB v7.3: HDF5 behind a 512-byte MAT header, every
  array stored with its axes reversed, complex as a compound of ``real`` and
  ``imag``, ``MATLAB_class`` attributes, as MATLAB writes them): a stepped-
  frequency scan ``F`` of shape (nf, nx) as MATLAB holds it, ``f`` (1, nf) in
  Hz, ``da`` (1, nx) in mm, an echo ``a exp(-j 4 pi f R / c)`` per antenna;
- ``scan.dzt``: a GSSI DZT B-scan, 16-bit, one channel, antenna ``51600S``
  (1.6 GHz), 50 scans per metre, a 20 ns window of 512 samples; a Ricker
  pulse of 1.6 GHz (zero phase about its peak) from the target, delayed by
  the round trip after time zero at sample :data:`DZT_TIME_ZERO`, and a
  direct coupling (the same in every trace) at time zero;
- ``capture.bin``: a TI DCA1000 capture, ``complex-2lane`` (xWR16xx/18xx/
  68xx), 4 receivers, 2 chirps per frame, 20 frames with the radar moved
  :data:`DCA["dx"]` between frames; the transmitter sits at receiver 0 and
  receiver ``k`` ``k d`` beside it; each sample is TI's IF
  ``TX conj(RX) = a exp(+j 2 pi (f0 tau + S tau t - S tau^2 / 2))`` of the
  bistatic delay, quantised to int16 with a little seeded noise.

Run from the repository root (rpm-cl's environment; a few seconds)::

    python benchmarks/readers_fixture.py [--out tests/data/readers]
"""

from __future__ import annotations

import argparse
import struct
from pathlib import Path

import numpy as np

C0 = 299_792_458.0

# ------------------------------------------------------------------ scenes
#: Stepped-frequency scan of the MAT files: antennas (mm), band (Hz), target (m).
MAT = {
    "x_mm": np.arange(16) * 4.0 - 30.0,
    "f": 19.5e9 + 0.025e9 * np.arange(41),
    "target": (0.012, 0.45),
    "amplitude": 0.8,
}
#: DZT scan: scans, samples, window (s), scans per metre, antenna, Ricker (Hz),
#: target (m, x along the scan from the first scan, depth in air).
DZT = {
    "scans": 48,
    "samples": 512,
    "window": 20e-9,
    "spm": 50.0,
    "antenna": "51600S",
    "ricker": 1.6e9,
    "target": (0.47, 0.9),
    "coupling": 3.0,
}
#: Time zero of the DZT fixture, samples.
DZT_TIME_ZERO = 40.5
#: DCA1000 capture: chirp (TI profile), capture, geometry (m), target (m).
DCA = {
    "start_freq": 77e9,
    "slope": 29.982e12,
    "adc_rate": 10e6,
    "samples": 64,
    "adc_start_time": 6e-6,
    "receivers": 4,
    "chirps": 2,
    "frames": 20,
    "dx": 1e-3,
    "rx_spacing": C0 / 77e9 / 2,
    "target": (0.011, 1.2),
    "amplitude": 2000.0,
    "noise": 2.0,
    "seed": 7,
}


def mat_spectrum() -> np.ndarray:
    """The MAT files' ``F``, shape (nf, nx) (MATLAB's rows: frequencies)."""
    x = MAT["x_mm"] * 1e-3
    tx, ty = MAT["target"]
    r = np.hypot(x - tx, ty)
    return MAT["amplitude"] * np.exp(-4j * np.pi * np.outer(MAT["f"], r) / C0)


# ------------------------------------------------------------------ MATLAB
def write_mat_v5(path, arrays: dict, compress: bool = True, version: str = "5") -> None:
    """MATLAB v5/v7 (``compress``) or v4 (``version="4"``) through scipy."""
    from scipy.io import savemat

    savemat(path, arrays, do_compression=compress, format=version, oned_as="row")


def write_mat_v73(path, arrays: dict) -> None:
    """A MATLAB v7.3 MAT-file as MATLAB writes one: an HDF5 file with a
    512-byte user block holding the 128-byte MAT header (text, then version
    0x0200 and the endian mark ``IM``); each array (2-D at least, as in
    MATLAB) stored with its axes reversed, a ``MATLAB_class`` attribute, and
    complex values as a compound of ``real`` and ``imag``."""
    import h5py

    classes = {
        np.dtype(np.float64): "double",
        np.dtype(np.float32): "single",
        np.dtype(np.int16): "int16",
        np.dtype(np.int32): "int32",
        np.dtype(np.complex128): "double",
        np.dtype(np.complex64): "single",
    }
    with h5py.File(path, "w", userblock_size=512) as f:
        for name, value in arrays.items():
            v = np.asarray(value)
            if v.ndim < 2:
                v = v.reshape(1, -1) if v.ndim == 1 else v.reshape(1, 1)
            cls = classes[v.dtype]
            stored = v.T  # MATLAB's column-major = HDF5's reversed axes
            if v.dtype.kind == "c":
                part = v.real.dtype
                comp = np.empty(stored.shape, np.dtype([("real", part), ("imag", part)]))
                comp["real"], comp["imag"] = stored.real, stored.imag
                stored = comp
            ds = f.create_dataset(name, data=np.ascontiguousarray(stored))
            ds.attrs.create("MATLAB_class", np.bytes_(cls))
    text = (
        b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 "
        b"HDF5 schema 1.00 ."
    ).ljust(116, b" ")
    header = text + b"\0" * 8 + struct.pack("<H", 0x0200) + b"IM"
    with open(path, "r+b") as fh:
        fh.write(header)


# ------------------------------------------------------------------ GSSI DZT
def dzt_header(
    samples: int,
    bits: int,
    window: float,
    spm: float,
    antenna: str,
    channels: int = 1,
    zero: int | None = None,
    tag: int = 0x00FF,
    rh_data: int = 1024,
    sps: float = 64.0,
    epsr: float = 1.0,
) -> bytes:
    """One 1024-byte DZT channel header (``rpm_cl/io/dzt.py``'s table); the
    binary offset defaults to 0x80 / 0x8000 for 8 / 16 bits, 0 for 32."""
    if zero is None:
        zero = {8: 0x80, 16: 0x8000, 32: 0}[bits]
    h = bytearray(1024)
    struct.pack_into("<HHHHH", h, 0, tag, rh_data, samples, bits, zero)
    struct.pack_into("<fffff", h, 10, sps, spm, 0.0, 0.0, window * 1e9)
    struct.pack_into("<H", h, 52, channels)
    struct.pack_into("<f", h, 54, epsr)
    name = antenna.encode("ascii")[:14]
    h[98 : 98 + len(name)] = name
    h[114:126] = b"FIXTURE.DZT".ljust(12, b"\0")
    return bytes(h)


def ricker(t, f0):
    a = (np.pi * f0 * t) ** 2
    return (1 - 2 * a) * np.exp(-a)


def dzt_traces() -> np.ndarray:
    """The DZT fixture's traces (scans, samples), float: the echo and the
    direct coupling, before quantisation."""
    n, dt = DZT["samples"], DZT["window"] / DZT["samples"]
    t = (np.arange(n) - DZT_TIME_ZERO) * dt
    x = np.arange(DZT["scans"]) / DZT["spm"]
    tx, ty = DZT["target"]
    r = np.hypot(x - tx, ty)
    tau = 2 * r / C0
    echo = (ty / r)[:, None] * ricker(t[None, :] - tau[:, None], DZT["ricker"])
    return echo + DZT["coupling"] * ricker(t, DZT["ricker"])[None, :]


def dzt_bytes(traces: np.ndarray, bits: int = 16, channels: int = 1, **header) -> bytes:
    """Header(s) and quantised samples: unsigned with the binary offset (8,
    16 bits) or signed (32 bits), the first two samples of each trace the
    scan header words (here the scan number and 0); ``traces`` (scans,
    samples) is written to every channel."""
    scans, n = traces.shape
    head = b"".join(
        dzt_header(n, bits, DZT["window"], DZT["spm"], DZT["antenna"], channels, **header)
        for _ in range(channels)
    )
    full = {8: 120, 16: 30000, 32: 1 << 28}[bits]
    q = np.round(traces / np.abs(traces).max() * full)
    if bits < 32:
        q += 1 << (bits - 1)
    q[:, 0] = np.arange(scans)
    q[:, 1] = 0
    dtype = {8: "<u1", 16: "<u2", 32: "<i4"}[bits]
    data = np.repeat(q[:, None, :], channels, axis=1).astype(dtype)
    return head + data.tobytes()


# ------------------------------------------------------------------ TI DCA1000
def dca_if(real: bool = False) -> np.ndarray:
    """TI's IF of the DCA fixture: (frames, chirps, receivers, samples),
    complex (or its real part), before quantisation, with seeded noise."""
    p = DCA
    rng = np.random.default_rng(p["seed"])
    t = p["adc_start_time"] + np.arange(p["samples"]) / p["adc_rate"]
    radar = np.arange(p["frames"]) * p["dx"]  # transmitter x
    rx = radar[:, None] + np.arange(p["receivers"])[None, :] * p["rx_spacing"]
    tx_, ty = p["target"]
    tau = (np.hypot(radar - tx_, ty)[:, None] + np.hypot(rx - tx_, ty)) / C0
    phase = (
        2
        * np.pi
        * (
            p["start_freq"] * tau[..., None]
            + p["slope"] * tau[..., None] * t
            - p["slope"] * tau[..., None] ** 2 / 2
        )
    )
    z = p["amplitude"] * np.exp(1j * phase)  # (frames, rx, n)
    z = np.repeat(z[:, None], p["chirps"], axis=1)
    noise = rng.normal(size=z.shape) + 1j * rng.normal(size=z.shape)
    z = z + p["noise"] * noise
    return z.real if real else z


def dca_values(z: np.ndarray, layout: str) -> np.ndarray:
    """Samples (..., receivers, samples) of whole chirps -> the int16 stream
    of the layout (``rpm_cl/io/dca1000.py``)."""
    z = np.asarray(z)
    rx, n = z.shape[-2:]
    z = z.reshape(-1, rx, n)
    if layout == "real":
        return np.round(z.real).astype("<i2").ravel()
    i, q = np.round(z.real), np.round(z.imag)
    if layout == "complex-2lane":
        ii, qq = i.reshape(-1, 2), q.reshape(-1, 2)  # pairs of successive samples
        return np.stack([ii[:, 0], ii[:, 1], qq[:, 0], qq[:, 1]], axis=1).astype("<i2").ravel()
    lanes = np.zeros((z.shape[0], n, 8))
    lanes[:, :, :rx] = i.transpose(0, 2, 1)
    lanes[:, :, 4 : 4 + rx] = q.transpose(0, 2, 1)
    return lanes.astype("<i2").ravel()


# ------------------------------------------------------------------ main
def write_all(out: Path) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    arrays = {"F": mat_spectrum(), "f": MAT["f"], "da": MAT["x_mm"]}
    write_mat_v5(out / "targets.mat", arrays)
    write_mat_v73(out / "targets_v73.mat", arrays)
    (out / "scan.dzt").write_bytes(dzt_bytes(dzt_traces()))
    (out / "capture.bin").write_bytes(dca_values(dca_if(), "complex-2lane").tobytes())
    return {p.name: p.stat().st_size for p in sorted(out.iterdir()) if p.suffix != ".py"}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="tests/data/readers")
    for name, size in write_all(Path(ap.parse_args().out)).items():
        print(f"{name}: {size} bytes")


if __name__ == "__main__":
    main()
