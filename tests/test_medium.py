"""Imaging in a medium: a homogeneous dielectric and a half-space below antennas
in air (rpm_cl.io.medium, rpm_cl.rpm.halfspace, and the medium in DAS, RMA and the CLI).

The refracted ranges the tests trust are computed here by a dense search over
the surface crossing (:func:`_fermat`), independently of rpm_cl's Newton
solver.
"""

from dataclasses import replace

import numpy as np
import pytest

from rpm_cl.baselines.das import Grid, das_adjoint, das_numpy
from rpm_cl.baselines.peaks import image_peaks
from rpm_cl.baselines.rma import rma_image
from rpm_cl.cli import main
from rpm_cl.extract.rangepoints import RangePoints
from rpm_cl.imaging import run_method
from rpm_cl.io.data import C0, Array, DataWarning, InputError, RadarData, Waveform
from rpm_cl.io.formats import range_compress, range_sidelobe_db, window_bandwidth
from rpm_cl.io.medium import (
    Medium,
    air_ranges,
    crossing,
    in_medium,
    one_way,
    paraxial,
    point_on_ray,
    ray_through,
)
from rpm_cl.rpm import reference as ref
from rpm_cl.rpm.halfspace import halfspace_rpm
from rpm_cl.rpm.multipath import double_bounce, ghost_points
from rpm_cl.rpm.params import RPMParams, default_params

EPS = 6.0
N = np.sqrt(EPS)
H = 0.08  # antenna height above the surface, m
X = np.arange(51) * 0.01 - 0.25  # 51 antennas at 10 mm
#: point targets under the surface (x, y) in the imaging frame, m: the last
#: one 0.22 m aside at 0.06 m depth, seen at up to 80 degrees in air
TARGETS = np.array([[0.0, H + 0.10], [0.10, H + 0.20], [-0.12, H + 0.25], [0.22, H + 0.06]])


def _fermat(rho, h, d, n, step=2e-6):
    """Optical path from an antenna h above the surface to points d below it
    and rho aside: the minimum over crossings every ``step`` (error of order
    step^2 / h, far below 1e-9 m), one point at a time."""
    out = []
    for r, dd in zip(np.ravel(rho), np.ravel(np.broadcast_to(d, np.shape(rho)))):
        u = np.minimum(np.arange(0.0, r + step, step), r)
        out.append(np.min(np.hypot(u, h) + n * np.hypot(r - u, dd)))
    return np.reshape(out, np.shape(rho))


def _ranges(targets, x=X, h=H, n=N):
    """Air-equivalent ranges (antennas, targets) of point targets, m."""
    return np.stack([_fermat(np.abs(x - tx), h, ty - h, n) for tx, ty in targets], axis=1)


def _spectrum_data(r, band=(1e9, 3e9), nf=129, scale=1.0, x=X):
    """Frequency-domain data of unit echoes at air-equivalent ranges ``r``
    (antennas, echoes), frequencies multiplied by ``scale``, Hann-compressed."""
    f = np.linspace(*band, nf) * scale
    y = np.exp(-4j * np.pi * f[None, :, None] * r[:, None, :] / C0).sum(axis=2)
    s, rng = range_compress(y, f, f.mean(), "hann")
    w = Waveform(f.mean(), window_bandwidth(f, "hann"))
    return RadarData(s, Array(x), rng, w, None, range_sidelobe_db(f, "hann", w.bandwidth))


def _nearest(points, targets):
    return np.min(np.linalg.norm(points[:, None, :] - targets[None], axis=2), axis=1)


