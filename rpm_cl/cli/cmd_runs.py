"""The ``rpm-cl`` handlers of the runs over many scenes or frames:
``reproduce`` (the paper's tables), ``demo`` (the paper's scenes end to
end), ``bench`` (timings, or accuracy against S/N) and ``batch`` (every frame
of a folder or stack on a Dask cluster).
"""

from __future__ import annotations

import json
import logging
import sys
import warnings

from .. import __version__
from .common import _accuracy_line, _engine, _imaging_config_unused, _params
from .errors import CLIError

log = logging.getLogger("rpm_cl")


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


def cmd_bench(args) -> int:
    from .bench import run_bench

    _imaging_config_unused(args, "bench")
    from ..heap import keep_freed_memory

    keep_freed_memory()  # repeated runs: steady times (rpm_cl.heap)
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
    limits = None
    if not args.no_roofline:
        from .limits import measure_limits

        limits = measure_limits(env, args.precision)
    print(
        run_bench(
            engine,
            env,
            repeats=args.repeats,
            scenes=args.scene,
            das=das,
            volume=args.das_volume,
            bar=None,
            limits=limits,
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
