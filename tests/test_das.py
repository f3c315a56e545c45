"""SAR / DAS back-projection: kernel vs NumPy, physics, adjoint, reuse plan."""

import numpy as np
import pytest

from rpm_cl.baselines.das import (
    DASPlan,
    DeviceDAS,
    Grid,
    das_adjoint,
    das_numpy,
    parse_grid,
)
from rpm_cl.io.data import Array, InputError, RadarData, Waveform
from rpm_cl.simulate import simulate
from rpm_cl.simulate.scene import PointTarget, Scene


@pytest.fixture(scope="module")
def das32(cl_env):
    return DeviceDAS(cl_env, "float32")


@pytest.fixture(scope="module")
def das64(cl_env):
    if not cl_env.has_double:
        pytest.skip("no float64")
    return DeviceDAS(cl_env, "float64")


def random_data(rng, planar, nr=120, fc=20e9, bw=3e9):
    x = (np.arange(7) - 3) * 7.5e-3
    z = (np.arange(5) - 2) * 7.5e-3 if planar else None
    arr = Array(x, z)
    rng_axis = 0.3 + 2.5e-3 * np.arange(nr)
    sig = rng.normal(size=arr.shape + (nr,)) + 1j * rng.normal(size=arr.shape + (nr,))
    return RadarData(sig, arr, rng_axis, Waveform(fc, bw))


@pytest.mark.parametrize("planar", [False, True])
def test_kernel_matches_numpy_on_random_input(planar, das32, das64, rng):
    data = random_data(rng, planar)
    g = (
        Grid(np.linspace(-0.1, 0.1, 13), np.linspace(0.32, 0.55, 29))
        if not planar
        else Grid(np.linspace(-0.1, 0.1, 7), np.linspace(0.35, 0.5, 5), np.linspace(-0.1, 0.1, 11))
    )
    want = das_numpy(data, g)
    scale = np.abs(want).max()
    # float64: the kernel's Taylor phasor (|x| <= 1.05, truncation 4e-8 per
    # term) is the only difference from exp(); float32: rounding of d (1e-7 R)
    # times 2 k_c and of each of n_ant summands.
    np.testing.assert_allclose(das64.backproject(data, g), want, atol=1e-7 * scale)
    np.testing.assert_allclose(das32.backproject(data, g), want, atol=2e-4 * scale)


def test_voxels_off_the_range_axis_read_nothing(das32, das64, rng):
    # Voxels before the axis, just past its end, and so far away that their
    # fractional sample index exceeds the int range (1e7 m at 2.5 mm gates):
    # 0 exactly, as in das_numpy, never an out-of-bounds read or NaN.
    data = random_data(rng, False)
    g = Grid(np.array([-1e7, -50.0, 0.0, 0.02]), np.array([0.01, 0.299, 0.5, 0.6, 3.0, 1e7]))
    want = das_numpy(data, g)
    for das in (das32, das64):
        got = das.backproject(data, g)
        assert np.all(np.isfinite(got))
        off = want == 0
        assert off.sum() >= 14 and np.all(got[off] == 0)
        np.testing.assert_allclose(got, want, atol=2e-4 * np.abs(want).max())


def test_grid_parsing_and_errors():
    g = parse_grid("-0.1:0.1:0.05,0.5:0.6:0.1")
    np.testing.assert_allclose(g.x, [-0.1, -0.05, 0.0, 0.05, 0.1])
    assert g.shape == (5, 2) and g.dim == 2
    assert parse_grid("0:0:1,1:1:1,0:0.003:0.003").shape == (1, 1, 2)
    for bad in ("0:1", "0:1:0,0:1:1", "1:0:0.1,0:1:1", "a:b:c,0:1:1", "0:1:nan,0:1:1"):
        with pytest.raises(InputError):
            parse_grid(bad)


def test_point_target_peak_within_one_resolution_cell(das32):
    """2-D, 3 GHz: range cell c/2B = 50 mm; cross-range lambda R / 2L."""
    tgt = np.array([0.04, 0.62])
    arr = Array((np.arange(41) - 20) * 5e-3)
    data = simulate(
        Scene((PointTarget(tgt),)), arr, Waveform(20e9, 3e9), np.arange(0.3, 1.0, 2.5e-3)
    )
    g = parse_grid("-0.2:0.2:0.002,0.4:0.8:0.002")
    img = das32.backproject(data, g)
    i, j = np.unravel_index(np.argmax(np.abs(img)), img.shape)
    cross = 0.015 * 0.62 / (2 * 0.2)
    assert abs(g.x[i] - tgt[0]) <= cross and abs(g.y[j] - tgt[1]) <= 0.05
    # in fact much better: the phase focuses to a fraction of a wavelength
    assert np.hypot(g.x[i] - tgt[0], g.y[j] - tgt[1]) < 0.005


