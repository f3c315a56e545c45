"""rpm-cl: OpenCL-accelerated k-space range points migration radar imaging.

Data flow: scene -> simulate -> RadarData -> decompose -> RangePoints -> RPM
(OpenCL) -> Image -> metrics.
"""

__version__ = "0.1.0"

import sys as _sys
import types as _types

#: Each public name and the submodule that defines it, imported on first use:
#: ``import rpm_cl`` (and so the ``rpm-cl`` command's start-up, before its
#: Ctrl-C handler exists) loads neither NumPy nor OpenCL.
_WHERE = {
    "METHODS": "imaging",
    "Array": "io.data",
    "CLEnv": "cl",
    "DataWarning": "io.data",
    "DeviceRPM": "rpm",
    "Ellipsoid": "simulate.scene",
    "ImagingParams": "rpm.params",
    "InputError": "io.data",
    "KSpaceParams": "extract.kspace",
    "Medium": "io.medium",
    "NoOpenCLError": "cl",
    "PointTarget": "simulate.scene",
    "RPMParams": "rpm.params",
    "RadarData": "io.data",
    "Scene": "simulate.scene",
    "Truth": "io.data",
    "Waveform": "io.data",
    "create_env": "cl",
    "decompose": "extract.kspace",
    "default_params": "rpm.params",
    "err_range": "metrics",
    "err_rpm": "metrics",
    "frame_count": "io.formats",
    "get_preset": "simulate.scene",
    "list_devices": "cl",
    "load_data": "io.formats",
    "load_npz": "io.data",
    "range_compress": "io.formats",
    "run_method": "imaging",
    "save_data": "io.formats",
    "save_npz": "io.data",
    "save_result": "io.formats",
    "simulate": "simulate",
    "simulate_preset": "simulate",
    "summary": "metrics",
}


def __getattr__(name):
    where = _WHERE.get(name)
    if where is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from importlib import import_module

    value = getattr(import_module(f".{where}", __name__), name)
    setattr(_sys.modules[__name__], name, value)
    return value


def __dir__():
    return sorted(set(globals()) | set(_WHERE))


class _Package(_types.ModuleType):
    def __setattr__(self, name, value):
        # the import system binds each submodule to its name in the package;
        # where a public function has its module's name (simulate), the
        # function keeps the name
        if (
            isinstance(value, _types.ModuleType)
            and _WHERE.get(name) == name
            and value.__name__ == f"{self.__name__}.{name}"
        ):
            value = getattr(value, name)
        super().__setattr__(name, value)


_sys.modules[__name__].__class__ = _Package

__all__ = [
    "METHODS",
    "Array",
    "CLEnv",
    "DataWarning",
    "DeviceRPM",
    "Ellipsoid",
    "ImagingParams",
    "InputError",
    "KSpaceParams",
    "Medium",
    "NoOpenCLError",
    "PointTarget",
    "RPMParams",
    "RadarData",
    "Scene",
    "Truth",
    "Waveform",
    "__version__",
    "create_env",
    "decompose",
    "default_params",
    "err_range",
    "err_rpm",
    "frame_count",
    "get_preset",
    "list_devices",
    "load_data",
    "load_npz",
    "range_compress",
    "run_method",
    "save_data",
    "save_npz",
    "save_result",
    "simulate",
    "simulate_preset",
    "summary",
]
