"""Command line: ``rpm-cl {info,simulate,convert,image,params,das,rma,view,figure,reproduce,
demo,bench,batch}``.

Every error the user can cause (bad input file, bad option, no OpenCL) is
reported as one line ``rpm-cl: error: ...`` on stderr with exit code 2.
Every subcommand takes ``-v/--verbose`` (resolved parameters and stage
timings on stderr, through the ``rpm_cl`` logger) and ``-q/--quiet`` (nothing
but errors); those that image take ``--config FILE.toml`` and a flag per
parameter (:mod:`rpm_cl.cli.config`).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import logging
import math
import sys
import warnings
from dataclasses import asdict

from .. import __version__

__all__ = ["main"]

log = logging.getLogger("rpm_cl")


class CLIError(Exception):
    """A user error: printed as one line, exit code 2."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2 (argparse prints usage too)
        raise CLIError(f"{self.prog}: {message}")


def _engine(args):
    from ..cl import create_env
    from ..rpm import DeviceRPM

    env = create_env(args.device)
    try:
        return DeviceRPM(env, args.precision), env
    except ValueError as exc:
        raise CLIError(str(exc)) from None


def _snr(text):
    if text.lower() in ("inf", "none"):
        return None
    try:
        v = float(text)
    except ValueError:
        v = float("nan")
    if v == float("inf"):
        return None
    if not (math.isfinite(v) and abs(v) <= 300):
        raise argparse.ArgumentTypeError(
            f"S/N must be a number of dB in [-300, 300] or 'inf', got {text!r}"
        )
    return v


def _int_at_least(lo: int, what: str):
    """argparse type: an integer >= lo, else one line ``{what}must be an
    integer >= lo, got ...``."""

    def parse(text):
        try:
            v = int(text)
        except ValueError:
            v = lo - 1
        if v < lo:
            raise argparse.ArgumentTypeError(f"{what}must be an integer >= {lo}, got {text!r}")
        return v

    return parse


_seed = _int_at_least(0, "seed ")


def _bind_negative_values(argv: list) -> list:
    """``--opt -1e-3`` / ``--grid -0.4:0.4:...``: argparse takes a value that
    starts with '-' and is not a plain decimal for an option; bind such values
    to their flag (``--opt=-1e-3``)."""
    out, i = [], 0
    while i < len(argv):
        tok = argv[i]
        nxt = argv[i + 1] if i + 1 < len(argv) else None
        if (
            tok.startswith("--")
            and "=" not in tok
            and nxt is not None
            and nxt.startswith("-")
            and len(nxt) > 1
            and (nxt[1].isdigit() or nxt[1] == ".")
        ):
            out.append(f"{tok}={nxt}")
            i += 2
        else:
            out.append(tok)
            i += 1
    return out


def _bounded_float(lo: float, hi: float, what: str):
    """argparse type: a finite float in [lo, hi], else one line naming ``what``."""

    def parse(text):
        try:
            v = float(text)
        except ValueError:
            v = float("nan")
        if not (math.isfinite(v) and lo <= v <= hi):
            raise argparse.ArgumentTypeError(f"{what}, got {text!r}")
        return v

    return parse


_dynamic_range = _bounded_float(1e-3, 400, "dynamic range must be between 0.001 and 400 dB")
_iso_db = _bounded_float(
    -400, -1e-6, "iso-surface level must be below the maximum, in [-400, 0) dB"
)
_budget_gb = _bounded_float(1e-3, 1e6, "memory budget must be between 0.001 and 1e6 GB")
_metres = _bounded_float(-1e4, 1e4, "must be a length in m within +-1e4")


_frame = _int_at_least(0, "frame ")


