"""The medium a linear scan's hyperbola apexes imply: the coherent focus at
each apex, against ``eps_r``.

A point at true depth ``d`` below the antennas' line, in a homogeneous
medium of index ``n``, has the air-equivalent range

    R(x) = sqrt(R0^2 + eps_r (x - x0)^2),   R0 = n d,

and its echo, range-compressed, carries the phase ``-2 k_c R(x)``
(:func:`rpm_cl.baselines.das.das_numpy`'s convention), so the sum

    D(eps) = | sum_a s_a(R_a) exp(+j 2 k_c R_a) | / (sum_a |s_a(R_a)| + N f |s_apex|)

over the N antennas within ``R0`` of the apex in x (f = :data:`FLOOR`) is
near 1 at the true ``eps_r`` and falls where the trial curve leaves the
echo's phase or the echo.  Each
apex candidate (a local maximum of the echo envelope over half a range
resolution either way) is focused over a small grid of apex positions
(half a range resolution either way, steps of an eighth and a sixteenth of
a wavelength) for every ``eps_r`` of a geometric grid; the ``eps_r`` of the
best focus is that apex's reading.

This reads the curvature from the echoes' phase, where the envelope peaks
that :func:`rpm_cl.extract.hyperbola.tracks` links cannot: bars 0.15 m
apart under a GPR line, each visible over +-0.08 m of the scan, walk less
than a range resolution and their envelopes merge, so no track is long
enough to fit.  Two conditions keep it to data that pin the curvature
(measured with ``python benchmarks/medium_apex.py --gprmax DATA``):

- the antennas see the apex :data:`SEEN_DEG` either side in the medium
  its reading names (``tan(SEEN_DEG) R0 / sqrt(eps_r)`` of scan either
  side): over a narrower angle the focus trades ``eps_r`` against the apex
  position (20 random gprMax air scenes at four bands: 6 of 80 runs read
  above 1.5 from every apex, none is read with this condition);
- a band of at least :data:`MIN_FRACTIONAL_BAND` of the centre frequency
  (a 1.6 GHz GSSI antenna's Hann band is 0.49 of it), so that the
  envelope's peak places the apex within about a wavelength and the grid
  of apex positions stays small.

A trial curve that leaves the record over the aperture is not read
(:data:`MIN_INSIDE`).  A lone echo reads its ``eps_r`` to 2 %; the tails of neighbouring echoes
inside the aperture pull the reading, mostly up (docs/decisions.md).
:func:`rpm_cl.extract.hyperbola.check_medium` uses it where no track
qualifies.
"""

from __future__ import annotations

import numpy as np

from ..filters import maximum_filter
from ..io.medium import EPS_R_MAX

__all__ = ["MIN_APEXES", "MIN_COHERENCE", "MIN_FRACTIONAL_BAND", "apex_eps_r", "focus_curve"]

