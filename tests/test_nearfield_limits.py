"""Bounds of the near-field search on input without targets in it.

Pure noise, a one-sample spike and 3 range samples would run an unbounded
matching pursuit to 8 centres and 10-26 s.  The search is bounded (rpm_cl.extract.nearfield:
MIN_SEARCH_GATES, the centre cap N // (2 SEARCH_TERMS), FIT_BUDGET,
POLISH_MAX_NFEV).  Time is not asserted (shared machines); what bounds it is:
the number of clusters, of candidate fits and of polish evaluations.
"""

import numpy as np
import pytest

from rpm_cl.extract import nearfield
from rpm_cl.extract.kspace import KSpaceParams, decompose
from rpm_cl.io.data import RadarData
from rpm_cl.simulate import simulate_preset


@pytest.fixture(scope="module")
def sparse():
    return simulate_preset("paper-2d-sparse")[0]


def _like(data, signal, rng_axis=None, x=None):
    arr = data.array if x is None else type(data.array)(x)
    return RadarData(signal, arr, data.range if rng_axis is None else rng_axis, data.waveform)


def _record(monkeypatch):
    """Keep the search object and the polish result of the next decomposition."""
    seen = {}
    run, lsq = nearfield._Search.run, nearfield.least_squares

    def run_rec(self):
        seen["search"] = self
        return run(self)

    def lsq_rec(*a, **k):
        seen["polish"] = res = lsq(*a, **k)
        return res

    monkeypatch.setattr(nearfield._Search, "run", run_rec)
    monkeypatch.setattr(nearfield, "least_squares", lsq_rec)
    return seen


def test_three_range_samples_give_no_cluster(sparse, monkeypatch):
    """3 samples across the strongest echo leave one gate inside the axis,
    fewer than MIN_SEARCH_GATES: no cluster, and no search is run (one
    would run to 6 centres)."""
    seen = _record(monkeypatch)
    g = int(np.argmax(np.abs(sparse.signal).max(axis=0)))
    short = _like(sparse, sparse.signal[:, g - 1 : g + 2], sparse.range[g - 1 : g + 2])
    dec = decompose(short, KSpaceParams())
    assert dec.clusters == ()
    assert "search" not in seen


def test_single_sample_spike_gives_no_cluster(sparse, monkeypatch):
    """One non-zero sample is one gate above the threshold: no cluster, and
    no search is run (one would run to 7 centres)."""
    seen = _record(monkeypatch)
    spike = np.zeros_like(sparse.signal)
    spike[10, 300] = 1.0
    assert decompose(_like(sparse, spike), KSpaceParams()).clusters == ()
    assert "search" not in seen


def test_pure_noise_search_is_bounded(sparse, monkeypatch):
    """White noise on the paper's sparse array (21 antennas, 600 gates), on
    which an unbounded search takes 8 centres and 4820 + 1732 scans (~28 M
    candidate fits): at most 5 centres (21 // 4), at most FIT_BUDGET
    candidate fits plus one pair scan (the check precedes each scan) and at
    most POLISH_MAX_NFEV polish evaluations.  Measured: 5 clusters, 3.0 M
    fits, 100 evaluations (the budget, not the time per fit, bounds it)."""
    seen = _record(monkeypatch)
    rng = np.random.default_rng(7)
    noise = rng.standard_normal(sparse.signal.shape) + 1j * rng.standard_normal(sparse.signal.shape)
    dec = decompose(_like(sparse, noise), KSpaceParams())
    search = seen["search"]
    assert search.max_centres() == 5
    assert 1 <= len(dec.clusters) <= 5
    one_pair_scan = (nearfield.PAIR_GRID[0] * nearfield.PAIR_GRID[1]) ** 2
    assert search.model.fits <= nearfield.FIT_BUDGET + one_pair_scan
    assert seen["polish"].nfev <= nearfield.POLISH_MAX_NFEV


def test_budget_stops_the_search_where_it_is(sparse, monkeypatch):
    """A small budget (50 k fits, under a fifth of what the paper's case
    uses: 0.27 M) stops the search early but still returns a valid
    decomposition (measured: 62 k fits, 3 clusters)."""
    monkeypatch.setattr(nearfield, "FIT_BUDGET", 50_000)
    seen = _record(monkeypatch)
    dec = decompose(sparse, KSpaceParams())
    one_pair_scan = (nearfield.PAIR_GRID[0] * nearfield.PAIR_GRID[1]) ** 2
    assert seen["search"].model.fits <= 50_000 + one_pair_scan
    assert 1 <= len(dec.clusters) <= 3


@pytest.mark.parametrize("n, cap", [(4, 1), (7, 1), (8, 2), (12, 3), (21, 5), (32, 8), (64, 8)])
def test_centre_cap_follows_the_antennas(sparse, n, cap):
    """N // (2 SEARCH_TERMS) centres, at least 1, at most MAX_CLUSTERS."""
    x = np.arange(n) * sparse.array.dx
    sig = np.repeat(sparse.signal[:1], n, axis=0)
    search = nearfield._Search(_like(sparse, sig, x=x), 10 ** (-10 / 20), 4)
    assert search.max_centres() == cap


def test_four_antennas_keep_one_centre(sparse):
    """4 antennas and 2 centres of 2 terms fit every gate exactly, whatever
    the centres: one cluster, not two."""
    data = _like(sparse, sparse.signal[:4], x=sparse.array.x[:4])
    assert len(decompose(data, KSpaceParams(near_field=True)).clusters) == 1


def test_paper_sparse_case_is_inside_the_bounds(sparse, monkeypatch):
    """The bounds must not touch the paper's case: 3 clusters found well
    inside the budget (measured 0.27 M of 3 M fits; asked: under half) and
    a polish that converges before its cap (measured 8 of 100)."""
    seen = _record(monkeypatch)
    dec = decompose(sparse, KSpaceParams())
    assert len(dec.clusters) == 3
    assert seen["search"].model.fits < nearfield.FIT_BUDGET / 2
    assert seen["polish"].nfev < nearfield.POLISH_MAX_NFEV
