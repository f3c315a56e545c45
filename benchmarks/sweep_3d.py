"""Human body: accuracy and time against the window period and the pairing.

Usage::

    python benchmarks/sweep_3d.py [--windows 60 100 150 200] [--neighbours 8 12 24]

For each k-space window period (rad/m, the same along k_x and k_z) and each
list length (``max_neighbours`` and ``meanshift_neighbours``), images the
human body at S/N inf and 20 dB (seed 0) and prints RP <= 10 mm, RPM <= 50 mm and RPM <= 10 mm (fractions), the number of
RPs and the median time from s(X, Z, R) to points over 3 runs after a warm-up.
With the list's argmax as the point this table picks 100 rad/m and 24;
with the exhaustive refinement (the default) the window is 60 rad/m, chosen
on ``pareto.py``'s grid.
"""

import argparse

from rpm_cl.cl import create_env
from rpm_cl.imaging import timed_run
from rpm_cl.metrics import summary
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import simulate_preset


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--windows", type=float, nargs="+", default=[60.0, 100.0, 150.0, 200.0])
    ap.add_argument("--neighbours", type=int, nargs="+", default=[8, 12, 24])
    ap.add_argument("--precision", default="float32")
    args = ap.parse_args()
    env = create_env()
    engine = DeviceRPM(env, args.precision)
    print(f"device: {env.name} | precision: {args.precision}")
    print(
        f"{'window':>7s} {'nbrs':>5s} {'S/N':>4s} {'RPs':>5s} {'RP<=10':>7s} {'RPM<=50':>8s} "
        f"{'RPM<=10':>8s} {'ms':>7s}"
    )
    data = {snr: simulate_preset("human-body", snr, 0, noise="receiver") for snr in (None, 20.0)}
    for w in args.windows:
        for k in args.neighbours:
            for snr, (d, pre) in data.items():
                # the body's clusters are all refined: their list is meanshift_neighbours
                params = default_params(
                    d,
                    **{
                        **pre.defaults,
                        "window_x": w,
                        "window_z": w,
                        "max_neighbours": k,
                        "meanshift_neighbours": k,
                    },
                )
                res, sec, _ = timed_run("kspace-rpm", d, params, engine, repeats=3)
                s = summary(res.rps, res.image, d.truth)
                n, m = max(1, s["rp_total"]), max(1, s["rpm_total"])
                print(
                    f"{w:7.0f} {k:5d} {'inf' if snr is None else f'{snr:g}':>4s} "
                    f"{s['rp_total']:5d} {s['rp_within_10mm'] / n:7.1%} "
                    f"{s['rpm_within_50mm'] / m:8.1%} {s['rpm_within_10mm'] / m:8.1%} "
                    f"{1e3 * sec:7.1f}",
                    flush=True,
                )


if __name__ == "__main__":
    main()
