"""Option groups of the ``rpm-cl`` subcommands: those several commands share
(``--config`` and the [engine] flags, how a data file is read, a flag per
imaging or medium parameter, ``-v``/``-q``) and the options of ``convert``
(the inputs, the reader, each reader's own).
"""

from __future__ import annotations

from .argtypes import _band, _bounded_float, _frame, _int_at_least, _memory_size, _positive_int


def device_opts(sp) -> None:
    """``--config`` and the [engine] flags (``--device``, ``--precision``)."""
    # --device, --precision: the [engine] section (rpm_cl.cli.config.EngineParams)
    from .config import add_flags

    sp.add_argument(
        "--config",
        metavar="FILE.toml",
        help="parameters from this TOML file (flags override it; see "
        "`rpm-cl params` and examples/config.toml)",
    )
    add_flags(sp, ("engine",))


def input_opts(sp) -> None:
    """How a data file is read: ``--frame``, ``--range-window``, ``--conjugate``,
    ``--max-memory``."""
    from ..io.formats import RANGE_WINDOWS

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
        "minus their range), or range profiles recorded with the carrier phase "
        "exp(+j 2 k_c R) (their targets come out mirrored across the array)",
    )
    sp.add_argument(
        "--max-memory",
        metavar="BYTES",
        type=_memory_size,
        help="refuse an input whose run would need more memory than this "
        "(e.g. 8G; default RPM_CL_MAX_MEMORY or half the machine's memory), "
        "checked from the file's headers before any data is read",
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


def preprocess_opts(sp) -> None:
    """The flags of the steps before imaging ([imaging] ``background``,
    ``time_zero``, ``gain_db_per_m``, ``max_range``), for ``das`` and
    ``rma``: they image the data as ``image`` does, after those steps."""
    from ..rpm.params import PREPROCESS_FIELDS
    from .config import add_flags

    add_flags(sp, ("imaging",), only=PREPROCESS_FIELDS)


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


def convert_opts(sp) -> None:
    """The options of ``convert``: the inputs, the reader, and each reader's
    own (:data:`rpm_cl.io.readers.FORMATS` says which belongs to which)."""
    from ..io.readers import FORMATS

    sp.add_argument(
        "inputs",
        nargs="+",
        metavar="IN",
        help="the file(s) to convert: gprMax "
        ".out/.h5 (a merged B-scan or the per-trace files), .mat/.npz/.npy/.h5 "
        "with --map, GSSI .dzt, Sensors & Software .DT1 (its .HD beside it), MALÅ .rd3/.rd7 "
        "(its .rad beside it), DCA1000 .bin "
        "(several: concatenated in order)",
    )
    sp.add_argument("-o", "--output", required=True, help="OUT.npz or OUT.h5")
    sp.add_argument(
        "--format",
        choices=sorted(FORMATS),
        help="the reader (default: from the "
        "extension; .h5 with --map is arrays, without it gprmax)",
    )
    _gprmax_opts(sp.add_argument_group("gprMax output (--format gprmax)"))
    _arrays_opts(sp.add_argument_group("named arrays (--format arrays: .mat, .npz, .npy, .h5)"))
    _dzt_opts(sp.add_argument_group("GSSI DZT, pulseEKKO DT1, MALÅ rd3 (--format dzt, dt1, mala)"))
    _dca1000_opts(sp.add_argument_group("TI mmWave + DCA1000 (--format dca1000)"))


def _gprmax_opts(g) -> None:
    """``convert``'s options of gprMax output, on the argument group ``g``."""
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
        "(e.g. 2e9:4e9); required for gprMax; dzt, dt1, mala: default the antenna's nominal "
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


def _arrays_opts(g) -> None:
    """``convert``'s options of named arrays (.mat, .npz, .npy, .h5), on ``g``."""
    scale = _bounded_float(1e-15, 1e15, "a scale factor must be 1e-15 .. 1e15")
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
    g.add_argument(
        "--axes",
        metavar="A,B,...",
        help="the data array's axes in the file's order, each of x, z, f (spectrum) or r "
        "(signal), and frame (a stack): e.g. f,z,x for F(nf, nz, nx); instead of --transpose",
    )
    g.add_argument("--scale-x", type=scale, help="factor to metres for x and z (1e-3: mm)")
    g.add_argument(
        "--scale-f", type=scale, help="factor to Hz for frequency, fc and bandwidth (1e9: GHz)"
    )
    g.add_argument(
        "--conjugate",
        action="store_true",
        help="conjugate a spectrum recorded as exp(+j 4 pi f R / c), or profiles "
        "recorded with the carrier phase exp(+j 2 k_c R)",
    )


def _dzt_opts(g) -> None:
    """``convert``'s options of GSSI .dzt, pulseEKKO .DT1 and MALÅ .rd3 files
    (``--channel``: .dzt only), on the argument group ``g``."""
    g.add_argument(
        "--dx",
        type=_bounded_float(1e-9, 1e4, "dx must be a length in m, 1e-9 .. 1e4"),
        help="dzt: scan spacing, m (default 1 / the header's scans per "
        "metre); dt1, mala: trace spacing, m (default the header's step); dca1000: the radar's "
        "step between frames, m",
    )
    g.add_argument(
        "--time-zero",
        type=_bounded_float(0, 1e6, "time zero must be a sample number >= 0"),
        metavar="SAMPLE",
        help="sample of time zero (the transmit "
        "instant; may be fractional; default 0, the window's start)",
    )
    g.add_argument(
        "--channel",
        type=_int_at_least(0, "channel "),
        help="dzt: channel, from 0 (default 0)",
    )
    g.add_argument(
        "--subtract-mean",
        action="store_true",
        help="subtract the mean trace (direct coupling, ground bounce, horizontal bands)",
    )


def _dca1000_opts(g) -> None:
    """``convert``'s options of TI mmWave + DCA1000 captures, on ``g``."""
    from ..io.dca1000 import LAYOUTS

    hz = _bounded_float(1.0, 1e15, "start frequency must be in Hz, 1 .. 1e15")
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
