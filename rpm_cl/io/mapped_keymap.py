"""The key mapping of recorded arrays to the input schema's names
(:class:`KeyMap`: ``"spectrum=F,frequency=f,x=da"``, with transpose, scales and
conjugation), checked for a complete and consistent set of names."""

from __future__ import annotations

from dataclasses import dataclass

from .checks import InputError, _finite_scalar

#: Names a mapping may give (the input schema's, without the truth).
SCHEMA_NAMES = ("spectrum", "frequency", "signal", "range", "fc", "bandwidth", "x", "z")
#: The data arrays: one of them, exactly.
DATA_NAMES = ("spectrum", "signal")
#: What each data array needs, and what it refuses.
_NEEDS = {"spectrum": ("frequency", "x"), "signal": ("range", "fc", "bandwidth", "x")}
_REFUSES = {"spectrum": ("range",), "signal": ("frequency",)}
#: The names an axis of the data array may take in ``KeyMap.axes``: the
#: antenna axes, the data's own axis (``f`` / ``frequency`` for a spectrum,
#: ``r`` / ``range`` for a signal) and a stack's frames.
AXIS_NAMES = {
    "x": "x",
    "z": "z",
    "f": "n",
    "frequency": "n",
    "r": "n",
    "range": "n",
    "frame": "frame",
    "frames": "frame",
}


@dataclass(frozen=True)
class KeyMap:
    """Which array of the input becomes which name of the schema.

    Attributes
    ----------
    pairs : tuple of (str, str)
        ``(schema name, key in the file)``; a key may name a member of a
        group (HDF5, MATLAB v7.3 struct) as ``a/b`` or ``a.b``.
    transpose : bool
        Reverse all axes of the data array (``spectrum`` / ``signal``).
    scale_x : float
        Factor applied to ``x`` and ``z`` (to metres), > 0.
    scale_f : float
        Factor applied to ``frequency``, ``fc`` and ``bandwidth`` (to Hz), > 0.
    conjugate : bool
        Conjugate the data array: a ``spectrum`` recorded as ``a exp(+j 4 pi
        f R / c)``, or range profiles recorded with the carrier phase
        ``exp(+j 2 k_c R)``.
    axes : tuple of str, optional
        The data array's axes in the file's order, each one of ``x``, ``z``,
        ``f`` (``frequency``) or ``r`` (``range``), and ``frame`` for a
        stack (:data:`AXIS_NAMES`): ``("f", "z", "x")`` for an array kept as
        ``F(nf, nz, nx)``.  The data are permuted to the schema's
        ``([frame,] x[, z], n)``.  None: the schema's order (or, with
        ``transpose``, its reverse).
    """

    pairs: tuple
    transpose: bool = False
    scale_x: float = 1.0
    scale_f: float = 1.0
    conjugate: bool = False
    axes: tuple | None = None

    def __post_init__(self):
        pairs = tuple((str(a), str(b)) for a, b in self.pairs)
        object.__setattr__(self, "pairs", pairs)
        names = [a for a, _ in pairs]
        for name, key in pairs:
            if name not in SCHEMA_NAMES:
                raise InputError(
                    f"unknown name {name!r} in the mapping; the schema's names are "
                    f"{', '.join(SCHEMA_NAMES)}"
                )
            if not key:
                raise InputError(f"{name} is mapped to an empty key")
            if names.count(name) > 1:
                raise InputError(f"{name} is mapped twice")
        data = [n for n in DATA_NAMES if n in names]
        if not data:
            raise InputError(
                "the mapping names neither spectrum (frequency domain) nor signal (time domain)"
            )
        if len(data) == 2:
            raise InputError("the mapping names both spectrum and signal; keep one")
        kind = data[0]
        extra = [n for n in _REFUSES[kind] if n in names]
        if extra:
            raise InputError(
                f"{extra[0]} does not go with {kind} (spectrum takes frequency, signal takes range)"
            )
        missing = [n for n in _NEEDS[kind] if n not in names]
        if missing:
            raise InputError(
                f"the mapping lacks {', '.join(missing)} ({kind} needs {', '.join(_NEEDS[kind])})"
            )
        for what in ("scale_x", "scale_f"):
            object.__setattr__(self, what, _finite_scalar(what, getattr(self, what)))
        if self.axes is not None:
            object.__setattr__(self, "axes", _axes(self.axes, kind, "z" in names))
            if self.transpose:
                raise InputError(
                    "give either --axes (axes=) or --transpose (transpose=True), not both"
                )

    def order(self, ndim: int) -> tuple | None:
        """The permutation taking an ``ndim``-axis data array of the file to
        the schema's axis order (``np.transpose``'s ``axes``), or None where
        the file keeps that order already.

        Raises
        ------
        InputError
            ``axes`` names another number of axes than the array has.
        """
        if self.axes is None:
            return tuple(range(ndim))[::-1] if self.transpose else None
        axes = self.axes
        if len(axes) == ndim + 1 and axes[-1] in ("frame", "frames"):
            axes = axes[:-1]  # MATLAB drops a trailing axis of one: a single frame
        if len(axes) != ndim:
            raise InputError(
                f"--axes (axes=) names {len(self.axes)} axes ({','.join(self.axes)}), "
                f"the data array has {ndim}"
            )
        canon = [AXIS_NAMES[a] for a in axes]
        want = [a for a in ("frame", "x", "z", "n") if a in canon]
        return tuple(canon.index(a) for a in want)

    @classmethod
    def parse(cls, text: str, **options) -> KeyMap:
        """``"spectrum=F,frequency=f,x=da"`` (``NAME=KEY`` pairs, commas between)."""
        pairs = []
        for part in str(text).split(","):
            name, sep, key = part.partition("=")
            if not sep or "=" in key:
                raise InputError(
                    f"the mapping must be NAME=KEY pairs separated by commas "
                    f"(e.g. spectrum=F,frequency=f,x=da), got {part.strip()!r}"
                )
            pairs.append((name.strip(), key.strip()))
        return cls(tuple(pairs), **options)

    @property
    def kind(self) -> str:
        """``"spectrum"`` or ``"signal"``."""
        return next(a for a, _ in self.pairs if a in DATA_NAMES)


def _axes(axes, kind: str, planar: bool) -> tuple:
    """``axes`` (a tuple of names, or a comma-separated string) checked: each
    of :data:`AXIS_NAMES` at most once, ``x`` and the data's own axis
    present, ``z`` exactly when the array is planar."""
    if isinstance(axes, str):
        axes = axes.split(",")
    out = tuple(str(a).strip().lower() for a in axes)
    own = "f, frequency" if kind == "spectrum" else "r, range"
    for a in out:
        if a not in AXIS_NAMES:
            raise InputError(
                f"unknown axis {a!r} in --axes (axes=); name each of x, z (planar), "
                f"{own} and frame (a stack), e.g. f,x"
            )
        if AXIS_NAMES[a] == "n" and a not in own.split(", "):
            raise InputError(f"axis {a!r} does not go with {kind} (its axis is {own})")
    canon = [AXIS_NAMES[a] for a in out]
    for c in set(canon):
        if canon.count(c) > 1:
            raise InputError(f"--axes (axes=) names the {c if c != 'n' else own} axis twice")
    need = ["x", "n"] + (["z"] if planar else [])
    missing = [c for c in need if c not in canon]
    if missing:
        what = ", ".join(own if c == "n" else c for c in missing)
        raise InputError(f"--axes (axes=) lacks {what}")
    if "z" in canon and not planar:
        raise InputError("--axes (axes=) names z, but the mapping gives no z")
    return out
