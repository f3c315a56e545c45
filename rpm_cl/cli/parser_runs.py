"""The ``rpm-cl`` subparsers of the runs over many scenes or frames:
``reproduce``, ``demo``, ``bench`` and ``batch`` (their handlers:
:mod:`rpm_cl.cli.cmd_runs`).
"""

from __future__ import annotations

import argparse

from .argtypes import _budget_gb, _frame_memory, _frame_timeout, _positive_int, _seed, _snr
from .options import device_opts, param_opts


def add_reproduce(sub) -> argparse.ArgumentParser:
    """The ``reproduce`` subcommand (the paper's tables), added to ``sub``."""
    from .reproduce import CASES

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
    return sp


def add_demo(sub) -> argparse.ArgumentParser:
    """The ``demo`` subcommand (the paper's scenes simulated, imaged and scored),
    added to ``sub``."""
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
    return sp


def add_bench(sub) -> argparse.ArgumentParser:
    """The ``bench`` subcommand (each method and stage timed on the paper's scenes),
    added to ``sub``."""
    from .bench import SCENES

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
        "--no-roofline",
        action="store_true",
        help="leave out the machine's measured limits, the roofline table and the "
        "equal-accuracy comparison with DAS",
    )
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
    return sp


def add_batch(sub) -> argparse.ArgumentParser:
    """The ``batch`` subcommand (every frame of a folder or stack on a Dask cluster),
    added to ``sub``."""
    from ..imaging import DEFAULT_METHOD, METHODS
    from .watchdog import DEFAULT_FRAME_MEMORY_FRACTION, DEFAULT_FRAME_TIMEOUT

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
    return sp
