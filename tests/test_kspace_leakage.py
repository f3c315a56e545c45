"""Range sidelobes are not centres (rpm_cl.extract.kspace_detect.above_leakage).

The scenes are synthesised here from facets (physical optics), not by
rpm_cl.simulate: a flat plate seen by a line at high S/N, whose compression's
sidelobes a plain regime's relative threshold took for echoes of their own.
"""

from dataclasses import replace

import numpy as np
import pytest

from rpm_cl.extract.kspace_detect import LEAK_MARGIN, above_leakage, sidelobe_envelope
from rpm_cl.imaging import run_method
from rpm_cl.io.compress import spectrum_data
from rpm_cl.io.data import C0, Array
from rpm_cl.rpm import reference
from rpm_cl.rpm.params import default_params

X = (np.arange(41) - 20) * 5e-3  # 41 antennas at 5 mm


def _facets(x0, x1, y, n=500):
    """A plate from x0 to x1 at depth y: facets (points, weights), facing the line."""
    s = (np.arange(n) + 0.5) / n
    return np.column_stack([x0 + s * (x1 - x0), np.full(n, y)]), np.full(n, (x1 - x0) / n)


def _spectrum(freq, facets, points=()):
    """Physical optics: each facet's echo weighted by its cosine to the
    antenna and 1/R^2; point targets (x, y, amplitude) as 1/R^2 echoes."""
    ant = np.column_stack([X, np.zeros_like(X)])
    k2 = 4 * np.pi * freq / C0
    p, w = facets
    d = ant[:, None, :] - p[None]
    r = np.linalg.norm(d, axis=2)
    g = w[None] * np.clip(-d[..., 1] / r, 0, None) / r**2  # normal (0, -1)
    y = np.einsum("am,amf->af", g, np.exp(-1j * k2[None, None, :] * r[..., None]))
    for px, py, a in points:
        rr = np.hypot(X - px, py)
        y += (a / rr[:, None] ** 2) * np.exp(-1j * k2[None, :] * rr[:, None])
    return y


@pytest.mark.parametrize(
    "band, nf",
    [(2e9, 161), (4e9, 201)],  # the sidelobe wrapped to the axis's end; the first sidelobe
)
def test_a_noise_free_plate_images_without_its_range_sidelobes(band, nf):
    freq = np.linspace(24e9 - band / 2, 24e9 + band / 2, nf)
    data = spectrum_data(_spectrum(freq, _facets(-0.05, 0.05, 0.40)), freq, Array(X))
    pts = run_method("phase-rpm", data, default_params(data), reference).image.points
    assert len(pts) >= 20
    # every point on the plate: none at its first sidelobe (0.29 m) or at
    # the wrap (11.98 m), where the plain regime's threshold let them in
    assert np.all(np.abs(pts[:, 1] - 0.40) < 0.01) and np.all(np.abs(pts[:, 0]) < 0.06)


def test_the_bound_is_the_leakage_at_the_centres_own_k():
    """On a map with one strong echo at (k 10, gate 100): a candidate at its
    k on a sidelobe gate is dropped, one as weak at another k on the same
    gate is kept, and one at its k far beyond the sidelobes' reach too."""
    freq = np.linspace(23e9, 25e9, 161)
    data = spectrum_data(np.ones((3, freq.size), complex), freq, Array(X[:3]))
    env = sidelobe_envelope(data)
    off = int(np.argmax(env))  # the first sidelobe's offset, gates
    det = np.zeros((64, data.range.size))
    det[10, 100] = 1.0
    level = 1.5 * env[off]  # above the sidelobe, below LEAK_MARGIN times it
    det[10, 100 + off] = det[30, 100 + off] = level
    far = 100 + data.range.size // 2  # half the axis away, where env is lowest
    det[10, far] = 1e-4  # -80 dB: above the sidelobes there (Hann: below -150 dB)
    idx = np.array([[10, 100], [10, 100 + off], [30, 100 + off], [10, far]])
    kept = above_leakage(idx, det, 0, data)
    assert [tuple(c) for c in kept] == [(10, 100), (30, 100 + off), (10, far)]
    # profiles of no known compression (given without their samples, or
    # after a gain): all kept
    td = replace(data, spectrum=None, compression=None)
    assert len(above_leakage(idx, det, 0, td)) == 4


def test_the_sidelobe_envelope_of_a_hann_compression():
    freq = np.linspace(23e9, 25e9, 161)
    data = spectrum_data(np.ones((3, freq.size), complex), freq, Array(X[:3]))
    env = sidelobe_envelope(data)
    assert env.size == data.compression.gates // 2 + 1  # offsets round the axis
    db = 20 * np.log10(env[env > 0])
    # Hann's first sidelobe is -31.5 dB; the envelope only falls from it
    assert db.max() == pytest.approx(-31.5, abs=0.5)
    assert np.all(np.diff(env[env > 0]) <= 0)
    # the main lobe (out to the first null, two resolutions c / 2B) is no sidelobe
    null = np.flatnonzero(env > 0)[0] * data.dr
    assert null == pytest.approx(2 * C0 / (2 * 2e9), rel=0.05)
    assert LEAK_MARGIN >= 1


@pytest.mark.parametrize("nf", [100, 101])  # an even and an odd compressed axis (1600, 1617)
def test_offsets_wrap_round_the_compressed_axis(nf):
    """A candidate on the far side of the axis's wrap is as far from the
    echo as one on the near side at the same offset."""
    freq = np.linspace(23e9, 25e9, nf)
    data = spectrum_data(np.ones((3, nf), complex), freq, Array(X[:3]))
    n = data.compression.gates
    env = sidelobe_envelope(data)
    off = int(np.argmax(env))
    det = np.zeros((8, n))
    det[2, 5] = 1.0
    det[2, 5 + off] = det[2, (5 - off) % n] = 1.5 * env[off]  # explained by the echo
    idx = np.array([[2, 5], [2, 5 + off], [2, (5 - off) % n]])
    assert [tuple(c) for c in above_leakage(idx, det, 0, data)] == [(2, 5)]


@pytest.mark.parametrize("steps", [{"background": "mean"}, {"time_zero": 0.05}])
def test_the_bound_holds_after_a_background_or_a_time_zero(steps):
    """A background or a cut of the axis leaves each echo the window's
    response (the frequency samples are dropped, the compression is kept):
    the plate images without its sidelobes still."""
    from rpm_cl.extract.preprocess import preprocess

    freq = np.linspace(22e9, 26e9, 201)
    data = spectrum_data(_spectrum(freq, _facets(-0.05, 0.05, 0.40)), freq, Array(X))
    pre = preprocess(data, **steps)
    assert pre.spectrum is None and pre.compression == data.compression
    assert preprocess(data, gain_db_per_m=6.0).compression is None
    pts = run_method("phase-rpm", data, default_params(data, **steps), reference).image.points
    assert len(pts) >= 20
    y0 = 0.40 - steps.get("time_zero", 0.0)
    assert np.all(np.abs(pts[:, 1] - y0) < 0.01)
