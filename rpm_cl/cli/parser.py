"""The ``rpm-cl`` argument parser: :func:`build` makes the top-level parser
and one subparser per command (the ``add_*`` functions here and in
:mod:`rpm_cl.cli.parser_runs`, in the order of :data:`SUBCOMMANDS`), each with
``-v``/``-q``; :func:`_bind_negative_values` prepares the argument list.

A parsing error raises :class:`rpm_cl.cli.errors.CLIError` (one line, exit
code 2).  Building the parser imports neither SciPy nor OpenCL.
"""

from __future__ import annotations

import argparse

from .. import __version__
from .argtypes import (
    _budget_gb,
    _dynamic_range,
    _iso_db,
    _metres,
    _picture_size,
    _positive_int,
    _seed,
    _snr,
)
from .errors import CLIError
from .options import (
    common_opts,
    convert_opts,
    device_opts,
    input_opts,
    medium_opts,
    param_opts,
    preprocess_opts,
)
from .parser_runs import add_batch, add_bench, add_demo, add_reproduce


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2 (argparse prints usage too)
        # "rpm-cl: error: " comes first: the top level's name once, a
        # command's by its name ("convert: argument --band: ...")
        cmd = self.prog.removeprefix("rpm-cl").strip()
        raise CLIError(f"{cmd}: {message}" if cmd else message)


def build(handlers: dict) -> argparse.ArgumentParser:
    """The ``rpm-cl`` parser.

    Parameters
    ----------
    handlers : dict
        ``{command: handler}`` for every command of :data:`SUBCOMMANDS`; a
        parsed command's ``func`` is its handler.

    Returns
    -------
    argparse.ArgumentParser
    """
    p = _Parser(prog="rpm-cl", description="OpenCL k-space range points migration imaging")
    p.add_argument("--version", action="version", version=f"rpm-cl {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name, add in SUBCOMMANDS:
        add(sub).set_defaults(func=handlers[name])
    for sp in sub.choices.values():  # every subcommand, those added later too
        common_opts(sp)
    return p


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


def add_info(sub) -> argparse.ArgumentParser:
    """The ``info`` subcommand (the OpenCL devices), added to ``sub``."""
    sp = sub.add_parser("info", help="list OpenCL platforms/devices and the one chosen")
    sp.add_argument("--device")
    return sp


def add_simulate(sub) -> argparse.ArgumentParser:
    """The ``simulate`` subcommand (a preset scene to a data file), added to ``sub``."""
    from ..simulate.scene import PRESETS
    from ..simulate.synth import NOISE_MODELS

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
    return sp


def add_convert(sub) -> argparse.ArgumentParser:
    """The ``convert`` subcommand (recorded or simulated data to the input schema),
    added to ``sub``."""
    sp = sub.add_parser(
        "convert",
        help="recorded or simulated data -> the input schema: "
        "gprMax output, MATLAB/NumPy/HDF5 arrays by a key mapping, GSSI .dzt, "
        "Sensors & Software .DT1 (+ .HD), MALÅ .rd3 (+ .rad), TI DCA1000 .bin",
    )
    convert_opts(sp)
    return sp


def add_image(sub) -> argparse.ArgumentParser:
    """The ``image`` subcommand (image a data file), added to ``sub``."""
    from ..imaging import DEFAULT_METHOD, METHODS

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
    return sp


def add_params(sub) -> argparse.ArgumentParser:
    """The ``params`` subcommand (the parameters resolved for an input, as TOML),
    added to ``sub``."""
    sp = sub.add_parser(
        "params", help="print the parameters resolved for an input as TOML (a starting --config)"
    )
    sp.add_argument("input")
    sp.add_argument("-o", "--output", help="write the TOML here instead of stdout")
    input_opts(sp)
    device_opts(sp)
    param_opts(sp)
    return sp


def add_view(sub) -> argparse.ArgumentParser:
    """The ``view`` subcommand (draw an image result or a DAS/RMA image), added to ``sub``."""
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
    return sp


def add_figure(sub) -> argparse.ArgumentParser:
    """The ``figure`` subcommand (the paper-style figures of a data file), added to ``sub``."""
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
    return sp


def add_das(sub) -> argparse.ArgumentParser:
    """The ``das`` subcommand (SAR / delay-and-sum back-projection), added to ``sub``."""
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
    preprocess_opts(sp)
    return sp


def add_rma(sub) -> argparse.ArgumentParser:
    """The ``rma`` subcommand (the range migration image: f-k, Stolt), added to ``sub``."""
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
    preprocess_opts(sp)
    return sp


#: The subcommands in the order ``rpm-cl --help`` lists them, each with the
#: function that adds its parser.
SUBCOMMANDS = (
    ("info", add_info),
    ("simulate", add_simulate),
    ("convert", add_convert),
    ("image", add_image),
    ("params", add_params),
    ("reproduce", add_reproduce),
    ("demo", add_demo),
    ("view", add_view),
    ("figure", add_figure),
    ("das", add_das),
    ("rma", add_rma),
    ("bench", add_bench),
    ("batch", add_batch),
)
