"""Bring your own data: the input contract from plain NumPy arrays.

rpm-cl reads an ``.npz`` with ``signal`` (nx, nr) complex range-compressed
profiles, ``x`` (nx,) antenna positions (m, uniform), ``range`` (nr,) (m,
uniform), ``fc`` and ``bandwidth`` (Hz); see the README's input contract.
Here those arrays are made by hand for two point targets, the way a measured
scan would be arranged, saved with ``np.savez``, loaded back with
``rpm_cl.load_data`` (which validates them; .npz or .h5), imaged and the result saved.

To image a real measurement, pass its file:  main("my_scan.npz")
Run: python examples/measured_data.py [my_scan.npz] [--quick]
"""

import sys

import numpy as np

from rpm_cl import load_data
from rpm_cl.cl import create_env
from rpm_cl.imaging import run_method
from rpm_cl.io.formats import save_result
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.params import default_params

C0 = 299_792_458.0
TARGETS = [(-0.15, 0.40), (0.10, 0.45)]  # (x, y), m


def make_scan(path, n_antennas=41):
    """Write a hand-made scan of TARGETS: 20 GHz, 1 GHz, antennas at 5 mm on y = 0."""
    fc, bandwidth = 20e9, 1e9
    x = (np.arange(n_antennas) - n_antennas // 2) * 5e-3
    rng = np.arange(0.2, 0.8, 2.5e-3)
    kc, resolution = 2 * np.pi * fc / C0, C0 / (2 * bandwidth)
    signal = np.zeros((x.size, rng.size), np.complex128)
    for tx, ty in TARGETS:
        r_t = np.hypot(x - tx, ty)[:, None]  # range from each antenna, m
        # range response peaking at r_t (sinc^2: a windowed spectrum's low sidelobes,
        # -26 dB), times the carrier phase exp(-2j kc r_t) of the input contract
        signal += np.sinc((rng[None, :] - r_t) / resolution) ** 2 * np.exp(-2j * kc * r_t)
    np.savez(path, signal=signal, x=x, range=rng, fc=fc, bandwidth=bandwidth)


def main(path=None, quick=False, output="measured_result.npz"):
    if path is None:  # no file given: make one (a real scan replaces this line)
        path = "hand_made_scan.npz"
        make_scan(path, 21 if quick else 41)
    data = load_data(path)  # validated RadarData, or one-line InputError
    result = run_method("kspace-rpm", data, default_params(data), DeviceRPM(create_env()))
    save_result(output, result, {"input": str(path)})
    print(
        f"{path}: {len(result.rps)} RPs in {len(np.unique(result.rps.cluster))} clusters -> "
        f"{len(result.image.points)} points; wrote {output}"
    )
    for c in np.unique(result.image.cluster):
        x, y = np.median(result.image.points[result.image.cluster == c], axis=0)
        print(f"  cluster {c}: median point ({1e3 * x:.1f}, {1e3 * y:.1f}) mm")
    return result


if __name__ == "__main__":
    files = [a for a in sys.argv[1:] if not a.startswith("--")]
    main(files[0] if files else None, quick="--quick" in sys.argv)