# ------------------------------------------------------------------ physics
def test_one_way_is_fermats_shortest_path_and_obeys_snell(rng):
    m = Medium(EPS, H)
    rho = rng.uniform(0.0, 0.5, 40)
    d = rng.uniform(1e-3, 0.4, 40)
    pts = np.stack([rho, H + d, np.zeros(40)], axis=1)
    got = one_way(m, np.zeros((1, 3)), pts)
    np.testing.assert_allclose(got, _fermat(rho, H, d, N), atol=1e-9)
    # Snell at the crossing: sin(theta_air) = n sin(theta_in)
    u = crossing(rho, H, d, N)
    np.testing.assert_allclose(u / np.hypot(u, H), N * (rho - u) / np.hypot(rho - u, d), atol=1e-9)
    # 3-D: the same path in the vertical plane through antenna and point
    az = rng.uniform(0, 2 * np.pi, 40)
    p3 = np.stack([rho * np.cos(az), H + d, rho * np.sin(az)], axis=1)
    np.testing.assert_allclose(one_way(m, np.zeros((1, 3)), p3), got, rtol=1e-12)
    # above the surface, straight; a homogeneous medium: n times the distance
    up = np.array([[0.1, 0.05, 0.0]])
    assert one_way(m, np.zeros((1, 3)), up)[0] == pytest.approx(np.hypot(0.1, 0.05))
    assert one_way(Medium(EPS), np.zeros((1, 3)), up)[0] == pytest.approx(N * np.hypot(0.1, 0.05))


def test_point_on_ray_inverts_ray_through(rng):
    m = Medium(EPS, H)
    ant = np.column_stack([rng.uniform(-0.2, 0.2, 50), np.zeros(50), rng.uniform(-0.2, 0.2, 50)])
    pts = np.column_stack(
        [rng.uniform(-0.4, 0.4, 50), rng.uniform(0.01, 0.5, 50), rng.uniform(-0.4, 0.4, 50)]
    )  # some above the surface
    p, e = ray_through(m, ant, pts)
    got, t = point_on_ray(m, ant, p, e, one_way(m, ant, pts))
    np.testing.assert_allclose(got, pts, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(t, axis=1), 1.0, rtol=1e-12)


def test_medium_validation():
    for bad in (0.5, float("nan"), 101.0, True, "6"):
        with pytest.raises(InputError, match="eps_r"):
            Medium(bad)
    for bad in (-0.01, float("inf"), True):
        with pytest.raises(InputError, match="antenna_height"):
            Medium(EPS, bad)
    assert Medium().air and not Medium().half_space and not Medium().homogeneous
    assert Medium(1.0, 0.1).air  # air above air is free space
    assert Medium(EPS).homogeneous and Medium(EPS, 0.0).homogeneous
    assert Medium(EPS, H).half_space
    # the paraxial virtual antenna n h above the surface, ranges (R + h (n^2 - 1)) / n
    y_v, scale, offset = paraxial(Medium(EPS, H))
    assert y_v == pytest.approx(H * (1 - N)) and scale == pytest.approx(1 / N)
    assert offset == pytest.approx(H * (EPS - 1) / N)
    assert air_ranges(Medium(EPS, H), scale * 0.7 + offset) == pytest.approx(0.7)


# ------------------------------------------------------------ free space
def test_air_is_bit_identical(p2, dev32):
    """eps_r = 1 (the default, or given) changes nothing: the same objects
    in, the same numbers out."""
    from rpm_cl.io.formats import load_data

    data = load_data(p2)
    assert in_medium(data, Medium()) is data and in_medium(data, Medium(1.0, 0.05)) is data
    base = default_params(data)
    given = default_params(data, eps_r=1.0)
    assert given == base and base.medium == Medium()
    for method in ("phase-rpm", "kspace-rpm"):
        a = run_method(method, data, base, dev32)
        b = run_method(method, data, replace(base, medium=Medium(1.0, 0.05)), dev32)
        np.testing.assert_array_equal(a.image.points, b.image.points)
        np.testing.assert_array_equal(a.rps.range, b.rps.range)
    g = Grid(np.linspace(-0.1, 0.1, 21), np.linspace(0.3, 0.5, 21))
    np.testing.assert_array_equal(das_numpy(data, g), das_numpy(data, g, medium=Medium()))
    for u, v in zip(
        rma_image(data, y_min=0.2, y_max=0.6),
        rma_image(data, y_min=0.2, y_max=0.6, medium=Medium()),
    ):
        np.testing.assert_array_equal(u, v)


