"""The imager registry (rpm_cl.imaging.METHODS): every method behind one
call with one result type, DAS and RMA among them (rpm_cl.baselines.imagers)."""

import json

import numpy as np
import pytest

from rpm_cl.baselines.imagers import default_grid, echo_span, in_reach
from rpm_cl.cli import main
from rpm_cl.imaging import METHODS, RPM_METHODS, run_method
from rpm_cl.io.data import InputError
from rpm_cl.io.medium import Medium
from rpm_cl.metrics import err_rpm
from rpm_cl.result import ImageResult
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import simulate_preset


@pytest.fixture(scope="module")
def paper2d():
    return simulate_preset("paper-2d", None, 0)[0]


def test_registry_lists_every_method():
    assert set(METHODS) == {"kspace-rpm", "phase-rpm", "mf-rpm", "capon-rpm", "das", "rma"}
    assert RPM_METHODS == ("kspace-rpm", "phase-rpm", "mf-rpm", "capon-rpm")
    assert all(m.family in ("rpm", "coherent") and m.summary for m in METHODS.values())


def test_every_method_one_call_one_result(paper2d, dev32):
    """Each method returns an ImageResult whose points lie in the plane of a
    linear array's scene, with one score, cluster and RP index per point."""
    params = default_params(paper2d)
    for name in METHODS:
        res = run_method(name, paper2d, params, dev32)
        assert isinstance(res, ImageResult) and res.method == name
        m = len(res.image.points)
        assert m > 0 and res.image.points.shape == (m, 2), name
        assert res.image.score.shape == res.image.cluster.shape == res.image.rp_index.shape == (m,)
        assert res.timings["total"] > 0


def test_das_points_are_the_targets(paper2d, dev32):
    """DAS through the registry: its points (the image's peaks within 6 dB)
    lie within 50 mm of the paper scene's three targets and hit each; the
    NumPy back-projection (no device) gives the same points."""
    params = default_params(paper2d)
    res = run_method("das", paper2d, params, dev32)
    d = err_rpm(res.image.points, paper2d.truth)
    assert np.all(d <= 0.05)
    tg = np.array([t["position"] for t in json.loads(paper2d.truth.scene)["targets"]])
    near = np.linalg.norm(res.image.points[:, None] - tg[None], axis=2) <= 0.05
    assert near.any(axis=0).all()
    ref = run_method("das", paper2d, params, None)
    np.testing.assert_allclose(ref.image.points, res.image.points, atol=1e-9)


def test_planar_arrays_take_das_not_rma(dev32):
    data = simulate_preset("human-body", None, 0)[0]
    res = run_method("das", data, default_params(data), dev32)
    assert res.image.points.shape[1] == 3 and np.all(err_rpm(res.image.points, data.truth) <= 0.05)
    with pytest.raises(InputError, match="linear arrays only"):
        run_method("rma", data, default_params(data), dev32)


def test_default_grid_covers_the_echoes(paper2d):
    """The grid spans the echoes' depths (one echo at 0.6 m of a 1-3 GHz
    band whose axis runs to 9.6 m: within three resolutions of it) and the
    array's extent plus that depth sideways; its size is capped; in a medium
    the depths are true ones."""
    from test_medium import X, _spectrum_data

    data = _spectrum_data(np.full((X.size, 1), 0.6))
    res = data.waveform.range_resolution
    lo, hi = echo_span(data)
    assert 0.6 - 3 * res <= lo < 0.6 < hi <= 0.6 + 3 * res and data.range[-1] > 9
    g = default_grid(data)
    step = g.y[1] - g.y[0]
    assert g.y[0] == pytest.approx(lo) and hi - step <= g.y[-1] <= hi + 1e-12
    assert g.x[0] == pytest.approx(X[0] - hi) and g.x[-1] >= X[-1] + hi - step
    gn = default_grid(data, Medium(4.0))
    assert gn.y[-1] == pytest.approx(g.y[-1] / 2, rel=0.02)
    assert default_grid(paper2d).size <= 1_000_000