def _picture_size(text):
    """argparse type: 'WxH' pixels, each 100..10000."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        w = h = 0
    if not (100 <= w <= 10000 and 100 <= h <= 10000):
        raise argparse.ArgumentTypeError(f"size must be WxH pixels, each 100-10000, got {text!r}")
    return w, h


_positive_int = _int_at_least(1, "")


def _positive_quantity(parse, what: str, examples: str, none_ok: bool):
    """argparse type: ``parse(text)`` as a float > 0, or with ``none_ok``
    ``none`` (inf); else one line naming ``what`` and ``examples``."""

    def convert(text):
        from ..io.data import InputError

        if none_ok and text.strip().lower() == "none":
            return float("inf")
        try:
            v = float(parse(text.strip()))
        except (ValueError, KeyError, TypeError, InputError):
            v = float("nan")
        if not (math.isfinite(v) and v > 0):
            raise argparse.ArgumentTypeError(
                f"{what} > 0 (e.g. {examples}){' or none' if none_ok else ''}, got {text!r}"
            )
        return v

    return convert


def _dask_time(text):
    from dask.utils import parse_timedelta

    return parse_timedelta(text, default="seconds")


def _bytes(text):
    from ..io.guard import parse_bytes

    return parse_bytes(text)


_frame_timeout = _positive_quantity(
    _dask_time, "frame timeout must be a time", "90, 90s, 10m, 1h", True
)
_frame_memory = _positive_quantity(_bytes, "frame memory must be a size", "2G, 500MB, 1.5GiB", True)
_memory_size = _positive_quantity(
    _bytes, "a memory size must be a number of bytes", "8G, 512MB, 1.5GiB", False
)


# --------------------------------------------------------------------------
def cmd_info(args) -> int:
    from ..cl import choose_device, list_devices

    devices = list_devices()
    chosen = choose_device(args.device)
    print(f"rpm-cl {__version__}")
    for d in devices:
        mark = "*" if d.spec == chosen.spec else " "
        print(
            f"{mark} [{d.spec}] {d.kind:4s} {d.name} | {d.platform} | "
            f"{d.compute_units} compute units | float64: {'yes' if d.double else 'no'}"
        )
    print(f"chosen: [{chosen.spec}] {chosen.name} (--device or PYOPENCL_CTX picks another)")
    return 0


def cmd_simulate(args) -> int:
    from ..io.formats import DATA_EXTENSIONS, check_output, save_data
    from ..simulate.synth import simulate_preset

    check_output(args.output, DATA_EXTENSIONS, "data output")
    data, _ = simulate_preset(args.scene, args.snr, args.seed, noise=args.noise)
    save_data(args.output, data)
    print(
        f"wrote {args.output}: {args.scene}, signal {data.signal.shape}, "
        f"S/N {'inf' if args.snr is None else f'{args.snr:g} dB ({args.noise} noise)'}"
    )
    return 0


def _band(text):
    """argparse type: 'F0:F1' in Hz, 0 < F0 < F1."""
    try:
        f0, f1 = (float(v) for v in text.split(":"))
    except ValueError:
        f0 = f1 = float("nan")
    if not (math.isfinite(f0) and math.isfinite(f1) and 0 < f0 < f1):
        raise argparse.ArgumentTypeError(
            f"band must be F0:F1 in Hz with 0 < F0 < F1 (e.g. 2e9:4e9), got {text!r}"
        )
    return f0, f1


def cmd_convert(args) -> int:
    from ..io.data import refuse_overwrite
    from ..io.formats import DATA_EXTENSIONS, check_output
    from ..io.gprmax import SourceWaveform
    from ..io.readers import FORMATS, convert, save

    inputs = (
        list(args.inputs) + list(args.background or []) + ([args.sidecar] if args.sidecar else [])
    )
    check_output(args.output, DATA_EXTENSIONS, "data output")
    refuse_overwrite(args.output, inputs)
    names = {o for f in FORMATS.values() for o in f.options}
    options = {k: getattr(args, k) for k in names}
    if args.waveform:
        options["waveform"] = SourceWaveform.parse(args.waveform)
    fmt, arrays = convert(args.inputs, args.format, **options)
    save(args.output, arrays, inputs)
    data = "spectrum" if "spectrum" in arrays else "signal"
    print(
        f"wrote {args.output}: {fmt}, {data} {arrays[data].shape}, {_axes_line(arrays)}"
        f"{', with the sidecar truth' if 'truth_boundary' in arrays else ''}"
        f"{'; no background subtracted' if fmt == 'gprmax' and not args.background else ''}"
    )
    return 0


def _axes_line(arrays) -> str:
    x = arrays["x"]
    pos = f"x {x[0]:.4g}..{x[-1]:.4g} m"
    if "frequency" not in arrays:
        r = arrays["range"]
        return f"range {r[0]:.4g}..{r[-1]:.4g} m, {pos}"
    f = arrays["frequency"]
    return (
        f"{f[0] / 1e9:g}-{f[-1] / 1e9:g} GHz at {(f[1] - f[0]) / 1e6:.4g} MHz "
        f"({f.size} samples), {pos}"
    )


def _params(args, data, base=None):
    """Imaging parameters: flags over --config over ``base`` (a preset's
    values) over the defaults derived from ``data``."""
    from .config import dump_toml, flag_values, merge, resolve, settings

    flags = flag_values(args)
    sources = {k: str(args.config) for k in args.cfg_file}
    sources.update(
        {(s.section, s.name): s.flag for s in settings() if (s.section, s.name) in flags}
    )
    params = resolve(data, merge(args.cfg_file, flags), base, sources)
    if log.isEnabledFor(logging.INFO):
        log.info("resolved parameters:\n%s", dump_toml(params, comments=False).rstrip())
    return params


def _load_config(args) -> None:
    """--config read into ``args.cfg_file``; --device/--precision resolved
    (flag, else file, else default) into ``args.device``/``args.precision``."""
    from .config import flag_values, load_config, merge, resolve_engine

    args.cfg_file = load_config(args.config) if args.config else {}
    flags = flag_values(args)
    sources = {k: str(args.config) for k in args.cfg_file}
    engine = resolve_engine(merge(args.cfg_file, flags), sources)
    args.device, args.precision = engine.device, engine.precision
    args.engine_params = engine


def _imaging_config_unused(args, what: str) -> None:
    if any(k[0] != "engine" for k in args.cfg_file):
        log.warning(
            "%s: only the [engine] section of %s applies (%s uses the paper's "
            "parameters of each scene)",
            args.command,
            args.config,
            what,
        )


def cmd_image(args) -> int:
    import time

    from ..extract.preprocess import shift_truth
    from ..imaging import run_method
    from ..io.formats import RESULT_EXTENSIONS, check_output, load_data, save_result
    from ..metrics import summary

    check_output(args.output, RESULT_EXTENSIONS, "result")
    data = load_data(
        args.input,
        frame=args.frame,
        range_window=args.range_window,
        conjugate=args.conjugate,
        max_memory=args.max_memory,
    )
    params = _params(args, data)
    engine, env = _engine(args)
    verbose = log.isEnabledFor(logging.INFO) and hasattr(engine, "kernel_times")
    if verbose:  # each kernel waited for and timed
        engine.timing = True
    result = run_method(args.method, data, params, engine)
    meta = {
        "version": __version__,
        "device": env.name,
        "precision": args.precision,
        "input": args.input,
        "frame": args.frame,
        "range_window": args.range_window,
        "conjugate": args.conjugate,
        "params": asdict(params),
    }
    if data.truth is not None and data.truth.scene not in ("", "{}"):
        meta["scene"] = json.loads(data.truth.scene)  # for `rpm-cl view`
    t0 = time.perf_counter()
    save_result(args.output, result, meta)
    stages = {**result.timings, "write": time.perf_counter() - t0}
    if verbose:
        stages.update({f"rpm.{k}": v for k, v in engine.kernel_times.items()})
    log.info("stage timings (ms): %s", ", ".join(f"{k} {1e3 * v:.1f}" for k, v in stages.items()))
    dropped = "".join(
        f", {n} {why}"
        for why, n in (
            ("double-bounce points dropped", result.dropped.get("multipath", 0)),
            ("points beyond the antennas' reach dropped", result.dropped.get("reach", 0)),
        )
        if n
    )
    print(
        f"{args.method}: {len(result.rps)} RPs in {len(set(result.rps.cluster.tolist()))} "
        f"clusters -> {len(result.image.points)} points{dropped}, "
        f"{1e3 * result.timings['total']:.1f} ms; wrote {args.output}"
    )
    truth = shift_truth(data.truth, params.time_zero)  # as the method measured ranges
    if truth is not None:
        s = summary(result.rps, result.image, truth)
        print(_accuracy_line(s))
    return 0


def cmd_params(args) -> int:
    from ..io.data import atomic_write_text
    from ..io.formats import load_data
    from .config import dump_toml

    data = load_data(
        args.input,
        frame=args.frame,
        range_window=args.range_window,
        conjugate=args.conjugate,
        max_memory=args.max_memory,
    )
    params = _params(args, data)
    text = dump_toml(
        params,
        args.engine_params,
        header=f"rpm-cl {__version__}: parameters resolved for {args.input}\n"
        "(derived from the data, then --config, then flags); read back "
        'with --config.\n"auto" stands for None: see each key\'s comment.',
    )
    if args.output:
        atomic_write_text(args.output, text)
        print(f"wrote {args.output}")
    else:
        print(text, end="")
    return 0


def _accuracy_line(s: dict) -> str:
    from .reproduce import pct

    rp = (
        "unavailable (no truth_rp_*)"
        if s["rp_within_10mm"] is None
        else pct(s["rp_within_10mm"], s["rp_total"])
    )
    return (
        f"Err_range<=10mm {rp}, "
        f"Err_RPM<=50mm {pct(s['rpm_within_50mm'], s['rpm_total'])}, "
        f"<=100mm {pct(s['rpm_within_100mm'], s['rpm_total'])}"
    )


def cmd_reproduce(args) -> int:
    from .reproduce import format_markdown, format_table, reproduce, update_markdown, write_json

    _imaging_config_unused(args, "reproduce")
    engine, env = _engine(args)
    progress = (lambda m: log.info("running %s", m)) if log.isEnabledFor(logging.INFO) else None
    das = None
    if not args.no_das:
        from ..baselines.das import DeviceDAS

        das = DeviceDAS(env, args.precision)
    rows = reproduce(
        args.name,
        engine,
        trials=args.trials,
        seed=args.seed,
        progress=progress,
        das=das,
        skip_volume=args.skip_volume,
        rma=not args.no_rma,
        bar=None,
    )
    print(
        f"{args.name} on {env.name} ({args.precision}); noisy rows pooled over "
        f"{args.trials} noise realisations"
    )
    print(format_table(rows))
    meta = {
        "version": __version__,
        "device": env.name,
        "precision": args.precision,
        "trials": args.trials,
        "seed": args.seed,
        "command": " ".join(
            ["rpm-cl reproduce", args.name, f"--trials {args.trials}"]
            + [
                f"--{f.replace('_', '-')}"
                for f in ("no_das", "no_rma", "skip_volume")
                if getattr(args, f)
            ]
            + ([f"--seed {args.seed}"] if args.seed else [])
            + [f"--markdown {args.markdown}"]
        ),
    }
    if args.json:
        write_json(args.json, rows, meta)
        print(f"wrote {args.json}")
    if args.markdown:
        update_markdown(args.markdown, args.name, format_markdown(args.name, rows, meta))
        print(f"wrote the {args.name} section of {args.markdown}")
    return 0


def cmd_demo(args) -> int:
    from ..imaging import DEFAULT_METHOD, timed_run
    from ..metrics import summary
    from ..simulate.synth import simulate_preset

    engine, env = _engine(args)
    print(f"rpm-cl {__version__} demo on {env.name}")
    # the paper's scenes with the paper's S/N definition (rpm_cl.simulate)
    data, preset = simulate_preset("paper-2d", None, seed=args.seed, noise="receiver")
    params = _params(args, data, preset.defaults)
    print(
        "\npaper-2d: 3 point targets within 80 mm of range (0.1 of the 750 mm range "
        "resolution), 21 antennas at 5 mm, noise-free"
    )
    for method in dict.fromkeys((DEFAULT_METHOD, "kspace-rpm", "mf-rpm")):
        r, sec, _ = timed_run(method, data, params, engine)
        print(
            f"  {method:10s}: {len(r.rps):3d} RPs -> {len(r.image.points):3d} points in "
            f"{1e3 * sec:6.2f} ms | {_accuracy_line(summary(r.rps, r.image, data.truth))}"
        )

    data, preset = simulate_preset(
        "human-body", args.snr, seed=args.seed, progress=None, noise="receiver"
    )
    params = _params(args, data, preset.defaults)
    res, sec, stages = timed_run(DEFAULT_METHOD, data, params, engine)
    label = "noise-free" if args.snr is None else f"S/N {args.snr:g} dB"
    print(
        f"\nhuman-body: 11 ellipsoids about 1 m away, 20 GHz / 3 GHz, 11 x 17 antennas "
        f"at 7.5 mm, {label}"
    )
    n_clusters = len(set(res.rps.cluster.tolist()))
    print(
        f"  {DEFAULT_METHOD}: {len(res.rps)} RPs in {n_clusters} clusters "
        f"-> {len(res.image.points)} points in {1e3 * sec:.0f} ms ("
        + ", ".join(f"{k} {1e3 * v:.0f}" for k, v in stages.items() if k != "total")
        + " ms)"
    )
    print(f"  {_accuracy_line(summary(res.rps, res.image, data.truth))}")
    print(f"  {'body part':16s} {'points':>6s} {'median Err_RPM':>15s}")
    for name, n, med in _points_per_part(res.image.points, preset.scene):
        print(f"  {name:16s} {n:6d} {'-' if n == 0 else f'{1e3 * med:.1f} mm':>15s}")
    if args.png:
        import os
        import tempfile

        from ..io.formats import save_result
        from ..viz.view import view

        with tempfile.TemporaryDirectory() as tmp:
            out = os.path.join(tmp, "human-body.npz")
            save_result(out, res, {"scene": json.loads(data.truth.scene)})
            view(out, args.png)
        print(f"  wrote {args.png}")
    else:
        print(
            "  (--png FILE draws it; or: rpm-cl simulate human-body -o hb.npz && "
            "rpm-cl image hb.npz -o out.npz && rpm-cl view out.npz --png out.png)"
        )
    return 0


def _points_per_part(points, scene):
    """(part name, number of points nearest that part, their median distance)."""
    import numpy as np
    from scipy.spatial import cKDTree

    from ..simulate.scene import HUMAN_BODY_PARTS, boundary_samples

    trees = [cKDTree(boundary_samples(t, 3e-3)) for t in scene.targets]
    if len(points) == 0:
        return [(n, 0, 0.0) for n, _, _ in HUMAN_BODY_PARTS]
    d = np.stack([t.query(points)[0] for t in trees], axis=1)
    part = np.argmin(d, axis=1)
    best = d[np.arange(len(points)), part]
    return [
        (
            name,
            int(np.sum(part == k)),
            float(np.median(best[part == k])) if np.any(part == k) else 0.0,
        )
        for k, (name, _, _) in enumerate(HUMAN_BODY_PARTS)
    ]


def cmd_view(args) -> int:
    from ..viz.view import view

    view(args.input, args.png, dynamic_range=args.dynamic_range, iso=args.iso)
    if args.png:
        print(f"wrote {args.png}")
    return 0


def cmd_figure(args) -> int:
    from ..viz.figures import figure

    engine = das = grid = None
    if args.name == "compare":
        engine, env = _engine(args)
        if args.grid:
            from ..baselines.das import parse_grid

            grid = parse_grid(args.grid)
        if args.backend == "opencl":
            from ..baselines.das import DeviceDAS

            das = DeviceDAS(env, args.precision)
    figure(
        args.name,
        args.input,
        args.png,
        size=args.size,
        dynamic_range=args.dynamic_range,
        grid=grid,
        engine=engine,
        das=das,
        frame=args.frame,
        range_window=args.range_window,
        conjugate=args.conjugate,
        params=lambda data: _params(args, data),
    )  # --config and flags, as `image`
    if args.png:
        print(f"wrote {args.png}")
    return 0


def cmd_das(args) -> int:
    import time

    import numpy as np

    from ..baselines.das import DeviceDAS, das_numpy, parse_grid
    from ..extract.hyperbola import check_medium
    from ..io.formats import VOLUME_EXTENSIONS, check_output, load_data, write_volume
    from ..progress import callback

    check_output(args.output, VOLUME_EXTENSIONS, "image")
    data = load_data(
        args.input,
        frame=args.frame,
        range_window=args.range_window,
        conjugate=args.conjugate,
        max_memory=args.max_memory,
        with_truth=False,
    )
    grid = parse_grid(args.grid)
    if grid.dim != data.array.dim:
        raise CLIError(
            f"--grid has {grid.dim} axes; this {'planar' if data.array.planar else 'linear'}"
            f" array needs {data.array.dim} (x, y{', z' if data.array.planar else ''})"
        )
    medium = _medium(args)
    check_medium(data, medium)
    budget = args.memory_budget * 1e9
    n_bp = grid.size * data.array.n
    timing = {}
    backend = args.backend
    if medium.half_space and backend == "opencl":
        # the kernel's distances are straight lines from its grid axes
        log.info(
            "das: above a half-space the refracted ranges are computed on the host "
            "(the numpy backend, float64)"
        )
        backend = "numpy"
    if backend == "opencl":
        from ..cl import create_env

        env = create_env(args.device)
        try:
            dev = DeviceDAS(env, args.precision, budget)
        except ValueError as exc:
            raise CLIError(str(exc)) from None
        device, dtype = env.name, dev.cplx

        def fill(out):
            with callback(None, total=grid.size, desc="das", unit="voxel") as bar:
                t0 = time.perf_counter()
                dev.backproject(data, grid, out=out, progress=bar, medium=medium)
                timing["seconds"] = time.perf_counter() - t0
    else:
        device, dtype = "numpy (float64)", np.complex128

        def fill(out):
            with callback(None, total=grid.size, desc="das", unit="voxel") as bar:
                t0 = time.perf_counter()
                das_numpy(data, grid, budget, out=out, progress=bar, medium=medium)
                timing["seconds"] = time.perf_counter() - t0

    meta = {
        "version": __version__,
        "method": "das",
        "backend": backend,
        "device": device,
        "precision": args.precision if backend == "opencl" else "float64",
        "input": args.input,
        "frame": args.frame,
        "range_window": args.range_window,
        "conjugate": args.conjugate,
        "medium": asdict(medium),
        "grid": args.grid,
        "timing": timing,
    }
    write_volume(args.output, grid, fill, dtype, meta)
    sec = timing.get("seconds", float("nan"))
    print(
        f"das ({backend}): image {grid.shape} from {data.array.n} antennas in {sec:.3f} s "
        f"({n_bp / sec:.3g} back-projections/s); wrote {args.output}"
    )
    return 0


def cmd_rma(args) -> int:
    import time

    from ..baselines.das import Grid
    from ..baselines.rma import rma_image
    from ..extract.hyperbola import check_medium
    from ..io.formats import VOLUME_EXTENSIONS, check_output, load_data, write_volume

    check_output(args.output, VOLUME_EXTENSIONS, "image")
    data = load_data(
        args.input,
        frame=args.frame,
        range_window=args.range_window,
        conjugate=args.conjugate,
        max_memory=args.max_memory,
        with_truth=False,
    )
    if args.y_min is not None and args.y_max is not None and args.y_min >= args.y_max:
        raise CLIError(f"--y-min ({args.y_min}) must be below --y-max ({args.y_max})")
    medium = _medium(args)
    check_medium(data, medium)
    t0 = time.perf_counter()
    img, x, y = rma_image(
        data, upsample_x=args.upsample_x, y_min=args.y_min, y_max=args.y_max, medium=medium
    )
    sec = time.perf_counter() - t0
    meta = {
        "version": __version__,
        "method": "rma",
        "input": args.input,
        "seconds": sec,
        "upsample_x": args.upsample_x,
        "medium": asdict(medium),
    }

    def fill(out):
        out[...] = img

    write_volume(args.output, Grid(x, y), fill, img.dtype, meta)  # by extension, as das
    print(f"rma: image {img.shape} in {1e3 * sec:.1f} ms; wrote {args.output}")
    return 0


def cmd_bench(args) -> int:
    from .bench import run_bench

    _imaging_config_unused(args, "bench")
    engine, env = _engine(args)
    das = None
    if not args.no_das:
        from ..baselines.das import DeviceDAS

        das = DeviceDAS(env, args.precision)
    if args.robustness:
        from .robustness import GEOMETRIES_2D, GEOMETRY_3D, SNRS, run, table

        geos = GEOMETRIES_2D if args.robustness == "quick" else (*GEOMETRIES_2D, GEOMETRY_3D)
        print(table(run(engine, das, geos, SNRS, (0,))))
        return 0
    print(
        run_bench(
            engine,
            env,
            repeats=args.repeats,
            scenes=args.scene,
            das=das,
            volume=args.das_volume,
            bar=None,
        )
    )
    return 0


def cmd_batch(args) -> int:
    from .batch import BatchConfig, run_batch

    if args.scheduler is not None and args.workers is not None:
        raise CLIError(
            "--workers sizes the embedded cluster; with --scheduler the cluster's "
            "own workers run the frames"
        )
    import os

    from ..io.formats import DATA_EXTENSIONS, frame_count

    if os.path.isfile(args.input) and args.input.lower().endswith(DATA_EXTENSIONS):
        frame_count(args.input)  # one file: unreadable or no frames is a user error (exit 2)
    from .config import flag_values, merge

    values = merge(args.cfg_file, flag_values(args))
    overrides = tuple((k, v) for k, v in values.items() if k[0] != "engine")
    config = BatchConfig(
        args.method,
        overrides,
        args.device,
        args.precision,
        args.das_grid,
        args.memory_budget * 1e9,
        args.das_reuse,
        args.frame_timeout,
        args.frame_memory,
    )

    from ..io.data import DataWarning

    def progress(rec):
        for line in rec.get("warnings", ()):
            warnings.warn(f"frame {rec['frame']}: {line}", DataWarning, stacklevel=1)
        if args.verbose:
            what = "done" if rec["status"] == "done" else f"FAILED: {rec['error']}"
            print(f"  {rec['frame']}: {what}", file=sys.stderr)

    s = run_batch(
        args.input,
        args.output,
        config,
        workers=args.workers or 1,
        scheduler=args.scheduler,
        progress=progress,
    )
    print(
        f"batch: {s.frames} frames, {s.done} done, {s.skipped} skipped, {len(s.failed)} failed "
        f"on {s.workers} workers; {s.frames_per_s:.2f} frames/s, median "
        f"{1e3 * s.stage_median_s.get('total', float('nan')):.1f} ms per frame; "
        f"wrote {args.output}/summary.json"
    )
    for f in s.failed:
        print(f"  failed {f['frame']}: {f['error']}", file=sys.stderr)
    return s.exit_code


# --------------------------------------------------------------------------
def build_parser() -> argparse.ArgumentParser:
    from ..imaging import DEFAULT_METHOD, METHODS
    from ..io.formats import RANGE_WINDOWS
    from ..simulate.scene import PRESETS
    from ..simulate.synth import NOISE_MODELS
    from .bench import SCENES
    from .reproduce import CASES
    from .watchdog import DEFAULT_FRAME_MEMORY_FRACTION, DEFAULT_FRAME_TIMEOUT

    p = _Parser(prog="rpm-cl", description="OpenCL k-space range points migration imaging")
    p.add_argument("--version", action="version", version=f"rpm-cl {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    def device_opts(sp):
        # --device, --precision: the [engine] section (rpm_cl.cli.config.EngineParams)
        from .config import add_flags

        sp.add_argument(
            "--config",
            metavar="FILE.toml",
            help="parameters from this TOML file (flags override it; see "
            "`rpm-cl params` and examples/config.toml)",
        )
        add_flags(sp, ("engine",))

    def input_opts(sp):
        sp.add_argument(
            "--frame",
            type=_frame,
            help="frame N (from 0) of a stacked input (signal/spectrum with a leading frame axis)",
        )
        sp.add_argument(
            "--range-window",
            choices=sorted(RANGE_WINDOWS),
            default="hann",
            help="window of the range compression of frequency-domain input "
            "(spectrum + frequency; default hann)",
        )
        sp.add_argument(
            "--conjugate",
            action="store_true",
            help="conjugate a spectrum before compressing it (samples recorded as "
            "exp(+j 4 pi f R / c), whose echoes land at the unambiguous range "
            "minus their range)",
        )
        sp.add_argument(
            "--max-memory",
            metavar="BYTES",
            type=_memory_size,
            help="refuse an input whose run would need more memory than this "
            "(e.g. 8G; default RPM_CL_MAX_MEMORY or half the machine's memory), "
            "checked from the file's headers before any data is read",
        )

    sp = sub.add_parser("info", help="list OpenCL platforms/devices and the one chosen")
    sp.add_argument("--device")
    sp.set_defaults(func=cmd_info)

    sp = sub.add_parser("simulate", help="simulate a preset scene to an .npz or .h5")
    sp.add_argument("scene", choices=sorted(PRESETS))
    sp.add_argument("-o", "--output", required=True)
    sp.add_argument("--snr", type=_snr, default=None, help="S/N in dB (default: noise-free)")
    sp.add_argument(
        "--noise",
        choices=NOISE_MODELS,
        default="in-band",
        help="noise model of --snr: in-band (default; white noise on the band's "
        "frequency samples, S/N = peak / mean noise power of the range "
        "profiles) or receiver (the paper's tables: white noise at the range "
        "axis's sample rate, S/N before the matched filter)",
    )
    sp.add_argument("--seed", type=_seed, default=0)
    sp.set_defaults(func=cmd_simulate)

    sp = sub.add_parser(
        "convert",
        help="recorded or simulated data -> the input schema: "
        "gprMax output, MATLAB/NumPy/HDF5 arrays by a key mapping, GSSI .dzt, "
        "TI DCA1000 .bin",
    )
    convert_opts(sp)
    sp.set_defaults(func=cmd_convert)

    sp = sub.add_parser(
        "image",
        help="image an .npz or .h5 (input schema: docs/input-format.md); -o .npz, .h5, .ply or .vtp",
    )
    sp.add_argument("input")
    sp.add_argument("-o", "--output", required=True)
    sp.add_argument(
        "--method",
        choices=sorted(METHODS),
        default=DEFAULT_METHOD,
        help=f"imaging method (default {DEFAULT_METHOD}): "
        + "; ".join(f"{m.name}: {m.summary}" for m in METHODS.values()),
    )
    input_opts(sp)
    device_opts(sp)
    param_opts(sp)
    sp.set_defaults(func=cmd_image)

    sp = sub.add_parser(
        "params", help="print the parameters resolved for an input as TOML (a starting --config)"
    )
    sp.add_argument("input")
    sp.add_argument("-o", "--output", help="write the TOML here instead of stdout")
    input_opts(sp)
    device_opts(sp)
    param_opts(sp)
    sp.set_defaults(func=cmd_params)

    sp = sub.add_parser("reproduce", help="reproduce the paper's tables")
    sp.add_argument("name", choices=sorted(CASES))
    sp.add_argument("--json", help="write the rows as JSON here")
    sp.add_argument(
        "--markdown",
        metavar="FILE.md",
        help="write (or replace) this case's section of a Markdown results file (docs/results.md)",
    )
    sp.add_argument(
        "--trials", type=_positive_int, default=10, help="noise realisations per noisy row"
    )
    sp.add_argument("--no-das", action="store_true", help="leave out the DAS (SAR) rows")
    sp.add_argument("--no-rma", action="store_true", help="leave out the RMA rows")
    sp.add_argument(
        "--skip-volume",
        action="store_true",
        help="leave out the full 2 m x 2 m x 2 m DAS volume of paper-3d (minutes)",
    )
    sp.add_argument("--seed", type=_seed, default=0)
    device_opts(sp)
    sp.set_defaults(func=cmd_reproduce)

    sp = sub.add_parser("demo", help="simulate, image and score the paper's scenes end to end")
    sp.add_argument("--seed", type=_seed, default=0)
    sp.add_argument(
        "--snr",
        type=_snr,
        default=None,
        help="S/N of the human body in dB, "
        "receiver noise model as in the paper's tables (default: noise-free)",
    )
    sp.add_argument("--png", help="also draw the human-body image here (needs pyvista)")
    device_opts(sp)
    param_opts(sp)
    sp.set_defaults(func=cmd_demo)

    sp = sub.add_parser("view", help="draw an image result (3-D: pyvista; 2-D: matplotlib)")
    sp.add_argument(
        "input",
        help="a result .npz or .h5 of `rpm-cl image`, or an image "
        ".npz or .h5 of `rpm-cl das` / `rpm-cl rma`",
    )
    sp.add_argument("--png", help="write the picture here (off-screen) instead of opening a window")
    sp.add_argument(
        "--dynamic-range",
        type=_dynamic_range,
        default=40.0,
        metavar="DB",
        help="DAS/RMA images: dB below the maximum shown (default 40)",
    )
    sp.add_argument(
        "--iso",
        type=_iso_db,
        metavar="DB",
        help="3-D DAS images: an iso-surface "
        "at this level (dB below the maximum, < 0) instead of slices",
    )
    sp.set_defaults(func=cmd_view)

    sp = sub.add_parser("figure", help="paper-style figures of a data file (matplotlib)")
    sp.add_argument(
        "name",
        choices=("kspace", "rps", "compare"),
        help="kspace: |S(kx, R)| with the cluster centres; rps: decomposed RPs per "
        "cluster over the true RPs; compare: RPM points beside the DAS image",
    )
    sp.add_argument("input", help="an input .npz (input contract)")
    sp.add_argument("--png", help="write the picture here (off-screen) instead of opening a window")
    sp.add_argument(
        "--dynamic-range",
        type=_dynamic_range,
        default=40.0,
        metavar="DB",
        help="dB below the maximum shown on the maps (default 40)",
    )
    sp.add_argument(
        "--grid",
        help="compare: the DAS grid 'x0:x1:dx,y0:y1:dy', m (default: the "
        "scene's box plus 0.15 m, at most 400 pixels a side)",
    )
    sp.add_argument(
        "--backend", choices=("opencl", "numpy"), default="opencl", help="compare: where DAS runs"
    )
    sp.add_argument(
        "--size",
        type=_picture_size,
        default=(1200, 700),
        metavar="WxH",
        help="picture size in pixels (default 1200x700)",
    )
    device_opts(sp)
    input_opts(sp)
    param_opts(sp)
    sp.set_defaults(func=cmd_figure)

    sp = sub.add_parser("das", help="SAR / delay-and-sum back-projection onto a grid")
    sp.add_argument("input")
    sp.add_argument("-o", "--output", required=True)
    sp.add_argument(
        "--grid",
        required=True,
        help="'x0:x1:dx,y0:y1:dy' (linear array) or 'x0:x1:dx,y0:y1:dy,z0:z1:dz' "
        "(planar), m, ends inclusive",
    )
    sp.add_argument("--backend", choices=("opencl", "numpy"), default="opencl")
    sp.add_argument(
        "--memory-budget",
        type=_budget_gb,
        default=2.0,
        help="GB the back-projection may hold (default 2)",
    )
    input_opts(sp)
    device_opts(sp)
    medium_opts(sp)
    sp.set_defaults(func=cmd_das)

    sp = sub.add_parser("rma", help="range migration (f-k, Stolt) image of a linear-array file")
    sp.add_argument("input")
    sp.add_argument("-o", "--output", required=True)
    sp.add_argument("--y-min", type=_metres, help="crop the image to y >= this, m")
    sp.add_argument("--y-max", type=_metres, help="crop the image to y <= this, m")
    sp.add_argument(
        "--upsample-x", type=_positive_int, default=1, help="x pixels per array pitch (default 1)"
    )
    input_opts(sp)
    medium_opts(sp)
    sp.set_defaults(func=cmd_rma)

    sp = sub.add_parser("bench", help="time each method and stage on the paper's scenes")
    sp.add_argument("--repeats", type=_positive_int, default=20)
    sp.add_argument(
        "--scene",
        action="append",
        choices=sorted({s[0] for s in SCENES}),
        help="benchmark only this scene (repeatable; default: all)",
    )
    sp.add_argument("--no-das", action="store_true", help="leave out the DAS rows")
    sp.add_argument(
        "--das-volume",
        action="store_true",
        help="add the human body's full 2 m x 2 m x 2 m DAS volume at 3 mm (minutes)",
    )
    sp.add_argument(
        "--robustness",
        nargs="?",
        const="full",
        choices=("full", "quick"),
        help="instead: accuracy of every method against in-band S/N on "
        "independently synthesised scenes (rpm_cl.cli.robustness; 'quick': the 2-D "
        "scenes only; benchmarks/robustness.py pools several noise seeds)",
    )
    device_opts(sp)
    sp.set_defaults(func=cmd_bench)

    sp = sub.add_parser(
        "batch", help="image every frame of a folder or HDF5 stack on a Dask cluster"
    )
    sp.add_argument("input", help="folder of .npz/.h5 frames, or an HDF5 stack")
    sp.add_argument("-o", "--output", required=True, help="output folder (results, summary.json)")
    sp.add_argument(
        "--workers",
        type=_positive_int,
        help="worker processes of the embedded Dask LocalCluster (default 1)",
    )
    sp.add_argument(
        "--scheduler",
        help="address of an existing Dask scheduler "
        "(tcp://host:port) instead of the embedded cluster",
    )
    sp.add_argument(
        "--method",
        choices=sorted(METHODS),
        default=DEFAULT_METHOD,
        help=f"imaging method (default {DEFAULT_METHOD}): "
        + "; ".join(f"{m.name}: {m.summary}" for m in METHODS.values()),
    )
    sp.add_argument(
        "--das-grid", help="also write a DAS image per frame on this grid (as `das --grid`)"
    )
    sp.add_argument(
        "--memory-budget",
        type=_budget_gb,
        default=2.0,
        help="GB per worker for the DAS reuse tables (default 2)",
    )
    sp.add_argument(
        "--das-reuse",
        choices=("auto", "plan", "direct"),
        default="auto",
        help="DAS per frame from reuse tables built once per worker, by the direct "
        "kernel, or whichever was faster on the first frame (default auto)",
    )
    sp.add_argument(
        "--frame-timeout",
        type=_frame_timeout,
        metavar="SECONDS",
        default=DEFAULT_FRAME_TIMEOUT,
        help="wall-time limit of one frame (90, 90s, 10m, 1h, or none; default "
        f"{DEFAULT_FRAME_TIMEOUT:g} s); a frame over it is stopped and reported failed",
    )
    sp.add_argument(
        "--frame-memory",
        type=_frame_memory,
        metavar="BYTES",
        help="limit of a worker's resident memory while it runs a frame (2G, 500MB, "
        "1.5GiB, or none; default "
        f"{100 * DEFAULT_FRAME_MEMORY_FRACTION:g} %% of the worker's Dask memory limit, "
        "i.e. of RAM / workers on the embedded cluster); a frame over it is stopped "
        "and reported failed",
    )
    device_opts(sp)
    param_opts(sp)
    sp.set_defaults(func=cmd_batch)

    for sp in sub.choices.values():  # every subcommand, those added later too
        common_opts(sp)
    return p


def convert_opts(sp) -> None:
    """The options of ``convert``: the inputs, the reader, and each reader's
    own (:data:`rpm_cl.io.readers.FORMATS` says which belongs to which)."""
    from ..io.dca1000 import LAYOUTS
    from ..io.readers import FORMATS

    hz = _bounded_float(1.0, 1e15, "start frequency must be in Hz, 1 .. 1e15")
    scale = _bounded_float(1e-15, 1e15, "a scale factor must be 1e-15 .. 1e15")
    sp.add_argument(
        "inputs",
        nargs="+",
        metavar="IN",
        help="the file(s) to convert: gprMax "
        ".out/.h5 (a merged B-scan or the per-trace files), .mat/.npz/.npy/.h5 "
        "with --map, GSSI .dzt, DCA1000 .bin (several: concatenated in order)",
    )
    sp.add_argument("-o", "--output", required=True, help="OUT.npz or OUT.h5")
    sp.add_argument(
        "--format",
        choices=sorted(FORMATS),
        help="the reader (default: from the "
        "extension; .h5 with --map is arrays, without it gprmax)",
    )
    g = sp.add_argument_group("gprMax output (--format gprmax)")
    g.add_argument(
        "--background",
        nargs="+",
        metavar="BG",
        help="the same scan without "
        "targets (merged, or per-trace files), subtracted trace by trace",
    )
    g.add_argument(
        "--band",
        type=_band,
        metavar="F0:F1",
        help="frequency band kept, Hz "
        "(e.g. 2e9:4e9); required for gprMax; dzt: default the antenna's nominal "
        "band",
    )
    g.add_argument(
        "--waveform",
        metavar="KIND:FREQ[:AMP]",
        help="gprMax's source waveform, e.g. ricker:3e9 (else from --sidecar or the trace files)",
    )
    g.add_argument(
        "--sidecar",
        metavar="F.json",
        help="JSON with the waveform, scan positions "
        "and geometry (tests/data/gprmax/scene.json is one); the geometry becomes "
        "the truth_* arrays",
    )
    g.add_argument(
        "--df",
        type=_bounded_float(1.0, 1e12, "df must be a frequency step in Hz, 1 .. 1e12"),
        help="frequency step, Hz (default: the band in at least "
        "64 steps, and at most 1/(2T) for a record of T)",
    )
    g.add_argument(
        "--rx",
        type=_positive_int,
        help="gprmax: the receiver number (default 1); "
        "dca1000: the number of receivers enabled (default 4)",
    )
    g = sp.add_argument_group("named arrays (--format arrays: .mat, .npz, .npy, .h5)")
    g.add_argument(
        "--map",
        metavar="NAME=KEY,...",
        help="schema name = key in the file, e.g. "
        "spectrum=F,frequency=f,x=da (time domain: signal, range, fc, bandwidth, x; "
        "z for a planar array; a .npy's key is its file name)",
    )
    g.add_argument(
        "--transpose",
        action="store_true",
        help="reverse the axes of the data array (MATLAB's F(nf, nx) -> (nx, nf))",
    )
    g.add_argument("--scale-x", type=scale, help="factor to metres for x and z (1e-3: mm)")
    g.add_argument(
        "--scale-f", type=scale, help="factor to Hz for frequency, fc and bandwidth (1e9: GHz)"
    )
    g.add_argument(
        "--conjugate",
        action="store_true",
        help="conjugate a spectrum recorded as exp(+j 4 pi f R / c)",
    )
    g = sp.add_argument_group("GSSI DZT (--format dzt)")
    g.add_argument(
        "--dx",
        type=_bounded_float(1e-9, 1e4, "dx must be a length in m, 1e-9 .. 1e4"),
        help="dzt: scan spacing, m (default 1 / the header's scans per "
        "metre); dca1000: the radar's step between frames, m",
    )
    g.add_argument(
        "--time-zero",
        type=_bounded_float(0, 1e6, "time zero must be a sample number >= 0"),
        metavar="SAMPLE",
        help="sample of time zero (the transmit "
        "instant; may be fractional; default 0, the window's start)",
    )
    g.add_argument(
        "--channel", type=_int_at_least(0, "channel "), help="channel, from 0 (default 0)"
    )
    g.add_argument(
        "--subtract-mean",
        action="store_true",
        help="subtract the mean trace (direct coupling, ground bounce, horizontal bands)",
    )
    g = sp.add_argument_group("TI mmWave + DCA1000 (--format dca1000)")
    g.add_argument(
        "--slope",
        type=_bounded_float(1e6, 1e16, "slope must be Hz/s, 1e6 .. 1e16 (TI's MHz/us x 1e12)"),
        metavar="HZ/S",
        help="chirp slope, Hz/s",
    )
    g.add_argument(
        "--adc-rate",
        type=_bounded_float(1.0, 1e10, "ADC rate must be samples/s, 1 .. 1e10"),
        metavar="SPS",
        help="ADC sample rate, samples/s",
    )
    g.add_argument(
        "--samples", type=_int_at_least(2, "samples "), metavar="N", help="ADC samples per chirp"
    )
    g.add_argument("--start-freq", type=hz, metavar="HZ", help="start frequency of the ramp, Hz")
    g.add_argument(
        "--adc-start-time",
        type=_bounded_float(0, 1.0, "ADC start time must be 0 .. 1 s"),
        metavar="S",
        help="first ADC sample after the ramp's start, s (TI's adcStartTime; default 0)",
    )
    g.add_argument(
        "--chirps",
        type=_positive_int,
        metavar="N",
        help="chirps per frame, averaged per position (default 1)",
    )
    g.add_argument(
        "--layout",
        choices=sorted(LAYOUTS),
        help="complex-2lane (xWR16xx/18xx/68xx, default), complex-4lane (xWR12xx/14xx), real",
    )
    g.add_argument(
        "--rx-spacing",
        type=_bounded_float(1e-9, 1e4, "rx spacing must be a length in m, 1e-9 .. 1e4"),
        metavar="M",
        help="receiver spacing, m: the "
        "receivers as the array, at their midpoints with the transmitter (d/2 apart)",
    )
    g.add_argument(
        "--receiver",
        type=_int_at_least(0, "receiver "),
        help="with --dx: the receiver used, from 0 (default 0)",
    )


def common_opts(sp) -> None:
    """-v/--verbose and -q/--quiet (a group of every subcommand)."""
    g = sp.add_mutually_exclusive_group()
    g.add_argument(
        "-v",
        "--verbose",
        action="store_true",
        help="resolved parameters and stage timings on stderr",
    )
    g.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")


def param_opts(sp) -> None:
    """A flag per imaging parameter ([kspace], [rpm], [medium], [imaging] of
    --config)."""
    from .config import add_flags

    add_flags(sp, ("kspace", "rpm", "medium", "imaging"))


def medium_opts(sp) -> None:
    """``--config`` and a flag per field of the [medium] section (``das``,
    ``rma``: the material the waves travel in)."""
    from .config import add_flags

    if not any("--config" in a.option_strings for a in sp._actions):
        sp.add_argument(
            "--config",
            metavar="FILE.toml",
            help="parameters from this TOML file (its [medium] section; flags override it)",
        )
    add_flags(sp, ("medium",))


def _medium(args):
    """The :class:`rpm_cl.io.medium.Medium` of ``--config`` [medium] and the
    flags."""
    from .config import flag_values, merge, resolve_medium, settings

    flags = flag_values(args)
    sources = {k: str(args.config) for k in args.cfg_file}
    sources.update(
        {(s.section, s.name): s.flag for s in settings() if (s.section, s.name) in flags}
    )
    return resolve_medium(merge(args.cfg_file, flags), sources)


class _Terminated(BaseException):
    """SIGTERM, raised in the main thread so that every ``finally`` and the
    atomic writers' clean-up run as for Ctrl-C (temporary files removed)."""


