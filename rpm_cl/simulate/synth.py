"""Geometric-optics forward model: scene -> range-compressed profiles s(X[,Z],R).

Model
-----
*Echoes.*  For each antenna and target, one monostatic specular echo
(geometric optics): a point target reflects from its position; an ellipse or
ellipsoid from its nearest (specular) point, :func:`rpm_cl.simulate.scene.specular_point`.
A specular path that crosses another ellipsoid is dropped.  Echoes interfere
(they add coherently); there is no multiple scattering.

*Amplitudes* (ray-tube divergence, perfectly conducting surface, distance d,
principal radii of curvature rho_k at the specular point):

- 3-D: ``sqrt(rho1 rho2 / ((rho1 + d)(rho2 + d))) / (2 d)`` -- which tends to
  ``sqrt(sigma/pi) / (2 d^2)`` with the GO cross-section ``sigma = pi rho1 rho2``
  when rho << d; point target ``amplitude / d^2``;
- 2-D: ``sqrt(rho / (2 d (rho + d)))``; point target ``amplitude / d``.

*Waveform.*  The transmit pulse has the amplitude spectrum
``P(f) = cos^2(pi f / (2 B))`` for ``|f| < B`` around ``fc`` (full width at half
amplitude = B, nominal range resolution ``c / 2B``).  The received baseband
spectrum at an antenna is ``Y(f) = P(f) sum_e a_e exp(-j 2 pi (fc + f) 2 R_e / c)``.

*Noise.*  S/N is the paper's "peak instantaneous signal power / average
noise power"; two models (``noise=``) differ in where that ratio is taken.

- ``"in-band"`` (default): complex white Gaussian noise of variance
  ``sigma^2`` is added to every in-band frequency sample ``Y(f)``
  (``|f| < B``, the bins of the receiver's DFT) before the matched filter,
  and S/N is measured *after* it: the peak is
  ``max |s_clean(R)|^2`` over all antennas and ranges of the noise-free
  matched-filter output (taken on a range grid of ``c / (64 B)``, 1/32 of
  the resolution, over the whole period of the bins, so it is the peak of
  the continuous output, not of the requested gates), and the matched
  filter leaves noise of power ``sigma^2 sum|P|^2 / (sum|P|^2)^2`` per range
  gate, so ``sigma^2 = peak sum|P|^2 / 10^(SNR/10)``.  The S/N then does not
  depend on the range axis (its spacing or length) nor on the number of
  frequency samples: it is what a range profile shows.
- ``"receiver"`` (the model with which ``rpm-cl reproduce`` and the paper's
  tables are reproduced; ``benchmarks/noise_bandwidth.py`` shows why the
  paper's 10 and 0 dB rows depend on it): noise added to the *received*
  signal before matched filtering, at the receiver sample rate
  ``receiver_fs``, by default the rate of the range axis's time grid,
  ``fs = c / (2 dr)`` (a time sample per range gate, as a time-domain
  simulator on that grid would have; never below ``2 B``), over a window
  long enough for the range axis plus 8 resolution cells.  The noise is
  white over that band, so the matched filter (band ``2 B``) keeps a
  fraction ``2 B / fs`` of it, and it gathers the pulse's spectrum into its
  peak, a further ``sum|P|^2 N / (sum P)^2 = 1.5`` for the cos^2 spectrum
  over N bins: the S/N *after* matched filtering, the in-band model's, is
  higher by ``10 log10(1.5 fs / 2B)`` dB (23.5 dB for the paper's 2-D case,
  0.2 GHz and 2.5 mm gates; 11.8 dB for the human body's 3 GHz).  Pass
  ``receiver_fs = 2 B`` for a receiver whose noise bandwidth equals the
  signal's.  The signal power is the peak over all
  antennas and all times of ``|r(t)|^2``, evaluated on a 16-times
  oversampled time grid; complex white Gaussian noise of variance
  ``sigma^2 = peak / 10^(SNR/10)`` per receiver sample is added to every
  antenna (done in the frequency domain with a unitary DFT, which is the
  same thing).

*Matched filter.*  ``s(R) = sum_f P*(f) Y(f) exp(j 4 pi f R / c) / sum_f |P(f)|^2``
evaluated directly on the requested range axis, so a lone echo of amplitude
``a`` peaks at ``|s| = a`` with phase ``exp(-j 2 k_c R_e)``.
"""

from __future__ import annotations

import numpy as np

from ..io.data import C0, Array, InputError, RadarData, Truth, Waveform
from .scene import Ellipsoid, PointTarget, Scene, boundary_samples, specular_point

