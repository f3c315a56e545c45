"""The medium check on GPR lines whose echo tracks break: eps_r read from the
apexes' focus (``rpm_cl/extract/apex.py``) against the tracks' fit
(``rpm_cl/extract/hyperbola.py``), and the warning each setting draws.

The lines are written as GSSI ``.dzt`` files from Ricker pulses by
``benchmarks/gpr_jitter.py`` (not by the engine's simulator; no jitter
here) and converted and loaded as ``rpm-cl convert`` and ``rpm-cl image``
take them: ``a`` and ``b`` of that script, ``c`` of
``benchmarks/gpr_time_zero.py`` (a ringing 2.6 GHz pulse, a recorder's
gain), and ``d`` here, a dense row: eight bars 0.15 m apart under 0.1 m
of cover and one 0.19 m down between them, whose echoes merge within a
range resolution.  Each is prepared with time zero at the transmit
instant (or ``--time-zero auto``) and the default background.

Columns: the true eps_r; the tracks' fit (value, tracks that qualified);
the apexes' (value +- error, apexes that focused); and the medium
warning's value, or ``-`` for none, when the line is imaged as air, in
its medium, and at twice its eps_r.

``--gprmax DATA`` adds the 20 random air scenes of
``benchmarks/gprmax_random.py`` (``simulate`` writes DATA) at its four
bands: the runs that draw a medium warning, and those whose apexes read
above 1.5 with and without the angle condition (``SEEN_DEG``).

Usage::

    python benchmarks/medium_apex.py [--lines a b c d] [--time-zero auto]
        [--gprmax DATA] [--out FILE.md]
"""

from __future__ import annotations

import argparse
import tempfile
import warnings
from pathlib import Path

from gpr_jitter import LINES, N0, SAMPLES, as_loaded, traces
from gpr_time_zero import RINGING

from rpm_cl.io.model import C0

DENSE = {
    "fc": 2.0e9,
    "eps": 5.0,
    "nx": 281,
    "dx": 0.005,
    "window": 8e-9,
    "bars": [(0.25 + 0.15 * k, 0.10) for k in range(8)] + [(0.625, 0.19)],
    "seed": 3,
    "noise": 0.01,
}
ALL = {**LINES, "c": RINGING, "d": DENSE}


def _checked(data, eps_r: float):
    """The medium warning's text (or None) for ``data``, prepared as
    ``rpm-cl image`` prepares it, checked with eps_r set."""
    from rpm_cl.extract.hyperbola import check_medium
    from rpm_cl.io.medium import Medium

    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        check_medium(data, Medium(eps_r))
    lines = [str(r.message) for r in rec if "range walks" in str(r.message)]
    return lines[0] if lines else None


def _named(text) -> str:
    if text is None:
        return "-"
    return text.split("eps_r = ")[1].split(" ")[0]


def line_rows(names, time_zero) -> list[str]:
    from rpm_cl.extract.apex import apex_eps_r
    from rpm_cl.extract.hyperbola import fit_eps_r, tracks
    from rpm_cl.imaging import prepared
    from rpm_cl.rpm.params import default_params

    rows = [
        (
            "| line | true eps_r | tracks' fit | apexes' focus | warning as air "
            "| in its medium | at twice |"
        ),
        "|---|---|---|---|---|---|---|",
    ]
    for name in names:
        line = ALL[name]
        raw = as_loaded(traces(line, 0.0)[0], line)
        zero = time_zero
        if zero is None:
            zero = N0 * line["window"] / SAMPLES * C0 / 2
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            data = prepared(raw, default_params(raw, time_zero=zero))[0]
        t, nt = fit_eps_r(data.array.positions(), tracks(data))
        a, na, err = apex_eps_r(data)
        eps = line["eps"]
        named = [_named(_checked(data, e)) for e in (1.0, eps, 2 * eps)]
        rows.append(
            f"| {name} | {eps:g} | {t:.2f} ({nt}) | {a:.2f} +- {err:.2f} ({na}) | "
            + " | ".join(named)
            + " |"
        )
    return rows


def gprmax_rows(root: Path) -> list[str]:
    from gprmax_image import band_data, ghz_band
    from gprmax_random import BANDS

    from rpm_cl.extract.apex import apex_eps_r
    from rpm_cl.imaging import prepared
    from rpm_cl.rpm.params import default_params

    background = root / "background_merged.h5"
    runs = warned = high = high_any = 0
    with tempfile.TemporaryDirectory() as tmp:
        for scene in sorted(root.glob("s[0-9][0-9][0-9]")):
            for band in map(ghz_band, BANDS.split(",")):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    raw = band_data(
                        scene / "targets_merged.h5", background, scene / "scene.json", band, tmp
                    )
                    data = prepared(raw, default_params(raw))[0]
                runs += 1
                warned += _checked(data, 1.0) is not None
                v, n, _ = apex_eps_r(data)
                high += n > 0 and v > 1.5
                v, n, _ = apex_eps_r(data, angle_check=False)
                high_any += n > 0 and v > 1.5
    return [
        "",
        (
            f"Random gprMax air scenes: {runs} runs; a medium warning in "
            f"{warned}; apexes read above 1.5 in {high} (angle condition) and "
            f"{high_any} (every apex)."
        ),
    ]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", nargs="+", choices=sorted(ALL), default=sorted(ALL))
    ap.add_argument("--time-zero", choices=["transmit", "auto"], default="transmit")
    ap.add_argument("--gprmax", type=Path, help="folder of gprmax_random.py simulate")
    ap.add_argument("--out", type=Path, help="also write the table here")
    args = ap.parse_args(argv)
    rows = line_rows(args.lines, None if args.time_zero == "transmit" else "auto")
    if args.gprmax:
        rows += gprmax_rows(args.gprmax)
    text = "\n".join(rows)
    print(text)
    if args.out:
        args.out.write_text(
            "# The medium check on GPR lines\n\n"
            f"`python benchmarks/medium_apex.py --time-zero {args.time_zero}"
            + (" --gprmax DATA" if args.gprmax else "")
            + "` (generated; DATA from `benchmarks/gprmax_random.py simulate`, see the "
            "script's notes).\n\n" + text + "\n"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