# ----------------------------------------------------- homogeneous medium
def test_homogeneous_medium_is_the_air_scene_with_ranges_divided():
    """Echoes recorded in a material, ranges n r (air-equivalent), imaged
    with eps_r, give exactly the image of the same targets in air recorded
    with a band n times higher: the ranges divided by sqrt(eps_r), the
    wavenumber times it.  Float64 throughout (the reference engine): equal to
    rounding.  The points lie on the targets at their true metres, where the
    same data imaged as air put them n times farther."""
    x = np.arange(41) * 0.01 - 0.2
    tg = np.array([[0.0, 0.12], [0.07, 0.20], [-0.09, 0.25]])
    r = np.hypot(x[:, None] - tg[None, :, 0], tg[None, :, 1])
    med = _spectrum_data(N * r, x=x)  # recorded in the material
    air = _spectrum_data(r, scale=N, x=x)  # the equivalent air scene
    p_air = default_params(air)
    p_med = default_params(med, eps_r=EPS)
    assert p_med.rpm.sigma_r == pytest.approx(p_air.rpm.sigma_r, rel=1e-12)
    assert p_med.kspace.window_x == pytest.approx(N * med.waveform.kc, rel=1e-12)
    for method in ("phase-rpm", "kspace-rpm", "mf-rpm"):
        a = run_method(method, med, replace(p_air, medium=Medium(EPS)), ref)
        b = run_method(method, air, p_air, ref)
        np.testing.assert_allclose(a.image.points, b.image.points, atol=1e-12)
        # RPs come back as measured, air-equivalent: n times the air scene's
        np.testing.assert_allclose(a.rps.range, N * b.rps.range, rtol=1e-12)
    pts = run_method("phase-rpm", med, p_med, ref).image.points
    assert np.median(_nearest(pts, tg)) < 0.002
    # imaged as air: the tracks' hyperbolas name the material's eps_r
    with pytest.warns(DataWarning, match=r"fit eps_r = (5\.[7-9]|6\.[0-3])\d"):
        wrong = run_method("phase-rpm", med, default_params(med), ref).image.points
    assert np.median(_nearest(wrong, tg)) > 0.1
    g = Grid(np.arange(-0.2, 0.2, 0.004), np.arange(0.05, 0.3, 0.004))
    a, b = das_numpy(med, g, medium=Medium(EPS)), das_numpy(air, g)
    assert np.max(np.abs(a - b)) <= 1e-10 * np.max(np.abs(b))
    (ia, _, ya), (ib, _, yb) = (
        rma_image(med, y_min=0.05, y_max=0.3, medium=Medium(EPS)),
        rma_image(air, y_min=0.05, y_max=0.3),
    )
    np.testing.assert_array_equal(ya, yb)
    assert np.max(np.abs(ia - ib)) <= 1e-10 * np.max(np.abs(ib))


# ------------------------------------------------------------ half-space
def _exact_rps(targets, ranges, x=X):
    k, t = ranges.shape
    return RangePoints(
        np.tile(np.arange(k), t),
        np.tile(x, t),
        None,
        ranges.T.ravel(),
        np.ones(k * t),
        np.repeat(np.arange(t), k),
    )


def test_halfspace_rpm_puts_exact_range_points_on_the_targets():
    """RPs with the exact refracted ranges: every point on its target (the
    crossing of two refracted curves, Newton on the exact paths), to 1 um.
    Without the refinements the paraxial circles alone are centimetres off
    at wide angles, and straight rays (the path's air and material parts
    along the line of sight, no bending) are millimetres off."""
    rps = _exact_rps(TARGETS, _ranges(TARGETS))
    params = RPMParams(sigma_x=0.5, sigma_r=0.006)
    m = Medium(EPS, H)
    pts = halfspace_rpm(rps, params, ref, m).points
    assert len(pts) == len(rps) and np.max(_nearest(pts, TARGETS)) < 1e-6
    para = halfspace_rpm(rps, params, ref, m, iterations=0, polish=False).points
    assert np.max(_nearest(para, TARGETS)) > 0.02
    # straight rays: a line of sight of length L crosses h / y of it in air
    ant = np.column_stack([X, np.zeros_like(X)])
    straight = np.stack(
        [np.linalg.norm(t - ant, axis=1) * (H / t[1] + N * (1 - H / t[1])) for t in TARGETS], axis=1
    )
    bent = halfspace_rpm(_exact_rps(TARGETS, straight), params, ref, m).points
    assert np.percentile(_nearest(bent, TARGETS), 90) > 0.003


