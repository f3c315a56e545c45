"""Human body on larger arrays over several noise realisations.

Usage::

    python benchmarks/large_arrays.py [--sizes 32 64] [--seeds 0 1 2 3]

For each n x n array at 7.5 mm (``pareto.body_on_array``), images the body
noise-free and at 20 dB for each seed with the default settings and prints
the RPs found, the true echoes with an RP within 10 mm (``echoes``), RP <= 10
mm, RPM <= 50 mm and RPM <= 10 mm, and the time of the image: the alias choice
and the cluster detection of focused arrays depend on the noise, so one seed
(``pareto.py --arrays-only``) can hide a failure.
"""

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pareto import body_on_array, figures

from rpm_cl.cl import create_env
from rpm_cl.imaging import run_method
from rpm_cl.metrics import echoes_found
from rpm_cl.rpm import DeviceRPM


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[32, 64])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3])
    args = ap.parse_args()
    engine = DeviceRPM(create_env(), "float32")
    runs = [(None, 0)] + [(20.0, s) for s in args.seeds]
    for n in args.sizes:
        for snr, seed in runs:
            data, params = body_on_array(n, n, snr=snr, seed=seed)
            t0 = time.perf_counter()
            res = run_method("kspace-rpm", data, params, engine)
            sec = time.perf_counter() - t0
            rp10, rpm50, rpm10, _ = figures(res, data.truth)
            found = echoes_found(res.rps.antenna, res.rps.range, data.truth)
            true = data.truth.rp_range.size
            label = "noise-free" if snr is None else f"{snr:g} dB seed {seed}"
            print(
                f"{n} x {n} {label:16s}: {len(res.rps):6d} RPs, echoes {found}/{true} "
                f"({found / max(true, 1):6.1%})  RP<=10 {rp10:6.1%}  RPM<=50 {rpm50:6.1%}  "
                f"RPM<=10 {rpm10:6.1%}  {sec:6.2f} s",
                flush=True,
            )


if __name__ == "__main__":
    main()
