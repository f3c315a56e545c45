"""Corrupt samples (:func:`drop_spikes`): a handful of samples far above the
data's robust peak, replaced by their neighbours' mean with one warning."""

from __future__ import annotations

import numpy as np

from .checks import DataWarning

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
        :class:`~rpm_cl.io.radar.RadarData` to refuse.
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
