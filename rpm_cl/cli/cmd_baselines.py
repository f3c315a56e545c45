"""The ``rpm-cl`` handlers of the coherent baselines: ``das`` (SAR /
delay-and-sum back-projection onto a grid) and ``rma`` (range migration,
f-k / Stolt), each writing an image file.
"""

from __future__ import annotations

import logging
from dataclasses import asdict

from .. import __version__
from .common import _load_input, _medium, _preprocessed
from .errors import CLIError

log = logging.getLogger("rpm_cl")


def cmd_das(args) -> int:
    from ..baselines.das import parse_grid
    from ..extract.hyperbola import check_medium
    from ..io.formats import VOLUME_EXTENSIONS, check_output, write_volume

    check_output(args.output, VOLUME_EXTENSIONS, "image")
    data = _preprocessed(args, _load_input(args, with_truth=False))
    grid = parse_grid(args.grid)
    if grid.dim != data.array.dim:
        raise CLIError(
            f"--grid has {grid.dim} axes; this {'planar' if data.array.planar else 'linear'}"
            f" array needs {data.array.dim} (x, y{', z' if data.array.planar else ''})"
        )
    medium = _medium(args, data)
    check_medium(data, medium)
    n_bp = grid.size * data.array.n
    timing = {}
    backend = _das_backend(args.backend, medium)
    device, dtype, fill = _das_filler(args, backend, data, grid, medium, timing)
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


def _das_backend(backend: str, medium) -> str:
    """Where ``das`` back-projects: ``--backend``, except numpy above a half-space."""
    if medium.half_space and backend == "opencl":
        # the kernel's distances are straight lines from its grid axes
        log.info(
            "das: above a half-space the refracted ranges are computed on the host "
            "(the numpy backend, float64)"
        )
        backend = "numpy"
    return backend


def _das_filler(args, backend: str, data, grid, medium, timing: dict):
    """(device name, image dtype, ``fill``): ``fill(out)`` back-projects
    ``data`` onto ``grid`` into ``out`` on ``backend`` (with a progress bar)
    and records its seconds as ``timing["seconds"]``."""
    import time

    import numpy as np

    from ..baselines.das import DeviceDAS, das_numpy
    from ..progress import callback

    budget = args.memory_budget * 1e9
    if backend == "opencl":
        from ..cl import create_env

        env = create_env(args.device)
        try:
            dev = DeviceDAS(env, args.precision, budget)
        except ValueError as exc:
            raise CLIError(str(exc)) from None

        def fill(out):
            with callback(None, total=grid.size, desc="das", unit="voxel") as bar:
                t0 = time.perf_counter()
                dev.backproject(data, grid, out=out, progress=bar, medium=medium)
                timing["seconds"] = time.perf_counter() - t0

        return env.name, dev.cplx, fill

    def fill_numpy(out):
        with callback(None, total=grid.size, desc="das", unit="voxel") as bar:
            t0 = time.perf_counter()
            das_numpy(data, grid, budget, out=out, progress=bar, medium=medium)
            timing["seconds"] = time.perf_counter() - t0

    return "numpy (float64)", np.complex128, fill_numpy


def cmd_rma(args) -> int:
    import time

    from ..baselines.das import Grid
    from ..baselines.rma import rma_image
    from ..extract.hyperbola import check_medium
    from ..io.formats import VOLUME_EXTENSIONS, check_output, write_volume

    check_output(args.output, VOLUME_EXTENSIONS, "image")
    data = _preprocessed(args, _load_input(args, with_truth=False))
    if args.y_min is not None and args.y_max is not None and args.y_min >= args.y_max:
        raise CLIError(f"--y-min ({args.y_min}) must be below --y-max ({args.y_max})")
    medium = _medium(args, data)
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
