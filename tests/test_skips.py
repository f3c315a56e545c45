"""Skipping what a scene does not need: each skip changes nothing it
should not, and the work follows what the scene holds.

- Range gates that cannot hold a k-space centre are not transformed or
  searched (kspace.decompose, step 2): exact, so the clusters equal those of
  the full search (``skip_gates=False``) bit for bit.
- The noise floor (``noise_pfa``) keeps noise-only inputs empty and leaves the
  clusters of the paper's scenes unchanged.
- 2-D pairing within ``pair_cutoff_2d * sigma_x``: the windows equal a brute
  force, and the image equals the exhaustive one where the dropped weights are
  negligible.
"""

import dataclasses

import numpy as np
import pytest

from rpm_cl.extract import kspace
from rpm_cl.extract.kspace import decompose
from rpm_cl.imaging import run_method
from rpm_cl.io.data import Array, RadarData, Waveform
from rpm_cl.rpm.params import default_params
from rpm_cl.rpm.pipeline import pair_windows, rpm_image
from rpm_cl.simulate import simulate, simulate_preset
from rpm_cl.simulate.scene import Ellipsoid, PointTarget, Scene, get_preset


def _same_clusters(a, b):
    assert len(a.clusters) == len(b.clusters)
    for ca, cb in zip(a.clusters, b.clusters):
        assert np.array_equal(ca.k, cb.k) and ca.r_centre == cb.r_centre
        assert ca.r_slice == cb.r_slice and ca.peak == cb.peak
        np.testing.assert_array_equal(ca.signal, cb.signal)


@pytest.mark.parametrize(
    "name,snr", [("paper-2d", None), ("paper-2d", 10.0), ("human-body", None), ("human-body", 20.0)]
)
def test_gate_skip_is_exact(name, snr):
    data, preset = simulate_preset(name, snr, 3, noise="receiver")
    ks = default_params(data, **preset.defaults).kspace
    _same_clusters(decompose(data, ks), decompose(data, dataclasses.replace(ks, skip_gates=False)))


class _GateCounter:
    """Counts the range gates kspace_spectrum transforms."""

    def __init__(self, monkeypatch):
        self.gates = 0
        real = kspace.kspace_spectrum

        def spy(data, pad=4, taper=False, gates=None, dechirp=None):
            spec, axes = real(data, pad, taper, gates, dechirp)
            self.gates += spec.shape[-1]
            return spec, axes

        monkeypatch.setattr(kspace, "kspace_spectrum", spy)


def _body_like(targets, snr=None, seed=0):
    preset = get_preset("human-body")
    scene = Scene(tuple(targets), "test")
    return simulate(
        scene,
        preset.array,
        preset.waveform,
        preset.range_axis,
        snr,
        seed,
        boundary_spacing=5e-3,
        noise="receiver",
    ), preset


def test_work_follows_the_scene(monkeypatch):
    """All-zero input: no gate transformed.  One target: only the gates
    around it (its range +- a range resolution and the search margin), far
    fewer than the full search's two passes over every gate."""
    preset = get_preset("human-body")
    nr = preset.range_axis.size
    zero = RadarData(
        np.zeros(preset.array.shape + (nr,), complex),
        preset.array,
        preset.range_axis,
        preset.waveform,
    )
    ks = default_params(zero, **preset.defaults).kspace
    count = _GateCounter(monkeypatch)
    assert decompose(zero, ks).clusters == ()
    assert count.gates == 0

    one, _ = _body_like([Ellipsoid((0.0, 1.1, 1.0), (0.08, 0.05, 0.1))], snr=20.0)
    count.gates = 0
    dec = decompose(one, ks)
    assert 1 <= len(dec.clusters) <= 3
    skipped = count.gates
    count.gates = 0
    decompose(one, dataclasses.replace(ks, skip_gates=False))
    full = count.gates
    assert full >= 2 * nr
    # the target's echoes span ~0.15 m of range (0.7-1.7 m axis at 2.5 mm):
    # with margins of one resolution (50 mm) either side, under half the axis
    assert skipped < 0.5 * full


@pytest.mark.parametrize("seed", range(3))
def test_noise_only_is_empty(seed):
    """Pure noise at the human body's 20 dB noise level: no cluster (the floor
    is set for a false-cluster probability of 1e-3 per input); without the
    floor, the -20 dB relative threshold alone finds noise clusters."""
    data, preset = simulate_preset("human-body", 20.0, seed, noise="receiver")
    clean, _ = simulate_preset("human-body", None, seed)
    noise = dataclasses.replace(data, signal=data.signal - clean.signal, truth=None)
    params = default_params(noise, **preset.defaults)
    assert decompose(noise, params.kspace).clusters == ()
    assert len(decompose(noise, dataclasses.replace(params.kspace, noise_pfa=None)).clusters) > 0


