"""Focusing of large apertures (kspace module notes, steps 5 and 6).

Step 5 focuses a cluster as a point at its range: the focus term must be the
exact range of that point beyond the linear walk (checked against the
direct distance in extended precision).  Step 6 fits the Fresnel part of the
wavefront per array axis: a convex surface of curvature radius rho at range
R returns the wavefront of a point at R + rho (a mirror's image), so the
fitted factor must be R / (R + rho) along each axis, and 1 for a point.
"""

import itertools
from dataclasses import replace

import numpy as np
import pytest

from rpm_cl.extract import kspace
from rpm_cl.extract.rangepoints import rps_from_decomposition
from rpm_cl.io.data import Array, Waveform
from rpm_cl.metrics import err_range
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import simulate
from rpm_cl.simulate.scene import Ellipsoid, PointTarget, Scene


def test_focus_range_is_the_exact_point_range(rng):
    for _ in range(20):
        n_k = int(rng.integers(1, 3))
        step = 10.0 ** rng.uniform(np.log10(5e-4), np.log10(5e-2))
        axes = [rng.uniform(-1, 1) + np.arange(int(rng.integers(2, 40))) * step for _ in range(n_k)]
        r_c = 10.0 ** rng.uniform(np.log10(0.05), np.log10(20.0))
        u = rng.uniform(-0.95, 0.95, n_k)
        if np.sum(u * u) >= 0.98:
            u *= 0.9 / np.linalg.norm(u)
        got = kspace._focus_range(u, axes, r_c)
        # reference: the point p = centre + r_c (-u, sqrt(1 - |u|^2)), in long double
        ld = np.longdouble
        grids = np.meshgrid(
            *[np.asarray(ax, ld) - ld(0.5) * (ld(ax[0]) + ld(ax[-1])) for ax in axes], indexing="ij"
        )
        grids_ld = grids
        uu = [ld(v) for v in u]
        rr = ld(r_c)
        d2 = sum((grids[a] + rr * uu[a]) ** 2 for a in range(n_k))
        d2 = d2 + rr * rr * (1 - sum(v * v for v in uu))
        ref = np.sqrt(d2) - rr - sum(uu[a] * grids[a] for a in range(n_k))
        scale = max(float(np.max(np.abs(ref))), 1e-300)
        np.testing.assert_allclose(got, ref.astype(float), rtol=0, atol=1e-12 * scale + 1e-15)
        assert np.all(np.isfinite(got))
        # with a factor of 1 or more, only the Fresnel part of each axis is scaled
        f = rng.uniform(0, 1.2, n_k)
        f[int(rng.integers(n_k))] = rng.uniform(1.0, 1.2)
        extra = kspace._focus_range(u, axes, r_c, f) - got
        grids = np.meshgrid(*[ax - 0.5 * (ax[0] + ax[-1]) for ax in axes], indexing="ij")
        want = sum((f[a] - 1) * (1 - u[a] ** 2) * grids[a] ** 2 / (2 * r_c) for a in range(n_k))
        np.testing.assert_allclose(extra, want, rtol=1e-9, atol=1e-18)
        np.testing.assert_array_equal(kspace._focus_range(u, axes, r_c, np.ones(n_k)), got)
        # every factor below 1: a sphere of radius rho whose nearest point
        # lies at r_c, i.e. its centre at r_c + rho in the same direction
        rho = 10.0 ** rng.uniform(np.log10(0.01), np.log10(10.0))
        f = np.full(n_k, r_c / (r_c + rho))
        cc = rr + ld(rho)
        d2 = sum((grids_ld[a] + cc * uu[a]) ** 2 for a in range(n_k))
        d2 = d2 + cc * cc * (1 - sum(v * v for v in uu))
        ref = np.sqrt(d2) - ld(rho) - rr - sum(uu[a] * grids_ld[a] for a in range(n_k))
        scale = max(float(np.max(np.abs(ref))), 1e-300)
        np.testing.assert_allclose(
            kspace._focus_range(u, axes, r_c, f), ref.astype(float), rtol=0, atol=1e-9 * scale
        )


def test_focus_range_differs_from_the_fresnel_term_at_third_order():
    """To second order the exact term is :func:`kspace._curvature`'s: the
    difference shrinks as the cube of the aperture (at an oblique u, where
    the third-order term is not zero)."""
    u = np.array([0.3, -0.2])
    diffs = []
    for scale in (1e-2, 5e-3, 2.5e-3):
        axes = [np.linspace(-1, 1, 11) * scale, np.linspace(-1, 1, 7) * scale]
        diffs.append(
            np.max(np.abs(kspace._focus_range(u, axes, 1.0) - kspace._curvature(u, axes, 1.0)))
        )
    assert diffs[0] < 2e-2 * np.max(
        kspace._curvature(u, [np.linspace(-1, 1, 11) * 1e-2, np.linspace(-1, 1, 7) * 1e-2], 1.0)
    )
    for a, b in itertools.pairwise(diffs):
        assert 7.0 < a / b < 9.0, diffs


