"""One gprMax scan in the time domain (:class:`BScan`) and its antenna
positions: the transmitter/receiver midpoints along the scan line."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .checks import InputError, _finite_scalar
from .gprmax_waveform import SourceWaveform

#: Positions given twice (file and sidecar, scan and background) agree within, m.
POSITION_TOL = 1e-6


@dataclass(frozen=True)
class BScan:
    """Time-domain traces of one monostatic scan.

    Attributes
    ----------
    traces : ndarray, float64, shape (nt, nx)
        Ez, V/m; column i is antenna i.
    dt : float
        Time step, s.
    t0 : float
        Time of sample 0, s (0 for gprMax's E).
    x : ndarray, shape (nx,) or None
        Antenna x (transmitter/receiver midpoint), m, as recorded; None when
        the file holds no positions.
    y : float or None
        The scan line's y in gprMax's frame, m.
    source : str
        The file(s) read, for messages.
    waveform : SourceWaveform or None
        The waveform the file records (gprMax 4 one-file-per-trace output).
    """

    traces: np.ndarray
    dt: float
    t0: float
    x: np.ndarray | None
    y: float | None
    source: str
    waveform: SourceWaveform | None = field(default=None)

    def __post_init__(self):
        tr = np.asarray(self.traces, np.float64)
        if tr.ndim != 2 or tr.shape[0] < 2 or tr.shape[1] < 2:
            raise InputError(
                f"{self.source}: a B-scan needs >= 2 time samples and >= 2 traces, "
                f"got shape {tr.shape}"
            )
        if not np.all(np.isfinite(tr)):
            raise InputError(f"{self.source}: Ez contains NaN or Inf")
        object.__setattr__(self, "traces", tr)
        object.__setattr__(self, "dt", _finite_scalar("dt", self.dt))
        object.__setattr__(self, "t0", _finite_scalar("time offset", self.t0, positive=False))
        if self.x is not None:
            x = np.asarray(self.x, np.float64)
            if x.shape != (tr.shape[1],) or not np.all(np.isfinite(x)):
                raise InputError(
                    f"{self.source}: {tr.shape[1]} traces but positions of shape {x.shape}"
                )
            object.__setattr__(self, "x", x)

    @property
    def duration(self) -> float:
        """Record length ``nt dt``, s."""
        return self.traces.shape[0] * self.dt


def _midpoints(path, pos_rx, pos_tx):
    """(x, y) of the transmitter/receiver midpoints; (None, None) without
    receiver positions."""
    if pos_rx is None:
        return None, None
    mid = pos_rx if pos_tx is None else (pos_rx + pos_tx) / 2
    if np.ptp(mid[:, 1]) > POSITION_TOL or np.ptp(mid[:, 2]) > POSITION_TOL:
        raise InputError(
            f"{path}: the scan must run along x (y and z fixed); y spans "
            f"{mid[:, 1].min():g} .. {mid[:, 1].max():g} m"
        )
    return mid[:, 0], float(mid[0, 1])
