"""A near-field planar scan made without rpm_cl.simulate: a rough, curved
sample seen through a beam, with the scanner's own coupling and the repeat
echo, imaged by phase-rpm with its defaults.

The sample is a surface ``y = 0.105 + 0.04 x + 0.3 (x^2 + z^2)`` m (tilted
and bowed; 0.2 mm RMS roughness) sampled by facets on a 1.5 mm grid; each
antenna at (x, 0, z) of a 3 mm grid records the physical-optics sum of the
facets within ``REACH`` across, ``sum cos(theta)^16 t dA / r^2 exp(-j 4 pi f r / c)``
(``t`` a taper to 0 at ``REACH``)
(a two-way beam 3 dB down 12 degrees off its axis), at 11 frequencies over
22.2-26.2 GHz (the public 24 GHz scanner's).  On top, per antenna: the
repeat (the echo the antennas send back to the sample once more) at twice
the surface's range, a multiple of the median echo; the coupling at 12
mm, a multiple of it, the same at every antenna (in one variant its
amplitude falls 6 dB across the band: not one clean echo); white noise of
each variant's S/N (a unit echo's rect-compressed peak power over the
compressed noise power).  Nothing here is the engine's geometric-optics
model: the surface echo is what the facets add up to.

Per variant: points, the share within 15 mm of the surface and the median
distance, the repeat's points the engine dropped (or flagged, with
``--plain``), the points of coupling RPs it dropped (those left after the
samples' coupling was removed) and its time.

``--plain``: the same runs with ``background = "none"`` (the coupling left
in the samples; phase-rpm then drops its RPs' points) and ``multipath =
"flag"`` (the repeat's points kept, flagged, scored and counted).

``--variants clean``: the sample noise-free and at 60 dB, alone and with
the coupling and the repeat (a scanner's S/N can be that high, where the
range sidelobes of the surface's echo stand far above the noise).

``--write F``: write each variant's scan to the spectrum file F (the last
one written stays), to time a whole ``rpm-cl image`` run on it instead.

    python benchmarks/near_field_scan.py [--size 60x48] [--variants default|coupling|clean]
        [--plain] [--write F.npz]
"""

import argparse
import time

import numpy as np

C0 = 299792458.0
FREQ = np.linspace(22.2e9, 26.2e9, 11)
PITCH = 3e-3
#: Facets farther across from an antenna than this are not summed, m; the
#: sum is tapered to 0 there (cos^2), so that no edge of it echoes: the
#: beam is 44 dB down at 0.1 m across a sample 0.105 m away.
REACH = 0.1


def height(x, z):
    """The sample's surface, m."""
    return 0.105 + 0.04 * x + 0.3 * (x**2 + z**2)


def make(nx, nz, coupling, repeat, snr_db, slope_db=0.0, seed=5):
    """(spectrum (nx, nz, 11), x, z): the scan of the module notes."""
    x = (np.arange(nx) - (nx - 1) / 2) * PITCH
    z = (np.arange(nz) - (nz - 1) / 2) * PITCH
    rng = np.random.default_rng(seed)
    d = 1.5e-3
    fx = np.arange(x[0] - REACH, x[-1] + REACH, d)
    fz = np.arange(z[0] - REACH, z[-1] + REACH, d)
    gx, gz = np.meshgrid(fx, fz, indexing="ij")
    gy = height(gx, gz) + rng.normal(0, 0.2e-3, gx.shape)
    k = 4 * np.pi * FREQ / C0
    spec = np.zeros((nx, nz, FREQ.size), complex)
    for i, ax in enumerate(x):
        for j, az in enumerate(z):
            m = (np.abs(gx - ax) < REACH) & (np.abs(gz - az) < REACH)
            dx, dz, dy = gx[m] - ax, gz[m] - az, gy[m]
            r = np.sqrt(dx * dx + dy * dy + dz * dz)
            # the beam, and a taper to 0 at REACH across (no edge of the sum)
            rho = np.minimum(np.hypot(dx, dz) / REACH, 1.0)
            a = (dy / r) ** 16 * np.cos(0.5 * np.pi * rho) ** 2 * d * d / r**2
            spec[i, j] = np.exp(-1j * np.outer(k, r)) @ a
    spec /= np.median(np.abs(spec))
    h = height(x[:, None], z[None, :])[..., None]
    spec += repeat * np.exp(-1j * k * 2 * h)
    # a real coupling is seldom one clean echo: its amplitude may fall
    # slope_db across the band
    tilt = 10 ** (-slope_db * np.linspace(1, 0, FREQ.size) / 20)
    spec += coupling * tilt * np.exp(-1j * k * 0.012 + 0.3j)
    if snr_db is not None:
        s2 = FREQ.size / 10 ** (snr_db / 10)
        spec += np.sqrt(s2 / 2) * (
            rng.standard_normal(spec.shape) + 1j * rng.standard_normal(spec.shape)
        )
    return spec, x, z


