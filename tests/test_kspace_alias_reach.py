"""A non-principal alias must put the cluster's own echo at the cluster's
gate (``rpm_cl.extract.kspace_align.ALIAS_REACH``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from rpm_cl.cli import robustness as R
from rpm_cl.extract import kspace_align as KA
from rpm_cl.extract.kspace import decompose
from rpm_cl.rpm.params import default_params

#: The robustness benchmark's three spheres on 45 x 45 antennas at 7.5 mm,
#: 20 GHz: a half-wavelength pitch, so every cluster's k has a visible
#: alias one unit of u away.
SCENE = replace(R.GEOMETRY_3D, x=(45, 7.5e-3), z=(45, 7.5e-3))


def _slopes_fit(dec, data):
    """Per cluster: the largest gap between its slope u and the true range
    slopes dR/dX of the sphere echoes it holds, over its RPs' antennas."""
    from rpm_cl.extract.rangepoints import rps_from_decomposition

    rps = rps_from_decomposition(data, dec, -20.0)
    pos = data.array.positions()
    out = []
    for m, c in enumerate(dec.clusters):
        ant = np.asarray(rps.antenna)[np.asarray(rps.cluster) == m]
        rng = np.asarray(rps.range)[np.asarray(rps.cluster) == m]
        best = np.inf
        for cx, cy, cz, rho in SCENE.targets:
            d = pos[ant] - np.array([cx, cy, cz])
            r = np.linalg.norm(d, axis=1)
            if np.median(np.abs(r - rho - rng)) > 0.01:
                continue  # not this sphere's echo
            slope = np.median(d[:, [0, 2]] / r[:, None], axis=0)
            best = min(best, float(np.max(np.abs(slope - c.direction))))
        out.append(best)
    return np.array(out)


def test_clusters_of_the_spheres_take_their_own_direction(monkeypatch):
    """Every cluster that holds a sphere's echoes is aligned along that
    echo's own range slope (within 0.2 of u; a wrong alias is 1 away), and
    the reach rule adds one such cluster: without it a weak cluster of the
    nearest sphere took u_z = 0.9 where its echo walks at -0.1 (its shifts,
    up to 0.15 m at the array's edges, carried a stronger sphere's echo in
    at the edge of its gates, whose coherent peak beat the true alignment's
    by 2x), and its RPs then held no sphere's echo."""
    spec, f, _ = R.synthesize(SCENE, None, 0)
    data = R.radar_data(SCENE, spec, f)
    params = default_params(data).kspace
    gaps = _slopes_fit(decompose(data, params), data)
    held = np.isfinite(gaps)
    assert np.all(gaps[held] < 0.2), gaps
    monkeypatch.setattr(KA, "ALIAS_REACH", np.inf)
    loose = _slopes_fit(decompose(data, params), data)
    assert held.sum() > np.isfinite(loose).sum() >= 6


def test_range_points_beyond_the_data_axis_are_dropped():
    """An aligned profile holds range[g] + offset[X]: a peak that a cluster's
    offset puts beyond the data's range axis was read where the data hold
    nothing (a steep walk over a long line reached 68 m on a 3.6 m axis)."""
    from rpm_cl.extract.rangepoints import rps_from_decomposition
    from rpm_cl.extract.types import Cluster, Decomposition
    from rpm_cl.io.data import Array, RadarData, Waveform

    x = np.arange(4) * 0.01
    rng = np.arange(400) * 2.5e-3  # 0 .. 1 m
    wf = Waveform(20e9, 2e9)
    data = RadarData(np.zeros((4, rng.size), complex), Array(x), rng, wf)
    sig = np.zeros((4, 40), complex)
    sig[:, 20] = 1.0  # each antenna's peak at gate 100 + 20 of the slice: 0.3 m
    offset = np.array([0.0, 0.2, -0.35, 0.9])  # 0.3 + offset: 0.3, 0.5, -0.05, 1.2 m
    c = Cluster(np.zeros(1), 0.3, slice(100, 140), sig, 1.0, offset, np.zeros(1))
    dec = Decomposition((np.zeros(4),), np.zeros((4, rng.size)), (c,), gate0=0)
    rps = rps_from_decomposition(data, dec, -20.0)
    np.testing.assert_array_equal(rps.antenna, [0, 1])
    np.testing.assert_allclose(rps.range, [0.3, 0.5], atol=1e-9)
