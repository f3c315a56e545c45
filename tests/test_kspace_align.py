"""The range-walk alignment's interpolator shifts each antenna's profile alone.

``kspace.shift_rows`` evaluates a cubic B-spline along R per row.  Its
reference is SciPy's ``map_coordinates`` applied to one row at a time (1-D,
so nothing can leak between rows).  ``map_coordinates`` on the 2-D
(antenna, gate) coefficient array would also spread the spline across rows,
making every aligned profile 1/6, 2/3, 1/6 of three neighbouring antennas;
the tests below fail on that.
"""

import numpy as np
from scipy import ndimage

from rpm_cl.extract.kspace import shift_rows


def _coeffs(sig):
    return ndimage.spline_filter1d(
        sig.real, 3, axis=-1, mode="nearest"
    ) + 1j * ndimage.spline_filter1d(sig.imag, 3, axis=-1, mode="nearest")


def _row_reference(c, shift, lo, hi):
    """map_coordinates on each row alone (1-D: no mixing across rows)."""
    out = []
    for row, s in zip(c, shift):
        at = [np.arange(lo, hi) + s]
        out.append(
            ndimage.map_coordinates(row.real, at, order=3, prefilter=False, mode="nearest")
            + 1j * ndimage.map_coordinates(row.imag, at, order=3, prefilter=False, mode="nearest")
        )
    return np.array(out)


def test_shift_rows_matches_one_row_at_a_time(rng):
    n_rows, nr = int(rng.integers(2, 40)), int(rng.integers(40, 200))
    sig = rng.normal(size=(n_rows, nr)) + 1j * rng.normal(size=(n_rows, nr))
    c = _coeffs(sig)
    # shifts keep all four taps on the axis (the edge handling is checked below)
    shift = rng.uniform(-8.0, 8.0, n_rows)
    lo, hi = 10, nr - 11
    got = shift_rows(c, shift, lo, hi)
    ref = _row_reference(c, shift, lo, hi)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12 * np.abs(ref).max())


def test_shift_rows_interpolates_and_keeps_rows_apart(rng):
    sig = rng.normal(size=(5, 80)) + 1j * rng.normal(size=(5, 80))
    c = _coeffs(sig)
    # integer shifts return the samples themselves (an interpolating spline)
    got = shift_rows(c, np.array([0.0, 1.0, -2.0, 3.0, 0.0]), 5, 70)
    for row, s in enumerate((0, 1, -2, 3, 0)):
        np.testing.assert_allclose(got[row], sig[row, 5 + s : 70 + s], rtol=0, atol=1e-12)
    # one antenna's profile changed: no other row of the result moves
    sig2 = sig.copy()
    sig2[2] *= 5.0
    a = shift_rows(c, np.full(5, 0.37), 5, 70)
    b = shift_rows(_coeffs(sig2), np.full(5, 0.37), 5, 70)
    assert np.array_equal(np.delete(a, 2, axis=0), np.delete(b, 2, axis=0))
    assert not np.allclose(a[2], b[2])


def test_shift_rows_past_the_axis_is_finite_and_edge_valued():
    sig = np.tile(np.linspace(1.0, 2.0, 30), (2, 1)).astype(complex)
    c = _coeffs(sig)
    out = shift_rows(c, np.array([-100.0, 100.0]), 0, 30)
    assert np.all(np.isfinite(out))
    # the edge coefficient repeated (weights sum to 1), within 1 % of the edge sample
    np.testing.assert_allclose(out[0], c[0, 0], rtol=1e-12)
    np.testing.assert_allclose(out[1], c[1, -1], rtol=1e-12)
    np.testing.assert_allclose(out[:, 0], sig[:, [0, -1]].diagonal(), rtol=1e-2)
    assert shift_rows(_coeffs(sig), np.zeros(2), 4, 4).shape == (2, 0)


