"""The decomposition's two transform routes give the same clusters.

Arrays up to ``MATRIX_DFT_MAX`` antennas per axis are transformed with
DFT matrices (zero-padded DFT, window and inverse folded into one small
matrix per axis); larger ones with FFTs.  Both are the same linear map, so
forcing either route must give the same clusters to rounding, for a planar
array with and without the range-walk alignment and for a linear array.
"""

import dataclasses

import numpy as np
import pytest

from rpm_cl.extract import kspace
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import simulate
from rpm_cl.simulate.scene import get_preset


@pytest.mark.parametrize(
    "preset,align", [("human-body", None), ("human-body", False), ("paper-2d", None)]
)
def test_matrix_and_fft_routes_agree(preset, align, monkeypatch):
    pre = get_preset(preset)
    data = simulate(pre.scene, pre.array, pre.waveform, pre.range_axis, 20.0, 3, noise="receiver")
    kp = dataclasses.replace(default_params(data, **pre.defaults).kspace, align=align)
    monkeypatch.setattr(kspace, "MATRIX_DFT_MAX", 10**6)
    a = kspace.decompose(data, kp)
    monkeypatch.setattr(kspace, "MATRIX_DFT_MAX", 0)
    b = kspace.decompose(data, kp)
    np.testing.assert_allclose(a.magnitude, b.magnitude, rtol=0, atol=1e-12 * b.magnitude.max())
    assert len(a.clusters) == len(b.clusters) > 0
    for ca, cb in zip(a.clusters, b.clusters):
        assert np.array_equal(ca.k, cb.k) and ca.r_slice == cb.r_slice
        scale = np.abs(cb.signal).max()
        np.testing.assert_allclose(ca.signal, cb.signal, rtol=0, atol=1e-12 * scale)
