"""What the ``rpm-cl`` command handlers share: the RPM engine of
``--device``/``--precision``, the imaging parameters and the medium resolved
from the data, ``--config`` and the flags (:mod:`rpm_cl.cli.config`), and the
accuracy line printed against the truth.
"""

from __future__ import annotations

import logging

from .errors import CLIError

log = logging.getLogger("rpm_cl")


def _engine(args):
    from ..cl import create_env
    from ..rpm import DeviceRPM

    env = create_env(args.device)
    try:
        return DeviceRPM(env, args.precision), env
    except ValueError as exc:
        raise CLIError(str(exc)) from None


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


def _medium(args, data):
    """The :class:`rpm_cl.io.medium.Medium` of ``--config`` [medium] and the
    flags (``eps_r`` "auto" read from ``data``, as imaged)."""
    from .config import flag_values, merge, resolve_medium, settings

    flags = flag_values(args)
    sources = {k: str(args.config) for k in args.cfg_file}
    sources.update(
        {(s.section, s.name): s.flag for s in settings() if (s.section, s.name) in flags}
    )
    return resolve_medium(merge(args.cfg_file, flags), sources, data)


def _accuracy_line(s: dict) -> str:
    from ..metrics import pct

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


def _preprocessed(args, data):
    """``data`` after the steps before imaging that ``--config`` [imaging] and
    the flags set (background, time zero, gain, region; the defaults
    ``image`` takes otherwise: :func:`rpm_cl.imaging.prepared`), for the
    coherent baselines."""
    from ..imaging import prepared
    from ..rpm.params import PREPROCESS_FIELDS, default_params
    from .config import flag_values, merge

    values = merge(args.cfg_file, flag_values(args))
    given = {n: v for (sec, n), v in values.items() if sec == "imaging" and n in PREPROCESS_FIELDS}
    return prepared(data, default_params(data, **given))[0]


def _load_input(args, **kw):
    """``args.input`` as the input options say (frame, range window,
    conjugation, memory limit); ``kw`` as for
    :func:`rpm_cl.io.formats.load_data`."""
    from ..io.formats import load_data

    return load_data(
        args.input,
        frame=args.frame,
        range_window=args.range_window,
        conjugate=args.conjugate,
        max_memory=args.max_memory,
        **kw,
    )
