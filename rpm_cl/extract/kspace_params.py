"""Settings of the k-space decomposition (:mod:`rpm_cl.extract.kspace`):
:class:`KSpaceParams` and the bound on its zero-padding factor.

The steps named in the docstrings below ("module notes, step N") are those
of the notes of :mod:`rpm_cl.extract.kspace`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..io.data import InputError

#: Largest zero-padding factor of the k-space FFT: beyond it the k samples
#: are finer than a 64th of the aperture's resolution cell, which locates
#: no peak better, while memory grows with it (a factor of 1e9 asked for
#: exabytes).
PAD_MAX = 64


@dataclass(frozen=True)
class KSpaceParams:
    """Settings of the decomposition.

    Attributes
    ----------
    window_x : float
        Raised-cosine window period (full width) along k_x, rad/m (paper: 417).
    window_z : float or None
        Same along k_z for planar arrays, rad/m; None = ``window_x``.
    close_centres : bool or None
        Keep cluster centres down to one aperture resolution cell ``2 pi /
        L`` apart in k on linear arrays (step 2 of the module notes), rather
        than a quarter window period: targets closer in direction than that
        (7 degrees at broadside for the paper's period at 21 GHz) then get a
        centre each.  None (default): the method decides: phase-rpm does,
        kspace-rpm (the paper's method) does not.  Planar arrays keep the
        quarter period, and the near-field decomposition of sparse arrays
        (``near_field``) has its own search.
    coherent_centres : bool or None
        On a linear array whose band is at least a fifth of its carrier, add
        a centre at each peak of the coherent (delay-and-sum) image over the
        searched gates that no centre of the map lies near (step 2 of the
        module notes): a weak echo on the flank of a strong one's spread in
        (k, R) is no maximum of the map, but the image focuses it.  None
        (default): the method decides: phase-rpm does, kspace-rpm (the
        paper's method) does not.  Planar arrays and the near-field
        decomposition do not read it.
    pad : int
        Zero-padding factor of the FFT along each array axis (1 .. PAD_MAX = 64).
    peak_threshold_db : float
        Cluster centres below this level relative to max |S| are ignored, dB (< 0).
    detect_taper : bool
        Search the centres on the Hann-tapered spectrum (default True).
    range_gate : float or None
        Half-width of the range interval kept per cluster, m; None = the
        nominal range resolution c / 2B.
    align : bool or None
        Align each cluster's envelopes across the array before windowing
        (step 4 of the module notes).  None (default): align when the array
        is at least a quarter of the range resolution long, i.e. when a target's
        range walk across it can be a sizeable fraction of the resolution (the
        paper's 3-D case: 0.13 m against 0.05 m); for shorter arrays (the
        paper's 2-D case: 0.1 m against 0.75 m) it is measured to cost more,
        through interpolation and leakage, than it gains.
    near_field : bool or None
        Use the near-field decomposition (:mod:`rpm_cl.extract.nearfield`, linear
        arrays only); None = where the pitch is half a wavelength or more and
        the aperture is at most 1.2 range resolutions long
        (:func:`rpm_cl.extract.nearfield.near_field_wanted`) and its focused
        map fits ``MAP_TERMS_MAX`` terms (else the plane-wave path; True
        refuses such a map).
    focus : bool or None
        Remove each aligned cluster's wavefront curvature (step 5 of the
        module notes).  None (default): where the curvature phase at the
        array's corners exceeds pi at the cluster's range.
    autofocus : bool
        With focusing, fit the wavefront curvature of each cluster along each
        array axis (step 6 of the module notes) rather than take that of a
        point at the cluster's range (default True).
    noise_pfa : float or None
        Noise floor of the centre search (step 2 of the module notes): the
        probability that pure noise yields a cluster anywhere in the (k, R)
        map; a centre must also exceed that floor.  None: no floor, only
        ``peak_threshold_db``.
    noise_power : float or None
        Noise power per sample of the range profiles (mean |noise|^2, in the
        signal's units squared), e.g. measured on an empty frame.  None:
        estimated from the data where that is sound (the range axis spans at
        least :data:`rpm_cl.extract.kspace.NOISE_ESTIMATE_CELLS` range
        resolutions, so that most gates hold no echo), else no floor.
    skip_gates : bool
        Skip the range gates that cannot hold a centre (module notes, step 2;
        exact).  False transforms and searches every gate: the reference the
        skip is tested and benchmarked against.
    """

    window_x: float = 417.0
    window_z: float | None = None
    close_centres: bool | None = None
    coherent_centres: bool | None = None
    pad: int = 4
    peak_threshold_db: float = -20.0
    range_gate: float | None = None
    detect_taper: bool = True
    align: bool | None = None
    near_field: bool | None = None
    focus: bool | None = None
    autofocus: bool = True
    noise_pfa: float | None = 1e-3
    noise_power: float | None = None
    skip_gates: bool = True

    def __post_init__(self):
        for name in ("window_x", "window_z", "range_gate"):
            v = getattr(self, name)
            if v is not None and not (np.isfinite(v) and v > 0):
                raise InputError(f"{name} must be > 0, got {v}")
        try:
            pad_ok = 1 <= float(self.pad) <= PAD_MAX and int(self.pad) == self.pad
        except (TypeError, ValueError, OverflowError):  # NaN passes the first test
            pad_ok = False
        if not pad_ok:
            raise InputError(f"pad must be an integer from 1 to {PAD_MAX}, got {self.pad}")
        if not (np.isfinite(self.peak_threshold_db) and self.peak_threshold_db < 0):
            raise InputError(f"peak_threshold_db must be < 0, got {self.peak_threshold_db}")
        if self.noise_pfa is not None and not (0 < self.noise_pfa < 1):
            raise InputError(f"noise_pfa must be in (0, 1) or None, got {self.noise_pfa}")
        if self.noise_power is not None and not (
            np.isfinite(self.noise_power) and self.noise_power >= 0
        ):
            raise InputError(f"noise_power must be >= 0 or None, got {self.noise_power}")
        if self.close_centres not in (None, True, False):
            raise InputError(
                f"close_centres must be True, False or None, got {self.close_centres!r}"
            )
        if self.coherent_centres not in (None, True, False):
            raise InputError(
                f"coherent_centres must be True, False or None, got {self.coherent_centres!r}"
            )
        if self.near_field not in (None, True, False):
            raise InputError(f"near_field must be True, False or None, got {self.near_field!r}")
