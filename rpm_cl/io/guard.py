"""Inputs from strangers: what is checked before a byte of data is read.

Every input file is treated as hostile until its headers say otherwise:

- only a regular file is opened (after links): a FIFO blocks the reader
  forever, a link to ``/dev/zero`` or ``/dev/urandom`` never ends;
- every array's shape and dtype come from its header (an ``.npy`` member's
  header, an HDF5 dataset's metadata) and are checked against the others
  and against the memory a run on them would take (:func:`run_bytes`)
  before any data is read; above the limit (:func:`memory_limit`) the run
  is refused with the size named;
- a member that declares far more bytes than the file stores for it
  (:data:`BOMB_RATIO`) is a compression bomb or a corrupt header: refused
  without inflating it;
- an HDF5 dataset is read only from the file itself: external links,
  external raw storage and virtual datasets are refused (each would pull
  another file of the machine into the run).
"""

from __future__ import annotations

import os
import re
import stat

import numpy as np

from .data import InputError

__all__ = [
    "BOMB_MIN_BYTES",
    "BOMB_RATIO",
    "RUN_BASE_BYTES",
    "check_declared",
    "fmt_bytes",
    "h5_chunks_bounded",
    "h5_dataset",
    "h5_has",
    "h5_inside",
    "h5_resolve",
    "memory_limit",
    "parse_bytes",
    "regular_file",
    "run_bytes",
]

#: Share of the machine's memory a run may take when no limit is given: a
#: run holds a few copies of its data at once and the machine is shared.
MEMORY_SHARE = 0.5
#: Working memory of a run, in complex128 copies of its range profiles:
#: SPECTRUM_COPIES of the k-space spectrum, zero-padded PAD times along each
#: array axis (the decomposition's default ``KSpaceParams.pad``), and
#: DATA_COPIES of the profiles themselves (the input, its range compression,
#: windows, the back-projection's inputs).  A 187 x 144 planar scan of 300
#: gates peaked at 6.3 GB, 49 copies of its 129 MB of profiles; this counts
#: 52 there and 16 for a linear array.
SPECTRUM_COPIES = 3
DATA_COPIES = 4
PAD = 4
#: Fixed memory of a run, bytes: the interpreter, NumPy/SciPy and the OpenCL
#: runtime (a small run peaks at 230-280 MB resident).
RUN_BASE_BYTES = 512 << 20
#: Declared bytes per stored byte above which a member is refused as a
#: compression bomb (deflate cannot exceed ~1030:1; radar samples, noisy by
#: nature, compress by a few times at most).
BOMB_RATIO = 100
#: Members declaring less than this are never taken for bombs (a small
#: all-zero input compresses well and is harmless).
BOMB_MIN_BYTES = 64 << 20

_KINDS = (
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISDIR, "a folder"),
)


def regular_file(path, what: str = "input") -> str:
    """``path`` as a string if it names a regular file (after links).

    Raises
    ------
    InputError
        No such file, not readable, or not a regular file (a FIFO, a device
        such as ``/dev/zero``, a socket, a folder): one line naming it.
    """
    path = os.fspath(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read the {what} ({exc.strerror or exc})") from None
    if not stat.S_ISREG(st.st_mode):
        kind = next((name for test, name in _KINDS if test(st.st_mode)), "not a file")
        raise InputError(f"{path}: the {what} must be a regular file, this is {kind}")
    return path


def fmt_bytes(n: float) -> str:
    """``n`` bytes as a short decimal figure: '3.2 GB', '41 MB', '12 kB', '7 B'."""
    for unit, scale in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n:.0f} B"


#: Units of :func:`parse_bytes`: decimal (k, M, G, T, optionally with B) and
#: binary (KiB, MiB, GiB, TiB), case-insensitive; no unit means bytes.
_BYTE_UNITS = {
    "": 1,
    "b": 1,
    "k": 1e3,
    "kb": 1e3,
    "m": 1e6,
    "mb": 1e6,
    "g": 1e9,
    "gb": 1e9,
    "t": 1e12,
    "tb": 1e12,
    "kib": 2**10,
    "mib": 2**20,
    "gib": 2**30,
    "tib": 2**40,
}


