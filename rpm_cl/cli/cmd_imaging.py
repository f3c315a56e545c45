"""The ``rpm-cl`` handlers that image and draw: ``image``, ``params`` (the
parameters resolved for an input), ``view`` and ``figure``.
"""

from __future__ import annotations

import json
import logging
from dataclasses import asdict

from .. import __version__
from .common import _accuracy_line, _engine, _load_input, _params

log = logging.getLogger("rpm_cl")


def cmd_image(args) -> int:
    import time

    from ..extract.preprocess import shift_truth
    from ..imaging import METHODS, run_method
    from ..io.formats import RESULT_EXTENSIONS, check_output, save_result
    from ..metrics import summary

    check_output(args.output, RESULT_EXTENSIONS, "result")
    data = _load_input(args)
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
            (
                "multipath points (double bounces, repeats) dropped",
                result.dropped.get("multipath", 0),
            ),
            ("points beyond the antennas' reach dropped", result.dropped.get("reach", 0)),
            ("points of the antennas' own coupling dropped", result.dropped.get("coupling", 0)),
            ("points beside a coherent peak dropped", result.dropped.get("coherence", 0)),
        )
        if n
    )
    source = (
        f"{len(result.rps)} RPs in {len(set(result.rps.cluster.tolist()))} clusters"
        if METHODS[args.method].family == "rpm"
        else "the image's peaks"
    )
    print(
        f"{args.method}: {source} -> {len(result.image.points)} points{dropped}, "
        f"{1e3 * result.timings['total']:.1f} ms; wrote {args.output}"
    )
    truth = shift_truth(data.truth, params.time_zero)  # as the method measured ranges
    if truth is not None:
        s = summary(result.rps, result.image, truth)
        print(_accuracy_line(s))
    return 0


def cmd_params(args) -> int:
    from ..io.data import atomic_write_text
    from .config import dump_toml
    from .constants import constants, format_constants

    data = _load_input(args)
    params = _params(args, data)
    text = dump_toml(
        params,
        args.engine_params,
        header=f"rpm-cl {__version__}: parameters resolved for {args.input}\n"
        "(derived from the data, then --config, then flags); read back "
        'with --config.\n"auto" stands for None: see each key\'s comment.',
    )
    text = text.rstrip("\n") + "\n\n" + format_constants(constants()) + "\n"
    if args.output:
        atomic_write_text(args.output, text)
        print(f"wrote {args.output}")
    else:
        print(text, end="")
    return 0


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
