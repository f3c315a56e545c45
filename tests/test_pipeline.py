"""Physics: targets at known places, each imager must find them."""

import numpy as np
import pytest

from rpm_cl.extract.kspace import KSpaceParams, decompose
from rpm_cl.extract.rangepoints import profile_peaks, rps_from_decomposition
from rpm_cl.imaging import run_method
from rpm_cl.io.data import Array, Waveform
from rpm_cl.metrics import cumulative, echoes_found, err_range, err_rpm, summary
from rpm_cl.rpm import reference
from rpm_cl.rpm.params import ImagingParams, default_params
from rpm_cl.rpm.pipeline import rpm_image
from rpm_cl.simulate import simulate, simulate_preset
from rpm_cl.simulate.scene import PointTarget, Scene


def test_profile_peak_refinement_is_subsample():
    # samples of a parabola-like smooth peak at a non-grid position
    t = np.arange(50.0)
    true = 23.37
    env = np.exp(-0.5 * ((t - true) / 6.0) ** 2)[None, :]
    row, pos, val = profile_peaks(env, 0.1)
    assert row.tolist() == [0]
    assert abs(pos[0] - true) < 0.01  # a 3-point parabola on a Gaussian of 6 samples
    assert abs(val[0] - 1.0) < 1e-3


def test_decomposition_separates_targets_within_one_range_cell():
    """Two targets 40 mm apart in range (0.05 of a 750 mm cell) at different
    directions: the k-space clusters each hold one target's ranges."""
    data, _ = simulate_preset("paper-2d")
    dec = decompose(data, KSpaceParams())
    assert len(dec.clusters) == 3
    rps = rps_from_decomposition(data, dec, ImagingParams().rp_threshold_db)
    truth = data.truth
    true_r = truth.rp_range.reshape(3, -1)  # (target, antenna)
    for c in range(3):
        sel = rps.cluster == c
        # each cluster's RPs all sit within 10 mm of one single target's range
        errs = [np.abs(rps.range[sel] - true_r[t, rps.antenna[sel]]) for t in range(3)]
        best = int(np.argmin([np.median(e) for e in errs]))
        assert np.mean(errs[best] <= 0.010) >= 0.85, (c, best)


@pytest.mark.parametrize("engine_name", ["reference", "float32", "float64"])
def test_kspace_rpm_images_paper_targets(engine_name, dev32, dev64):
    engine = {"reference": reference, "float32": dev32, "float64": dev64}[engine_name]
    data, pre = simulate_preset("paper-2d")
    res = run_method("kspace-rpm", data, default_params(data, **pre.defaults), engine)
    targets = data.truth.boundary
    d = np.linalg.norm(res.image.points[:, None] - targets[None], axis=2)
    # every target has points within 20 mm of it; most points are near a target
    assert np.all(np.sum(d <= 0.020, axis=0) >= 5)
    assert np.mean(d.min(axis=1) <= 0.050) >= 0.9


def test_kspace_beats_matched_filter_rpm():
    data, pre = simulate_preset("paper-2d", 20.0, seed=4, noise="receiver")
    p = default_params(data, **pre.defaults)
    k = summary(*_res(run_method("kspace-rpm", data, p, reference)), data.truth)
    m = summary(*_res(run_method("mf-rpm", data, p, reference)), data.truth)
    # three targets inside one range cell: the MF finds one merged echo per
    # antenna at most, the decomposition one per target per antenna.
    assert k["rp_within_10mm"] >= 2 * m["rp_within_10mm"]
    assert k["rpm_within_50mm"] > m["rpm_within_50mm"]


def _res(r):
    return r.rps, r.image


def test_device_and_reference_images_agree(dev32):
    data, pre = simulate_preset("paper-2d", 10.0, seed=2, noise="receiver")
    p = default_params(data, **pre.defaults)
    a = run_method("kspace-rpm", data, p, reference)
    b = run_method("kspace-rpm", data, p, dev32)
    np.testing.assert_array_equal(a.image.rp_index, b.image.rp_index)
    # Where float32 picked another candidate (a near-tie), its score must equal
    # the best float64 score to float32 accuracy (scores are sums of <= 21
    # positive terms, each with ~1e-6 relative error).
    np.testing.assert_allclose(b.image.score, a.image.score, rtol=1e-4)


def test_empty_and_zero_input_give_empty_image(dev32):
    data, _pre = simulate_preset("paper-2d")
    from rpm_cl.io.data import RadarData

    zero = RadarData(np.zeros_like(data.signal), data.array, data.range, data.waveform)
    for m in ("kspace-rpm", "mf-rpm"):
        res = run_method(m, zero, default_params(zero), dev32)
        assert len(res.rps) == 0 and res.image.points.shape == (0, 2)