def _circle_data(echoes, offset=0.0):
    """A 1-4 GHz sweep of 101 samples (unambiguous range 5 m) of echoes
    ``(range m, amplitude)`` seen alike by 5 antennas, loaded as a spectrum
    file loads (the Hann compression over the whole axis); ``offset`` moves
    the range axis off 0 (then it is no compressed circle)."""
    from dataclasses import replace

    from rpm_cl.cli.robustness import Geometry, loaded_data

    g = Geometry("circle", 2.5e9, 3e9, 101, (5, 0.01), None, ((0.0, 1.0),))
    f = g.fc - g.band / 2 + np.arange(g.nf) * g.band / (g.nf - 1)
    y = sum(a * np.exp(-4j * np.pi * f * r / 299_792_458.0) for r, a in echoes)
    data = loaded_data(g, np.tile(y, (5, 1)), f)
    return replace(data, range=data.range + offset) if offset else data


def test_echo_span_of_a_wrapped_main_lobe():
    """An echo 20 mm away: its Hann main lobe wraps to the far end of the
    5 m axis, which is not an echo there; the span stays at the scene.  An
    axis moved off 0 is no compressed circle and keeps the plain rule."""
    data = _circle_data([(0.02, 1.0)])
    assert data.range[-1] > 4.9
    power = np.sum(np.abs(data.signal) ** 2, axis=0)
    assert power[-1] > 1e-3 * power.max()  # the wrapped lobe is there
    res = data.waveform.range_resolution
    lo, hi = echo_span(data)
    assert lo == data.range[0] and hi < 0.02 + 2.5 * res < 1.0
    lo, hi = echo_span(_circle_data([(0.02, 1.0)], offset=0.05))
    assert hi == pytest.approx(data.range[-1] + 0.05)


@pytest.mark.parametrize("far", [2.6, 4.0])
def test_echo_span_keeps_far_echoes_on_a_circle(far):
    """Beside an echo near 0 whose lobe wraps, a weaker echo farther out
    (2.6 m, or 4 m: 1 m from the axis' end, beyond a wrapped lobe) stays in
    the span."""
    data = _circle_data([(0.01, 1.0), (far, 0.3)])
    lo, hi = echo_span(data)
    assert lo == data.range[0] and hi > far


def test_reach_filter():
    pos = np.array([[-0.05, 0.0], [0.05, 0.0]])
    pts = np.array([[0.0, 0.1], [0.05, 0.001], [0.5, 0.1], [-0.05 - 0.09, 0.1]])
    np.testing.assert_array_equal(in_reach(pos, pts, 45.0), [True, True, False, True])
    np.testing.assert_array_equal(in_reach(pos, pts, 41.0), [True, True, False, False])


def test_cli_image_method_das(tmp_path, capsys, p2):
    out = tmp_path / "das.npz"
    assert main(["image", str(p2), "-o", str(out), "--method", "das"]) == 0
    text = capsys.readouterr().out
    assert text.startswith("das:") and "Err_RPM<=50mm 100.0%" in text
    with np.load(out) as z:
        assert z["points"].shape[1] == 2 and z["rp_range"].size == 0
        assert json.loads(str(z["meta"]))["method"] == "das"


def test_coherent_imagers_above_a_halfspace(dev32):
    """Rods under 80 mm of air in eps_r 6 (synthetic, Fermat's paths): das
    and rma through the registry image the material only and put their
    three strongest peaks on the three rods: within one pixel of das's
    default grid (a quarter wavelength in the material, 15 mm), within 5 mm
    for rma (pixels a quarter of the pitch)."""
    from test_medium import TARGETS, H, _ranges, _spectrum_data

    tg = TARGETS[:3]
    data = _spectrum_data(_ranges(tg))
    params = default_params(data, eps_r=6.0, antenna_height=H)
    step = float(np.diff(default_grid(data, params.medium).x[:2])[0])
    for name, tol in (("das", step), ("rma", 0.005)):
        pts = run_method(name, data, params, dev32).image.points
        assert np.all(pts[:, 1] >= H - 1e-9), name
        d = np.linalg.norm(pts[:3, None] - tg[None], axis=2)
        assert np.all(d.min(axis=0) <= tol) and np.all(d.min(axis=1) <= tol), (name, pts[:3])


def test_default_grid_stays_under_its_cap():
    data = simulate_preset("human-body", None, 0)[0]
    g = default_grid(data)
    assert 0.5 * 4_000_000 < g.size <= 4_000_000