def parse_bytes(text) -> int:
    """A size in bytes from a number (``8e9``) or a number with a unit
    (``8G``, ``512MB``, ``1.5GiB``; :data:`_BYTE_UNITS`).

    Raises
    ------
    InputError
        Not a positive size.
    """
    m = re.fullmatch(r"\s*([0-9.eE+-]+)\s*([A-Za-z]*)\s*", str(text))
    try:
        value = float(m.group(1)) * _BYTE_UNITS[m.group(2).lower()]
    except (AttributeError, KeyError, ValueError):
        value = float("nan")
    if not (value >= 1 and value < 1e18):
        raise InputError(
            f"a memory size must be a positive number of bytes (e.g. 8G, 512MB, "
            f"1.5GiB), got {text!r}"
        )
    return int(value)


def _physical_memory() -> int:
    try:
        return int(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):  # not POSIX: assume a small machine
        return 8 << 30


def memory_limit(limit=None) -> int:
    """The memory a run may take, bytes: ``limit`` (bytes or a size string,
    :func:`parse_bytes`), else the environment's ``RPM_CL_MAX_MEMORY``, else
    :data:`MEMORY_SHARE` of the machine's memory."""
    if limit is None:
        limit = os.environ.get("RPM_CL_MAX_MEMORY") or None
    if limit is None:
        return int(MEMORY_SHARE * _physical_memory())
    return parse_bytes(limit)


def run_bytes(samples: int, other_bytes: int = 0, array_axes: int = 1) -> int:
    """Memory a run on ``samples`` complex range-profile samples of an array
    with ``array_axes`` axes (1 linear, 2 planar) takes, bytes:
    :data:`RUN_BASE_BYTES`, 16 bytes a sample times
    ``SPECTRUM_COPIES * PAD ** array_axes + DATA_COPIES``, and
    ``other_bytes`` read beside them (axes, truth)."""
    copies = SPECTRUM_COPIES * PAD ** int(array_axes) + DATA_COPIES
    return RUN_BASE_BYTES + 16 * copies * int(samples) + int(other_bytes)


def check_budget(need: int, limit: int, what: str) -> None:
    """Refuse a run needing ``need`` bytes above ``limit`` (one line naming both)."""
    if need > limit:
        raise InputError(
            f"{what} would need about {fmt_bytes(need)} of memory, above the "
            f"limit of {fmt_bytes(limit)} (--max-memory / RPM_CL_MAX_MEMORY "
            f"raise it)"
        )


def check_declared(key: str, declared: int, stored: int) -> None:
    """Refuse a member declaring ``declared`` bytes of data in ``stored``
    bytes of file where that is a compression bomb or a corrupt header."""
    if declared >= BOMB_MIN_BYTES and declared > BOMB_RATIO * max(stored, 1):
        raise InputError(
            f"{key} declares {fmt_bytes(declared)} of data in "
            f"{fmt_bytes(stored)} of file ({declared / max(stored, 1):.0f}:1): a "
            f"compression bomb or a corrupt header; refused unread"
        )


def h5_has(f, key: str) -> bool:
    """Whether the HDF5 file ``f`` has a link ``key`` at its root (without
    following it: an external link is there, and refused when used)."""
    try:
        return f.get(key, getlink=True) is not None
    except (KeyError, ValueError, OSError, RuntimeError):
        return False


#: Most soft links followed on the way to one dataset (a loop ends here).
H5_LINK_HOPS = 16