def test_metrics_by_hand():
    from rpm_cl.io.data import Truth

    truth = Truth([0, 0, 1], [1.0, 1.5, 2.0], [[0.0, 1.0], [1.0, 1.0]])
    e = err_range([0, 0, 1, 2], [1.004, 1.3, 2.02, 1.0], truth)
    np.testing.assert_allclose(e[:3], [0.004, 0.2, 0.02])
    assert np.isinf(e[3])  # no true echo at antenna 2
    assert cumulative(e, 0.010) == (1, 4)
    np.testing.assert_allclose(err_rpm([[0.0, 1.03], [0.5, 1.0]], truth), [0.03, 0.5])
    # echoes found: (0, 1.0) by the RP at 1.004; (0, 1.5) is 0.2 m from the
    # nearest RP; (1, 2.0) is 20 mm off, found with a 25 mm tolerance only
    assert echoes_found([0, 0, 1, 2], [1.004, 1.3, 2.02, 1.0], truth) == 1
    assert echoes_found([0, 0, 1, 2], [1.004, 1.3, 2.02, 1.0], truth, 0.025) == 2
    assert echoes_found(np.zeros(0, int), [], truth) == 0


def test_single_target_one_cluster_near_truth(dev32):
    arr = Array((np.arange(31) - 15) * 5e-3)
    data = simulate(
        Scene((PointTarget([0.05, 0.6]),)), arr, Waveform(20e9, 0.2e9), np.arange(0, 1.5, 2.5e-3)
    )
    p = default_params(data)
    res = run_method("kspace-rpm", data, p, dev32)
    assert len(set(res.rps.cluster.tolist())) == 1
    assert np.median(np.linalg.norm(res.image.points - [0.05, 0.6], axis=1)) < 0.005