def test_large_array_takes_the_true_alias_for_every_body_part():
    """The human body seen by a 64 x 64 array at 7.5 mm (lambda / 2): every
    cluster's range slope u = dR/dX must be a body part's (fitted to its
    true echo ranges), not an alias of it, which is 1 away in u_x or u_z.
    With this noise (seed 0, the one ``benchmarks/pareto.py`` uses) a
    whole-aperture focused ranking takes u_x = -0.89 and +0.89 for the two
    lower legs (seeds 1 and 2 pass with it); the sub-aperture ranking takes
    u_x = -+0.11, with a sub-aperture peak 2.5 times the wrong alias's (56
    against 23; whole-aperture: 4.8 against 7.9)."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from pareto import body_on_array

    from rpm_cl.extract import kspace
    from rpm_cl.simulate import echoes
    from rpm_cl.simulate.scene import get_preset

    data, params = body_on_array(64, 64, snr=20.0, seed=0)
    dec = kspace.decompose(data, params.kspace)
    u = np.array([c.direction for c in dec.clusters])
    assert len(u) >= 11
    # each part's true range slope at the array's centre: a plane fitted to
    # its echo ranges over the antennas (aliases are 1 apart in u_x or u_z)
    ant, rng, _, target = echoes(get_preset("human-body").scene, data.array)
    pos = data.array.positions()
    true_u = []
    for t in np.unique(target):
        a = ant[target == t]
        design = np.column_stack(
            [np.ones(a.size), pos[a, 0] - pos[:, 0].mean(), pos[a, 2] - pos[:, 2].mean()]
        )
        true_u.append(np.linalg.lstsq(design, rng[target == t], rcond=None)[0][1:])
    true_u = np.array(true_u)
    off = np.linalg.norm(u[:, None, :] - true_u[None, :, :], axis=2).min(axis=1)
    assert np.all(off < 0.15), (u, off)


def _body(n, snr=None, seed=0):
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from pareto import body_on_array

    return body_on_array(n, n, snr=snr, seed=seed)


def test_focused_detection_finds_one_cluster_per_body_part():
    """32 x 32 array, noise-free: the 11 body parts are 11 clusters.  On the
    plain spectrum the wavefront curvature spreads the two thighs (k_x = +-72
    rad/m) over each other and raises a twelfth maximum at k_x = 0 between
    them, whose points are 46 % more than 50 mm off; the Fresnel-dechirped
    detection has no such maximum."""
    from rpm_cl.extract import kspace

    data, params = _body(32)
    dec = kspace.decompose(data, params.kspace)
    assert len(dec.clusters) == 11
    thighs = [c for c in dec.clusters if abs(c.r_centre - 1.08) < 0.03 and c.k[1] < -150]
    assert sorted(round(abs(c.k[0])) for c in thighs) == [72, 72]


def test_dechirp_only_where_the_fresnel_phase_holds():
    """Detection is dechirped at focused gates only while the quartic term of
    the path at the array's corners stays under a quarter cycle."""
    from rpm_cl.extract import kspace
    from rpm_cl.io.data import Array, RadarData, Waveform

    data, params = _body(64)
    on = kspace._dechirp_gates(data, params.kspace)
    r = data.range
    assert on is not None and on[(r > 1.0) & (r < 1.3)].all()  # the body's ranges
    assert not on[r < 0.9].any()  # quartic term over pi/2 at 0.9 m
    small, sp = _body(11)
    assert kspace._dechirp_gates(small, sp.kspace) is None  # no focusing
    # a 1 m linear array at 0.3-0.6 m: focused, but the Fresnel phase fails
    arr = Array((np.arange(201) - 100) * 5e-3)
    lin = RadarData(
        np.ones((201, 121), complex), arr, 0.3 + np.arange(121) * 2.5e-3, Waveform(20e9, 0.2e9)
    )
    assert kspace._dechirp_gates(lin, kspace.KSpaceParams()) is None


def test_near_target_at_plain_gates_is_kept_beside_a_dechirped_one():
    """64 x 64 array: a point at 1.0 m (gates dechirped) and one at 0.8 m with
    half its echo amplitude (gates kept plain: the quartic term is over a
    quarter cycle there).  Dechirping raises the far point's detection peak;
    with one relative threshold over all gates the near point falls under
    -20 dB of it and is lost (1 cluster)."""
    from rpm_cl.extract import kspace
    from rpm_cl.io.data import Array, Waveform
    from rpm_cl.rpm.params import default_params
    from rpm_cl.simulate import simulate
    from rpm_cl.simulate.scene import PointTarget, Scene

    arr = Array((np.arange(64) - 31.5) * 7.5e-3, 1.0 + (np.arange(64) - 31.5) * 7.5e-3)
    # 3-D point echoes fall as amplitude / d^2: 0.5 * 0.8^2 gives half the echo
    scene = Scene(
        (PointTarget((0.0, 0.8, 1.0), 0.5 * 0.64), PointTarget((0.05, 1.0, 1.02), 1.0)),
        "two ranges",
    )
    data = simulate(scene, arr, Waveform(20e9, 3e9), np.arange(0.6, 1.3, 2.5e-3), None, 0)
    params = default_params(data).kspace
    on = kspace._dechirp_gates(data, params)
    assert on is not None and on[np.argmin(abs(data.range - 1.0))]
    assert not on[np.argmin(abs(data.range - 0.8))]
    dec = kspace.decompose(data, params)
    assert sorted(round(c.r_centre, 2) for c in dec.clusters) == [0.8, 1.01]


def test_coherent_sum_is_the_weighted_sum_of_the_shifted_rows(rng):
    """The autofocus's coherent sum equals summing the map_coordinates
    reference of every row with its weight, the edges included."""
    from rpm_cl.extract.kspace_align import coherent_sum

    n_rows, nr = int(rng.integers(2, 60)), int(rng.integers(30, 120))
    sig = rng.normal(size=(n_rows, nr)) + 1j * rng.normal(size=(n_rows, nr))
    c = _coeffs(sig)
    shift = rng.uniform(-12.0, 12.0, n_rows)
    weights = np.exp(1j * rng.uniform(0, 2 * np.pi, n_rows)) * rng.uniform(0.5, 2, n_rows)
    for lo, hi in ((0, nr), (5, 12), (nr - 4, nr)):
        ref = (weights[:, None] * _row_reference(c, shift, lo, hi)).sum(axis=0)
        got = coherent_sum(c, shift, lo, hi, weights)
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    assert coherent_sum(c, shift, 7, 7, weights).shape == (0,)
