"""The near-field search's map peak finder (rpm_cl/extract/nearfield.py, ``_peaks``)
against its definition: the points equal to scipy's maximum filter."""

import numpy as np
import pytest
from scipy import ndimage

from rpm_cl.extract import nearfield


def _reference(fmap, size, floor, count):
    local = fmap == ndimage.maximum_filter(fmap, size=size, mode="nearest")
    local &= fmap >= floor
    idx = np.argwhere(local)
    idx = idx[np.argsort(-fmap[tuple(idx.T)], kind="stable")][:count]
    return [tuple(int(v) for v in p) for p in idx]


@pytest.mark.parametrize("seed", range(20))
def test_peaks_equal_the_maximum_filter(seed):
    """Random smooth maps (peaks at edges and corners included), rough maps
    and maps with plateaus (values rounded to a few levels: ties, equal
    neighbours), windows as the search uses them (odd, wider along R)."""
    rng = np.random.default_rng(seed)
    shape = (int(rng.integers(5, 60)), int(rng.integers(5, 80)))
    fmap = rng.random(shape)
    if seed % 3 == 0:
        fmap = ndimage.uniform_filter(fmap, size=5, mode="nearest")
    if seed % 3 == 1:
        fmap = np.round(4 * fmap) / 4
    size = [2 * int(rng.integers(0, 6)) + 1, 2 * int(rng.integers(0, 20)) + 1]
    for floor in (0.0, float(np.quantile(fmap, 0.7))):
        for count in (1, 3, 50):
            assert nearfield._peaks(fmap, size, floor, count) == _reference(
                fmap, size, floor, count
            )


def test_peaks_of_known_bumps():
    """Three Gaussian bumps at known places, strongest first; one below the
    floor is left out, one inside another's window is not a peak."""
    u, r = np.meshgrid(np.arange(100), np.arange(60), indexing="ij")
    bump = lambda i, j, a, w: a * np.exp(-((u - i) ** 2 + (r - j) ** 2) / (2 * w * w))
    fmap = bump(20, 30, 1.0, 3) + bump(70, 0, 0.8, 3) + bump(99, 59, 0.6, 3) + bump(50, 30, 0.1, 3)
    assert nearfield._peaks(fmap, [11, 11], 0.2, 3) == [(20, 30), (70, 0), (99, 59)]
    assert nearfield._peaks(fmap, [11, 11], 0.7, 3) == [(20, 30), (70, 0)]
    # a narrow bump on the strongest one's flank, 5 cells away: higher than
    # its 8 neighbours, lower than the strongest, so hidden by an 11 x 11
    # window and a peak in a 3 x 3 one
    wide = fmap + bump(25, 30, 0.5, 1)
    assert nearfield._peaks(wide, [11, 11], 0.2, 5) == [(20, 30), (70, 0), (99, 59)]
    assert nearfield._peaks(wide, [3, 3], 0.2, 5) == [(20, 30), (70, 0), (25, 30), (99, 59)]
