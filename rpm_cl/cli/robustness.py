"""Robustness benchmark: accuracy against in-band S/N on data rpm_cl.simulate
did not make.

Scenes are synthesised here, in the frequency domain, independently of
:mod:`rpm_cl.simulate`: a stepped-frequency sweep of ``nf`` samples over the
band, each echo ``a exp(-j 4 pi f R / c)`` (2-D point targets: ``a = 1/R``;
3-D spheres of radius rho: the specular point's range ``|X - c| - rho`` and
the geometric-optics amplitude ``sqrt(rho^2 / (R (R + rho))^2 ...)``, see
:func:`_sphere_echoes`), and complex white Gaussian noise added to the
frequency samples, before range compression, with

    S/N = (peak compressed power) / (mean compressed noise power),

the compression being the plain sum over the band (a matched filter for a
flat spectrum): the peak of ``|sum_n Y_n exp(j 4 pi f_n R / c) / nf|^2`` over
antennas and ranges, against ``sigma^2 / nf`` for a per-sample noise variance
``sigma^2``.  The engine then reads the spectrum as ``rpm-cl image`` reads
a spectrum file (:func:`loaded_data`: the Hann compression over the whole
unambiguous range, the samples kept) and images it with a region of
interest of twice the farthest echo plus 0.5 m (``max_range``).
``samples=False`` (``benchmarks/robustness.py --profiles``) hands it the
range profiles of that region alone instead, as a range-domain file holds
them (:func:`radar_data`): no samples, and no gates beyond the scene to
measure the noise on.

Each method's points are scored as the paper scores RPM (Err_RPM: the
distance to the nearest sample of the true boundary): the fraction within
50 mm (20 mm for the 3-D scene) and the median.  DAS is scored by the local
maxima of its image (:func:`rpm_cl.baselines.peaks.image_peaks`, 5 x 5
pixels, -10 dB).  A target is hit when a point lies within that distance of
it.  Beside them, the Cramer-Rao bounds of one target alone in the same
noise: the range at one antenna, and the position from the whole array
(:func:`crb`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..io.data import C0, Array, RadarData, Waveform
from ..io.formats import range_compress

__all__ = [
    "GEOMETRIES_2D",
    "SNRS",
    "Geometry",
    "crb",
    "direction_cells",
    "hits",
    "loaded_data",
    "random_geometry",
    "region",
    "run",
    "synthesize",
    "table",
]

#: In-band S/N of the benchmark, dB (None: noise-free).
SNRS = (None, 40.0, 30.0, 20.0, 10.0)


@dataclass(frozen=True)
class Geometry:
    """One benchmark scene.

    Attributes
    ----------
    name : str
    fc, band : float
        Sweep centre and width, Hz (``nf`` samples from ``fc - band/2``).
    nf : int
    x : tuple
        Antenna x grid: (n, pitch), m, centred on 0.
    z : tuple or None
        Antenna z grid for a planar array: (n, pitch), m.
    targets : tuple
        2-D: point targets (x, y), m; 3-D: spheres (x, y, z, radius), m.
    tol : float
        Accuracy threshold of the score, m.
    """

    name: str
    fc: float
    band: float
    nf: int
    x: tuple
    z: tuple | None
    targets: tuple
    tol: float = 0.05

    @property
    def dim(self) -> int:
        return 2 if self.z is None else 3


def _polar(r, deg):
    return (r * np.sin(np.radians(deg)), r * np.cos(np.radians(deg)))


#: Narrow-band 2-D scenes like the paper's (20-24 GHz, 0.2-0.25 GHz, 21-31
#: antennas at 4-5 mm, three or four point targets at 0.35-0.5 m).
GEOMETRIES_2D = (
    Geometry(
        "2d-a",
        20e9,
        0.2e9,
        64,
        (21, 5e-3),
        None,
        (_polar(0.42, -28), _polar(0.46, 3), _polar(0.49, 25)),
    ),
    Geometry(
        "2d-b",
        22e9,
        0.25e9,
        64,
        (31, 4e-3),
        None,
        (_polar(0.36, -30), _polar(0.44, -12), _polar(0.40, 8), _polar(0.48, 27)),
    ),
    Geometry(
        "2d-c",
        24e9,
        0.2e9,
        64,
        (25, 4.5e-3),
        None,
        (_polar(0.50, -20), _polar(0.38, 0), _polar(0.45, 22)),
    ),
    Geometry(
        "2d-d",
        21e9,
        0.22e9,
        64,
        (27, 5e-3),
        None,
        (_polar(0.35, -33), _polar(0.47, -15), _polar(0.41, 14), _polar(0.37, 33)),
    ),
)
#: A 3-D scene: three spheres before a planar array, 20 GHz / 3 GHz.
GEOMETRY_3D = Geometry(
    "3d-spheres",
    20e9,
    3e9,
    96,
    (15, 7.5e-3),
    (15, 7.5e-3),
    ((-0.10, 0.60, 0.02, 0.06), (0.08, 0.70, -0.05, 0.08), (0.02, 0.55, 0.10, 0.04)),
    tol=0.02,
)


def random_geometry(seed: int, min_separation: float = 0.06) -> Geometry:
    """A narrow-band 2-D scene drawn at random from the envelope of
    :data:`GEOMETRIES_2D` (and of the paper's 2-D case): carrier 20-24 GHz,
    band 0.2-0.25 GHz, 32-128 frequencies, 21-31 antennas at 4-5 mm, three
    or four point targets at 0.35-0.5 m within +-35 degrees of broadside, at
    least ``min_separation`` (m) apart.  Targets may lie closer in direction
    than the k-space window, or than the aperture resolves.

    Parameters
    ----------
    seed : int
        The scene's generator seed (named ``r<seed>``).
    """
    rng = np.random.default_rng(seed)
    fc = rng.uniform(20e9, 24e9)
    band = rng.uniform(0.2e9, 0.25e9)
    nf = int(rng.choice([32, 51, 64, 101, 128]))
    nx, pitch = int(rng.integers(21, 32)), float(rng.uniform(4e-3, 5e-3))
    nt = int(rng.integers(3, 5))
    for _ in range(10_000):
        pts = np.array(
            [_polar(r, a) for r, a in zip(rng.uniform(0.35, 0.5, nt), rng.uniform(-35, 35, nt))]
        )
        gap = np.linalg.norm(pts[:, None] - pts[None], axis=2) + np.eye(nt)
        if gap.min() >= min_separation:
            break
    else:
        raise ValueError(f"no layout of {nt} targets keeps {min_separation} m apart")
    return Geometry(f"r{seed}", fc, band, nf, (nx, pitch), None, tuple(map(tuple, pts)))


def direction_cells(g: Geometry) -> np.ndarray:
    """Per target of a 2-D scene, its direction's distance to the nearest
    other target's, in the aperture's resolution cells: the two-way
    wavenumber difference ``2 k_c |sin a - sin b|`` over ``2 pi / L``."""
    t = np.asarray(g.targets, float)
    s = t[:, 0] / np.hypot(t[:, 0], t[:, 1])
    kc = 2 * np.pi * g.fc / C0
    cell = 2 * np.pi / ((g.x[0] - 1) * g.x[1])
    d = np.abs(s[:, None] - s[None]) + np.diag(np.full(len(s), np.inf))
    return 2 * kc * d.min(axis=1) / cell


def hits(points: np.ndarray, g: Geometry) -> np.ndarray:
    """Per target of a 2-D scene, whether a point lies within ``g.tol`` of it."""
    p = np.asarray(points, float).reshape(-1, 2)
    c = np.asarray(g.targets, float)
    if not len(p):
        return np.zeros(len(c), bool)
    return np.min(np.linalg.norm(p[:, None] - c[None], axis=2), axis=0) < g.tol


def _axis(spec) -> np.ndarray:
    n, d = spec
    return (np.arange(n) - (n - 1) / 2) * d


def _freqs(g: Geometry) -> np.ndarray:
    return g.fc - g.band / 2 + np.arange(g.nf) * g.band / (g.nf - 1)


def _positions(g: Geometry) -> np.ndarray:
    x = _axis(g.x)
    if g.z is None:
        return np.column_stack([x, np.zeros_like(x)])
    xx, zz = np.meshgrid(x, _axis(g.z), indexing="ij")
    return np.column_stack([xx.ravel(), np.zeros(xx.size), zz.ravel()])


def _sphere_echoes(pos: np.ndarray, sph) -> tuple[np.ndarray, np.ndarray]:
    """Range and amplitude of a sphere's specular echo at each antenna:
    ``R = |X - c| - rho`` and the geometric-optics amplitude of a doubly
    curved surface, ``rho / (2 R (R + rho))``."""
    c, rho = np.asarray(sph[:3]), float(sph[3])
    r = np.linalg.norm(pos - c, axis=1) - rho
    return r, rho / (2 * r * (r + rho))


def _echoes(g: Geometry, pos: np.ndarray):
    """(ranges, amplitudes), each (n_antennas, n_targets)."""
    if g.dim == 2:
        t = np.asarray(g.targets)
        r = np.linalg.norm(pos[:, None, :] - t[None], axis=2)
        return r, 1.0 / r
    parts = [_sphere_echoes(pos, s) for s in g.targets]
    return np.stack([p[0] for p in parts], 1), np.stack([p[1] for p in parts], 1)


def truth_boundary(g: Geometry, spacing: float = 1e-3) -> np.ndarray:
    """Samples of the true boundary: the points themselves (2-D), the spheres'
    surfaces facing the array (3-D), m."""
    if g.dim == 2:
        return np.asarray(g.targets, float)
    out = []
    for cx, cy, cz, rho in g.targets:
        n = max(16, int(np.ceil(np.pi * rho / spacing)))
        th, ph = np.meshgrid(np.linspace(0, np.pi, n), np.linspace(0, 2 * np.pi, 2 * n))
        p = np.column_stack(
            [
                np.sin(th).ravel() * np.cos(ph).ravel(),
                np.cos(th).ravel(),
                np.sin(th).ravel() * np.sin(ph).ravel(),
            ]
        )
        p = p[p[:, 1] <= 0.2]  # the half facing the array (y < centre)
        out.append(np.array([cx, cy, cz]) + rho * p)
    return np.concatenate(out)


def synthesize(g: Geometry, snr_db: float | None, seed: int = 0):
    """The frequency samples of a scene with in-band noise (module notes).

    Returns
    -------
    spectrum : ndarray, complex128, shape (nx[, nz], nf)
    frequency : ndarray, shape (nf,), Hz
    sigma2 : float
        The per-sample noise variance added (0 noise-free).
    """
    pos = _positions(g)
    f = _freqs(g)
    r, a = _echoes(g, pos)
    y = np.zeros((len(pos), g.nf), complex)
    for t in range(r.shape[1]):
        y += a[:, t : t + 1] * np.exp(-4j * np.pi * f[None, :] * r[:, t : t + 1] / C0)
    sigma2 = 0.0
    if snr_db is not None:
        n = 16 * g.nf
        peak = float(np.max(np.abs(np.fft.ifft(y, n, axis=1) * n / g.nf)) ** 2)
        sigma2 = peak / 10 ** (snr_db / 10) * g.nf
        rng = np.random.default_rng(seed)
        y = y + np.sqrt(sigma2 / 2) * (
            rng.standard_normal(y.shape) + 1j * rng.standard_normal(y.shape)
        )
    shape = (g.x[0],) if g.z is None else (g.x[0], g.z[0])
    return y.reshape(shape + (g.nf,)), f, sigma2


def radar_data(g: Geometry, spectrum, frequency) -> RadarData:
    """The spectrum range-compressed as a range-domain file holds it (Hann
    window), the range axis cut to the region of interest (:func:`region`);
    no samples."""
    fc = 0.5 * (frequency[0] + frequency[-1])
    s, rng = range_compress(spectrum, frequency, fc, "hann")
    keep = rng <= region(g)
    arr = Array(_axis(g.x), None if g.z is None else _axis(g.z))
    # the engine's B for a Hann window over the sweep: its FWHM, nf df / 2
    df = float(frequency[1] - frequency[0])
    return RadarData(s[..., keep], arr, rng[keep], Waveform(fc, g.nf * df / 2))


def region(g: Geometry) -> float:
    """The region of interest the benchmark images: ranges up to twice the
    farthest echo plus 0.5 m, m."""
    return 2 * float(np.max(_echoes(g, _positions(g))[0])) + 0.5


def loaded_data(g: Geometry, spectrum, frequency) -> RadarData:
    """The spectrum as :func:`rpm_cl.io.load.load_data` loads a spectrum
    file without ``fc`` and ``bandwidth``
    (:func:`rpm_cl.io.compress.spectrum_data`, Hann window): the
    compression over the whole unambiguous range, the samples kept."""
    from ..io.compress import spectrum_data

    return spectrum_data(
        spectrum, frequency, Array(_axis(g.x), None if g.z is None else _axis(g.z))
    )


def crb(g: Geometry, sigma2: float) -> tuple[float, float]:
    """Cramer-Rao bounds of one target alone (each target in turn, the median
    over them) in noise of per-sample variance ``sigma2``: the range at the
    array's centre antenna, and the position (RMS over the coordinates'
    bounds) from every antenna's samples, m.  Unknowns: the position and a
    complex amplitude; the Fisher information ``2 Re(J^H J) / sigma2`` with
    the Jacobian J of the noise-free samples by central differences.
    """
    if sigma2 <= 0:
        return 0.0, 0.0
    pos = _positions(g)
    f = _freqs(g)
    k = 4j * np.pi * f / C0
    out_r, out_p = [], []
    for t in range(len(g.targets)):
        sub = Geometry(g.name, g.fc, g.band, g.nf, g.x, g.z, (g.targets[t],), g.tol)

        def model(p, sub=sub):
            tt = list(sub.targets[0])
            tt[: len(p)] = p
            r, a = _echoes(
                Geometry(sub.name, sub.fc, sub.band, sub.nf, sub.x, sub.z, (tuple(tt),), sub.tol),
                pos,
            )
            return (a * np.exp(-k[None, :] * r)).ravel()

        p0 = np.asarray(g.targets[t][: g.dim], float)
        s0 = model(p0)
        cols = []
        for i in range(len(p0)):
            h = np.zeros_like(p0)
            h[i] = 1e-6
            cols.append((model(p0 + h) - model(p0 - h)) / 2e-6)
        cols += [s0, 1j * s0]  # d/d(Re a), d/d(Im a) of a * s0
        jac = np.stack(cols, 1)
        fim = 2 * np.real(jac.conj().T @ jac) / sigma2
        cov = np.linalg.inv(fim)
        out_p.append(float(np.sqrt(np.trace(cov[: len(p0), : len(p0)]) / len(p0))))
        # range at the centre antenna: one antenna's samples, unknown range and amplitude
        centre = int(np.argmin(np.linalg.norm(pos - pos.mean(axis=0), axis=1)))
        r0, a0 = _echoes(sub, pos[centre : centre + 1])
        e = np.exp(-k * r0[0, 0])
        j1 = np.stack([-k * a0[0, 0] * e, e, 1j * e], 1)
        f1 = 2 * np.real(j1.conj().T @ j1) / sigma2
        out_r.append(float(np.sqrt(np.linalg.inv(f1)[0, 0])))
    return float(np.median(out_r)), float(np.median(out_p))


def _score(points: np.ndarray, g: Geometry, boundary: np.ndarray):
    """(fraction within tol, median Err_RPM, targets hit, points)."""
    if len(points) == 0:
        return 0.0, float("nan"), 0, 0
    p = np.asarray(points, float)
    d = np.min(np.linalg.norm(p[:, None, :] - boundary[None], axis=2), axis=1)
    if g.dim == 2:
        hit = int(np.sum(hits(p, g)))
    else:
        hit = 0
        for cx, cy, cz, rho in g.targets:
            dist = np.abs(np.linalg.norm(p - [cx, cy, cz], axis=1) - rho)
            hit += int(np.any(dist < g.tol))
    return float(np.mean(d < g.tol)), float(np.median(d)), hit, len(p)


def _das_points(das, data: RadarData, g: Geometry) -> np.ndarray:
    from ..baselines.das import Grid
    from ..baselines.peaks import image_peaks

    if g.dim == 2:
        grid = Grid(np.arange(-0.4, 0.4, 1e-3), np.arange(0.2, 0.7, 1e-3))
        return image_peaks(das.backproject(data, grid), grid.axes, threshold_db=-10.0, size=5)[0]
    from .reproduce import das_points

    grid = Grid(
        np.arange(-0.25, 0.25, 4e-3), np.arange(0.4, 0.8, 2e-3), np.arange(-0.2, 0.25, 4e-3)
    )
    return das_points(das, data, grid, "volume")[0]


def run(
    engine,
    das=None,
    geometries=None,
    snrs=SNRS,
    seeds=(0,),
    methods=None,
    progress=False,
    samples=True,
):
    """Every method on every scene, S/N and noise seed.

    ``samples``: the data as a spectrum file loads (:func:`loaded_data`,
    imaged with ``max_range`` = :func:`region`), else the region's range
    profiles alone (:func:`radar_data`).

    Returns
    -------
    list of dict
        One row per (scene, S/N, method), the seeds pooled: ``fraction``
        (points within the scene's tolerance), ``median`` (m), ``hit`` (targets
        hit, summed over seeds), ``targets``, ``points``, ``seconds`` (median
        imaging time), ``crb_range``, ``crb_position`` (m).
    """
    from .. import imaging
    from ..rpm.params import default_params

    geometries = geometries or (*GEOMETRIES_2D, GEOMETRY_3D)
    methods = list(methods or ("kspace-rpm", "phase-rpm", "mf-rpm", "capon-rpm"))
    rows = []
    for g in geometries:
        boundary = truth_boundary(g)
        for snr in snrs:
            acc = {}
            crbs = None
            for seed in seeds:
                spec, f, sigma2 = synthesize(g, snr, seed)
                crbs = crbs or crb(g, sigma2)
                if samples:
                    data = loaded_data(g, spec, f)
                    params = default_params(data, max_range=region(g))
                else:
                    data = radar_data(g, spec, f)
                    params = default_params(data)
                names = [m for m in methods if not (g.dim == 3 and m in ("mf-rpm", "capon-rpm"))]
                for m in names:
                    t0 = time.perf_counter()
                    res = imaging.run_method(m, data, params, engine)
                    sec = time.perf_counter() - t0
                    acc.setdefault(m, []).append((*_score(res.image.points, g, boundary), sec))
                if das is not None:
                    t0 = time.perf_counter()
                    pts = _das_points(das, data, g)
                    sec = time.perf_counter() - t0
                    acc.setdefault("das", []).append((*_score(pts, g, boundary), sec))
                if progress:
                    print(f"  {g.name} S/N {snr} seed {seed} done", flush=True)
            for m, vals in acc.items():
                v = np.array(vals, float)
                n_pts = v[:, 3]
                frac = float(np.sum(v[:, 0] * n_pts) / max(1.0, np.sum(n_pts)))
                rows.append(
                    {
                        "scene": g.name,
                        "snr": snr,
                        "method": m,
                        "fraction": frac,
                        "median": float(np.nanmedian(v[:, 1])) if np.any(n_pts) else None,
                        "hit": int(np.sum(v[:, 2])),
                        "targets": len(g.targets) * len(seeds),
                        "points": int(np.sum(n_pts)),
                        "seconds": float(np.median(v[:, 4])),
                        "crb_range": crbs[0],
                        "crb_position": crbs[1],
                        "tol": g.tol,
                    }
                )
    return rows


def table(rows) -> str:
    """Rows as a Markdown table."""
    head = (
        "| scene | S/N dB | method | within tol | median Err_RPM mm | targets hit | points | "
        "ms | CRB range mm | CRB position mm |\n|---|---|---|---|---|---|---|---|---|---|\n"
    )
    lines = []
    for r in rows:
        snr = "inf" if r["snr"] is None else f"{r['snr']:g}"
        med = "-" if r["median"] is None else f"{1e3 * r['median']:.1f}"
        lines.append(
            f"| {r['scene']} | {snr} | {r['method']} | "
            f"{100 * r['fraction']:.1f} % (<= {1e3 * r['tol']:.0f} mm) | {med} | "
            f"{r['hit']}/{r['targets']} | {r['points']} | {1e3 * r['seconds']:.1f} | "
            f"{1e3 * r['crb_range']:.2f} | {1e3 * r['crb_position']:.2f} |"
        )
    return head + "\n".join(lines) + "\n"


def plot(rows, path) -> None:
    """Fraction within tolerance and median error against S/N, one panel
    pair per scene kind (2-D pooled over scenes, 3-D), the position and
    range CRBs beside the medians."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kinds = {
        "2-D (4 scenes)": [r for r in rows if r["scene"].startswith("2d")],
        "3-D spheres": [r for r in rows if r["scene"].startswith("3d")],
    }
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5))
    for col, (label, rs) in enumerate(kinds.items()):
        if not rs:
            continue
        snrs = sorted({r["snr"] for r in rs}, key=lambda s: 1e9 if s is None else s)
        xs = [60 if s is None else s for s in snrs]
        for m in sorted({r["method"] for r in rs}):
            fr, md = [], []
            for s in snrs:
                sel = [r for r in rs if r["method"] == m and r["snr"] == s]
                pts = sum(r["points"] for r in sel)
                fr.append(100 * sum(r["fraction"] * r["points"] for r in sel) / max(1, pts))
                meds = [r["median"] for r in sel if r["median"] is not None]
                md.append(1e3 * float(np.median(meds)) if meds else np.nan)
            axes[0, col].plot(xs, fr, "o-", label=m)
            axes[1, col].semilogy(xs, md, "o-", label=m)
        for key, style, text in (
            ("crb_position", "k--", "CRB position (one target)"),
            ("crb_range", "k:", "CRB range (one antenna)"),
        ):
            bound = []
            for s in snrs:
                sel = [r[key] for r in rs if r["snr"] == s]
                bound.append(1e3 * float(np.median(sel)) if sel else np.nan)
            axes[1, col].semilogy(xs, bound, style, label=text)
        tol = 1e3 * rs[0]["tol"]
        axes[0, col].set(
            title=f"{label}: points within {tol:.0f} mm",
            ylabel="%",
            xlabel="in-band S/N, dB (60 = noise-free)",
            ylim=(0, 102),
        )
        axes[1, col].set(
            title=f"{label}: median Err_RPM",
            ylabel="mm",
            xlabel="in-band S/N, dB (60 = noise-free)",
        )
        axes[0, col].legend(fontsize=8)
        axes[1, col].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
