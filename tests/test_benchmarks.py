"""The helpers the benchmark scripts draw their conclusions with."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from pareto import pareto


def test_pareto_front_with_a_time_tolerance():
    """(time, error) pairs: a pair is beaten by one as accurate and faster
    by more than the tolerance, or by one more accurate and no slower than
    the tolerance allows; the same error within the tolerance beats
    nothing, so run-to-run noise alone does not decide the front."""
    pts = [(100.0, 0.02), (110.0, 0.02),    # same error, 10 % apart
           (50.0, 0.10),                    # faster, worse: on the front
           (130.0, 0.02),                   # same error, 30 % slower than the first
           (200.0, 0.05)]                   # slower and worse than the first
    assert pareto(pts) == [0, 2]             # exact: 110 ms loses to 100 ms
    assert pareto(pts, 0.15) == [0, 1, 2]    # within 15 %: neither beats the other
    # more accurate and within the tolerance beats a faster one; beyond it, not
    assert pareto([(100.0, 0.02), (112.0, 0.01)], 0.15) == [1]
    assert pareto([(100.0, 0.02), (120.0, 0.01)], 0.15) == [0, 1]


def test_eq10_density_is_the_untruncated_reference_density():
    """``exhaustive_3d.eq10_density`` (global points, every triplet of the
    cluster) equals the reference mean-shift density (local frames) where
    the reference's truncations leave nothing out: sigma_D and sigma_r wide
    against the clusters (antennas within 0.15 m, candidates within 3.2 m of
    each main RP, cutoffs 4 sigma = 4 m), and it differs once a cutoff bites."""
    import numpy as np
    from exhaustive_3d import eq10_density
    from test_spheres import planar_cluster

    from rpm_cl.rangepoints import RangePoints
    from rpm_cl.rpm import reference as ref

    rng = np.random.default_rng()
    sizes = [12, 9]
    x, z, r, amp, ant, st, ct = planar_cluster(rng, sizes, dup=False)
    rps = RangePoints(ant, x, z, r, amp, np.repeat([0, 1], sizes))
    main = rng.permutation(x.size)[:8]
    pts = np.column_stack([x[main], np.zeros(main.size), z[main]]) + rng.normal(0, 0.3, (8, 3))
    pts[:, 1] += r[main]
    local = (pts - np.column_stack([x[main], np.zeros(main.size), z[main]])).T[:, None, :]
    for sd, sr, same in ((1.0, 1.0, True), (1.0, 0.05, False)):
        got = eq10_density(rps, main, pts, sd, sr)
        want = np.array([ref.density_spheres(x, z, r, amp, st, ct, local[:, :, [q]], sd, sr,
                                             int(i), 1)[0, 0] for q, i in enumerate(main)])
        if same:
            np.testing.assert_allclose(got, want, rtol=1e-12)
        else:   # points 0.3 m off against 4 sigma_r = 0.2 m: the reference truncates
            assert np.all(got >= want) and np.any(got > want * (1 + 1e-9))
