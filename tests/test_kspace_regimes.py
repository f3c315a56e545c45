"""Dechirped and plain range gates are thresholded apart, but a regime that
holds no target of its own must not turn the other's leakage into centres."""

from __future__ import annotations

from dataclasses import replace

from rpm_cl.cli import robustness as R
from rpm_cl.extract.kspace import REGIME_GAIN_DB, decompose
from rpm_cl.rpm.params import default_params


def test_a_regime_without_targets_detects_nothing():
    """One sphere 0.54-0.6 m from a 15 x 15 planar array, noise-free: the
    gates nearer than ~0.13 m are plain (not dechirped) and hold only
    leakage 67-70 dB below the sphere's peak.  Thresholded only against
    their own strongest value, they made a second cluster of 463 RPs at
    0.08-0.19 m (three RPs an antenna where there is one echo)."""
    g = replace(R.GEOMETRY_3D, targets=R.GEOMETRY_3D.targets[:1])
    spec, f, _ = R.synthesize(g, None, 0)
    data = R.radar_data(g, spec, f)
    params = default_params(data).kspace
    dec = decompose(data, params)
    assert len(dec.clusters) == 1
    assert REGIME_GAIN_DB > 25.6  # the dechirp's gain at broadside on 64 x 64


def test_dechirped_gates_answer_to_the_plain_threshold():
    """The three spheres on 64 x 64 antennas at 7.5 mm, noise-free: every
    sphere lies at plain gates, and the dechirped gates beyond 0.94 m hold
    their leakage only, 46 dB under the strongest peak.  Against their own
    strongest peak (and 30 dB under the strongest regime's) that leakage
    made a cluster at 0.95 m; against the plain regime's threshold, which
    dechirping can only raise a target above, no cluster lies beyond the
    spheres (every echo, a sphere's nearest point, lies within 0.74 m of
    its antenna)."""
    g = replace(R.GEOMETRY_3D, x=(64, 7.5e-3), z=(64, 7.5e-3))
    spec, f, _ = R.synthesize(g, None, 0)
    data = R.radar_data(g, spec, f)
    dec = decompose(data, default_params(data).kspace)
    assert len(dec.clusters) >= 10
    assert max(c.r_centre for c in dec.clusters) < 0.8
