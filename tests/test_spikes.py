"""Corrupt samples (rpm_cl.io.data.drop_spikes): a handful far above the rest
are replaced by their neighbours with one warning; real data are left alone."""

import time

import numpy as np
import pytest

from rpm_cl.cli import main
from rpm_cl.io.data import DataWarning, drop_spikes


@pytest.mark.parametrize("spike", [-3.6e64, 1e3])
def test_one_corrupt_sample_neither_hangs_nor_changes_the_image(tmp_path, capsys, p2, spike):
    """The paper's scene with one sample of `signal` replaced (a flipped
    exponent bit gives -3.6e64): one warning naming one sample, and the image
    of the clean file, in about the clean run's time."""
    d = dict(np.load(p2))
    clean = tmp_path / "clean.npz"
    assert main(["image", str(p2), "-o", str(clean), "-q"]) == 0
    s = d["signal"].copy()
    s[7, 123] = spike
    bad = tmp_path / "bad.npz"
    np.savez(bad, **{**d, "signal": s})
    t0 = time.perf_counter()
    assert main(["image", str(bad), "-o", str(tmp_path / "o.npz")]) == 0
    assert time.perf_counter() - t0 < 30  # a bound, not a benchmark (unchecked: two minutes)
    err = capsys.readouterr().err
    assert err.count("rpm-cl: warning:") == 1 and "1 sample(s)" in err
    with np.load(clean) as a, np.load(tmp_path / "o.npz") as b:
        assert len(b["points"]) == len(a["points"])
        np.testing.assert_allclose(b["points"], a["points"], atol=2e-3)


def test_real_echoes_are_not_spikes(p2):
    """Every sample of a strong echo is kept: the paper's scene, and one point
    echo 60 dB above a weak one, pass unchanged and without a warning."""
    import warnings

    d = dict(np.load(p2))
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        assert drop_spikes(d["signal"], "signal") is d["signal"]
        loud = d["signal"] * 1e3
        loud[:, :50] = d["signal"][:, :50]
        assert drop_spikes(loud, "signal") is loud


def test_spikes_are_replaced_and_counted():
    rng = np.random.default_rng(4)
    x = rng.standard_normal((30, 200)) + 1j * rng.standard_normal((30, 200))
    x[3, 4] = 1e6
    x[5, 6] = -2e7j
    with pytest.warns(DataWarning, match="2 sample"):
        y = drop_spikes(x, "spectrum")
    assert y[3, 4] == pytest.approx((x[3, 3] + x[3, 5]) / 2) and x[3, 4] == 1e6
    assert y[5, 6] == pytest.approx((x[5, 5] + x[5, 7]) / 2)
    mask = np.ones(x.shape, bool)
    mask[3, 4] = mask[5, 6] = False
    np.testing.assert_array_equal(y[mask], x[mask])