#: Trial eps_r: a geometric grid from 0.5 (extended targets read below 1) to
#: EPS_R_MAX, steps of about 10 %
#: (refined by a parabola through the best value and its neighbours).
EPS_GRID = np.geomspace(0.5, EPS_R_MAX, 56)
#: Least band over centre frequency of a scan that is read (module notes;
#: the paper's narrow-band scenes, 0.0125, are not).
MIN_FRACTIONAL_BAND = 0.4
#: Least coherence D of an apex's best focus that counts: on lines of white
#: noise (tests/test_apex.py's geometry, 50 seeds) the strongest maxima focus
#: at up to 0.58, never three in one line; the bars of
#: ``benchmarks/medium_apex.py``'s lines at 0.60-0.93.
MIN_COHERENCE = 0.6
#: Fewest apexes whose readings make an estimate.
MIN_APEXES = 3
#: Most apex candidates focused (the strongest): enough for a median, and
#: 90-220 ms a reading on the 200-300 antennas of the lines of
#: ``benchmarks/medium_apex.py``.
MAX_APEXES = 16
#: Envelope maxima below this level (dB from the strongest) are no candidates.
APEX_THRESHOLD_DB = -20.0
#: Least share of the aperture's antennas whose trial range lies inside the
#: record for a focus to count (deep maxima of a recorder's gained noise, at
#: steep trial curves that leave the record, would focus on the few samples
#: left inside and read eps_r in the tens).
MIN_INSIDE = 0.9
#: A floor under the focus's divisor, per antenna, as a share of the apex's
#: own amplitude (-34 dB).  Without it a steep trial curve that leaves a
#: noise-free echo at once keeps the apex's sample alone and focuses at
#: D ~ 1: lines of bars in eps_r 5-9 read 40-87 (tests/test_apex.py).  A
#: share of 0.01 leaves +29 % on a row 0.08 m apart, 0.03 reads nothing on
#: a new user's 1.6 GHz line (eps_r 8) that 0.02 reads 8.5.
FLOOR = 0.02
#: Most antennas summed per focus (an evenly strided subset beyond it).
MAX_ANTENNAS = 96
#: Least angle, deg, either side of an apex over which the antennas see it,
#: in the medium its reading names (``tan(SEEN_DEG) R0 / sqrt(eps_r)`` of
#: scan either side; module notes).  On the 80 random gprMax air runs of
#: ``benchmarks/medium_apex.py`` no apex is read from 30 degrees up, and at
#: 20 two runs read 2.8 and 5.9; the rebar fixture's bars (eps_r 6, 61
#: antennas) are read at 40 (5.90) and at 30.
SEEN_DEG = 40.0


def focus_curve(x, s, rng, kc, x0, r0, half, eps=EPS_GRID, lam=None, floor=0.0):
    """Best coherence D(eps) of one apex over a grid of apex positions.

    Parameters
    ----------
    x : ndarray, shape (A,)
        Antenna positions along the line, m.
    s : complex ndarray, shape (A, G)
        Range profiles on the gates ``rng`` (uniform, m, air-equivalent).
    rng : ndarray, shape (G,)
    kc : float
        Centre wavenumber, rad/m.
    x0, r0 : float
        The apex candidate: antenna position and air-equivalent range, m.
    half : float
        Half-width of the grid of apex positions in x and in range, m.
    eps : ndarray, shape (E,)
        Trial relative permittivities.
    lam : float, optional
        Wavelength setting the grid's steps (lam / 8 in x, lam / 16 in
        range); default ``2 pi / kc``.
    floor : float
        Added to the divisor per antenna (the magnitude :data:`FLOOR` of
        the apex's amplitude, in ``s``'s unit); 0: the plain coherence.

    Returns
    -------
    ndarray, shape (E,)
        The largest D over the grid for each trial eps_r, in [0, 1].
    """
    lam = 2 * np.pi / kc if lam is None else lam
    gx = x0 + np.arange(-half, half + 1e-12, lam / 8)
    gr = r0 + np.arange(-half, half + 1e-12, lam / 16)
    gr = gr[gr > 0]
    dr = float(rng[1] - rng[0])
    ai = np.arange(x.size)
    out = np.empty(len(eps))
    for i, e in enumerate(eps):
        ra = np.sqrt(gr[None, :, None] ** 2 + e * (x[None, None, :] - gx[:, None, None]) ** 2)
        g = (ra - rng[0]) / dr
        inside = (g >= 0) & (g < rng.size - 1)
        g = np.clip(g, 0, rng.size - 1 - 1e-9)
        k = g.astype(np.int64)
        f = g - k
        v = (1 - f) * s[ai, k] + f * s[ai, k + 1]
        v = np.where(inside, v, 0)
        num = np.abs(np.sum(v * np.exp(2j * kc * ra), axis=-1))
        den = np.sum(np.abs(v), axis=-1) + floor * x.size
        # a curve that leaves the record over the aperture is not read: the
        # few samples left inside would focus by chance
        num = np.where(np.mean(inside, axis=-1) >= MIN_INSIDE, num, 0.0)
        out[i] = float(np.max(num / np.maximum(den, 1e-300)))
    return out


