"""The ``rpm-cl`` handlers of the data commands: ``info`` (the OpenCL
devices), ``simulate`` (a preset scene to a data file) and ``convert``
(recorded or simulated data to the input schema).
"""

from __future__ import annotations

from .. import __version__


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