__all__ = ["NOISE_MODELS", "echoes", "simulate", "simulate_preset", "synthesize"]

#: Noise models of :func:`synthesize` (module notes, *Noise*).
NOISE_MODELS = ("in-band", "receiver")


def _blocked(start: np.ndarray, end: np.ndarray, ell: Ellipsoid) -> np.ndarray:
    """True where the open segment start->end crosses ``ell``.

    Parameters
    ----------
    start, end : ndarray, shape (n, dim)
    """
    rot = ell.rotation
    q0 = ((start - ell.center) @ rot) / ell.semi_axes
    dq = ((end - start) @ rot) / ell.semi_axes
    a = np.sum(dq * dq, axis=1)
    b = 2 * np.sum(q0 * dq, axis=1)
    c = np.sum(q0 * q0, axis=1) - 1.0
    disc = b * b - 4 * a * c
    hit = disc > 0
    sq = np.sqrt(np.where(hit, disc, 0.0))
    t1 = (-b - sq) / (2 * a)
    t2 = (-b + sq) / (2 * a)
    eps = 1e-9
    return hit & (t2 > eps) & (t1 < 1 - eps)


def echoes(scene: Scene, array: Array):
    """Specular echoes of every target at every antenna.

    Parameters
    ----------
    scene : Scene
    array : Array
        Must match the scene's dimension (linear for 2-D, planar for 3-D).

    Returns
    -------
    antenna : ndarray of int, shape (E,)
        Flat antenna index of each echo.
    rng : ndarray, shape (E,)
        Echo range, m.
    amp : ndarray, shape (E,)
        Echo amplitude (real, > 0).
    target : ndarray of int, shape (E,)
        Index of the target in ``scene.targets``.
    """
    if scene.dim != array.dim:
        raise InputError(f"scene is {scene.dim}-D but the array is {array.dim}-D")
    pos = array.positions()
    n = len(pos)
    ells = [(k, t) for k, t in enumerate(scene.targets) if isinstance(t, Ellipsoid)]
    out_a, out_r, out_m, out_t = [], [], [], []
    for k, tgt in enumerate(scene.targets):
        if isinstance(tgt, PointTarget):
            spec = np.broadcast_to(tgt.position, pos.shape)
            d = np.linalg.norm(spec - pos, axis=1)
            amp = tgt.amplitude / d ** (scene.dim - 1)
        else:
            spec, d, radii = specular_point(tgt, pos)
            if np.any(np.isnan(d)):
                raise InputError(f"an antenna lies inside target {k}")
            rr = radii
            if scene.dim == 2:
                rho = rr[:, 0]
                amp = tgt.amplitude * np.sqrt(rho / (2 * d * (rho + d)))
            else:
                amp = (
                    tgt.amplitude
                    * np.sqrt(rr[:, 0] * rr[:, 1] / ((rr[:, 0] + d) * (rr[:, 1] + d)))
                    / (2 * d)
                )
        keep = d > 0
        for k2, other in ells:
            if k2 != k:
                keep &= ~_blocked(pos, spec, other)
        idx = np.nonzero(keep)[0]
        out_a.append(idx)
        out_r.append(d[idx])
        out_m.append(amp[idx])
        out_t.append(np.full(idx.size, k))
    return (
        (np.concatenate(out_a), np.concatenate(out_r), np.concatenate(out_m), np.concatenate(out_t))
        if n
        else (np.zeros(0, int),) * 4
    )


def _receiver_grid(waveform: Waveform, r_max: float):
    """In-band frequency bins (|f| < B) of the receiver's DFT and P(f) there.

    Returns
    -------
    f : ndarray, shape (nf,)
        Baseband frequencies, Hz, spaced 1 / window.
    p : ndarray, shape (nf,)
        Transmit amplitude spectrum.
    window : float
        Length of the receiver's time window, s.
    """
    bw = waveform.bandwidth
    window = 2.0 * (r_max + 8.0 * waveform.range_resolution) / C0  # s
    half = int(np.ceil(bw * window))
    f = np.arange(-half, half + 1) / window
    p = np.where(np.abs(f) < bw, np.cos(np.pi * f / (2 * bw)) ** 2, 0.0)
    keep = p > 0
    return f[keep], p[keep], window