N = 48
ARRAY = Array((np.arange(N) - (N - 1) / 2) * 7.5e-3, (np.arange(N) - (N - 1) / 2) * 7.5e-3)


def _decompose(scene, autofocus=True):
    data = simulate(
        scene, ARRAY, Waveform(20e9, 3e9), np.arange(0.85, 1.2, 2.5e-3), boundary_spacing=2e-3
    )
    params = default_params(data, pad=2)
    dec = kspace.decompose(data, replace(params.kspace, autofocus=autofocus))
    rps = rps_from_decomposition(data, dec, params.rp_threshold_db)
    return dec, int(np.sum(err_range(rps.antenna, rps.range, data.truth) <= 0.002))


@pytest.mark.parametrize(
    "semi, front, want",
    [
        # a sphere of radius 0.3 m whose front is 1.0 m away: 1 / 1.3 on both axes
        ((0.3, 0.3, 0.3), 1.0, (1 / 1.3, 1 / 1.3)),
        # an ellipsoid long in z: radius 0.08 along x, 0.5^2 / 0.08 = 3.1 m along z
        ((0.08, 0.08, 0.5), 1.0, (1 / 1.08, 1 / (1 + 0.25 / 0.08))),
    ],
)
def test_autofocus_fits_a_convex_surface(semi, front, want):
    """48 x 48 antennas at 7.5 mm, the surface's front 1 m away on
    broadside: the fitted factors are R / (R + rho) along each axis (the
    grid steps 0.1; measured 0.8, 0.8 and 0.9, 0.3), and nearly every
    antenna then gives an RP within 2 mm (the point focus leaves the edges
    out: measured 2074 and 1068 of 2292 for these two against 2292)."""
    scene = Scene((Ellipsoid((0.0, front + semi[1], 0.0), semi),))
    dec, good = _decompose(scene)
    assert len(dec.clusters) == 1
    np.testing.assert_allclose(dec.clusters[0].focus, want, atol=0.08)
    _, good_point = _decompose(scene, autofocus=False)
    assert good >= 0.97 * N * N
    assert good > good_point


def test_autofocus_keeps_a_point_a_point():
    dec, good = _decompose(Scene((PointTarget((0.02, 1.0, -0.01)),)))
    assert len(dec.clusters) == 1
    np.testing.assert_allclose(dec.clusters[0].focus, [1.0, 1.0], atol=0.1)
    assert good >= 0.97 * N * N


def test_unfocused_clusters_have_no_focus():
    """The paper's 11 x 17 array is not focused (2.1 rad at its corners)."""
    from rpm_cl.simulate import simulate_preset

    data, pre = simulate_preset("human-body")
    dec = kspace.decompose(data, default_params(data, **pre.defaults).kspace)
    assert dec.clusters and all(c.focus is None for c in dec.clusters)


def test_autofocus_fits_a_surface_close_to_a_wide_aperture():
    """A surface 0.1 m from a 0.36 m aperture (a near-field scan): the
    point's higher-order terms at 0.1 m are 0.1 m at the corners, so the
    fitted wavefront must be the surface's own (a point at R + rho), and its
    factor is fine enough that every antenna's echo stays in the window: the
    fit is within 0.005 of R / (R + rho) = 0.04, and nearly every antenna
    gives an RP within 2 mm (Fresnel scaling alone on the 0.1-step grid took
    0.2, whose walk is 8 mm off 0.1 m from the centre, and kept a central
    disc of the array)."""
    rho = 2.4
    scene = Scene((Ellipsoid((0.0, 0.1 + rho, 0.0), (rho, rho, rho)),))
    data = simulate(
        scene, ARRAY, Waveform(24e9, 4e9), np.arange(0.0, 0.3, 2e-3), boundary_spacing=2e-3
    )
    params = default_params(data, pad=2)
    dec = kspace.decompose(data, params.kspace)
    assert len(dec.clusters) == 1
    np.testing.assert_allclose(dec.clusters[0].focus, 0.1 / (0.1 + rho), atol=0.005)
    rps = rps_from_decomposition(data, dec, params.rp_threshold_db)
    good = int(np.sum(err_range(rps.antenna, rps.range, data.truth) <= 0.002))
    assert good >= 0.97 * N * N


def test_a_point_focus_is_not_refined():
    """A point 0.46 m from a 1 m linear array (201 antennas at 5 mm, 0.2 GHz):
    its cluster's direction is a little off the point's, and the coherent
    peak over the focus factor has side lobes (0.9375 stands 1.9 times above
    the point focus).  The coarse fit finds no surface, so the point focus
    stays."""
    arr = Array((np.arange(201) - 100) * 5e-3)
    data = simulate(
        Scene((PointTarget((-0.1, 0.45)),)),
        arr,
        Waveform(20e9, 0.2e9),
        np.arange(0.0, 1.5, 2.5e-3),
        30.0,
        0,
        noise="receiver",
    )
    params = default_params(data, sigma_x=0.05, sigma_r=0.05)
    dec = kspace.decompose(data, params.kspace)
    assert len(dec.clusters) == 1
    np.testing.assert_array_equal(dec.clusters[0].focus, [1.0])