def h5_resolve(f, path: str, name: str):
    """The object at ``path`` in the open file ``f``, reached one link at a
    time so that no link leads out of the file.

    h5py follows a chain of links by itself, and a soft link to a path
    through an external link opens another file (a FIFO there blocks) before
    the object could be looked at; here every step is seen first.

    Raises
    ------
    InputError
        No such object, an external link anywhere on the way, or more than
        :data:`H5_LINK_HOPS` soft links.
    """
    import h5py

    parts = [p for p in path.split("/") if p]
    node, hops = f["/"], 0
    while parts:
        part = parts.pop(0)
        try:
            link = node.get(part, getlink=True)
        except (KeyError, ValueError, OSError, RuntimeError):
            link = None
        if link is None:
            raise InputError(f"{name}: no such object ({path})")
        if isinstance(link, h5py.ExternalLink):
            raise InputError(
                f"{name} leads through an external link (to {link.filename}:"
                f"{link.path}); only data inside the input is read"
            )
        if isinstance(link, h5py.SoftLink):
            hops += 1
            if hops > H5_LINK_HOPS:
                raise InputError(f"{name}: more than {H5_LINK_HOPS} soft links (a loop?)")
            target = [p for p in link.path.split("/") if p]
            if link.path.startswith("/"):
                node = f["/"]
            parts = target + parts
            continue
        try:
            node = node[part]
        except (KeyError, ValueError, OSError, RuntimeError) as exc:
            raise InputError(f"{name} cannot be opened ({' '.join(str(exc).split())})") from None
        if parts and not isinstance(node, h5py.Group):
            raise InputError(f"{name}: {part} is not a group ({path})")
    return node


def h5_dataset(f, key: str):
    """The dataset ``key`` at the root of ``f``, if its data lives in ``f``
    (:func:`h5_resolve`, :func:`h5_inside`).

    Raises
    ------
    InputError
        ``key`` leads through an external link, is a group, a virtual
        dataset or one whose raw data is stored in external files, or a
        compressed chunk of it inflates beyond its size.
    """
    import h5py

    obj = h5_resolve(f, key, key)
    if not isinstance(obj, h5py.Dataset):
        raise InputError(f"{key} must be a dataset at the file root, not a group")
    h5_inside(f, obj, key)
    return obj


def h5_chunks_bounded(ds, name: str) -> None:
    """Refuse a deflate-compressed dataset one of whose chunks inflates to
    more than a chunk's bytes.

    HDF5's deflate filter grows its output buffer until the stream ends, so
    a chunk of a dataset that declares kilobytes can inflate to gigabytes
    before HDF5 keeps the chunk's share; each chunk is inflated here first,
    at most one chunk's bytes (the data's whole size, which the caller has
    budgeted, at most once)."""
    import zlib

    if ds.chunks is None or "gzip" not in (ds.compression or ""):
        return
    raw = int(np.prod(ds.chunks)) * ds.dtype.itemsize
    ident = ds.id
    try:
        n = ident.get_num_chunks()
    except Exception:  # noqa: BLE001 - an HDF5 too old to list chunks: nothing to check by
        return
    for i in range(n):
        try:
            offset = ident.get_chunk_info(i).chunk_offset
            _, buf = ident.read_direct_chunk(offset)
        except Exception as exc:  # noqa: BLE001 - a corrupt chunk index
            raise InputError(
                f"{name}: a chunk cannot be read ({' '.join(str(exc).split())})"
            ) from None
        d = zlib.decompressobj()
        try:
            d.decompress(buf, raw + 1)
        except zlib.error:
            continue  # not a plain deflate stream first (other filters): HDF5 judges it
        if d.unconsumed_tail or not (d.eof or len(buf) == 0):
            raise InputError(
                f"{name}: a compressed chunk inflates beyond the chunk's "
                f"{raw} bytes (a compression bomb or a corrupt file); refused"
            )


def h5_inside(f, ds, name: str) -> None:
    """Refuse the dataset ``ds`` of the open file ``f`` (named ``name`` in
    the message) unless its data live in ``f``: not reached through a link
    into another file, not virtual, no external raw storage."""
    if os.path.realpath(ds.file.filename) != os.path.realpath(f.filename):
        raise InputError(
            f"{name} leads to another file ({ds.file.filename}); only data inside the input is read"
        )
    if ds.is_virtual:
        raise InputError(
            f"{name} is a virtual dataset (its data lives in other files); only "
            f"data inside the input is read"
        )
    if ds.external:
        raise InputError(
            f"{name} keeps its data in external files; only data inside the input is read"
        )


def h5_stored(ds) -> int:
    """Bytes of file ``ds`` occupies (its storage size; 0 when unallocated)."""
    try:
        return int(ds.id.get_storage_size())
    except Exception:  # noqa: BLE001 - a corrupt layout: nothing known stored
        return 0
