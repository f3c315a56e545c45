"""The k-space window of eq. 4 (kspace module notes, step 3):

    W(dk) = (1 + cos(2 pi dk / T)) / 2  for |dk| < T / 2, else 0,

with dk = k - k0 wrapped onto the periodic k axis (period 2 pi / d for the
array pitch d).  The unit tests compare ``kspace._window`` with a second
evaluation at points whose values are known; the end-to-end test puts a
cluster on the edge of the k axis (a target 48 degrees off broadside: its
k = -2 k_c sin(48 deg) = -623 rad/m lies at the wrapped edge -pi/d = -628
rad/m of a 5 mm array), where only the right wrap keeps its window whole.

Mutations of ``_window`` that these tests catch (each makes a test here
fail): the period halved or doubled, the wrap removed, the wrap over
twice the k period, ``k + k0`` for ``k - k0``, the support ``|dk| < T``,
``1 - cos`` for ``1 + cos``.
"""

import numpy as np
import pytest

from rpm_cl.extract.kspace import _window, decompose
from rpm_cl.imaging import run_method
from rpm_cl.io.data import Array, Waveform
from rpm_cl.rpm import reference
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import simulate
from rpm_cl.simulate.scene import PointTarget, Scene

PITCH = 5e-3
K_PERIOD = 2 * np.pi / PITCH  # 1256.6 rad/m
T = 417.0  # the paper's 2-D window period, rad/m


def _second_evaluation(k, k0, period, k_period):
    """W by another route: the circular distance as the angle of a phasor
    (np.angle wraps it into (-pi, pi]) and cos^2(pi dk / T), the same raised
    cosine by the half-angle identity."""
    dk = np.angle(np.exp(2j * np.pi * (np.asarray(k) - k0) / k_period)) * k_period / (2 * np.pi)
    return np.where(np.abs(dk) < 0.5 * period, np.cos(np.pi * dk / period) ** 2, 0.0)


def test_window_at_known_points():
    k0 = 100.0
    k = k0 + np.array([0.0, T / 4, -T / 4, T / 8, 0.499 * T, 0.5 * T, -0.5 * T, 0.7 * T])
    w = _window(k, k0, T, K_PERIOD)
    assert w[0] == pytest.approx(1.0, abs=1e-15)  # the centre
    np.testing.assert_allclose(w[1:3], 0.5, atol=1e-12)  # the half-width point T/4
    assert w[3] == pytest.approx((1 + np.cos(np.pi / 4)) / 2, abs=1e-12)  # 0.854
    assert 0 < w[4] < 1e-4  # just inside the edge
    np.testing.assert_array_equal(w[5:], 0.0)  # the edge and beyond


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_window_wraps_across_the_k_axis_edge(side):
    """A centre T/8 inside one end of the k axis: the point T/8 inside the
    other end is T/4 away on the circle (W = 1/2), not k_period - T/4 (W = 0)."""
    k0 = side * (K_PERIOD / 2 - T / 8)
    k = np.array([-side * (K_PERIOD / 2 - T / 8), -side * (K_PERIOD / 2 - T / 2.5)])
    w = _window(k, k0, T, K_PERIOD)
    assert w[0] == pytest.approx(0.5, abs=1e-12)
    # 0.4 T from its end: 0.525 T away, outside the support
    assert w[1] == 0.0
    # one k period away is the same point
    np.testing.assert_allclose(_window(k + K_PERIOD, k0, T, K_PERIOD), w, atol=1e-12)


def test_window_matches_a_second_evaluation(rng):
    for _ in range(200):
        kp = 2 * np.pi / rng.uniform(1e-3, 5e-2)
        period = rng.uniform(0.05, 1.0) * kp
        k0 = rng.uniform(-kp / 2, kp / 2)
        k = rng.uniform(-kp / 2, kp / 2, 64)
        # the FFT grid of an axis too (kspace_spectrum's k axes), where the
        # windows are used
        grid = 2 * np.pi * np.fft.fftfreq(int(rng.integers(8, 200)), 2 * np.pi / kp)
        for kk in (k, grid):
            np.testing.assert_allclose(
                _window(kk, k0, period, kp),
                _second_evaluation(kk, k0, period, kp),
                rtol=0,
                atol=1e-9,
            )


def test_cluster_on_the_k_axis_edge_is_decomposed():
    """Two point targets within one range resolution (0.45 and 0.42 m, 0.2
    GHz: 0.75 m), one 48 degrees off broadside, whose cluster centre lies
    on the edge of the k axis, one near broadside.  Bars: the paper's 2-D
    noise-free figures (RP <= 10 mm 94 %, RPM <= 50 mm 67 %) for the
    decomposition's RPs and for each target's points, 21 antennas each.
    Without the wrap the steep target's points all lie beyond 50 mm (32/42
    RPs within 10 mm), with the period halved too; with k + k0 the
    broadside target keeps 8 of 21."""
    arr = Array((np.arange(21) - 10) * PITCH)
    th = np.radians(48.0)
    targets = np.array([(0.45 * np.sin(th), 0.45 * np.cos(th)), (-0.03, 0.42)])
    data = simulate(
        Scene(tuple(PointTarget(tuple(t)) for t in targets)),
        arr,
        Waveform(20e9, 0.2e9),
        np.arange(0.0, 1.5, 2.5e-3),
    )
    params = default_params(data, window_x=T)  # the paper's period, as the bars are its
    ks = sorted(float(c.k[0]) for c in decompose(data, params.kspace).clusters)
    assert len(ks) == 2 and abs(abs(ks[0]) - K_PERIOD / 2) < 0.02 * K_PERIOD / 2
    res = run_method("kspace-rpm", data, params, reference)
    true_r = np.linalg.norm(arr.positions()[:, None] - targets[None], axis=2)
    rp_err = np.abs(true_r[res.rps.antenna] - res.rps.range[:, None]).min(axis=1)
    assert len(rp_err) >= 40 and np.mean(rp_err <= 0.010) >= 0.94
    dist = np.linalg.norm(res.image.points[:, None] - targets[None], axis=2)
    near = np.argmin(dist, axis=1)
    for i in range(2):
        assert np.sum((near == i) & (dist.min(axis=1) <= 0.05)) >= 0.67 * 21, i