def test_halfspace_rpm_3d():
    """A planar array (15 x 15 at 20 mm) over the half-space: exact RPs of
    three point targets are imaged on them (the triplet's exact crossing)."""
    xs = np.arange(15) * 0.02 - 0.14
    gx, gz = np.meshgrid(xs, xs, indexing="ij")
    ant = np.column_stack([gx.ravel(), np.zeros(gx.size), gz.ravel()])
    tg = np.array([[0.0, H + 0.10, 0.0], [0.08, H + 0.20, -0.05], [-0.10, H + 0.15, 0.06]])
    rho = np.hypot(ant[:, None, 0] - tg[None, :, 0], ant[:, None, 2] - tg[None, :, 2])
    r = np.stack([_fermat(rho[:, j], H, tg[j, 1] - H, N, step=1e-5) for j in range(3)], axis=1)
    k = len(ant)
    rps = RangePoints(
        np.tile(np.arange(k), 3),
        np.tile(ant[:, 0], 3),
        np.tile(ant[:, 2], 3),
        r.T.ravel(),
        np.ones(3 * k),
        np.repeat(np.arange(3), k),
    )
    params = RPMParams(sigma_x=0.05, sigma_r=0.005, meanshift_max_rps=0)
    pts = halfspace_rpm(rps, params, ref, Medium(EPS, H)).points
    # the brute-force ranges are exact to (1e-5)^2 / h: points to 1e-5 m
    assert len(pts) > 0.95 * len(rps) and np.max(_nearest(pts, tg)) < 1e-5


def test_halfspace_methods_on_synthetic_data(dev32):
    """Frequency-domain echoes of three buried points (1-3 GHz, noise-free):
    the RPM methods with the half-space put their points on them.  With
    exact RPs the points are exact (above), so what is left is each
    method's RP error: within 5 mm at the median for phase-rpm and 10 mm
    for the envelope-only methods, a sixth of the band's Hann range
    resolution in the material (60 mm).  (The wide-angle fourth target is
    left out: its echo shares a k-space window with the first one's, and
    the mixed cluster is the decomposition's limit, not the medium's.)
    Without the half-space (air, or the material with the antennas in it,
    refraction and the air gap dropped) no point comes within 20 mm: those
    models are off by h (1 - 1/n) = 47 mm in depth at the normal and more
    off it."""
    tg = TARGETS[:3]
    data = _spectrum_data(_ranges(tg))
    good = default_params(data, eps_r=EPS, antenna_height=H)
    for method, med in (("phase-rpm", 0.005), ("kspace-rpm", 0.010), ("mf-rpm", 0.010)):
        d = _nearest(run_method(method, data, good, dev32).image.points, tg)
        assert np.median(d) < med, method
    for wrong in (default_params(data), default_params(data, eps_r=EPS)):
        with pytest.warns(DataWarning, match="range walks fit"):
            d = _nearest(run_method("phase-rpm", data, wrong, dev32).image.points, tg)
        assert np.min(d) > 0.02


def test_halfspace_das_and_rma_peak_at_the_targets():
    """DAS with the refracted ranges and RMA (phase shift through the air,
    Stolt in the material) peak within 3 mm of each target, the wide-angle
    one included (1 mm pixels; RMA's x pixel is 2.5 mm, a quarter pitch)."""
    data = _spectrum_data(_ranges(TARGETS))
    m = Medium(EPS, H)
    g = Grid(np.arange(-0.3, 0.3, 0.001), np.arange(H + 0.02, H + 0.3, 0.001))
    img = das_numpy(data, g, medium=m)
    peaks, _ = image_peaks(img, (g.x, g.y), n_peaks=4, min_separation=0.05, threshold_db=-20)
    assert np.max(_nearest(peaks, TARGETS)) <= 0.003
    rma, rx, ry = rma_image(data, medium=m, upsample_x=4, y_max=H + 0.3, dy=1e-3)
    assert ry[0] >= H
    peaks, _ = image_peaks(rma, (rx, ry), n_peaks=4, min_separation=0.05, threshold_db=-20)
    assert np.max(_nearest(peaks, TARGETS)) <= 0.003
    with pytest.raises(InputError, match="material below the surface"):
        rma_image(data, medium=m, y_min=0.0, y_max=0.3)


