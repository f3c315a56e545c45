"""Progress bars (tqdm) for the long loops, silent unless asked for.

Library functions take a ``progress`` argument and pass it here:

- ``False`` (the library default): no bar, whatever the terminal;
- ``None``: a bar when stderr is a terminal (tqdm's ``disable=None``);
- ``True``: a bar in any case;
- a callable ``f(done, total)`` (the DAS functions' callback form):
  :func:`callback` turns a setting above into one.

The command line passes ``None``; ``--quiet`` enters :func:`bars_off`, a
context-local switch that silences every bar started inside it (threads and
asyncio tasks started from that context included), so a library function can
never print while the CLI is quiet.
"""

from __future__ import annotations

import contextlib
from contextvars import ContextVar

__all__ = ["bars_off", "callback", "progress"]

_OFF: ContextVar[bool] = ContextVar("rpm_cl_bars_off", default=False)


@contextlib.contextmanager
def bars_off():
    """Within this block no bar is drawn (the CLI's ``--quiet``)."""
    token = _OFF.set(True)
    try:
        yield
    finally:
        _OFF.reset(token)


def _resolve(setting: bool | None) -> bool | None:
    """``setting`` after :func:`bars_off`: False (no bar), None (a bar on a
    terminal) or True."""
    if _OFF.get() or setting is False:
        return False
    return setting


def progress(
    iterable=None,
    total: int | None = None,
    desc: str | None = None,
    enabled: bool | None = False,
    unit: str = "it",
    leave: bool = False,
):
    """A tqdm bar over ``iterable`` (or a manual one with ``total``).

    Parameters
    ----------
    iterable : iterable, optional
    total : int, optional
        Number of steps, when ``iterable`` has no ``len``.
    desc : str, optional
        Label in front of the bar.
    enabled : bool or None
        False: no bar (default); None: a bar when stderr is a terminal;
        True: a bar on stderr in any case.  :func:`bars_off` overrides all.
    unit : str
    leave : bool
        Keep the finished bar on screen.

    Returns
    -------
    tqdm.tqdm
        Iterate over it, or call ``update``/``close`` (also a context manager).
    """
    from tqdm import tqdm

    on = _resolve(enabled)
    # disable=None is tqdm's own "on a terminal only" test (stderr.isatty())
    return tqdm(
        iterable,
        total=total,
        desc=desc,
        unit=unit,
        leave=leave,
        disable=None if on is None else not on,
        dynamic_ncols=True,
    )


@contextlib.contextmanager
def callback(setting, total: int | None = None, desc: str | None = None, unit: str = "it"):
    """A ``f(done, total)`` callback that drives one bar, for the loops that
    report progress that way (:func:`rpm_cl.baselines.das.das_numpy`,
    :meth:`rpm_cl.baselines.das.DeviceDAS.backproject`).

    ``setting`` is a callable (returned unchanged) or one of the settings of
    :func:`progress`; with False the callback is None (nothing is called).
    """
    if callable(setting):
        yield setting
        return
    if _resolve(setting) is False:
        yield None
        return
    bar = progress(total=total, desc=desc, enabled=setting, unit=unit)

    def update(done, tot):
        if bar.total != tot:
            bar.total = tot
        bar.update(done - bar.n)

    try:
        yield update
    finally:
        bar.close()