def _on_sigterm(signum, frame):
    raise _Terminated()


def _show_warning(shown):
    """A ``warnings.showwarning`` that prints a :class:`rpm_cl.io.data.DataWarning`
    as one line ``rpm-cl: warning: ...`` through the ``rpm_cl`` logger (so
    ``-q`` silences it) and hands every other warning to ``shown``."""
    from ..io.data import DataWarning

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, DataWarning):
            log.warning("warning: %s", " ".join(str(message).split()))
        else:
            shown(message, category, filename, lineno, file, line)

    return show


#: Arguments that name files a command reads, and files it writes.
_READS = ("input", "inputs", "background", "config", "sidecar")
_WRITES = ("output", "png", "json")


def _refuse_overwriting_inputs(args) -> None:
    """No command writes over a file it reads (the same path, or the same
    file through a link): one error line, before anything is computed."""
    from ..io.data import refuse_overwrite

    reads = []
    for name in _READS:
        v = getattr(args, name, None)
        reads += [v] if isinstance(v, str) else list(v or [])
    for name in _WRITES:
        v = getattr(args, name, None)
        if isinstance(v, str):
            refuse_overwrite(v, reads)


def _declared_too_large(args) -> str | None:
    """After a MemoryError: a member of an ``.npz`` or HDF5 file the command
    reads whose header declares more than the file holds for it
    (:func:`rpm_cl.io.formats.check_members`), as one line; None where there is
    none (the problem is too large)."""
    from ..io.data import InputError
    from ..io.formats import check_members

    for name in _READS:
        v = getattr(args, name, None)
        for path in [v] if isinstance(v, str) else list(v or []):
            try:
                check_members(path, budget=False)
            except InputError as exc:
                return str(exc)
            except Exception:  # noqa: BLE001, S110 - unreadable: the plain out-of-memory line
                pass
    return None


