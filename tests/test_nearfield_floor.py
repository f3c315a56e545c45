"""Near-field search: the noise floor that ends re-seating, and the focusing
table kept across calls (rpm_cl/extract/nearfield.py)."""

import numpy as np
import pytest

from rpm_cl.extract import nearfield
from rpm_cl.extract.kspace import KSpaceParams, decompose
from rpm_cl.io.data import RadarData
from rpm_cl.simulate import simulate, simulate_preset
from rpm_cl.simulate.scene import PointTarget, Scene, get_preset


@pytest.fixture(scope="module")
def sparse():
    return simulate_preset("paper-2d-sparse")[0]


def test_noise_estimate_matches_white_noise(sparse):
    """White complex noise of power 2 per sample on every gate: the estimate
    per dimension across the array is 2 x gates (the mean of the smaller half
    of the squared singular values sits a little under it for 21 antennas
    over ~600 gates: Marchenko-Pastur)."""
    rng = np.random.default_rng(3)
    shape = sparse.signal.shape
    noise = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)
    data = RadarData(noise, sparse.array, sparse.range, sparse.waveform)
    search = nearfield._Search(data, 10 ** (-80 / 20), 4)  # every gate searched
    ratio = search.noise / (2.0 * search.gates.size)
    assert 0.6 < ratio < 1.05
    # the same product in another order: equal up to rounding
    assert search.floor(1) >= (1 - 1e-12) * nearfield.FLOOR_MARGIN * search.noise * (search.n - 2)


def test_reseat_stops_at_the_floor(sparse, monkeypatch):
    """The paper's noise-free case: after its third centre the residual is
    under FLOOR_REL of the energy, so no re-seat search (best_with with a
    centre excluded) follows it; the centres still land on the targets."""
    calls = []
    real = nearfield._Search.best_with

    def rec(self, fixed, exclude=None):
        calls.append((len(fixed), exclude is not None))
        return real(self, fixed, exclude)

    monkeypatch.setattr(nearfield._Search, "best_with", rec)
    dec = decompose(sparse, KSpaceParams())
    assert (2, True) not in calls  # no re-seat with three centres
    assert (1, True) in calls  # the two-centre re-seat still runs
    k0 = sparse.waveform.kc
    found = sorted((c.k[0] / (2 * k0), c.r_centre) for c in dec.clusters)
    pos = [np.asarray(t.position) for t in get_preset("paper-2d-sparse").scene.targets]
    truth = sorted((p[0] / np.hypot(*p), np.hypot(*p)) for p in pos)
    assert len(found) == len(truth) == 3
    for (u, r), (ut, rt) in zip(found, truth):
        assert abs(u - ut) < 0.01 and abs(r - rt) < 0.01


def test_focusing_table_kept_per_geometry(monkeypatch):
    """A second search on the same geometry builds no focusing phases and
    maps the same; another range axis gets a table of its own; the kept
    tables stay within TABLE_CACHE_BYTES."""
    pre = get_preset("paper-2d-sparse")
    data = simulate(Scene((PointTarget((0.05, 0.45)),)), pre.array, pre.waveform, pre.range_axis)
    nearfield._TABLES.clear()
    built = []
    real = nearfield._Search._phases
    monkeypatch.setattr(
        nearfield._Search, "_phases", lambda self, r: built.append(np.size(r)) or real(self, r)
    )
    first = nearfield._Search(data, 10 ** (-20 / 20), 4)
    assert built and len(nearfield._TABLES) == 1
    built.clear()
    second = nearfield._Search(data, 10 ** (-20 / 20), 4)
    assert built == []
    np.testing.assert_array_equal(first.focus_map(first.s_det), second.focus_map(second.s_det))
    cut = RadarData(data.signal[:, 100:500], data.array, data.range[100:500], data.waveform)
    nearfield._Search(cut, 10 ** (-20 / 20), 4)
    assert built and len(nearfield._TABLES) == 2
    assert sum(t.nbytes for t, _ in nearfield._TABLES.values()) <= nearfield.TABLE_CACHE_BYTES
