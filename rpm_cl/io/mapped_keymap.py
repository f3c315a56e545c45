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
        Conjugate a ``spectrum`` (one recorded as ``a exp(+j 4 pi f R / c)``).
    """

    pairs: tuple
    transpose: bool = False
    scale_x: float = 1.0
    scale_f: float = 1.0
    conjugate: bool = False

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
        if self.conjugate and kind != "spectrum":
            raise InputError("conjugate applies to a spectrum, not to a time-domain signal")
        for what in ("scale_x", "scale_f"):
            object.__setattr__(self, what, _finite_scalar(what, getattr(self, what)))

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
