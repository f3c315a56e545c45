"""Modules imported on first use.

SciPy's subpackages cost 0.1-0.4 s each to import; the command line imports
the imaging modules for its parser (their parameters are its flags), so a
module-level SciPy import there delays every command, a refusal of a bad
input included.  ``lazy("scipy.fft")`` stands for the module and imports it
at the first attribute looked up.
"""

from __future__ import annotations

import importlib

__all__ = ["lazy"]


class _Lazy:
    def __init__(self, name: str):
        self.__dict__["_name"] = name

    def __getattr__(self, attr):
        mod = importlib.import_module(self.__dict__["_name"])
        self.__dict__.update(mod.__dict__)  # later lookups need no import at all
        return getattr(mod, attr)


def lazy(name: str):
    """A stand-in for the module ``name``, imported on first attribute use."""
    return _Lazy(name)