def synthesize(
    antenna,
    rng_e,
    amp,
    n_antennas: int,
    waveform: Waveform,
    range_axis,
    snr_db: float | None = None,
    rng: np.random.Generator | None = None,
    receiver_fs: float | None = None,
    progress: bool | None = False,
    noise: str = "in-band",
):
    """Matched-filter output of a set of echoes, with optional noise.

    Parameters
    ----------
    antenna : ndarray of int, shape (E,)
        Flat antenna index of each echo.
    rng_e : ndarray, shape (E,)
        Echo ranges, m.
    amp : ndarray, shape (E,)
        Echo amplitudes (real or complex).
    n_antennas : int
    waveform : Waveform
    range_axis : ndarray, shape (nr,)
        Output range gates, m.
    snr_db : float or None
        Peak-signal-to-average-noise power ratio, dB, as ``noise`` defines
        it; None for noise-free data.
    rng : numpy.random.Generator, optional
        Noise source (required when ``snr_db`` is given).
    receiver_fs : float, optional
        ``noise="receiver"`` only: complex sample rate of the received
        signal, Hz, over which the noise is white; default
        ``max(c / (2 dr), 2 B)`` for the spacing ``dr`` of ``range_axis``.
        Must be >= 2 B.
    progress : bool or None
        Progress bar on stderr (:func:`rpm_cl.progress.progress`): False
        none (default), None on a terminal, True always.
    noise : {"in-band", "receiver"}
        Noise model (module notes, *Noise*): ``"in-band"`` white noise on
        the in-band frequency samples with S/N measured after the matched
        filter, ``sigma^2 = peak sum|P|^2 / 10^(SNR/10)``; ``"receiver"``
        white noise at ``receiver_fs`` with S/N measured before it (the
        model the paper's tables are reproduced with).

    Returns
    -------
    ndarray, complex128, shape (n_antennas, nr)
    """
    if noise not in NOISE_MODELS:
        raise InputError(f"noise must be one of {', '.join(NOISE_MODELS)}, got {noise!r}")
    range_axis = np.asarray(range_axis, np.float64)
    f, p, window = _receiver_grid(waveform, float(range_axis[-1]))
    if noise == "in-band" and receiver_fs is not None:
        raise InputError("receiver_fs applies to noise='receiver' only")
    if receiver_fs is None:
        receiver_fs = max(
            C0 / (2.0 * float(range_axis[1] - range_axis[0])), 2.0 * waveform.bandwidth
        )
    if not (np.isfinite(receiver_fs) and receiver_fs >= 2 * waveform.bandwidth * (1 - 1e-9)):
        raise InputError(f"receiver_fs must be >= 2*bandwidth, got {receiver_fs:g} Hz")
    y = np.zeros((n_antennas, f.size), np.complex128)
    # the work in blocks (echoes, antennas), each block one step of the bar;
    # blocks in order, so the sums are the same as without them
    e_step, a_step, mf_step = max(1, (1 << 22) // max(1, f.size)), 256, 1024
    steps = (
        -(-len(antenna) // e_step)
        + (-(-n_antennas // a_step) if snr_db is not None else 0)
        + -(-n_antennas // mf_step)
    )
    bar = _bar(progress, steps)
    rng_e, amp, antenna = np.asarray(rng_e), np.asarray(amp), np.asarray(antenna)
    for lo in range(0, len(antenna), e_step):
        sl = slice(lo, lo + e_step)
        phase = np.exp(-2j * np.pi * (waveform.fc + f)[None, :] * (2.0 * rng_e[sl, None] / C0))
        np.add.at(y, antenna[sl], amp[sl, None] * phase)
        bar.update()
    y *= p
    p2 = float(np.sum(np.abs(p) ** 2))
    if snr_db is not None:
        if rng is None:
            raise InputError("a noise generator is needed when snr_db is given")
        if noise == "receiver":
            # Y holds the in-band bins of the receiver's unitary DFT of length
            # n_rx: r(t) = sum_k Y_k exp(j 2 pi f_k t) / sqrt(n_rx)
            n_rx = receiver_fs * window
            peak = _peak_power(y, f, np.sqrt(n_rx), waveform, window, a_step, bar)
            # white noise of variance sigma2 per receiver sample has variance
            # sigma2 in every bin of the unitary DFT; out-of-band bins are
            # removed by the matched filter and are not drawn.
            sigma2 = peak / 10.0 ** (snr_db / 10.0)
        else:
            # s(R) = sum_k P_k Y_k exp(j 4 pi f_k R / c) / sum|P|^2, and noise
            # of variance sigma2 per bin leaves sigma2 sum|P|^2 / (sum|P|^2)^2
            peak = _peak_power(y * np.conj(p), f, p2, waveform, window, a_step, bar)
            sigma2 = peak * p2 / 10.0 ** (snr_db / 10.0)
        if peak > 0:
            draw = rng.standard_normal((n_antennas, f.size, 2)) @ np.array([1.0, 1j])
            y += np.sqrt(sigma2 / 2.0) * draw
    mf = np.conj(p)[:, None] * np.exp(4j * np.pi * f[:, None] * range_axis[None, :] / C0)
    out = np.empty((n_antennas, range_axis.size), np.complex128)
    for lo in range(0, n_antennas, mf_step):
        np.matmul(y[lo : lo + mf_step], mf, out=out[lo : lo + mf_step])
        bar.update()
    bar.close()
    out /= p2
    return out


def _peak_power(y, f, norm: float, waveform: Waveform, window: float, a_step: int, bar) -> float:
    """``max |sum_k y_k exp(j 2 pi f_k t) / norm|^2`` over the antennas (rows
    of ``y``) and a time grid 16 times finer than ``1 / (2 B)`` over the
    window (one period of the bins ``f``, so every time is covered; in range,
    ``R = c t / 2``, a grid of ``c / (64 B)``)."""
    n_t = int(np.ceil(16 * 2 * waveform.bandwidth * window))
    t = np.arange(n_t) * (window / n_t)
    kern = np.exp(2j * np.pi * f[:, None] * t[None, :])
    peak = 0.0
    for lo in range(0, y.shape[0], a_step):
        r_t = y[lo : lo + a_step] @ kern / norm
        peak = max(peak, float(np.max(np.abs(r_t) ** 2)) if r_t.size else 0.0)
        bar.update()
    return peak


def _bar(progress, total):
    from ..progress import progress as bar

    return bar(total=total, desc="simulate", enabled=progress, unit="block")


def simulate(
    scene: Scene,
    array: Array,
    waveform: Waveform,
    range_axis,
    snr_db: float | None = None,
    seed: int | None = None,
    boundary_spacing: float = 1e-3,
    receiver_fs: float | None = None,
    progress: bool | None = False,
    noise: str = "in-band",
) -> RadarData:
    """Simulate a scene: echoes, interference, noise, matched filter, truth.

    Parameters
    ----------
    scene : Scene
    array : Array
    waveform : Waveform
    range_axis : ndarray, shape (nr,)
        Uniform output range axis, m.
    snr_db : float or None
        See :func:`synthesize`; None = noise-free.
    seed : int, optional
        Seed of the noise generator (``numpy.random.default_rng``).
    boundary_spacing : float
        Spacing of the true-boundary samples stored for Err_RPM, m.
    receiver_fs : float, optional
        See :func:`synthesize` (``noise="receiver"`` only).
    progress : bool or None
        See :func:`synthesize`.
    noise : {"in-band", "receiver"}
        Noise model, see :func:`synthesize`; ``"receiver"`` reproduces the
        paper's tables.

    Returns
    -------
    RadarData
        With ``truth`` filled: the true RPs and boundary samples.
    """
    if snr_db is not None and not np.isfinite(snr_db):
        raise InputError(f"snr must be finite, got {snr_db}")
    ant, r_e, a_e, _ = echoes(scene, array)
    sig = synthesize(
        ant,
        r_e,
        a_e,
        array.n,
        waveform,
        range_axis,
        snr_db,
        np.random.default_rng(seed),
        receiver_fs,
        progress,
        noise,
    )
    sig = sig.reshape(array.shape + (np.size(range_axis),))
    boundary = np.concatenate([boundary_samples(t, boundary_spacing) for t in scene.targets])
    truth = Truth(ant, r_e, boundary, scene.to_json())
    return RadarData(sig, array, range_axis, waveform, truth)


def simulate_preset(
    name: str,
    snr_db: float | None = None,
    seed: int | None = None,
    progress: bool | None = False,
    noise: str = "in-band",
):
    """Simulate a named preset (:data:`rpm_cl.simulate.scene.PRESETS`); ``progress``
    and ``noise`` as in :func:`synthesize` (``noise="receiver"`` gives the
    data the paper's tables are reproduced with).

    Returns
    -------
    data : RadarData
    preset : rpm_cl.simulate.scene.Preset
    """
    from .scene import get_preset

    preset = get_preset(name)
    data = simulate(
        preset.scene,
        preset.array,
        preset.waveform,
        preset.range_axis,
        snr_db,
        seed,
        boundary_spacing=preset.boundary_spacing,
        progress=progress,
        noise=noise,
    )
    return data, preset