def off_surface(points, x, z):
    """Distance of each point to the surface sampled on 0.5 mm over the scan
    and 30 mm beyond, m."""
    from scipy.spatial import cKDTree

    bx = np.arange(x[0] - 0.03, x[-1] + 0.03, 5e-4)
    bz = np.arange(z[0] - 0.03, z[-1] + 0.03, 5e-4)
    mx, mz = np.meshgrid(bx, bz, indexing="ij")
    surf = np.column_stack([mx.ravel(), height(mx, mz).ravel(), mz.ravel()])
    return cKDTree(surf).query(points)[0]


#: (label, coupling, repeat, S/N dB, the coupling's fall across the band dB)
VARIANTS = {
    "default": [
        ("sample alone, 30 dB", 0.0, 0.0, 30.0, 0.0),
        ("repeat 0.3, 30 dB", 0.0, 0.3, 30.0, 0.0),
        ("coupling 3 + repeat 0.2, 30 dB", 3.0, 0.2, 30.0, 0.0),
        ("coupling 30 + repeat 0.2, 30 dB", 30.0, 0.2, 30.0, 0.0),
        ("coupling 0.3 + repeat 0.3, 20 dB", 0.3, 0.3, 20.0, 0.0),
        ("coupling 3 + repeat 0.3, 10 dB", 3.0, 0.3, 10.0, 0.0),
        ("coupling 3 falling 6 dB, 30 dB", 3.0, 0.2, 30.0, 6.0),
    ],
    "coupling": [("coupling 3 falling 6 dB, 30 dB", 3.0, 0.2, 30.0, 6.0)],
    "clean": [
        ("sample alone, noise-free", 0.0, 0.0, None, 0.0),
        ("sample alone, 60 dB", 0.0, 0.0, 60.0, 0.0),
        ("coupling 3 + repeat 0.2, 60 dB", 3.0, 0.2, 60.0, 0.0),
        ("coupling 3 + repeat 0.2, noise-free", 3.0, 0.2, None, 0.0),
    ],
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="60x48", help="antennas NXxNZ (default 60x48)")
    ap.add_argument("--variants", default="default", choices=sorted(VARIANTS))
    ap.add_argument("--device", help="OpenCL device (as rpm-cl --device)")
    ap.add_argument(
        "--plain",
        action="store_true",
        help="background none and multipath flag: the coupling left in, the repeat kept",
    )
    ap.add_argument("--write", help="write the scan to this .npz instead of imaging it")
    args = ap.parse_args()
    nx, nz = (int(v) for v in args.size.split("x"))

    from rpm_cl.cl import create_env
    from rpm_cl.imaging import run_method
    from rpm_cl.io.compress import spectrum_data
    from rpm_cl.io.data import Array
    from rpm_cl.rpm import DeviceRPM
    from rpm_cl.rpm.params import default_params

    env = create_env(args.device)
    engine = DeviceRPM(env)
    print(f"near-field scan {nx} x {nz} at 3 mm, 11 frequencies 22.2-26.2 GHz; device {env.name}")
    print(
        f"{'variant':36s} {'points':>6s} {'<=15 mm':>8s} {'median':>9s} "
        f"{'repeat':>14s} {'coupling dropped':>16s} {'engine s':>8s}"
    )
    for label, coupling, repeat, snr, slope in VARIANTS[args.variants]:
        spec, x, z = make(nx, nz, coupling, repeat, snr, slope)
        if args.write:
            np.savez(args.write, spectrum=spec.astype(np.complex64), frequency=FREQ, x=x, z=z)
            print(f"{label}: wrote {args.write}")
            continue
        data = spectrum_data(spec, FREQ, Array(x, z))
        t0 = time.perf_counter()
        kw = {"background": "none", "multipath": "flag"} if args.plain else {}
        res = run_method("phase-rpm", data, default_params(data, **kw), engine)
        sec = time.perf_counter() - t0
        flagged = 0 if res.image.multipath is None else int(np.count_nonzero(res.image.multipath))
        pts = res.image.points
        d = off_surface(pts, x, z) if len(pts) else np.zeros(0)
        share = f"{100 * np.mean(d < 0.015):7.1f}%" if len(d) else "       -"
        med = f"{1e3 * np.median(d):6.2f} mm" if len(d) else "        -"
        print(
            f"{label:36s} {len(pts):6d} {share} {med} "
            f"{res.dropped.get('multipath', 0) + flagged:14d} "
            f"{res.dropped.get('coupling', 0):16d} {sec:8.2f}"
        )


if __name__ == "__main__":
    main()
