"""OpenCL environment: device choice, program build and cache.

The environment (context, queue, device) is always passed explicitly; there is
no module-level context.  Programs are built once per (context, source file,
build options) and kernels are fetched once per program.

Device choice, in order of precedence:

1. an explicit ``spec`` (the CLI's ``--device``): ``"P:D"`` platform and device
   indices, or a case-insensitive substring of the device or platform name;
2. the ``PYOPENCL_CTX`` environment variable, same syntax as pyopencl's;
3. the first CPU device of any platform (PoCL's CPU device when installed from
   pip), else the first device of any kind.
"""

from __future__ import annotations

import os
import threading
import weakref
from dataclasses import dataclass
from importlib import resources

import numpy as np

__all__ = [
    "CLEnv",
    "DeviceInfo",
    "NoOpenCLError",
    "build_program",
    "choose_device",
    "create_env",
    "get_kernels",
    "kernel_source",
    "list_devices",
    "load_pyopencl",
    "read_only",
]

INSTALL_HINT = (
    "no OpenCL platform found; install a CPU OpenCL runtime with "
    "'python3 -m pip install \"pyopencl[pocl]\"' (PoCL, no system install needed)"
)


class NoOpenCLError(RuntimeError):
    """No usable OpenCL platform or device (message says how to get one)."""


@dataclass(frozen=True)
class DeviceInfo:
    """One OpenCL device as listed by :func:`list_devices`."""

    platform_index: int
    device_index: int
    platform: str
    name: str
    kind: str
    compute_units: int
    double: bool

    @property
    def spec(self) -> str:
        """The ``"P:D"`` string that selects this device."""
        return f"{self.platform_index}:{self.device_index}"


@dataclass(frozen=True)
class CLEnv:
    """An explicit OpenCL environment.

    Attributes
    ----------
    context : pyopencl.Context
    queue : pyopencl.CommandQueue
        In-order queue on ``device``.
    device : pyopencl.Device
    """

    context: object
    queue: object
    device: object

    @property
    def name(self) -> str:
        """Human-readable ``"device (platform)"`` name."""
        return f"{self.device.name.strip()} ({self.device.platform.name.strip()})"

    @property
    def has_double(self) -> bool:
        """True when the device supports float64 arithmetic."""
        return bool(self.device.double_fp_config)


#: Signals whose Python handlers may raise (Ctrl-C, and the command line's
#: SIGTERM): held back while pyopencl's extension initialises.
_HELD_SIGNALS = ("SIGINT", "SIGTERM")


def load_pyopencl():
    """The ``pyopencl`` module, imported with SIGINT and SIGTERM held back.

    pyopencl's extension (nanobind) builds its enumerations with Python's
    :mod:`enum` while it initialises; an exception raised there, such as the
    KeyboardInterrupt of a Ctrl-C, makes nanobind abort the process
    ("Critical nanobind error", SIGABRT) with a traceback instead of the
    command's one line.  During the import, in the main thread, each of
    these signals that has a Python handler gets one that only notes it;
    once the import has finished the handlers are put back and a noted
    signal is raised again, so that its own handler deals with it.  (Masking
    the signals would not do: a process-directed signal goes to another
    thread, e.g. a BLAS worker, and Python runs the handler in the main
    thread all the same.)"""
    import sys

    cl = sys.modules.get("pyopencl")
    if cl is not None and hasattr(cl, "Context"):  # imported in full
        return cl
    import signal

    noted = []
    put_back = {}
    if threading.current_thread() is threading.main_thread():
        for name in _HELD_SIGNALS:
            sig = getattr(signal, name, None)
            if sig is not None and callable(signal.getsignal(sig)):
                put_back[sig] = signal.signal(sig, lambda signum, frame: noted.append(signum))
    try:
        import pyopencl as cl
    except ImportError as exc:  # pragma: no cover - dependency missing
        raise NoOpenCLError(f"pyopencl is not installed ({exc}); {INSTALL_HINT}") from exc
    finally:
        for sig, handler in put_back.items():
            signal.signal(sig, handler)
        for sig in dict.fromkeys(noted):
            signal.raise_signal(sig)
    return cl


def _platforms():
    cl = load_pyopencl()
    try:
        platforms = cl.get_platforms()
    except cl.Error:  # PLATFORM_NOT_FOUND_KHR when no ICD is installed
        platforms = []
    if not platforms:
        raise NoOpenCLError(INSTALL_HINT)
    return platforms


def _kind(device) -> str:
    cl = load_pyopencl()
    t = device.type
    if t & cl.device_type.GPU:
        return "GPU"
    if t & cl.device_type.CPU:
        return "CPU"
    if t & cl.device_type.ACCELERATOR:
        return "ACCELERATOR"
    return "OTHER"


def _all_devices():
    out = []
    for ip, p in enumerate(_platforms()):
        try:
            devices = p.get_devices()
        except load_pyopencl().Error:
            devices = []
        for idev, d in enumerate(devices):
            out.append((ip, idev, p, d))
    if not out:
        raise NoOpenCLError(INSTALL_HINT)
    return out


