"""Coherent centres (``KSpaceParams.coherent_centres``, phase-rpm's default):
the peaks of the delay-and-sum image over the searched gates that no
centre of the k-space map holds become centres of their own
(rpm_cl.extract.kspace_detect.coherent_centres)."""

from dataclasses import replace

import numpy as np
import pytest

from rpm_cl.extract.kspace import decompose, kspace_spectrum
from rpm_cl.extract.kspace_detect import coherent_centres, wants_coherent_centres
from rpm_cl.extract.kspace_params import KSpaceParams
from rpm_cl.io.data import C0, Array, RadarData, Waveform
from rpm_cl.io.formats import range_compress

FC, BAND = 3e9, 2e9
X = (np.arange(41) - 20) * 8e-3  # 41 antennas at 8 mm, 0.32 m
STRONG = np.array([0.0, 0.35])
WEAK = np.array([0.13, 0.45])


def _line(targets, amps, f0=FC - BAND / 2, f1=FC + BAND / 2, rmax=1.0):
    """Range profiles of point targets under the line X, synthesised here:
    exact two-way phases over 128 frequencies, Hann compression."""
    f = np.linspace(f0, f1, 128)
    r = np.hypot(X[:, None] - targets[None, :, 0], targets[None, :, 1])
    y = np.sum(
        amps[None, :, None] * np.exp(-4j * np.pi * f[None, None, :] * r[:, :, None] / C0), axis=1
    )
    s, rng = range_compress(y, f, 0.5 * (f0 + f1), "hann")
    keep = rng < rmax
    return RadarData(s[:, keep], Array(X), rng[keep], Waveform(0.5 * (f0 + f1), f1 - f0))


def _k_gate(data, p, k_axis):
    """(k index, gate) of point p seen from the array's middle."""
    r = float(np.hypot(*p))
    k = 2 * data.waveform.kc * p[0] / r
    period = 2 * np.pi / data.array.dx
    dk = (k_axis - k + 0.5 * period) % period - 0.5 * period
    return int(np.argmin(np.abs(dk))), int(np.rint((r - data.range[0]) / data.dr))


def test_only_linear_wide_band_arrays_with_the_setting_on():
    on = KSpaceParams(coherent_centres=True)
    wide = _line(STRONG[None], np.ones(1))
    assert wants_coherent_centres(wide, on)
    assert not wants_coherent_centres(wide, KSpaceParams())
    assert not wants_coherent_centres(wide, replace(on, coherent_centres=False))
    narrow = _line(STRONG[None], np.ones(1), 2.9e9, 3.1e9)
    assert not wants_coherent_centres(narrow, on)
    with pytest.raises(ValueError, match="coherent_centres"):
        KSpaceParams(coherent_centres="yes")


def test_a_peak_no_centre_holds_becomes_one_at_its_direction_and_range():
    """A strong point and a weak one (-16 dB) 13 degrees and 0.1 m apart:
    given the strong one's centre, the weak one is proposed at its own k
    (``2 k_c sin(theta)`` from the array's middle, to a k bin) and gate (to
    a quarter range resolution); given both, nothing is."""
    data = _line(np.stack([STRONG, WEAK]), np.array([1.0, 0.16]))
    k_axis = kspace_spectrum(data, 4, gates=slice(0, 0))[1][0]
    strong, weak = _k_gate(data, STRONG, k_axis), _k_gate(data, WEAK, k_axis)
    window, gate = 62.9, data.waveform.range_resolution
    runs = [(1, data.range.size - 1)]
    got = coherent_centres(data, np.array([strong]), runs, k_axis, 0.1, window, gate)
    assert len(got) == 1
    quarter = 0.25 * data.waveform.range_resolution / data.dr
    assert abs(got[0][0] - weak[0]) <= 1 and abs(got[0][1] - weak[1]) <= quarter
    held = coherent_centres(data, np.array([strong, weak]), runs, k_axis, 0.1, window, gate)
    assert held.size == 0
    # nothing above the relative threshold but the strong one, already held
    assert coherent_centres(data, np.array([strong]), runs, k_axis, 0.5, window, gate).size == 0


def test_a_rise_past_the_end_of_the_searched_gates_is_no_peak():
    """An echo just beyond the range axis (its flank rising to the last
    gate) proposes nothing: the image may rise beyond an edge node."""
    beyond = np.array([0.05, 0.62])
    data = _line(beyond[None], np.ones(1), rmax=0.6)
    k_axis = kspace_spectrum(data, 4, gates=slice(0, 0))[1][0]
    runs = [(data.range.size // 2, data.range.size)]
    got = coherent_centres(data, np.zeros((0, 2), np.intp), runs, k_axis, 0.01, 62.9, 0.1)
    assert got.size == 0


def test_the_decomposition_adds_them_only_where_asked():
    """The same data decomposed with the setting on holds a cluster at the
    weak target's direction and range; off, the map's centres alone (the
    paper's method)."""
    data = _line(np.stack([STRONG, WEAK]), np.array([1.0, 0.16]))
    base = KSpaceParams(window_x=62.9, close_centres=True)
    off = decompose(data, base)
    on = decompose(data, replace(base, coherent_centres=True))
    assert len(on.clusters) >= len(off.clusters)
    near = [
        abs(c.k[0] - 2 * data.waveform.kc * WEAK[0] / np.hypot(*WEAK)) < 10
        and abs(c.r_centre - np.hypot(*WEAK)) < 0.03
        for c in on.clusters
    ]
    assert any(near)