def _user_error(exc: Exception) -> bool:
    """Whether ``exc`` is an error of the user's input (printed as one line)."""
    from ..cl import NoOpenCLError
    from ..io.data import InputError

    return isinstance(exc, (CLIError, InputError, NoOpenCLError))


_SIGINT_SEEN = []


def _on_sigint(signum, frame):
    """SIGINT on the command line: KeyboardInterrupt, remembered (an import
    interrupted inside a C extension can turn it into an ImportError)."""
    _SIGINT_SEEN.append(True)
    raise KeyboardInterrupt


def _end_interrupted(argv_given: bool) -> int:
    print("rpm-cl: interrupted", file=sys.stderr)
    if argv_given:
        return 130
    # the command line: end here.  An interrupt that lands in code run by
    # exec() (SciPy's and NumPy's imports use it) marks the interpreter as
    # killed by SIGINT however it is caught, and Python would then exit by
    # SIGINT after this line; the handlers have cleaned up by now.
    import os

    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(130)


def main(argv=None) -> int:
    """Entry point of the ``rpm-cl`` command; returns the exit code.

    Ctrl-C (exit 130) and SIGTERM (143) end it with one line from the moment
    it is called: ``rpm_cl`` and this module import nothing heavy, so that
    the NumPy, SciPy and OpenCL imports happen inside its handlers."""
    import signal
    import threading

    args = None
    argv_given = argv is not None
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("rpm-cl: %(message)s"))
    # only where SIGTERM would kill us anyway (not when a supervisor set it
    # to be ignored, nor over a handler of the embedding program)
    term = (
        threading.current_thread() is threading.main_thread()
        and signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
    )
    if term:
        signal.signal(signal.SIGTERM, _on_sigterm)
    sigint = (
        not argv_given
        and threading.current_thread() is threading.main_thread()
        and signal.getsignal(signal.SIGINT) is signal.default_int_handler
    )
    _SIGINT_SEEN.clear()  # a call's own interrupts only
    if sigint:
        signal.signal(signal.SIGINT, _on_sigint)
    try:
        argv = _bind_negative_values(list(sys.argv[1:] if argv is None else argv))
        args = build_parser().parse_args(argv)
        log.addHandler(handler)
        log.propagate = False
        log.setLevel(
            logging.ERROR if args.quiet else logging.INFO if args.verbose else logging.WARNING
        )
        with contextlib.ExitStack() as stack:
            if args.quiet:
                from ..progress import bars_off

                stack.enter_context(bars_off())
                stack.enter_context(contextlib.redirect_stdout(io.StringIO()))
            stack.enter_context(warnings.catch_warnings())
            warnings.showwarning = _show_warning(warnings.showwarning)
            _refuse_overwriting_inputs(args)
            if hasattr(args, "config"):
                _load_config(args)
            return args.func(args)
    except KeyboardInterrupt:
        return _end_interrupted(argv_given)
    except _Terminated:
        print("rpm-cl: terminated", file=sys.stderr)
        return 143
    except BrokenPipeError:  # output piped into e.g. head: not an error
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except MemoryError:
        if _SIGINT_SEEN:
            return _end_interrupted(argv_given)
        line = _declared_too_large(args) if args is not None else None
        print(
            f"rpm-cl: error: {line or 'out of memory; lower the problem size or the RPM chunk size'}",
            file=sys.stderr,
        )
        return 2
    except Exception as exc:
        if _SIGINT_SEEN:  # an interrupted import's ImportError, and the like
            return _end_interrupted(argv_given)
        if _user_error(exc):  # one line, whatever a library put in the message
            print(f"rpm-cl: error: {' '.join(str(exc).split())}", file=sys.stderr)
            return 2
        if type(exc).__module__.startswith("pyopencl"):  # not the user's input
            print(
                f"rpm-cl: error: OpenCL: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}",
                file=sys.stderr,
            )
            return 2
        raise
    finally:
        log.removeHandler(handler)
        if term:
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
        if sigint:
            signal.signal(signal.SIGINT, signal.default_int_handler)
