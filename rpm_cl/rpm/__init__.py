"""Range points migration: float64 references, OpenCL wrappers, the driver."""

from . import reference
from .device import DeviceRPM

__all__ = ["DeviceRPM", "reference"]
