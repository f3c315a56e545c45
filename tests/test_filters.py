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
