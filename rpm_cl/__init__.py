"""rpm-cl: OpenCL-accelerated k-space range points migration radar imaging.

Data flow: scene -> simulate -> RadarData -> decompose -> RangePoints -> RPM
(OpenCL) -> Image -> metrics.
"""

__version__ = "0.1.0"

from .cl import CLEnv, NoOpenCLError, create_env, list_devices
from .data import Array, DataWarning, InputError, RadarData, Truth, Waveform, load_npz, save_npz
from .formats import frame_count, load_data, range_compress, save_data, save_result
from .imaging import METHODS, ImagingParams, RPMParams, default_params, run_method
from .kspace import KSpaceParams, decompose
from .medium import Medium
from .metrics import err_range, err_rpm, summary
from .rpm import DeviceRPM
from .scene import Ellipsoid, PointTarget, Scene, get_preset
from .simulate import simulate, simulate_preset

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
