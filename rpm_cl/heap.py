"""Keep freed memory in the process for the next allocation (glibc's malloc).

Large NumPy temporaries (the k-space spectra of a planar array: hundreds of
MB) are allocated and freed many times in one decomposition.  By default
glibc serves every block above its mmap threshold (128 kB, raised
dynamically up to 32 MB) with its own mapping and unmaps it when it is
freed, so the next temporary faults its pages in again, and the kernel
zeroes each one; with NumPy's transparent-huge-page hint the faults can
also stall on memory compaction.  Repeated in one process, a 45 x 45 array's
decomposition spends 0.2-0.7 s of system time on them beside its 0.7-0.9 s
of arithmetic and varies 0.9-1.6 s from run to run (docs/decisions.md).

:func:`keep_freed_memory` moves the mmap threshold to :data:`HEAP_ALLOC_MAX`
and the trim threshold to :data:`HEAP_TRIM_MIN`: blocks come from the heap,
and freed ones stay there for the next, so repeated runs in one process
(``rpm-cl bench``, a script imaging many inputs) fault nothing in after
the first and take steady times.  The process's resident memory then stays
at its peak until it exits, so it is for the caller to choose: ``rpm-cl
bench`` calls it; one-input commands gain nothing measurable (their one
decomposition faults its pages in once either way) and ``rpm-cl batch``
leaves its workers as they are (Dask watches their resident memory).
Elsewhere than glibc it does nothing.
"""

from __future__ import annotations

import ctypes
import sys

__all__ = ["HEAP_ALLOC_MAX", "HEAP_TRIM_MIN", "keep_freed_memory"]

#: glibc's mallopt parameters (malloc.h).
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
#: Allocations up to this size come from the heap, bytes (1 GiB: every
#: temporary of a 128 x 128 array; larger ones still get their own mapping).
HEAP_ALLOC_MAX = 1 << 30
#: Free memory at the top of the heap returned to the system only beyond
#: this, bytes (the largest value mallopt takes, 2 GiB - 1).
HEAP_TRIM_MIN = (1 << 31) - 1


def keep_freed_memory() -> bool:
    """Serve allocations up to :data:`HEAP_ALLOC_MAX` from the heap and keep
    freed memory there (module notes).  Returns True where glibc took both
    settings, False elsewhere (another C library, another system)."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # no mallopt: not glibc
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, HEAP_ALLOC_MAX)) & bool(
        mallopt(_M_TRIM_THRESHOLD, HEAP_TRIM_MIN)
    )
