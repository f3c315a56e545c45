"""Per-trace time-zero alignment on the direct wave (rpm_cl/extract/alignment.py).

The scans here are written out in the frequency domain by hand (not by the
engine's simulator): an impulse GPR line whose every trace, direct wave and
targets alike, arrives ``delta_i`` late by its sampler's trigger jitter.
"""

import warnings

import numpy as np
import pytest

from rpm_cl.extract.alignment import aligned, profiles, trace_shifts
from rpm_cl.extract.preprocess import preprocess, warn_jitter
from rpm_cl.imaging import run_method
from rpm_cl.io.compress import range_compress, spectrum_data
from rpm_cl.io.data import Array, DataWarning, RadarData
from rpm_cl.io.model import C0
from rpm_cl.rpm import reference
from rpm_cl.rpm.params import default_params

X = np.arange(80) * 0.01
FREQ = np.linspace(1.0e9, 3.0e9, 81)
#: two targets (x, range at closest approach), m, each echo 1/50 of the
#: direct wave
TARGETS = ((0.20, 0.30), (0.60, 0.45))
DIRECT = 0.08  # the direct wave's range, m


def _scan(jitter_m: float, seed: int = 7, direct: float = DIRECT, noise: float = 0.0):
    """Samples ``(nx, nf)`` of the line, and the traces' offsets (m of
    range).  Each echo is ``a exp(-j 4 pi f (R + delta_i) / c)``."""
    rng = np.random.default_rng(seed)
    delta = jitter_m * rng.standard_normal(X.size)
    k = 4 * np.pi * FREQ / C0
    values = np.exp(-1j * np.outer(direct + delta, k))
    for xt, rt in TARGETS:
        r = np.hypot(X - xt, rt) + delta
        values = values + 0.02 * np.exp(-1j * np.outer(r, k))
    if noise:
        values = values + noise * (
            rng.standard_normal(values.shape) + 1j * rng.standard_normal(values.shape)
        )
    return values, delta


def _data(values) -> RadarData:
    return spectrum_data(values, FREQ, Array(X))


def test_profiles_form_the_compressions_profiles():
    """Formed from the samples on the data's axis, the profiles are the
    compression's (the alignment re-forms them so)."""
    values, _ = _scan(0.0)
    want, rng = range_compress(values, FREQ, 0.5 * (FREQ[0] + FREQ[-1]))
    got = profiles(values, FREQ, "hann", 0.5 * (FREQ[0] + FREQ[-1]), rng)
    assert np.abs(got - want).max() < 1e-9 * np.abs(want).max()


@pytest.mark.parametrize("direct", [DIRECT, 0.002])
def test_offsets_are_measured_on_the_direct_wave(direct):
    """3 mm rms of jitter (20 ps) is measured within 20 um at every
    trace, with the direct wave inside the axis or straddling its start
    (its leading flank then wraps to the axis's end)."""
    values, delta = _scan(3e-3, direct=direct)
    got = trace_shifts(_data(values))
    err = got - (delta - delta.mean())
    assert np.abs(err).max() < 2e-5, np.abs(err).max()


def test_alignment_takes_the_jitter_out():
    """Aligned, the traces' direct waves are the same: the mean's removal
    leaves less than a hundredth of the residue it leaves unaligned; the
    samples are moved as the profiles are."""
    data = _data(_scan(3e-3)[0])
    out = aligned(data, trace_shifts(data))
    g = int(np.abs(data.signal.mean(axis=0)).argmax())

    def residue(d):
        return np.abs(d.signal[:, g] - d.signal[:, g].mean()).max()

    assert residue(out) < 0.01 * residue(data)
    cf = 0.5 * (FREQ[0] + FREQ[-1])
    again = range_compress(out.spectrum.values, FREQ, cf)[0]
    assert np.abs(again - out.signal).max() < 1e-9 * np.abs(out.signal).max()


def test_jitter_free_scan_stays_put():
    values, _ = _scan(0.0, noise=1e-3)
    data = _data(values)
    shifts = trace_shifts(data)
    assert np.abs(shifts).max() < 2e-5  # the noise's, 1/1000 of the direct wave
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        warn_jitter(data)


def test_jitter_is_warned_with_the_fix():
    with pytest.warns(DataWarning, match=r"--align-traces true"):
        warn_jitter(_data(_scan(3e-3)[0]))


def _hits(points, tol=0.01):
    return [bool(np.any(np.hypot(*(points - (xt, rt)).T) < tol)) for xt, rt in TARGETS]


def _image(data, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataWarning)
        points = run_method("phase-rpm", data, default_params(data, **kw), reference).image.points
    near = np.min([np.hypot(*(points - t).T) for t in TARGETS], axis=0)
    return points, float(np.mean(near < 0.02))


