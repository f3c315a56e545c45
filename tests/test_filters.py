"""rpm_cl.filters and the brute-force Err_RPM against SciPy, on fresh random inputs."""

import numpy as np
import pytest
from scipy import ndimage

from rpm_cl.filters import binary_dilation, maximum_filter


@pytest.mark.parametrize("seed", range(6))
def test_maximum_filter_equals_scipy(seed):
    rng = np.random.default_rng(seed)
    ndim = 1 + seed % 3
    shape = tuple(int(n) for n in rng.integers(1, 12, ndim))
    a = rng.standard_normal(shape)
    if seed % 2:  # ties, as a flat map has
        a = np.round(a)
    for _ in range(6):
        size = [int(s) for s in rng.integers(1, 2 * max(shape) + 2, ndim)]
        mode = [str(m) for m in rng.choice(["wrap", "nearest", "reflect", "constant"], ndim)]
        want = ndimage.maximum_filter(a, size=size, mode=mode)
        got = maximum_filter(a, size, mode)
        np.testing.assert_array_equal(got, want, err_msg=f"{shape} {size} {mode}")
        assert got.dtype == a.dtype and got.shape == a.shape
    f32 = a.astype(np.float32)
    np.testing.assert_array_equal(
        maximum_filter(f32, 3, "nearest"), ndimage.maximum_filter(f32, size=3, mode="nearest")
    )


@pytest.mark.parametrize("seed", range(4))
def test_binary_dilation_equals_scipy(seed):
    rng = np.random.default_rng(100 + seed)
    a = rng.random(int(rng.integers(1, 40))) < 0.1
    for k in (0, 1, 2, 5, 50):
        want = ndimage.binary_dilation(a, iterations=k) if k > 0 else a
        np.testing.assert_array_equal(binary_dilation(a, k), want)


@pytest.mark.parametrize("dim", [2, 3])
def test_err_rpm_brute_force_equals_the_tree(monkeypatch, dim):
    """Err_RPM by every pair (small scenes) and by a k-d tree (large ones)
    agree exactly."""
    from scipy.spatial import cKDTree

    from rpm_cl import metrics

    rng = np.random.default_rng(7 + dim)
    b = rng.uniform(-1, 1, (2000, dim))
    p = rng.uniform(-1, 1, (300, dim))

    class T:
        boundary = b

    want = cKDTree(b).query(p)[0]
    np.testing.assert_array_equal(metrics.err_rpm(p, T), want)
    monkeypatch.setattr(metrics, "BRUTE_FORCE_CHUNK", 5000)  # several chunks
    np.testing.assert_array_equal(metrics.err_rpm(p, T), want)
    monkeypatch.setattr(metrics, "BRUTE_FORCE_PAIRS", 10)  # the tree
    np.testing.assert_array_equal(metrics.err_rpm(p, T), want)


def test_range_windows_equal_scipy_bit_for_bit():
    from scipy.signal import windows as sw

    from rpm_cl.io.windows import window

    for name in ("boxcar", "hann", "hamming", "blackman", "taylor"):
        for n in (1, 2, 3, 4, 7, 64, 101, 4001):
            want = np.asarray(sw.get_window(name, n, fftbins=False), np.float64)
            np.testing.assert_array_equal(window(name, n), want, err_msg=f"{name} {n}")


def test_range_compression_equals_scipys_fft():
    """NumPy's FFT and length rule in the range compression give SciPy's
    numbers bit for bit (complex spectra, float32 and float64)."""
    import scipy.fft as sfft

    from rpm_cl.io.compress import next_fast_len, range_compress

    assert all(next_fast_len(n) == sfft.next_fast_len(n, real=False) for n in range(1, 5000))
    rng = np.random.default_rng(11)
    f = np.linspace(20e9, 20.2e9, 41)
    for dt in (np.complex64, np.complex128):
        y = (rng.standard_normal((7, 41)) + 1j * rng.standard_normal((7, 41))).astype(dt)
        s, r = range_compress(y, f, f.mean(), "hann")
        n = sfft.next_fast_len(16 * 41, real=False)
        w = np.asarray(__import__("scipy.signal").signal.get_window("hann", 41, fftbins=False))
        want = sfft.ifft(y * (w / w.sum()), n=n, axis=-1) * n
        want *= np.exp(4j * np.pi * (f[0] - f.mean()) * r / 299792458.0)
        np.testing.assert_array_equal(s, want.astype(s.dtype))


def test_transforms_equal_scipys_fft_bit_for_bit():
    """rpm_cl.transforms gives scipy.fft's numbers bit for bit, on random
    shapes, lengths (padded and cut) and axes: NumPy's for complex128,
    SciPy's own for complex64 and real input, where NumPy's differ."""
    import scipy.fft as sfft

    from rpm_cl.transforms import fft, ifft

    rng = np.random.default_rng(12)
    for _ in range(150):
        shape = tuple(int(v) for v in rng.integers(1, 60, int(rng.integers(1, 4))))
        axis = int(rng.integers(-len(shape), len(shape)))
        n = None if rng.random() < 0.3 else int(rng.integers(1, 4 * shape[axis] + 2))
        z = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)
        for a in (z, z.astype(np.complex64), z.real):
            for mine, theirs in ((fft, sfft.fft), (ifft, sfft.ifft)):
                got, want = mine(a, n=n, axis=axis), theirs(a, n=n, axis=axis)
                assert got.dtype == want.dtype
                np.testing.assert_array_equal(got, want, err_msg=f"{shape} {n} {axis} {a.dtype}")


def test_spline_prefilter_equals_scipy_bit_for_bit():
    """The cubic B-spline prefilter of the range-walk alignment equals
    SciPy's ``spline_filter1d(order 3, mode="nearest")`` bit for bit: rows of
    1-300 samples (the short ones, where the boundary's terms of order
    z^(2n) still count, included), float32 and float64, scales 1e-30-1e30."""
    from rpm_cl.filters import spline_filter_nearest

    rng = np.random.default_rng(13)
    for n in list(range(1, 40)) + [int(v) for v in rng.integers(40, 300, 40)]:
        rows = int(rng.integers(1, 30))
        a = rng.standard_normal((rows, n)) * 10.0 ** rng.uniform(-30, 30)
        for x in (a, a.astype(np.float32), a[0], np.asfortranarray(a)):
            want = ndimage.spline_filter1d(x, 3, axis=-1, mode="nearest")
            got = spline_filter_nearest(x)
            assert got.dtype == want.dtype == np.float64 and got.flags.c_contiguous
            np.testing.assert_array_equal(got, want, err_msg=f"n {n} {x.dtype}")
