"""Moving the array moves the image and changes nothing else: the same
profiles with every position offset image to the same points, offset by
the same amount (positions as a scan records them, metres along a line,
against the same positions centred)."""

import dataclasses

import numpy as np
import pytest

from rpm_cl.baselines.das import DeviceDAS
from rpm_cl.baselines.imagers import das_method, rma_method
from rpm_cl.imaging import run_method
from rpm_cl.io.data import Array, Waveform
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import simulate
from rpm_cl.simulate.scene import PointTarget, Scene


def test_moving_a_planar_array_moves_its_image(dev32):
    """Positions 3.21 m along x and -7.65 m along z."""
    from rpm_cl.cli import robustness as R

    g = dataclasses.replace(R.GEOMETRY_3D, x=(24, 7.5e-3), z=(20, 7.5e-3))
    spec, f, _ = R.synthesize(g, 30.0, 0)
    data = R.radar_data(g, spec, f)
    moved = dataclasses.replace(data, array=Array(data.array.x + 3.21, data.array.z - 7.65))
    for method in ("phase-rpm", "kspace-rpm"):
        a = run_method(method, data, default_params(data), dev32).image.points
        b = run_method(method, moved, default_params(moved), dev32).image.points
        assert a.shape == b.shape and len(a) > 500
        np.testing.assert_allclose(b - [3.21, 0.0, -7.65], a, atol=1e-6)


@pytest.mark.parametrize("imager", [das_method, rma_method])
def test_moving_a_line_moves_the_coherent_images(cl_env, imager):
    """DAS and RMA peaks of a line 12.345 m along."""
    x = (np.arange(41) - 20) * 0.005
    scene = Scene((PointTarget((-0.05, 0.4)), PointTarget((0.03, 0.5))))
    data = simulate(scene, Array(x), Waveform(20e9, 3e9), np.arange(0, 1.0, 2.5e-3), 30.0, 1)
    moved = dataclasses.replace(data, array=Array(x + 12.345), truth=None)
    engine = DeviceDAS(cl_env)
    a = imager(data, default_params(data), engine).image.points
    b = imager(moved, default_params(moved), engine).image.points
    assert a.shape == b.shape and len(a) == 2
    np.testing.assert_allclose(b - [12.345, 0.0], a, atol=1e-6)
