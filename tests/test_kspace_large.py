"""The decomposition's routes for large arrays give what the whole-map
routes give: the centre test read per candidate, the maps held over the
searched gates only, the FFTs in chunks of gates and one axis at a time.

Each is checked on fresh random inputs against the plain computation it
replaces (SciPy's filter, ``fftn`` with ``s=``, the 2-D padded window),
and a decomposition through all of them against one through none.
"""

import dataclasses

import numpy as np
import pytest
from scipy import fft as sfft
from scipy import ndimage

from rpm_cl.extract import kspace, kspace_detect
from rpm_cl.extract.kspace_clusters import _window, _window_fft
from rpm_cl.io.data import Array, Waveform
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import simulate
from rpm_cl.simulate.scene import Ellipsoid, Scene


@pytest.mark.parametrize("seed", range(4))
def test_window_max_equals_the_filter_at_each_point(seed):
    rng = np.random.default_rng(40 + seed)
    shape = tuple(int(n) for n in rng.integers(2, 14, 3))
    a = rng.standard_normal(shape)
    if seed % 2:  # ties
        a = np.round(a)
    pts = np.argwhere(rng.random(shape) < 0.3)
    for _ in range(5):
        size = [int(s) for s in rng.integers(1, 2 * max(shape) + 2, 3)]
        size = [min(s, n) for s, n in zip(size[:2], shape[:2])] + [size[2]]
        mode = ["wrap", "wrap", "nearest"]
        want = ndimage.maximum_filter(a, size=size, mode=mode)[tuple(pts.T)]
        got = kspace_detect._window_max(a, pts, size, mode)
        np.testing.assert_array_equal(got, want, err_msg=f"{shape} {size}")


@pytest.mark.parametrize("seed", range(3))
def test_centres_per_candidate_equal_the_filtered_map(seed, monkeypatch):
    rng = np.random.default_rng(60 + seed)
    # a smooth map: few local maxima, as a k-space map has
    det = ndimage.gaussian_filter(rng.random((40, 30, 25)), 2.0, mode="wrap")
    threshold = np.quantile(det, 0.5)
    args = (det, [7, 5, 9], 2, threshold, 3, 40)
    monkeypatch.setattr(kspace_detect, "SPARSE_SHARE", 0.0)
    dense = kspace_detect._centres(*args)
    monkeypatch.setattr(kspace_detect, "SPARSE_SHARE", np.inf)
    sparse = kspace_detect._centres(*args)
    assert len(dense[0]) > 2
    np.testing.assert_array_equal(sparse[0], dense[0])
    np.testing.assert_array_equal(sparse[1], dense[1])


def test_padded_fft_equals_fftn():
    rng = np.random.default_rng(7)
    sig = rng.standard_normal((9, 6, 4)) + 1j * rng.standard_normal((9, 6, 4))
    want = sfft.fftn(sig, s=(36, 24), axes=(0, 1))
    np.testing.assert_allclose(kspace._padded_fft(sig, (36, 24)), want, rtol=0, atol=1e-12)


@pytest.mark.parametrize("padded", [False, True])
def test_window_fft_equals_the_2d_padded_window(padded):
    rng = np.random.default_rng(8 + padded)
    shape, big = (9, 6), (36, 24)
    k = [2 * np.pi * np.fft.fftfreq(m, 0.004) for m in big]
    periods = [2 * np.pi / 0.004 for _ in big]
    wins = [_window(k[a], rng.uniform(-300, 300), 400.0, periods[a]) for a in range(2)]
    sig = rng.standard_normal(shape + (5,)) + 1j * rng.standard_normal(shape + (5,))
    spec = sfft.fftn(sig, s=big, axes=(0, 1))
    w = wins[0][:, None, None] * wins[1][None, :, None]
    want = sfft.ifftn(w * spec, axes=(0, 1))[: shape[0], : shape[1]]
    got = _window_fft(spec if padded else sig, wins, shape, padded)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())


def _planar_scene():
    x = (np.arange(24) - 11.5) * 0.0075
    z = (np.arange(20) - 9.5) * 0.0075
    scene = Scene((Ellipsoid((0.02, 0.35, -0.01), (0.04, 0.04, 0.04)),))
    return simulate(scene, Array(x, z), Waveform(20e9, 4e9), np.arange(0, 0.8, 0.004), 30.0, 2)


def test_large_array_routes_give_the_same_decomposition(monkeypatch):
    """FFT route, maps over the searched gates, chunks of one gate and the
    per-candidate centre test, against the matrix route with the whole-map
    filter: the same centres and the same decomposed signals."""
    data = _planar_scene()
    kp = default_params(data).kspace
    monkeypatch.setattr(kspace_detect, "SPARSE_SHARE", 0.0)
    a = kspace.decompose(data, kp)
    monkeypatch.setattr(kspace_detect, "SPARSE_SHARE", np.inf)
    monkeypatch.setattr(kspace, "MATRIX_DFT_MAX", 0)
    monkeypatch.setattr(kspace, "FFT_CHUNK_BYTES", 1)
    b = kspace.decompose(data, kp)
    nr = data.range.size
    assert a.gate0 == b.gate0 > 0  # the map starts at the first gate searched
    assert a.magnitude.shape[-1] < nr
    full = b.full_magnitude(nr)
    assert full.shape[-1] == nr and not full[..., : b.gate0].any()
    np.testing.assert_allclose(a.full_magnitude(nr), full, rtol=0, atol=1e-12 * a.magnitude.max())
    assert len(a.clusters) == len(b.clusters) > 0
    for ca, cb in zip(a.clusters, b.clusters):
        assert np.array_equal(ca.k, cb.k) and ca.r_slice == cb.r_slice
        assert ca.peak == pytest.approx(cb.peak, rel=1e-12)
        scale = np.abs(ca.signal).max()
        np.testing.assert_allclose(ca.signal, cb.signal, rtol=0, atol=1e-10 * scale)


def test_unaligned_clusters_cut_from_the_compact_spectrum(monkeypatch):
    """Without alignment the clusters are cut from S(k, R) held over the
    searched gates only: the same as from the whole map (matrix route)."""
    data = _planar_scene()
    kp = dataclasses.replace(default_params(data).kspace, align=False, skip_gates=False)
    full = kspace.decompose(data, kp)
    kp = dataclasses.replace(kp, skip_gates=True)
    monkeypatch.setattr(kspace, "MATRIX_DFT_MAX", 0)
    part = kspace.decompose(data, kp)
    assert full.gate0 == 0 and part.gate0 > 0
    assert [c.r_slice for c in full.clusters] == [c.r_slice for c in part.clusters]
    for ca, cb in zip(full.clusters, part.clusters):
        scale = np.abs(ca.signal).max()
        np.testing.assert_allclose(ca.signal, cb.signal, rtol=0, atol=1e-10 * scale)