def test_aligned_scan_images_as_the_steady_one():
    """Through the pipeline (``align_traces``, then the mean's removal),
    phase-rpm puts points within 10 mm of both targets, and as large a
    share of them within 20 mm as on the same line without jitter;
    unaligned, the direct wave's residue (0.37 of it, 18 times each
    target) is imaged instead."""
    data = _data(_scan(3e-3)[0])
    points, share = _image(data, align_traces=True, background="mean")
    assert all(_hits(points)), points
    steady = _image(_data(_scan(0.0)[0]), background="mean")[1]
    assert share >= steady - 0.05, (share, steady)
    plain, plain_share = _image(data, background="mean")
    assert not all(_hits(plain)) and plain_share < 0.5 * steady


def test_profiles_alone_are_aligned_too():
    """Range profiles without their samples: the flank is taken back to a
    grid over the band and the profiles are moved by interpolation; the
    offsets are those the samples give within 0.1 mm (a thirtieth of the
    jitter: the profiles' interpolation across an axis that is no period
    is not exact), and the profiles those the moved samples form, within
    1 % of the direct wave, away from the axis's ends (0.2 m: there the
    interpolation knows nothing of what lies beyond)."""
    data = _data(_scan(3e-3)[0])
    alone = RadarData(data.signal, data.array, data.range, data.waveform)
    want = trace_shifts(data)
    got = trace_shifts(alone)
    assert np.abs(got - want).max() < 1e-4, np.abs(got - want).max()
    moved = preprocess(alone, background="none", align_traces=True)
    exact = aligned(data, want)
    assert moved.spectrum is None
    inner = (data.range > 0.2) & (data.range < data.range[-1] - 0.2)
    diff = moved.signal[:, inner] - exact.signal[:, inner]
    assert np.abs(diff).max() < 0.01 * np.abs(exact.signal).max()


def test_preprocess_keeps_the_aligned_samples():
    data = _data(_scan(3e-3)[0])
    out = preprocess(data, background="none", align_traces=True)
    assert out.spectrum is not None and out.spectrum.values is not data.spectrum.values
    assert np.array_equal(out.range, data.range)


def test_lead_flank_wraps_round_a_periodic_axis():
    """A direct wave at the axis's start has its leading flank at the
    axis's end on a compressed spectrum's (periodic) axis; elsewhere it is
    cut at the start."""
    from rpm_cl.extract.alignment import _lead_gates

    mean = np.zeros(64)
    mean[[61, 62, 63, 0, 1]] = [0.3, 0.6, 0.9, 1.0, 0.5]
    assert list(_lead_gates(mean, True)) == [61, 62, 63, 0]
    assert list(_lead_gates(mean, False)) == [0, 1]
    mean[60] = 0.05  # under LEAD_FLOOR: the flank ends before it
    mean[40] = 0.2
    assert list(_lead_gates(mean, True)) == [61, 62, 63, 0]


def test_dead_traces_neither_move_nor_move_the_others():
    """All-zero traces have no offset to measure: they keep 0, and the live
    traces' offsets stay within 20 um (their mean taken over them alone)."""
    values, delta = _scan(3e-3)
    dead = np.arange(0, 80, 10)
    values[dead] = 0.0
    got = trace_shifts(_data(values))
    live = np.setdiff1d(np.arange(80), dead)
    want = delta[live] - delta[live].mean()
    assert np.all(got[dead] == 0.0)
    assert np.abs(got[live] - want).max() < 2e-5


def test_no_direct_wave_no_alignment():
    """The strongest echo a target's (no direct wave): its offsets are its
    range walk, and aligning on it would flatten the scene; the traces are
    left as they are, with a warning."""
    from rpm_cl.extract.preprocess import align

    k = 4 * np.pi * FREQ / C0
    values = sum(np.exp(-1j * np.outer(np.hypot(X - xt, rt), k)) for xt, rt in TARGETS)
    data = _data(values)
    with pytest.warns(DataWarning, match="no direct wave"):
        out = align(data)
    assert out is data


def test_heavy_jitter_is_warned_and_aligned():
    """40 ps (6 mm of range, 0.5 rad of the carrier's phase at 2 GHz) makes
    the direct wave fail the coupling test unaligned: the warning is still
    given, and auto time zero, picked on the aligned traces, still finds
    it."""
    from rpm_cl.extract.preprocess import coupling_dominates, pick_time_zero

    data = _data(_scan(6e-3)[0])
    assert not coupling_dominates(data)
    with pytest.warns(DataWarning, match="--align-traces true"):
        warn_jitter(data)
    assert pick_time_zero(data) == 0.0
    params = default_params(data, align_traces=True, time_zero=None)
    assert params.time_zero == pytest.approx(DIRECT, abs=0.002)