def test_example_runs():
    """examples/paper_2d.py runs and images three clusters."""
    import importlib.util
    import pathlib

    path = pathlib.Path(__file__).parents[1] / "examples" / "paper_2d.py"
    spec = importlib.util.spec_from_file_location("paper_2d_example", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    res = mod.main(snr_db=None)
    assert len(np.unique(res.rps.cluster)) == 3


def test_chunked_rpm_equals_whole_and_scale_invariant(dev32):
    from dataclasses import replace

    from rpm_cl.extract.kspace import decompose as dec_
    from rpm_cl.extract.rangepoints import rps_from_decomposition as rps_
    from rpm_cl.io.data import InputError, RadarData

    data, pre = simulate_preset("paper-2d", 20.0, seed=3, noise="receiver")
    p = default_params(data, **pre.defaults)
    rps = rps_(data, dec_(data, p.kspace), p.rp_threshold_db)
    whole = rpm_image(rps, p.rpm, dev32)
    chunked = rpm_image(rps, replace(p.rpm, chunk_slots=50), dev32)  # 2 main RPs a chunk
    np.testing.assert_array_equal(whole.points, chunked.points)
    # the data's scale must not matter, even for float32 kernels (1e300 and
    # 1e-300 would overflow / underflow a float32 weight)
    for k in (1e300, 1e-300):
        scaled = RadarData(data.signal * k, data.array, data.range, data.waveform, data.truth)
        res = run_method("kspace-rpm", scaled, p, dev32)
        np.testing.assert_allclose(
            res.image.points, run_method("kspace-rpm", data, p, dev32).image.points, atol=1e-4
        )
    with pytest.raises(InputError, match="pairs with .* more than max_cluster_rps=5"):
        rpm_image(rps, replace(p.rpm, max_cluster_rps=5), dev32)


def test_intersect_chunk_offset_matches_reference(dev32, rng):
    from rpm_cl.rpm import reference as ref

    n = 50
    x, r = rng.uniform(-0.05, 0.05, n), rng.uniform(0.3, 0.6, n)
    amp, st_, ct = rng.uniform(0, 1, n), np.repeat([0, 30], [30, 20]), np.repeat([30, 20], [30, 20])
    whole = ref.intersect_circles(x, r, amp, st_, ct, 30, 0.1)
    part = ref.intersect_circles(x, r, amp, st_, ct, 30, 0.1, 25, 10)
    np.testing.assert_array_equal(part[2], whole[2][25:35])
    np.testing.assert_array_equal(
        dev32.intersect_circles(x, r, amp, st_, ct, 30, 0.1, 25, 10)[2], part[2]
    )


def test_noise_free_paper_2d_meets_the_paper(dev32):
    """Acceptance: the noise-free k-space RPM row at or past Tables I/II."""
    from rpm_cl.cli.reproduce import PAPER

    data, pre = simulate_preset("paper-2d")
    res = run_method("kspace-rpm", data, default_params(data, **pre.defaults), dev32)
    s = summary(res.rps, res.image, data.truth)
    ref = PAPER[("points-5mm", "kspace-rpm", None)]
    assert s["rp_total"] == 63  # one RP per antenna per target
    assert s["rp_within_10mm"] / s["rp_total"] >= ref["rp10"]
    assert s["rpm_within_50mm"] / s["rpm_total"] >= ref["rpm50"]
    assert s["rpm_within_100mm"] / s["rpm_total"] >= ref["rpm100"]


def test_device_round_trip_recovers_scatterers(dev32, dev64, rng):
    """Kernels on exact ranges from random scatterers return the scatterers."""
    n_ant = 16
    x = np.linspace(-0.04, 0.04, n_ant)
    targets = np.stack([rng.uniform(-0.3, 0.3, 3), rng.uniform(0.2, 2.0, 3)], axis=1)
    xs = np.tile(x, 3)
    rs = np.concatenate([np.hypot(t[0] - x, t[1]) for t in targets])
    st_, ct = np.repeat([0, 16, 32], 16), np.full(48, 16)
    for dev, tol in ((dev64, 1e-9), (dev32, 2e-3)):
        _best, _score, pt = dev.rpm_circles(xs, rs, np.ones(48), st_, ct, 16, 0.05, 0.01)
        got = np.stack([xs + pt[0], pt[1]], axis=1)
        want = np.repeat(targets, 16, axis=0)
        # float32: range rounding 1e-7 R amplified by (R/baseline)^2 <= (2/0.005)^2
        assert np.all(np.linalg.norm(got - want, axis=1) <= tol), dev.precision


# --------------------------------------------------------------------------
# the matched-filter and Capon baselines where they should work
WIDE_TARGETS = np.array([(-0.10, 0.50), (0.05, 0.70), (0.15, 0.90)])


def _wide_scene(snr_db=None, seed=None):
    """Three point targets 0.2 m apart in range (four resolutions at 3 GHz:
    the matched filter separates their echoes at every antenna) before a
    0.2 m array of 41 antennas at 5 mm, 20 GHz."""
    arr = Array((np.arange(41) - 20) * 5e-3)
    scene = Scene(tuple(PointTarget(tuple(t)) for t in WIDE_TARGETS))
    return simulate(scene, arr, Waveform(20e9, 3e9), np.arange(0.3, 1.2, 2.5e-3), snr_db, seed)


def _target_distances(points):
    d = np.linalg.norm(points[:, None] - WIDE_TARGETS[None], axis=2)
    return np.argmin(d, axis=1), np.min(d, axis=1)


@pytest.mark.parametrize("method", ["mf-rpm", "capon-rpm"])
@pytest.mark.parametrize("engine_name", ["reference", "float32"])
def test_baselines_image_separated_targets(method, engine_name, dev32):
    """Noise-free: every antenna has one RP per target, each within 1 mm
    (separated echoes, a three-point parabola on a 20-gate main lobe), and
    the points fall within 10 mm of their target (range errors of 1 mm
    crossing over a 0.2 m baseline at up to 0.9 m move a point by about
    1 mm x R / L = 4.5 mm), at least 39 of each target's 41."""
    engine = {"reference": reference, "float32": dev32}[engine_name]
    data = _wide_scene()
    res = run_method(method, data, default_params(data), engine)
    e = err_range(res.rps.antenna, res.rps.range, data.truth)
    assert len(e) == 123 and np.all(e <= 0.001)
    near, dist = _target_distances(res.image.points)
    for t in range(3):
        assert np.sum((near == t) & (dist <= 0.010)) >= 39, (method, t)


@pytest.mark.parametrize("method", ["mf-rpm", "capon-rpm"])
@pytest.mark.parametrize("seed", [0, 1])
def test_baselines_image_separated_targets_at_30_db(method, seed):
    """In-band S/N 30 dB (of the strongest echo; the farthest is 5 dB
    weaker): the Cramer-Rao bound of a range estimate with the cos^4
    band's rms width (0.85 GHz) is c / (4 pi B_rms sqrt(2 S/N)) = 0.63 mm,
    1.1 mm for the farthest target, so 90 % of the RPs lie within 5 mm;
    over the 0.2 m aperture at up to 0.9 m a point moves about sqrt(2) R /
    L = 6.4 times a range error, so 50 mm holds 90 % of the points and 80 %
    of each target's."""
    data = _wide_scene(30.0, seed)
    res = run_method(method, data, default_params(data), reference)
    e = err_range(res.rps.antenna, res.rps.range, data.truth)
    assert np.mean(e <= 0.005) >= 0.9
    near, dist = _target_distances(res.image.points)
    assert np.mean(dist <= 0.050) >= 0.9
    for t in range(3):
        assert np.sum((near == t) & (dist <= 0.050)) >= 0.8 * 41, (method, t)
