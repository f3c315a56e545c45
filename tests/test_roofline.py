"""The machine-limit micro-benchmarks (kernels/limits.cl against their float64
references), the roofline arithmetic and the equal-accuracy choice of
``rpm-cl bench``."""

from __future__ import annotations

import numpy as np
import pytest

from rpm_cl.cli.bench_roofline import (
    TOLERANCES,
    equal_accuracy,
    roofline_rows,
    stage_models,
)
from rpm_cl.cli.limits import (
    LimitKernels,
    MachineLimits,
    measure_limits,
    peak_fma_reference,
    stream_read_reference,
)


@pytest.fixture(scope="module", params=["float32", "float64"])
def limit_kernels(request, cl_env):
    if request.param == "float64" and not cl_env.has_double:
        pytest.skip("device has no float64")
    return LimitKernels(cl_env, request.param)


def test_peak_fma_matches_reference(limit_kernels, rng):
    """The multiply-add chains on the device equal the float64 recurrence
    for random b < 1 and c (a wrong chain start, coefficient or lane count
    moves the sums far beyond rounding)."""
    k = limit_kernels
    for _ in range(3):
        b, c = rng.uniform(0.5, 0.99), rng.uniform(1e-3, 0.1)
        iters = int(rng.integers(1, 20))  # few: the chain starts still count
        got = k.peak_fma(37, iters, b, c)
        want = peak_fma_reference(37, iters, b, c, k.vw)
        tol = 1e-5 if k.dtype == np.float32 else 1e-12
        np.testing.assert_allclose(got, want, rtol=tol)


def test_stream_read_matches_reference(limit_kernels, rng):
    """Each work-item sums exactly its own vectors (random data: a wrong
    offset or stride changes every sum)."""
    k = limit_kernels
    per = 8
    a = rng.standard_normal(per * k.vw * 13)
    tol = 1e-5 if k.dtype == np.float32 else 1e-12
    np.testing.assert_allclose(k.stream_read(a, per), stream_read_reference(a, per, k.vw), atol=tol)
    with pytest.raises(ValueError, match="whole work-items"):
        k.stream_read(a[:-1], per)
    with pytest.raises(ValueError, match="whole work-items"):
        k.stream_read(a, 6)


def test_measure_limits_positive(cl_env):
    lim = measure_limits(cl_env, repeats=1, stream_bytes=1 << 20, peak_iters=1000)
    assert lim.flops > 0 and lim.bandwidth > 0
    assert "GFLOP/s" in lim.describe() and "GB/s" in lim.describe()
    with pytest.raises(ValueError, match="positive"):
        MachineLimits(0.0, 1.0, "float32", "x")
    with pytest.raises(ValueError, match="precision"):
        measure_limits(cl_env, "float16")


def test_stage_models_follow_the_kernels_arithmetic():
    """Counts that follow from the kernels' structure: a third axis adds one
    difference and one multiply-add to a Gaussian evaluation (3 FLOP) and
    one difference to a back-projection; float64's exponential has five
    more multiply-adds (degree 12 against 7); a slot writes DIM + 1 reals
    and one byte."""
    f2, f3, d3 = stage_models(2, "float32"), stage_models(3, "float32"), stage_models(3, "float64")
    assert f3["score"][1] - f2["score"][1] == 3
    assert d3["score"][1] - f3["score"][1] == 10
    assert f3["das"][1] - f2["das"][1] == 1
    assert f3["intersect"][2] == 4 * 4 + 1 and d3["intersect"][2] == 4 * 8 + 1
    assert f2["intersect"][2] == 3 * 4 + 1
    assert d3["decompose"][2] == 16 and f3["decompose"][2] == 8


def test_roofline_rows_rates_and_ratios():
    lim = MachineLimits(100e9, 20e9, "float32", "test")
    rows = roofline_rows(
        {"score": (0.5, 1e9, "evaluation"), "intersect": (0.1, 1e8, "slot"), "x": (2.0, 10, "u")},
        lim,
        3,
    )
    by = {r["stage"]: r for r in rows}
    flop = stage_models(3, "float32")["score"][1]
    assert by["score"]["rate"] == pytest.approx(2e9)
    assert by["score"]["gflops"] == pytest.approx(2 * flop)
    assert by["score"]["peak"] == pytest.approx(2e9 * flop / 100e9)
    assert np.isnan(by["score"]["bw"])
    assert by["intersect"]["gbps"] == pytest.approx(1e9 * 17 / 1e9)
    assert by["intersect"]["bw"] == pytest.approx(17e9 / 20e9)
    assert by["x"]["rate"] == 5 and np.isnan(by["x"]["peak"]) and by["x"]["ms"] == 2000


def _op(label, ms, f50, f20):
    return {"label": label, "ms": ms, "within": dict(zip(TOLERANCES, (f50, f20)))}


def test_equal_accuracy_takes_the_fastest_point_reaching_the_common_fraction():
    rpm = [_op("fast", 1.0, 0.5, 0.2), _op("good", 10.0, 0.95, 0.9)]
    das = [_op("coarse", 2.0, 0.6, 0.1), _op("fine", 50.0, 0.8, 0.85)]
    q50, q20 = equal_accuracy(rpm, das)
    # <= 50 mm: DAS's best is 0.8, which only "good" reaches on the RPM side
    assert q50["fraction"] == 0.8
    assert q50["rpm"]["label"] == "good" and q50["das"]["label"] == "fine"
    assert q50["ratio"] == pytest.approx(10.0 / 50.0)
    # <= 20 mm: the common level is 0.85 (DAS's best)
    assert q20["fraction"] == 0.85 and q20["rpm"]["label"] == "good"
    # a side whose best is lower sets the level: RPM's 0.5 is reached by the fast point
    q50b, _ = equal_accuracy([rpm[0]], das)
    assert q50b["fraction"] == 0.5 and q50b["das"]["label"] == "coarse"
    assert equal_accuracy([], das) == []