def test_das_adjoint_in_a_halfspace(rng):
    """<das_adjoint(x), s> = <x, das_numpy(s)> with the refracted ranges."""
    data = _spectrum_data(_ranges(TARGETS[:2]))
    g = Grid(np.linspace(-0.2, 0.2, 9), np.linspace(0.05, 0.4, 8))
    m = Medium(EPS, H)
    img = rng.standard_normal(g.shape) + 1j * rng.standard_normal(g.shape)
    sig = rng.standard_normal(data.signal.shape) + 1j * rng.standard_normal(data.signal.shape)
    s = replace(data, signal=sig)
    lhs = np.vdot(das_adjoint(img, data, g, medium=m), sig)
    rhs = np.vdot(img, das_numpy(s, g, medium=m))
    assert lhs == pytest.approx(rhs, rel=1e-10)


def test_double_bounce_and_ghosts_in_a_halfspace():
    """A double bounce below the surface: the refracted legs plus n times the
    leg between the objects; the predicted ghost lies at that range on its
    antenna's refracted ray."""
    m = Medium(EPS, H)
    ant = np.column_stack([X[::5], np.zeros(11), np.zeros(11)])
    a, b = np.array([[0.05, H + 0.1, 0.0]]), np.array([[-0.06, H + 0.16, 0.0]])
    r = double_bounce(ant, a, b, m)
    want = 0.5 * (one_way(m, ant, a) + N * np.linalg.norm(a - b) + one_way(m, ant, b))
    np.testing.assert_allclose(r, want, rtol=1e-12)
    g = ghost_points(ant, a, b, m)
    assert len(g) == len(ant)
    np.testing.assert_allclose(one_way(m, ant, g), r, atol=1e-9)
    assert np.all(g[:, 1] > H)


# -------------------------------------------------------------------- CLI
def test_cli_medium_flags(tmp_path, capsys):
    from rpm_cl.io.formats import save_data

    tg = TARGETS[:3]
    data = _spectrum_data(_ranges(tg))
    path = tmp_path / "scan.npz"
    save_data(path, data)
    assert main(["params", str(path), "--eps-r", "6", "--antenna-height", "0.08"]) == 0
    out = capsys.readouterr().out
    assert "[medium]" in out and "eps_r = 6.0" in out and "antenna_height = 0.08" in out
    res = tmp_path / "out.npz"
    assert (
        main(["image", str(path), "-o", str(res), "--eps-r", "6", "--antenna-height", "0.08", "-q"])
        == 0
    )
    pts = np.load(res)["points"]
    assert np.median(_nearest(pts, tg)) < 0.005
    toml = tmp_path / "m.toml"
    toml.write_text("[medium]\neps_r = 6.0\nantenna_height = 0.08\n")
    img = tmp_path / "das.npz"
    assert (
        main(
            [
                "das",
                str(path),
                "-o",
                str(img),
                "--grid",
                "-0.3:0.3:0.002,0.1:0.4:0.002",
                "--config",
                str(toml),
                "-q",
            ]
        )
        == 0
    )
    with np.load(img) as z:
        peaks, _ = image_peaks(
            z["image"], (z["x"], z["y"]), n_peaks=3, min_separation=0.05, threshold_db=-20
        )
    assert np.max(_nearest(peaks, tg)) <= 0.003
    assert (
        main(
            [
                "rma",
                str(path),
                "-o",
                str(tmp_path / "rma.npz"),
                "--eps-r",
                "6",
                "--antenna-height",
                "0.08",
                "-q",
            ]
        )
        == 0
    )
    capsys.readouterr()
    for argv, key in (
        (["image", str(path), "-o", str(res), "--eps-r", "0.5"], "eps_r"),
        (
            [
                "das",
                str(path),
                "-o",
                str(img),
                "--grid",
                "0:1:0.1,0:1:0.1",
                "--antenna-height",
                "-1",
            ],
            "antenna_height",
        ),
        (
            [
                "rma",
                str(path),
                "-o",
                str(tmp_path / "r.npz"),
                "--eps-r",
                "6",
                "--antenna-height",
                "0.08",
                "--y-min",
                "0.0",
            ],
            "below the surface",
        ),
    ):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and key in err, err
