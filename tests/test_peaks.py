"""The one peak picker of coherent images (rpm_cl.baselines.peaks)."""

import numpy as np
import pytest

from rpm_cl.baselines.peaks import image_peaks
from rpm_cl.io.data import InputError


def _blobs(shape, centres, amps, width=1.5):
    idx = np.indices(shape).reshape(len(shape), -1).T
    img = np.zeros(int(np.prod(shape)))
    for c, a in zip(centres, amps):
        img += a * np.exp(-np.sum((idx - c) ** 2, axis=1) / (2 * width**2))
    return img.reshape(shape)


@pytest.mark.parametrize("dim", [2, 3])
def test_peaks_at_known_places_strongest_first(rng, dim):
    """Blobs at random pixels: each found at its pixel, in order of strength,
    with its level in dB; below the threshold none."""
    shape = (40,) * dim
    centres = np.array([[8] * dim, [30] * dim, [8] * (dim - 1) + [30]])
    amps = np.array([0.5, 1.0, 0.2])
    axes = [np.sort(rng.uniform(-1, 1, n)) for n in shape]
    img = _blobs(shape, centres, amps) * np.exp(1j * rng.uniform(0, 6.3))
    pts, lev = image_peaks(img, axes, threshold_db=-20)
    order = np.argsort(-amps)
    want = np.array([[axes[k][c[k]] for k in range(dim)] for c in centres[order]])
    np.testing.assert_array_equal(pts, want)
    np.testing.assert_allclose(lev, 20 * np.log10(amps[order] / amps.max()), atol=1e-9)
    pts, _ = image_peaks(img, axes, threshold_db=-10)  # 0.2 is -14 dB
    assert len(pts) == 2


def test_border_and_neighbourhood():
    """A maximum on the border counts; a weaker maximum within the
    neighbourhood of a stronger one does not, outside it does."""
    img = np.zeros((9, 9))
    img[0, 4], img[0, 6], img[6, 6] = 1.0, 0.9, 0.8
    ax = [np.arange(9.0), np.arange(9.0)]
    pts3, _ = image_peaks(img, ax, threshold_db=-20, size=3)
    assert [tuple(p) for p in pts3] == [(0, 4), (0, 6), (6, 6)]
    pts5, _ = image_peaks(img, ax, threshold_db=-20, size=5)
    assert [tuple(p) for p in pts5] == [(0, 4), (6, 6)]


def test_separation_and_count():
    img = np.zeros((20, 20))
    img[2, 2], img[2, 5], img[15, 15] = 1.0, 0.9, 0.5
    ax = [np.arange(20) * 0.01, np.arange(20) * 0.01]
    pts, _ = image_peaks(img, ax, threshold_db=-20, min_separation=0.05)
    np.testing.assert_allclose(pts, [[0.02, 0.02], [0.15, 0.15]])
    pts, _ = image_peaks(img, ax, threshold_db=-20, n_peaks=1)
    np.testing.assert_allclose(pts, [[0.02, 0.02]])


def test_empty_and_bad_arguments():
    ax = [np.arange(4.0), np.arange(5.0)]
    pts, lev = image_peaks(np.zeros((4, 5)), ax)
    assert pts.shape == (0, 2) and lev.size == 0
    for kw in ({"size": 2}, {"n_peaks": 0}, {"min_separation": -1.0}):
        with pytest.raises(InputError):
            image_peaks(np.ones((4, 5)), ax, **kw)
    with pytest.raises(InputError, match="does not match"):
        image_peaks(np.ones((5, 4)), ax)
