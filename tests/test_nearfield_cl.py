"""The near-field pair scan's OpenCL kernel (kernels/nearfield.cl,
``pair_energy``) against its float64 NumPy reference
(``rpm_cl.extract.nearfield._pair_algebra``), the reference against a direct
least-squares projection, and the search with and without the device."""

import numpy as np
import pytest

from rpm_cl.extract import nearfield
from rpm_cl.extract.nearfield_cl import NearFieldDevice, device_for


@pytest.fixture(scope="module")
def nfdev(cl_env):
    if not cl_env.has_double:
        pytest.skip("device has no float64")
    return NearFieldDevice(cl_env)


def _bases(rng, nx, n):
    a = rng.standard_normal((nx, n, 2)) + 1j * rng.standard_normal((nx, n, 2))
    return nearfield._orthonormal(a)


def _products(qm, qn, sp):
    """The arguments _explained_pairs hands to the algebra, captured."""
    got = {}

    def capture(*args):
        got["args"] = args
        return nearfield._pair_algebra(*args)

    nearfield._explained_pairs(qm, qn, sp, capture)
    return got["args"]


@pytest.mark.parametrize("seed", range(6))
def test_kernel_matches_reference(nfdev, seed):
    """Fresh random bases and data of the search's sizes (odd and uneven
    candidate counts), with some n candidates equal to m candidates (C^H C =
    I: det at rounding level, the masked case) and some nearly so.  The kernel evaluates
    the reference's expression in another order (and may contract to FMA),
    float64 over some 100 operations on values of the order of the data's
    energy: 1e-11 of that energy bounds the difference with a wide margin."""
    rng = np.random.default_rng(seed)
    nx, ni, nj, g = (
        int(rng.integers(4, 33)),
        int(rng.integers(1, 130)),
        int(rng.integers(1, 130)),
        int(rng.integers(1, 22)),
    )
    qm, qn = _bases(rng, nx, ni), _bases(rng, nx, nj)
    k = min(ni, nj) // 3
    qn[:, :k] = qm[:, :k]  # the same atoms: masked
    qn[:, k : 2 * k] = nearfield._orthonormal(qm[:, k : 2 * k] + 1e-7 * qn[:, k : 2 * k])
    sp = rng.standard_normal((nx, g)) + 1j * rng.standard_normal((nx, g))
    args = _products(qm, qn, sp)
    ref = nearfield._pair_algebra(*args)
    got = nfdev.pair_algebra(*args)
    assert got.shape == ref.shape == (ni, nj)
    scale = float(np.sum(np.abs(sp) ** 2))
    exact = np.abs(ref - got) <= 1e-11 * scale
    # nearly parallel pairs divide by det ~ 1e-14: there both are noise of
    # the same size, the search never chooses them (it minimises the
    # residual), so only their finiteness is compared
    near = np.zeros_like(exact)
    near[k : 2 * k, k : 2 * k] = True
    assert np.all(exact | near)
    assert np.all(np.isfinite(got))
    assert np.array_equal(np.diag(got[:k, :k]), np.diag(ref[:k, :k]))  # masked: |g_m|^2
    assert np.array_equal(np.diag(ref[:k, :k]), args[4][:k])


def test_reference_is_the_projection():
    """The reference's energy is that of ``sp`` projected on the span of the
    pair's four atoms, computed directly (QR of the 4 columns)."""
    rng = np.random.default_rng(7)
    nx, ni, nj, g = 21, 9, 7, 5
    qm, qn = _bases(rng, nx, ni), _bases(rng, nx, nj)
    sp = rng.standard_normal((nx, g)) + 1j * rng.standard_normal((nx, g))
    got = nearfield._explained_pairs(qm, qn, sp)
    for i in range(ni):
        for j in range(nj):
            q, _ = np.linalg.qr(np.concatenate([qm[:, i], qn[:, j]], axis=1))
            want = float(np.sum(np.abs(q.conj().T @ sp) ** 2))
            assert got[i, j] == pytest.approx(want, rel=1e-9)


def test_no_device_without_env_or_double(cl_env):
    assert device_for(None) is None
    dev = device_for(cl_env)
    assert (dev is None) == (not cl_env.has_double)


def test_search_finds_the_paper_targets_with_and_without_device(cl_env):
    """The paper's sparse case: with the device and without, three centres,
    each within 10 mm of a true target's range and 0.02 of its sin(theta);
    both put them at the same places (within 1e-6 of a resolution cell)."""
    from rpm_cl.rpm.params import default_params
    from rpm_cl.simulate import simulate
    from rpm_cl.simulate.scene import get_preset

    pre = get_preset("paper-2d-sparse")
    data = simulate(pre.scene, pre.array, pre.waveform, pre.range_axis, None, None)
    params = default_params(data, **pre.defaults)
    k0 = data.waveform.kc
    du = np.pi / (k0 * float(np.ptp(data.array.x)))
    truth = np.array([t.position for t in pre.scene.targets])
    tr, tu = np.hypot(truth[:, 0], truth[:, 1]), truth[:, 0] / np.hypot(truth[:, 0], truth[:, 1])
    found = []
    for env in (None, cl_env):
        dec = nearfield.decompose_near_field(data, params.kspace, (None, None), env)
        c = sorted((float(cl.k[0]) / (2 * k0), cl.r_centre) for cl in dec.clusters)
        assert len(c) == 3
        for u, r in c:
            assert np.min(np.hypot((tu - u) / 0.02, (tr - r) / 0.01)) <= 1.0
        found.append(np.array(c))
    assert np.all(np.abs(found[0][:, 0] - found[1][:, 0]) <= 1e-6 * du)
    assert np.all(np.abs(found[0][:, 1] - found[1][:, 1]) <= 1e-6 * 0.0075)