def test_noise_floor_from_known_power():
    """2-D: the range axis is too short for the median over gates (one echo
    covers it), so the noise is estimated from the k-space map's low tail
    (:func:`rpm_cl.extract.kspace._kspace_noise`): noise-only data are empty with the
    estimate as with the known power, the estimate is within a factor 2.1 of
    the power (the bound its docstring gives for echoes filling half the
    map; pure noise fills none of it), and the paper's scene at 10 dB keeps
    its clusters under either floor."""
    from rpm_cl.extract.kspace import _kspace_noise, _taper

    data, preset = simulate_preset("paper-2d", 10.0, 1, noise="receiver")
    clean, _ = simulate_preset("paper-2d", None, 1)
    n = data.signal - clean.signal
    power = float(np.mean(np.abs(n) ** 2))
    ks = default_params(data, **preset.defaults).kspace
    noise = dataclasses.replace(data, signal=n, truth=None)
    scale = float(np.abs(n).max())
    est = _kspace_noise(noise, _taper(data.array.shape), scale) * scale**2
    assert power / 2.1 < est < 2.1 * power
    assert decompose(noise, ks).clusters == ()
    assert len(decompose(noise, dataclasses.replace(ks, noise_pfa=None)).clusters) > 0
    known = dataclasses.replace(ks, noise_power=power)
    assert decompose(noise, known).clusters == ()
    _same_clusters(decompose(data, known), decompose(data, ks))


def test_floor_leaves_the_body_alone():
    data, preset = simulate_preset("human-body", 20.0, 2, noise="receiver")
    ks = default_params(data, **preset.defaults).kspace
    _same_clusters(decompose(data, ks), decompose(data, dataclasses.replace(ks, noise_pfa=None)))


def test_noise_params_validated():
    from rpm_cl.extract.kspace import KSpaceParams
    from rpm_cl.io.data import InputError

    for bad in (
        {"noise_pfa": 0.0},
        {"noise_pfa": 1.5},
        {"noise_power": -1.0},
        {"noise_power": float("nan")},
    ):
        with pytest.raises(InputError, match=next(iter(bad))):
            KSpaceParams(**bad)


def test_pair_windows_brute_force(rng):
    n_clusters = 6
    sizes = rng.integers(1, 30, n_clusters)
    x = np.concatenate([np.sort(rng.uniform(-1, 1, s)) for s in sizes])
    start = np.repeat(np.r_[0, np.cumsum(sizes)[:-1]], sizes)
    count = np.repeat(sizes, sizes)
    cut = 0.3
    lo, cnt = pair_windows(x, start, count, cut)
    for i in range(x.size):
        members = np.arange(start[i], start[i] + count[i])
        inside = members[np.abs(x[members] - x[i]) <= cut]
        assert lo[i] == inside.min() and cnt[i] == inside.size
    lo, cnt = pair_windows(x, start, count, np.inf)
    assert np.array_equal(lo, start) and np.array_equal(cnt, count)


def test_pair_cutoff_2d_long_array(dev32):
    """A 1 m linear array (201 antennas) with sigma_x = 50 mm: pairing within
    4 sigma_x keeps, per main RP, the cluster's RPs at the 81 antennas within
    0.2 m of its own (fewer than half the cluster), and the image
    is the exhaustive one up to near-ties of the argmax (the dropped weights
    are below exp(-8) of the largest, but their candidates go too): the same
    number of points, the same accuracy, every point within 1 mm of the
    exhaustive one (measured: 68 % identical, the rest neighbouring
    intersections on the same arc)."""
    from rpm_cl.metrics import summary
    from rpm_cl.rpm.pipeline import _prepare

    arr = Array((np.arange(201) - 100) * 5e-3)
    # one point: two in one range cell (0.75 m at 0.2 GHz) are one cluster
    # focused on neither, which the exact focus (kspace step 5) keeps small
    scene = Scene((PointTarget((-0.1, 0.45)),), "long")
    data = simulate(
        scene, arr, Waveform(20e9, 0.2e9), np.arange(0.0, 1.5, 2.5e-3), 30.0, 0, noise="receiver"
    )
    params = default_params(data, sigma_x=0.05, sigma_r=0.05)
    rps = run_method("kspace-rpm", data, params, dev32).rps
    idx, _, _, s, c = _prepare(rps, params.rpm)
    x = np.asarray(rps.x)[idx]
    w = pair_windows(x, s, c, 0.2)[1]
    # antennas exactly 0.2 m apart may fall either side of the cutoff (rounding)
    near = [
        np.array([np.sum(np.abs(x[s0 : s0 + c0] - xi) <= 0.2 + tol) for xi, s0, c0 in zip(x, s, c)])
        for tol in (-1e-9, 1e-9)
    ]
    assert c.max() > 200 and np.all((near[0] <= w) & (w <= near[1])) and w.max() < 0.5 * c.max()
    cut = rpm_image(rps, params.rpm, dev32)
    full = rpm_image(rps, dataclasses.replace(params.rpm, pair_cutoff_2d=np.inf), dev32)
    assert np.array_equal(cut.rp_index, full.rp_index)
    same = np.all(np.abs(cut.points - full.points) < 1e-6, axis=1)
    assert same.mean() >= 0.5
    assert np.linalg.norm(cut.points - full.points, axis=1).max() <= 1e-3
    sc, sf = summary(rps, cut, data.truth), summary(rps, full, data.truth)
    for key in ("rpm_within_10mm", "rpm_within_50mm"):
        assert abs(sc[key] - sf[key]) <= 2
