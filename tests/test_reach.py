"""Points beyond the antennas' reach (ImagingParams.reach_deg)."""

import numpy as np
import pytest

from rpm_cl.extract.rangepoints import RangePoints
from rpm_cl.io.data import Array, InputError
from rpm_cl.result import Image
from rpm_cl.rpm.methods import in_reach, reach_angles
from rpm_cl.rpm.params import ImagingParams


def _rps(antenna, x):
    n = len(antenna)
    antenna = np.asarray(antenna)
    return RangePoints(
        antenna, np.asarray(x, float)[antenna], None, np.full(n, 0.5), np.ones(n), np.zeros(n, int)
    )


def test_angles_and_drop_in_2d():
    """Points at 0, 30, 69 and 80 deg from their antennas' boresight (two
    antennas, one of them off centre): reach 70 keeps the first three."""
    arr = Array(np.array([-0.1, 0.2]))
    rps = _rps([0, 1, 1, 0], arr.x)
    ang = np.radians([0.0, 30.0, 69.0, 80.0])
    base = arr.x[[0, 1, 1, 0]]
    pts = np.c_[base + 0.4 * np.sin(ang) * np.array([1, -1, 1, -1]), 0.4 * np.cos(ang)]
    img = Image(pts, np.zeros(4, int), np.ones(4), np.arange(4))
    np.testing.assert_allclose(reach_angles(arr, rps, img), [0, 30, 69, 80], atol=1e-9)
    kept = in_reach(arr, rps, img, 70.0)
    np.testing.assert_array_equal(kept.rp_index, [0, 1, 2])
    assert in_reach(arr, rps, img, 90.0) is img


def test_angles_in_3d_use_both_axes():
    arr = Array(np.array([0.0, 0.1]), np.array([0.0, 0.1]))
    pos = arr.positions()
    rps = RangePoints(
        np.arange(4), pos[:, 0], pos[:, 1], np.full(4, 1.0), np.ones(4), np.zeros(4, int)
    )
    # from antenna 3 at (0.1, 0.1): lateral (0.3, 0.4) = 0.5 at depth 0.5 -> 45 deg
    img = Image(np.array([[0.4, 0.5, 0.5]]), np.zeros(1, int), np.ones(1), np.array([3]))
    assert reach_angles(arr, rps, img)[0] == pytest.approx(45.0)


def test_reach_deg_validated():
    for bad in (0.0, -1.0, 91.0, float("nan")):
        with pytest.raises(InputError, match="reach_deg"):
            ImagingParams(reach_deg=bad)
