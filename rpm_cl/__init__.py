"""rpm-cl: OpenCL-accelerated k-space range points migration radar imaging.

Data flow: scene -> simulate -> RadarData -> decompose -> RangePoints -> RPM
(OpenCL) -> Image -> metrics.
"""

__version__ = "0.1.0"

from .cl import CLEnv, NoOpenCLError, create_env, list_devices
from .data import Array, InputError, RadarData, Truth, Waveform, load_npz, save_npz
from .imaging import ImagingParams, RPMParams, default_params, run_method, METHODS
from .kspace import KSpaceParams, decompose
from .metrics import err_range, err_rpm, summary
from .rpm import DeviceRPM
from .scene import Ellipsoid, PointTarget, Scene, get_preset
from .simulate import simulate, simulate_preset

__all__ = [
    "__version__", "CLEnv", "NoOpenCLError", "create_env", "list_devices", "Array",
    "InputError", "RadarData", "Truth", "Waveform", "load_npz", "save_npz", "ImagingParams",
    "RPMParams", "default_params", "run_method", "METHODS", "KSpaceParams", "decompose",
    "err_range", "err_rpm", "summary", "DeviceRPM", "Ellipsoid", "PointTarget", "Scene",
    "get_preset", "simulate", "simulate_preset",
]