def list_devices() -> list[DeviceInfo]:
    """List every OpenCL device of every platform.

    Raises
    ------
    NoOpenCLError
        When no platform or device exists.
    """
    return [
        DeviceInfo(
            ip,
            idev,
            p.name.strip(),
            d.name.strip(),
            _kind(d),
            int(d.max_compute_units),
            bool(d.double_fp_config),
        )
        for ip, idev, p, d in _all_devices()
    ]


def choose_device(spec: str | None = None) -> DeviceInfo:
    """Pick a device; see the module docstring for the rules.

    Parameters
    ----------
    spec : str, optional
        ``"P:D"`` indices, ``"P"`` (first device of platform P) or a name
        substring.  ``None`` falls back to ``PYOPENCL_CTX``, then to the first
        CPU device.

    Raises
    ------
    NoOpenCLError
        No platform, or ``spec`` matches nothing.
    """
    devices = list_devices()
    if spec is None:
        spec = os.environ.get("PYOPENCL_CTX") or None
    if spec is None:
        cpus = [d for d in devices if d.kind == "CPU"]
        return (cpus or devices)[0]
    spec = spec.strip()
    parts = spec.split(":")
    if all(p.isdigit() for p in parts if p) and parts[0]:
        ip = int(parts[0])
        idev = int(parts[1]) if len(parts) > 1 and parts[1] else 0
        for d in devices:
            if (d.platform_index, d.device_index) == (ip, idev):
                return d
        raise NoOpenCLError(f"no OpenCL device {ip}:{idev}; 'rpm-cl info' lists the devices")
    low = spec.lower()
    for d in devices:
        if low in d.name.lower() or low in d.platform.lower():
            return d
    raise NoOpenCLError(f"no OpenCL device matches {spec!r}; 'rpm-cl info' lists the devices")


def create_env(spec: str | None = None) -> CLEnv:
    """Create a context and an in-order queue on the chosen device.

    Parameters
    ----------
    spec : str, optional
        See :func:`choose_device`.
    """
    cl = load_pyopencl()
    info = choose_device(spec)
    device = cl.get_platforms()[info.platform_index].get_devices()[info.device_index]
    context = cl.Context([device])
    queue = cl.CommandQueue(context, device)
    return CLEnv(context, queue, device)


def kernel_source(filename: str) -> str:
    """Text of one ``.cl`` file shipped in ``rpm_cl.kernels``."""
    return resources.files("rpm_cl.kernels").joinpath(filename).read_text(encoding="utf-8")


def _include_dir() -> str:
    return str(resources.files("rpm_cl.kernels"))


# context -> {(filename, options): (program, {kernel name: Kernel})}
_PROGRAMS: weakref.WeakKeyDictionary[object, dict] = weakref.WeakKeyDictionary()
_LOCK = threading.Lock()


def _format_defines(defines: dict[str, object] | None) -> tuple[str, ...]:
    opts = []
    for key in sorted(defines or {}):
        value = defines[key]
        if isinstance(value, (float, np.floating)):
            value = repr(float(value))
        opts.append(f"-D{key}={value}")
    return tuple(opts)


def build_program(env: CLEnv, filename: str, defines: dict[str, object] | None = None):
    """Build ``filename`` for ``env`` once per (context, file, defines).

    Parameters
    ----------
    env : CLEnv
    filename : str
        A ``.cl`` file of ``rpm_cl.kernels``.
    defines : dict, optional
        Preprocessor definitions passed as ``-DKEY=VALUE`` build options.

    Returns
    -------
    program : pyopencl.Program
    kernels : dict
        Mutable per-program cache of ``pyopencl.Kernel`` objects by name; use
        :func:`get_kernels` rather than touching it.
    """
    cl = load_pyopencl()
    options = _format_defines(defines) + ("-I", _include_dir())
    key = (filename, options)
    with _LOCK:
        per_ctx = _PROGRAMS.setdefault(env.context, {})
        if key not in per_ctx:
            program = cl.Program(env.context, kernel_source(filename)).build(options=list(options))
            per_ctx[key] = (program, {})
        return per_ctx[key]


def get_kernels(env: CLEnv, filename: str, names, defines=None) -> dict:
    """Fetch the named kernels of a (memoized) program, each fetched once.

    Returns
    -------
    dict
        ``{name: pyopencl.Kernel}``.
    """
    cl = load_pyopencl()
    program, cache = build_program(env, filename, defines)
    with _LOCK:
        for n in names:
            if n not in cache:
                cache[n] = cl.Kernel(program, n)
        return {n: cache[n] for n in names}


def read_only(env: CLEnv, a, dtype):
    """A read-only device buffer holding ``a`` as ``dtype``, contiguous
    (one zero element where ``a`` is empty: OpenCL has no empty buffers)."""
    cl = load_pyopencl()
    a = np.ascontiguousarray(a, dtype)
    if a.size == 0:
        a = np.zeros(1, dtype)
    return cl.Buffer(env.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=a)
