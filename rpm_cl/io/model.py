"""The parts of radar data: the speed of light :data:`C0`, the transmit
waveform (:class:`Waveform`), the monostatic antenna array (:class:`Array`)
and the true geometry of a scene (:class:`Truth`).  SI units: metres, hertz,
seconds."""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from .checks import InputError, _finite_scalar, _real_kind, _uniform_axis, carrier

#: Speed of light in vacuum, m/s (the propagation speed in air used throughout).
C0 = 299_792_458.0


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