def test_point_target_3d(das32):
    tgt = np.array([-0.03, 0.8, 0.05])
    arr = Array((np.arange(11) - 5) * 7.5e-3, (np.arange(17) - 8) * 7.5e-3)
    data = simulate(
        Scene((PointTarget(tgt),)), arr, Waveform(20e9, 3e9), np.arange(0.5, 1.1, 2.5e-3)
    )
    g = parse_grid("-0.15:0.15:0.01,0.7:0.9:0.005,-0.1:0.2:0.01")
    img = das32.backproject(data, g)
    i = np.unravel_index(np.argmax(np.abs(img)), img.shape)
    p = np.array([g.x[i[0]], g.y[i[1]], g.z[i[2]]])
    # cross-range cell lambda R / 2L: 0.015*0.8/(2*0.075) = 80 mm (x), 47 mm (z)
    assert abs(p[0] - tgt[0]) <= 0.08 and abs(p[2] - tgt[2]) <= 0.047
    assert abs(p[1] - tgt[1]) <= 0.05


@pytest.mark.parametrize("planar", [False, True])
def test_adjoint_dot_product(planar, das32, rng):
    """<A x, s> = <x, DAS s>, A = das_adjoint (the discretised forward model)."""
    data = random_data(rng, planar, nr=80)
    g = (
        Grid(np.linspace(-0.05, 0.05, 9), np.linspace(0.33, 0.45, 11))
        if not planar
        else Grid(
            np.linspace(-0.05, 0.05, 5), np.linspace(0.35, 0.45, 4), np.linspace(-0.05, 0.05, 6)
        )
    )
    x = rng.normal(size=g.shape) + 1j * rng.normal(size=g.shape)
    lhs = np.vdot(das_adjoint(x, data, g), data.signal)
    rhs = np.vdot(x, das_numpy(data, g))
    assert abs(lhs - rhs) <= 1e-12 * abs(lhs)
    rhs32 = np.vdot(x, das32.backproject(data, g))
    assert abs(lhs - rhs32) <= 1e-4 * abs(lhs)


def test_memory_budget_chunks_give_the_same_image(rng):
    data = random_data(rng, True, nr=60)
    g = Grid(np.linspace(-0.05, 0.05, 6), np.linspace(0.35, 0.42, 5), np.linspace(-0.05, 0.05, 7))
    whole = das_numpy(data, g)
    tiny = das_numpy(data, g, memory_budget=160 * 35 * 3)  # 3 voxels per chunk (160 B each)
    np.testing.assert_allclose(tiny, whole, rtol=0, atol=0)


def test_reuse_plan_matches_and_refuses_beyond_budget(rng):
    data = random_data(rng, False)
    g = Grid(np.linspace(-0.1, 0.1, 11), np.linspace(0.32, 0.5, 19))
    plan = DASPlan(data, g)
    frame2 = RadarData(data.signal[..., ::-1].copy(), data.array, data.range, data.waveform)
    for d in (data, frame2):  # the tables serve every frame of the geometry
        want = das_numpy(d, g)
        np.testing.assert_allclose(plan.apply(d), want, atol=1e-5 * np.abs(want).max())
    with pytest.raises(InputError, match="GB"):
        DASPlan(data, g, memory_budget=g.size * 7 * 20 - 1)
    other = RadarData(data.signal, data.array, data.range, Waveform(24e9, 3e9))
    with pytest.raises(InputError, match="differs"):
        plan.apply(other)


def test_numpy_das_stays_within_its_memory_budget(rng):
    """Peak NumPy allocations (tracemalloc sees them) stay under the budget
    plus the image itself."""
    import tracemalloc

    data = random_data(rng, True, nr=200)
    g = Grid(np.linspace(-0.2, 0.2, 40), np.linspace(0.35, 0.7, 30), np.linspace(-0.2, 0.2, 40))
    budget = 4e6  # the unbounded computation would need ~ 48000 x 35 x 160 B = 270 MB
    out = np.empty(g.shape, np.complex128)
    tracemalloc.start()
    das_numpy(data, g, memory_budget=budget, out=out)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    # besides the chunk temporaries, das_numpy holds the signal as complex128
    # (35 x 200 x 16 B = 112 kB) and the antenna table: allow 0.2 MB for them
    assert peak <= budget + 0.2e6