def _refined(curve, eps):
    """The eps_r of the curve's maximum, a parabola through it and its
    neighbours in log eps_r; None at the grid's ends."""
    i = int(np.argmax(curve))
    if i == 0 or i == len(curve) - 1:
        return None
    y0, y1, y2 = curve[i - 1], curve[i], curve[i + 1]
    den = y0 - 2 * y1 + y2
    t = 0.5 * (y0 - y2) / den if den < 0 else 0.0
    le = np.log(eps)
    return float(np.exp(le[i] + t * (le[i + 1] - le[i])))


def apex_eps_r(data, angle_check: bool = True) -> tuple[float, int, float]:
    """``eps_r`` from the focus at a linear scan's hyperbola apexes.

    Parameters
    ----------
    data : RadarData
        Range-compressed data of a linear array (air-equivalent ranges), as
        imaged (after the steps before imaging).
    angle_check : bool
        Read only apexes the antennas see :data:`SEEN_DEG` either side in
        the medium of the reading (module notes); False reads every apex
        (a measurement of what the condition keeps out,
        ``benchmarks/medium_apex.py``).

    Returns
    -------
    (float, int, float)
        The median reading of the apexes that focus (coherence at least
        :data:`MIN_COHERENCE`, a maximum inside the eps_r grid), how many
        did, and the median's standard error (1.2533 * 1.4826 * MAD /
        sqrt(n), at least 5 % of it for the grid's and the model's
        resolution); ``(nan, 0, inf)`` where the data do not qualify
        (module notes) or fewer than :data:`MIN_APEXES` apexes focus.
    """
    none = (float("nan"), 0, float("inf"))
    if data.array.planar or data.range.size < 3:
        return none
    w = data.waveform
    if not w.bandwidth >= MIN_FRACTIONAL_BAND * w.fc:
        return none
    x = np.asarray(data.array.x, np.float64)
    s = data.signal.reshape(x.size, -1)
    rng = np.asarray(data.range, np.float64)
    env = np.abs(s)
    top = float(env.max()) if env.size else 0.0
    if not top > 0 or x.size < 3:
        return none
    res, dr = w.range_resolution, float(data.dr)
    na = max(1, round(0.5 * res / data.array.dx))  # the axis is uniform and increasing
    ng = max(1, round(0.5 * res / dr))
    peak = (env == maximum_filter(env, (2 * na + 1, 2 * ng + 1), mode="nearest")) & (
        env >= top * 10 ** (APEX_THRESHOLD_DB / 20)
    )
    ia, ig = np.nonzero(peak)
    r0 = rng[ig]
    x0 = x[ia]
    ok = (ig > ng) & (ig < rng.size - 1 - ng) & (r0 > 0.5 * res)
    # the antennas must see each apex SEEN_DEG either side in the medium its
    # reading names: tan(SEEN_DEG) R0 / sqrt(eps_r) of scan either side,
    # at least the share EPS_R_MAX allows
    seen = np.minimum(x0 - x.min(), x.max() - x0) / np.maximum(r0, 1e-300)
    need = np.tan(np.deg2rad(SEEN_DEG)) if angle_check else 0.0
    ok &= seen >= need / np.sqrt(EPS_R_MAX)
    ia, ig, seen = ia[ok], ig[ok], seen[ok]
    order = np.argsort(env[ia, ig], kind="stable")[::-1][:MAX_APEXES]
    readings = []
    for a, g, sn in zip(ia[order], ig[order], seen[order]):
        near = np.flatnonzero(np.abs(x - x[a]) <= rng[g])
        near = near[:: max(1, int(np.ceil(near.size / MAX_ANTENNAS)))]
        curve = focus_curve(
            x[near], s[near], rng, w.kc, x[a], rng[g], 0.5 * res, floor=FLOOR * env[a, g]
        )
        e = _refined(curve, EPS_GRID)
        if e is not None and curve.max() >= MIN_COHERENCE and sn >= need / np.sqrt(e):
            readings.append(e)
    if len(readings) < MIN_APEXES:
        return none
    e = np.asarray(readings)
    value = float(np.median(e))
    mad = float(np.median(np.abs(e - value)))
    err = max(1.2533 * 1.4826 * mad / np.sqrt(e.size), 0.05 * value)
    return value, int(e.size), err
