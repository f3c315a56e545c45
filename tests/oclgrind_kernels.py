"""Run every OpenCL kernel once on small inputs on the Oclgrind simulator.

Used by tests/test_oclgrind.py in a subprocess (Oclgrind's checks are set by
environment variables before the platform loads, and it reports on stderr).
Prints "OK" after comparing each kernel's output with its NumPy reference.
"""

import numpy as np
import pyopencl as cl

from rpm_cl.baselines.das import DeviceDAS, Grid, das_numpy
from rpm_cl.cl import CLEnv
from rpm_cl.io.data import Array, RadarData, Waveform
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm import reference as ref
from rpm_cl.rpm.neighbours import neighbour_lists


def main():
    plat = next(p for p in cl.get_platforms() if p.name == "Oclgrind")
    dev = plat.get_devices()[0]
    ctx = cl.Context([dev])
    env = CLEnv(ctx, cl.CommandQueue(ctx), dev)
    rng = np.random.default_rng(0)
    for precision in ("float32", "float64"):
        e = DeviceRPM(env, precision)
        n = 9  # rows of 9 slots: padded to 16 on the device
        x, z = rng.uniform(-0.02, 0.02, n), rng.uniform(-0.02, 0.02, n)
        p = np.array([0.01, 0.35, -0.01])
        r = np.sqrt((p[0] - x) ** 2 + p[1] ** 2 + (p[2] - z) ** 2) + rng.normal(0, 1e-4, n)
        amp = rng.uniform(0.1, 1.0, n)
        st, ct = np.zeros(n, int), np.full(n, n)
        got = e.rpm_circles(x, r, amp, st, ct, n, 0.05, 0.05, 2, 5)  # a chunk
        want = ref.rpm_circles(x, r, amp, st, ct, n, 0.05, 0.05, 2, 5)
        assert np.array_equal(got[0] >= 0, want[0] >= 0)
        nbr, nn = neighbour_lists(x, z, np.arange(n), st, ct, np.inf, 5)
        nn[3] = 1  # a main RP with too few neighbours: no valid slot
        got = e.rpm_spheres(x, z, r, amp, nbr, nn, 0.02, 0.05)
        want = ref.rpm_spheres(x, z, r, amp, nbr, nn, 0.02, 0.05)
        assert np.array_equal(got[0] >= 0, want[0] >= 0) and got[0][3] == -1
        pt = want[2][:, 2:7]  # mean shift of a chunk, from the argmax points
        ms = e.meanshift_spheres(x, z, r, amp, st, ct, pt, 0.02, 0.05, 2, 2, 5)
        ms_ref = ref.meanshift_spheres(x, z, r, amp, st, ct, pt, 0.02, 0.05, 2, 2, 5)
        assert np.abs(ms[0] - ms_ref[0]).max() <= 1e-4 and np.array_equal(ms[1] > 0, ms_ref[1] > 0)
        assert np.array_equal(ms[3], ms_ref[3])
        near = ms_ref[2][:, : ref.MS_DENSITY_T]  # the density at the nearest candidates
        f = e.density_spheres(x, z, r, amp, st, ct, near, 0.02, 0.05, 2, 5)
        f_ref = ref.density_spheres(x, z, r, amp, st, ct, near, 0.02, 0.05, 2, 5)
        assert np.allclose(f, f_ref, rtol=1e-2, atol=1e-6)
        arr = Array(np.arange(3) * 7.5e-3, np.arange(2) * 7.5e-3)
        data = RadarData(
            rng.normal(size=(3, 2, 20)) + 1j * rng.normal(size=(3, 2, 20)),
            arr,
            0.3 + 2.5e-3 * np.arange(20),
            Waveform(20e9, 3e9),
        )
        g = Grid(np.linspace(-0.01, 0.01, 3), np.array([0.32, 0.33]), np.linspace(-0.01, 0.01, 11))
        a, b = DeviceDAS(env, precision).backproject(data, g), das_numpy(data, g)
        assert np.abs(a - b).max() <= 1e-3 * np.abs(b).max()
    print("OK")


if __name__ == "__main__":
    main()
