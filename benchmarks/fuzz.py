"""Fuzz campaign: hostile and corrupted inputs through the CLI, seeded.

    python benchmarks/fuzz.py [--seed S] [--n N] [--out DIR] [--quick] [--jobs J]
                              [--timeout S] [--mem-cap GB] [--bomb-mb MB]

Base inputs are the paper's 2-D scene from ``rpm-cl simulate paper-2d``, as
.npz and .h5, in the time domain (``signal``/``range``) and re-expressed in the
frequency domain (``spectrum``/``frequency``: the simulated range profiles
transformed onto 81 frequencies over fc +- B), plus results of ``rpm-cl image``
and ``rpm-cl das`` for ``view``.  Each case mutates one of them (the families
in ``FAMILIES``), runs one command of the CLI (``image``, ``das``, ``view``,
``params``, ``batch``) in a fresh subprocess under a wall-clock limit and a
memory cap, and gets one outcome (``OUTCOMES``, first that applies):

overwritten   an input file's SHA-256 changed
outside-read  the marker planted in a file outside the input appears in the
              output or stdout, or a run whose data live only outside the input
              (HDF5 external storage, external link, virtual dataset) exited 0
hang          killed at the wall-clock limit (--timeout, or 4 x the slowest
              clean run of the command where that is longer)
memory        killed at the memory cap (the process group's summed RSS)
traceback     'Traceback' on stderr, or an exit status other than 0/1/2/130
garbage       exit 0 on an input with a few corrupted samples whose result
              collapsed against the clean run's (image: the share of points
              within 50 mm of a true target, or of true targets with a point
              within 50 mm, below half the clean run's, or more than 10 times
              its points; das: true targets within -6 dB of the image maximum
              below half the clean run's, or the maximum no longer within 50 mm
              of a target where the clean run's was); or exit 0 on an input in
              a wrong unit with no 'rpm-cl: warning:' line
leftover      an interrupted run left a temporary file beside its output
startup       a SIGINT that landed in Python's own start-up or in the module-level
              imports before rpm-cl's handlers exist (every rpm_cl frame of the
              KeyboardInterrupt's traceback, if any, at module level): outside
              reach (docs/decisions.md), Python's own traceback; not a target
slow-refusal  refused after more than 2 s, or with a peak RSS above 4 x the
              input's bytes on disk + the base (the largest RSS of refusing
              three tiny bad files: 10 bytes, an empty zip, an empty HDF5 file,
              and a clean input with an out-of-range --config value, refused
              once the engine is loaded; measured per command at the start,
              + 15 % for the modules a refusal's path imports)
slow-accept   exit 0 on a few-corrupted-samples input taking more than 2 x the
              median clean time of the same base and command, same run
bad-refusal   exit 2 but not exactly one line on stderr besides warnings
failed        exit 1 (batch: a frame failed, the others were imaged)
refused       exit 2 with one line
interrupted   exit 130 after SIGINT
accepted      exit 0

Prints a table of counts per family x outcome and writes OUT/cases.json (every
case: command line, mutation, exit status, time, peak RSS, flags).  The targets
are 0 hang, traceback, garbage, outside-read and overwritten (memory counts with
hang: a run stopped from outside).  ``tests/test_fuzz.py`` runs a fixed subset.
"""

import argparse
import hashlib
import io
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import zipfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

__all__ = [
    "FAILURES",
    "FAMILIES",
    "OUTCOMES",
    "Bases",
    "Case",
    "campaign",
    "classify",
    "main",
    "make_case",
    "run_case",
    "table",
]

C0 = 299792458.0
FAMILIES = (
    "bytes",
    "truncate",
    "dtypes",
    "extreme",
    "units",
    "zipbomb",
    "hdf5",
    "special",
    "outputs",
    "sigint",
    "config",
)
OUTCOMES = (
    "overwritten",
    "outside-read",
    "hang",
    "memory",
    "traceback",
    "garbage",
    "leftover",
    "startup",
    "slow-refusal",
    "slow-accept",
    "bad-refusal",
    "failed",
    "refused",
    "interrupted",
    "accepted",
)
# the targets (0 each); memory is a run stopped from outside, as a hang
FAILURES = ("overwritten", "outside-read", "hang", "memory", "traceback", "garbage")
GRID = "-0.3:0.3:0.01,0.2:0.6:0.01"
RADAR = ("td.npz", "td.h5", "fd.npz", "fd.h5")
REFUSE_S = 2.0  # a refusal later than this is slow
RSS_FACTOR = 4.0  # a refusal above this x the input's bytes (+ base) is slow
BASE_SLACK = 1.15  # the base RSS varies by the modules a refusal's path imports
ACCEPT_FACTOR = 2.0  # a few-bad-samples run above this x its clean time is slow
TOL = 0.05  # m: a point within this of a true target is accurate


# ----------------------------------------------------------------- files


def save_npz(path, d):
    np.savez(path, **d)


def save_h5(path, d):
    import h5py

    with h5py.File(path, "w") as f:
        for k, v in d.items():
            v = np.asarray(v)
            if v.dtype.kind in "UO":
                f.create_dataset(k, data=str(v), dtype=h5py.string_dtype("utf-8"))
            else:
                f.create_dataset(k, data=v)


def save(path, d):
    (save_h5 if str(path).endswith(".h5") else save_npz)(path, d)


def load(path):
    path = str(path)
    if path.endswith(".h5"):
        import h5py

        with h5py.File(path, "r") as f:
            return {k: (f[k].asstr()[()] if f[k].dtype.kind == "O" else f[k][()]) for k in f}
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def sha(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def to_spectrum(d, nf=81):
    """The simulated range profiles s(R) as frequency samples over fc +- B.

    The transform sum_R s(R) exp(-j 4 pi (f - fc) R / c) dR turns an echo
    a p(R - R0) exp(-j 2 k_c R0) into a P(f) exp(-j 4 pi f R0 / c), with P the
    simulator's pulse spectrum cos^2(pi (f - fc) / 2B); divided by P it is the
    schema's frequency-domain form, whose compression with the default Hann
    window over the band (the same cos^2) gives back the simulator's pulse.
    P is 0 at the two band edges, where the window is 0 too: those samples
    continue their neighbours' phase progression."""
    fc, b = float(d["fc"]), float(d["bandwidth"])
    r = d["range"]
    f = np.linspace(fc - b, fc + b, nf)
    kern = np.exp(-4j * np.pi * np.outer(r, f - fc) / C0) * (r[1] - r[0])
    y = d["signal"] @ kern
    p = np.cos(np.pi * (f - fc) / (2 * b)) ** 2
    y[:, 1:-1] /= p[1:-1]
    y[:, 0] = y[:, 1] ** 2 / y[:, 2]
    y[:, -1] = y[:, -2] ** 2 / y[:, -3]
    out = {k: v for k, v in d.items() if k not in ("signal", "range")}
    out["spectrum"] = y
    out["frequency"] = f
    return out


def npy_header(shape, dtype):
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buf,
        {
            "descr": np.lib.format.dtype_to_descr(np.dtype(dtype)),
            "fortran_order": False,
            "shape": tuple(shape),
        },
    )
    return buf.getvalue()


def npz_bomb(path, arrays, key, shape, dtype, inflate):
    """An .npz whose member ``key`` declares ``shape`` and inflates ``inflate``
    bytes of zeros (deflated: about 1/1000 of that on disk); the others as
    they are."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED, allowZip64=True) as z:
        for k, v in arrays.items():
            if k != key:
                buf = io.BytesIO()
                np.lib.format.write_array(buf, np.asarray(v), allow_pickle=False)
                z.writestr(k + ".npy", buf.getvalue())
        zi = zipfile.ZipInfo(key + ".npy", date_time=(2020, 1, 1, 0, 0, 0))
        zi.compress_type = zipfile.ZIP_DEFLATED
        with z.open(zi, "w", force_zip64=True) as f:
            f.write(npy_header(shape, dtype))
            block = bytes(16 << 20)
            left = inflate
            while left > 0:
                f.write(block[: min(left, len(block))])
                left -= len(block)


# ----------------------------------------------------------------- running


def _group_hwm(pgid):
    """Summed peak RSS (VmHWM, bytes) of the processes in group ``pgid``:
    the peak of each process's own memory since its exec (wait4's
    ru_maxrss would also count the harness's memory the child shared
    between fork and exec)."""
    total = 0
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            if os.getpgid(int(name)) != pgid:
                continue
            with open(f"/proc/{name}/status") as f:
                hwm = next((line for line in f if line.startswith("VmHWM:")), None)
        except (OSError, ProcessLookupError):
            continue
        if hwm:
            total += int(hwm.split()[1]) * 1024
    return total


def _group_rss(pgid):
    """Summed RSS (bytes) of the processes in process group ``pgid``."""
    total = 0
    page = os.sysconf("SC_PAGE_SIZE")
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat") as f:
                s = f.read()
        except OSError:
            continue
        rest = s[s.rfind(")") + 2 :].split()
        if len(rest) > 21 and int(rest[2]) == pgid:
            total += int(rest[21]) * page
    return total


def run_cli(argv, cwd, timeout, mem_cap, sigint_at=None):
    """``python -m rpm_cl argv`` in its own session; returns exit status
    (negative: signal), wall time, peak RSS (the group's summed VmHWM and
    RSS, polled every 0.05 s), stdout/stderr, and whether it was killed."""
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONUNBUFFERED="1")
    out, err = Path(cwd) / ".stdout", Path(cwd) / ".stderr"
    with open(out, "wb") as fo, open(err, "wb") as fe:
        t0 = time.perf_counter()
        p = subprocess.Popen(
            [sys.executable, "-m", "rpm_cl", *argv],
            cwd=cwd,
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=fo,
            stderr=fe,
            start_new_session=True,
        )
    peak, killed, sent, status = 0, None, False, None
    while True:
        pid, status, _ = os.wait4(p.pid, os.WNOHANG)
        if pid:
            break
        now = time.perf_counter() - t0
        rss = _group_rss(p.pid)
        peak = max(peak, rss, _group_hwm(p.pid))
        if sigint_at is not None and not sent and now >= sigint_at:
            _signal_group(p.pid, signal.SIGINT)
            sent = True
        if now > timeout:
            killed = "hang"
        elif rss > mem_cap:
            killed = "memory"
        if killed:
            _signal_group(p.pid, signal.SIGKILL)
            _, status, _ = os.wait4(p.pid, 0)
            break
        time.sleep(0.05)
    wall = time.perf_counter() - t0
    _signal_group(p.pid, signal.SIGKILL)  # workers left behind by the run
    rc = os.waitstatus_to_exitcode(status)
    p.returncode = rc

    def text(path):
        with open(path, "rb") as f:
            return f.read(1 << 20).decode("utf-8", "replace")

    return {
        "rc": rc,
        "wall": wall,
        "rss": peak,
        "killed": killed,
        "stdout": text(out),
        "stderr": text(err),
        "sigint_sent": sent,
    }


def _signal_group(pgid, sig):
    try:
        os.killpg(pgid, sig)
    except (ProcessLookupError, PermissionError):
        pass


# ----------------------------------------------------------------- bases


class Bases:
    """The clean inputs of a campaign under ``root/bases``, made once."""

    def __init__(self, root, bomb_bytes, seed):
        self.dir = Path(root) / "bases"
        self.dir.mkdir(parents=True, exist_ok=True)
        self.bomb_bytes = bomb_bytes
        self.marker = f"FUZZ-OUTSIDE-{seed:08x}-{os.getpid():x}".encode()
        d = self.dir
        if not (d / "td.npz").exists():
            for name in ("td.npz", "td.h5"):
                r = run_cli(["simulate", "paper-2d", "-o", str(d / name), "-q"], d, 120, 8 << 30)
                if r["rc"] != 0:
                    raise RuntimeError("simulate failed: " + r["stderr"])
            fd = to_spectrum(load(d / "td.npz"))
            save(d / "fd.npz", fd)
            save(d / "fd.h5", fd)
            for args in (
                ["image", "td.npz", "-o", "res.npz"],
                ["image", "td.npz", "-o", "res.h5"],
                ["das", "td.npz", "-o", "das.npz", "--grid", GRID],
            ):
                r = run_cli(args + ["-q"], d, 120, 8 << 30)
                if r["rc"] != 0:
                    raise RuntimeError(f"{args} failed: " + r["stderr"])
        self.arrays = {name: load(d / name) for name in (*RADAR, "res.npz", "das.npz")}
        self.truth = np.asarray(self.arrays["td.npz"]["truth_boundary"], float)
        self._bombs = {}

    def path(self, name):
        return self.dir / name

    def bomb(self, variant):
        """A cached zip bomb (an .npz) of the variant's name."""
        if variant in self._bombs:
            return self._bombs[variant]
        n = self.bomb_bytes
        path = self.dir / f"bomb-{variant}-{n >> 20}M.npz"
        if not path.exists():
            base, key, shape, dtype, inflate = {
                # an unused member (the truth boundary) of n bytes
                "unused": ("td.npz", "truth_boundary", (n // 16, 2), "f8", n),
                "signal": ("td.npz", "signal", (21, n // 336), "c16", n),
                "x": ("td.npz", "x", (n // 8,), "f8", n),
                "spectrum": ("fd.npz", "spectrum", (21, n // 336), "c16", n),
                "points": ("res.npz", "points", (n // 16, 2), "f8", n),
                # the header declares 336 GB, the stream holds 1 MB
                "declared": ("td.npz", "signal", (21, 10**9), "c16", 1 << 20),
            }[variant]
            tmp = path.with_suffix(".part")
            npz_bomb(tmp, self.arrays[base], key, shape, dtype, inflate)
            os.replace(tmp, path)
        self._bombs[variant] = path
        return path


# ----------------------------------------------------------------- cases


@dataclass
class Case:
    id: int
    family: str
    mutation: str
    base: str
    command: str = ""
    argv: list = field(default_factory=list)
    dir: str = ""
    inputs: list = field(default_factory=list)  # files whose hash must not change
    outdir: str = ""  # where outputs go (leftovers, marker)
    output: str = ""  # the result file to score
    few: bool = False  # a few corrupted samples: garbage and slow-accept apply
    units: bool = False  # a wrong unit: exit 0 needs a warning line
    outside: bool = False  # the data live only outside the input: exit 0 read them
    sigint: float | None = None
    data_bytes: int = 0
    detail: dict = field(default_factory=dict)


class Maker:
    """What a mutator gets: the generator, the case folder and the bases."""

    def __init__(self, rng, cdir, bases, command=None):
        self.rng, self.dir, self.b, self.command = rng, Path(cdir), bases, command

    def radar(self, names=RADAR):
        name = names[int(self.rng.integers(len(names)))]
        return name, {k: np.array(v) for k, v in self.b.arrays[name].items()}

    def write(self, name, d, ext=None):
        path = self.dir / ("in" + (ext or Path(name).suffix))
        save(path, d)
        return path

    def copy(self, name):
        path = self.dir / ("in" + Path(name).suffix)
        shutil.copyfile(self.b.path(name), path)
        return path

    def outside(self, data: bytes):
        o = self.dir / "outside"
        o.mkdir(exist_ok=True)
        path = o / f"secret{len(list(o.iterdir()))}.bin"
        path.write_bytes(data + b"\0" + self.b.marker + b"\0")
        return path


def key_of(d):
    return ("signal", "range") if "signal" in d else ("spectrum", "frequency")


# a mutator returns a dict: input (path), base (name), kind ('radar', 'result',
# 'image'), and optional few/units/outside/config/argv/command/sigint


def m_flip(mk, mode):
    names = (*RADAR, "res.npz", "res.h5", "das.npz")
    name = names[int(mk.rng.integers(len(names)))]
    path = mk.copy(name)
    buf = bytearray(path.read_bytes())
    n = {"bit": 1, "byte": 1, "few": 8, "many": 64}[mode]
    lo, hi = 0, len(buf)
    region = ("any", "head", "tail")[int(mk.rng.integers(3))]
    if region == "head":
        hi = min(len(buf), 1024)
    elif region == "tail":
        lo = max(0, len(buf) - 1024)
    where = mk.rng.integers(lo, hi, n)
    for i in where:
        buf[i] ^= (1 << int(mk.rng.integers(8))) if mode == "bit" else int(mk.rng.integers(1, 256))
    path.write_bytes(bytes(buf))
    kind = "radar" if name in RADAR else ("image" if name == "das.npz" else "result")
    return {
        "input": path,
        "base": name,
        "kind": kind,
        "few": n <= 8 and kind == "radar",
        "detail": {"region": region, "offsets": [int(i) for i in where]},
    }


def m_truncate(mk, mode):
    names = (*RADAR, "res.npz", "res.h5", "das.npz")
    name = names[int(mk.rng.integers(len(names)))]
    path = mk.copy(name)
    buf = path.read_bytes()
    size = {
        "empty": 0,
        "tiny": int(mk.rng.integers(1, 64)),
        "half": len(buf) // 2,
        "random": int(mk.rng.integers(1, len(buf))),
        "minus1": len(buf) - 1,
    }[mode]
    path.write_bytes(buf[:size])
    kind = "radar" if name in RADAR else ("image" if name == "das.npz" else "result")
    return {"input": path, "base": name, "kind": kind, "detail": {"size": size}}


def _dtype_mutations():
    """(name, function of (d, rng) editing the arrays of a radar input)."""

    def data(f):
        def g(d, rng):
            k = key_of(d)[0]
            d[k] = f(d[k])

        return g

    def axis(f):
        def g(d, rng):
            k = key_of(d)[1]
            d[k] = f(d[k])

        return g

    def put(k, v):
        def g(d, rng):
            d[k] = v() if callable(v) else v

        return g

    def drop(k):
        def g(d, rng):
            d.pop(k if k not in ("DATA", "AXIS") else key_of(d)[k == "AXIS"], None)

        return g

    return [
        ("data-real", data(lambda s: s.real.copy())),
        ("data-int16", data(lambda s: (s.real * 1000).astype(np.int16))),
        ("data-bool", data(lambda s: s.real > 0)),
        ("data-str", data(lambda s: np.array("not an array"))),
        ("data-bytes", data(lambda s: np.frombuffer(s.tobytes(), np.uint8).copy())),
        ("data-float16", data(lambda s: s.real.astype(np.float16))),
        ("data-bigendian", data(lambda s: s.astype(">c16"))),
        ("data-clongdouble", data(lambda s: s.astype(np.clongdouble))),
        ("data-transposed", data(lambda s: s.T.copy())),
        ("data-1d", data(lambda s: s.ravel())),
        ("data-3d-extra", data(lambda s: s[None, :, None, :])),
        ("data-empty", data(lambda s: s[:, :0])),
        ("data-scalar", data(lambda s: s[0, 0])),
        ("data-one-column", data(lambda s: s[:, :1])),
        ("data-fortran", data(lambda s: np.asfortranarray(s))),
        ("data-stack1", data(lambda s: s[None])),
        ("data-compound", data(lambda s: np.rec.fromarrays([s.real, s.imag], names="r,i"))),
        ("x-short", lambda d, rng: d.__setitem__("x", d["x"][:-1])),
        ("x-2d", lambda d, rng: d.__setitem__("x", d["x"][:, None])),
        ("x-complex", lambda d, rng: d.__setitem__("x", d["x"] + 0j)),
        ("x-int", lambda d, rng: d.__setitem__("x", (d["x"] * 1000).astype(np.int64))),
        ("x-unsorted", lambda d, rng: d.__setitem__("x", d["x"][::-1].copy())),
        ("x-duplicate", lambda d, rng: d.__setitem__("x", np.r_[d["x"][:1], d["x"][:-1]])),
        ("x-str", put("x", np.array("0.0,0.005"))),
        ("axis-descending", axis(lambda r: r[::-1].copy())),
        ("axis-nonuniform", axis(lambda r: r * (1 + 0.01 * np.linspace(0, 1, r.size) ** 2))),
        ("axis-short", axis(lambda r: r[:-1])),
        ("fc-array", lambda d, rng: d.__setitem__("fc", np.array([d["fc"], d["fc"]]))),
        ("fc-str", put("fc", np.array("20 GHz"))),
        ("fc-complex", lambda d, rng: d.__setitem__("fc", np.complex128(d["fc"]))),
        ("bandwidth-negative", lambda d, rng: d.__setitem__("bandwidth", -d["bandwidth"])),
        ("bandwidth-zero", put("bandwidth", np.float64(0))),
        ("missing-data", drop("DATA")),
        ("missing-axis", drop("AXIS")),
        ("missing-x", drop("x")),
        ("missing-fc", drop("fc")),
        (
            "both-domains",
            lambda d, rng: d.update(
                {"range": np.linspace(0, 1.5, 600), "signal": np.zeros((21, 600), complex)}
                if "spectrum" in d
                else {
                    "frequency": np.linspace(19.8e9, 20.2e9, 81),
                    "spectrum": np.zeros((21, 81), complex),
                }
            ),
        ),
        (
            "truth-antenna-float",
            lambda d, rng: d.__setitem__(
                "truth_rp_antenna", d["truth_rp_antenna"].astype(float) + 0.5
            ),
        ),
        (
            "truth-antenna-outside",
            lambda d, rng: d.__setitem__("truth_rp_antenna", d["truth_rp_antenna"] + 10**6),
        ),
        ("truth-boundary-shape", put("truth_boundary", np.zeros((3, 5)))),
        ("truth-scene-json", put("truth_scene", np.array("{not json"))),
        ("truth-scene-deep", put("truth_scene", np.array("[" * 100000 + "]" * 100000))),
        ("truth-scene-number", put("truth_scene", np.float64(3))),
        ("extra-key", put("unexpected", np.arange(10))),
        ("object-array", put("x", np.array([0.0, "a", None], dtype=object))),
    ]


DTYPES = _dtype_mutations()


def m_dtype(mk, name):
    fn = dict(DTYPES)[name]
    base, d = mk.radar()
    fn(d, mk.rng)
    if name == "object-array" or (base.endswith(".h5") and name in ("data-compound",)):
        base = base.replace(".h5", ".npz")
    if base.endswith(".h5") and name == "data-clongdouble":
        base = base.replace(".h5", ".npz")
    return {"input": mk.write(base, d), "base": base, "kind": "radar"}


def _view_mutation(mk, name):
    if name.startswith("das-"):
        d = {k: np.array(v) for k, v in mk.b.arrays["das.npz"].items()}
        if name == "das-axis-inf":
            d["x"] = d["x"].copy()
            d["x"][-1] = np.inf
        elif name == "das-axis-overflow":
            with np.errstate(over="ignore", invalid="ignore"):  # the point: inf axes
                d["x"] = np.linspace(-1e308, 1e308, d["x"].size) * 1.5
        elif name == "das-nan-pixel":
            d["image"].flat[7] = np.nan
        elif name == "das-huge-pixel":
            d["image"].flat[7] = 1e300
        elif name == "das-shape":
            d["image"] = d["image"][:, :-1]
        elif name == "das-zero":
            d["image"][:] = 0
        path = mk.dir / "in.npz"
        save_npz(path, d)
        return {"input": path, "base": "das.npz", "kind": "image"}
    d = {k: np.array(v) for k, v in mk.b.arrays["res.npz"].items()}
    if name == "points-nan":
        d["points"][3, 0] = np.nan
    elif name == "points-huge":
        d["points"][3, 0] = 1e300
    elif name == "points-shape":
        d["points"] = np.zeros((5, 7))
    elif name == "points-str":
        d["points"] = np.array("points")
    elif name == "meta-json":
        d["meta"] = np.array("{broken")
    elif name == "points-empty":
        d = {k: v[:0] if v.ndim else v for k, v in d.items()}
    path = mk.write("res.npz" if mk.rng.random() < 0.5 else "res.h5", d)
    return {"input": path, "base": "res", "kind": "result"}


VIEW_DTYPES = (
    "das-axis-inf",
    "das-axis-overflow",
    "das-shape",
    "das-zero",
    "points-shape",
    "points-str",
    "meta-json",
    "points-empty",
)
VIEW_EXTREME = ("das-nan-pixel", "das-huge-pixel", "points-nan", "points-huge")


def m_dtype_any(mk, name):
    return _view_mutation(mk, name) if name in VIEW_DTYPES else m_dtype(mk, name)


def m_extreme(mk, name):
    if name in VIEW_EXTREME:
        return _view_mutation(mk, name)
    base, d = mk.radar()
    k, ax = key_of(d)
    s = d[k] = d[k].astype(np.complex128)
    flat = s.reshape(-1)
    peak = np.abs(flat).max()
    # a sample near the echoes, where a corruption does most harm
    i = int(np.argmax(np.abs(flat) * (mk.rng.random(flat.size) < 0.2)))
    few = True
    one = {
        "one-1e300": 1e300,
        "one-neg-3.6e64": -3.6e64,
        "one-1e30": 1e30,
        "one-nan": np.nan,
        "one-inf": np.inf,
        "one-neg-inf": -np.inf,
        "one-nan-imag": complex(0, np.nan),
        "one-1e3x": 1e3 * peak,
    }
    if name in one:
        flat[i] = one[name]
    elif name.startswith("spikes-"):
        n, scale = {"spikes-3x1e3": (3, 1e3), "spikes-5x1e6": (5, 1e6), "spikes-10x1e2": (10, 1e2)}[
            name
        ]
        j = mk.rng.choice(flat.size, n, replace=False)
        flat[j] = scale * peak * np.exp(2j * np.pi * mk.rng.random(n))
    else:
        few = False
        edits = {
            "all-zero": lambda: s.__imul__(0),
            "scale-1e-300": lambda: s.__imul__(1e-300),
            "scale-1e250": lambda: s.__imul__(1e250),
            "fc-1e30": lambda: d.__setitem__("fc", np.float64(1e30)),
            "fc-1e-30": lambda: d.__setitem__("fc", np.float64(1e-30)),
            "fc-inf": lambda: d.__setitem__("fc", np.float64(np.inf)),
            "fc-nan": lambda: d.__setitem__("fc", np.float64(np.nan)),
            "bandwidth-1e30": lambda: d.__setitem__("bandwidth", np.float64(1e30)),
            "bandwidth-200Hz": lambda: d.__setitem__("bandwidth", np.float64(200.0)),
            "x-1e200": lambda: d.__setitem__("x", d["x"] * 1e200),
            "x-nan": lambda: d["x"].__setitem__(3, np.nan),
            "axis-1e300": lambda: d.__setitem__(ax, d[ax] * 1e290),
            "axis-inf": lambda: d[ax].__setitem__(-1, np.inf),
        }
        edits[name]()
    return {
        "input": mk.write(base, d),
        "base": base,
        "kind": "radar",
        "few": few,
        "detail": {"sample": i} if few else {},
    }


EXTREME = (
    "one-1e300",
    "one-neg-3.6e64",
    "one-1e30",
    "one-nan",
    "one-inf",
    "one-neg-inf",
    "one-nan-imag",
    "one-1e3x",
    "spikes-3x1e3",
    "spikes-5x1e6",
    "spikes-10x1e2",
    "all-zero",
    "scale-1e-300",
    "scale-1e250",
    "fc-1e30",
    "fc-1e-30",
    "fc-inf",
    "fc-nan",
    "bandwidth-1e30",
    "bandwidth-200Hz",
    "x-1e200",
    "x-nan",
    "axis-1e300",
    "axis-inf",
    *VIEW_EXTREME,
)


def m_units(mk, name):
    base, d = mk.radar()
    ax = key_of(d)[1]
    freq = {"GHz": 1e-9, "MHz": 1e-6, "kHz": 1e-3}
    unit = name.split("-")[1]
    if name.startswith("f-"):
        for key in ("fc", "bandwidth", "frequency"):
            if key in d:
                d[key] = d[key] * freq[unit]
    elif name.startswith("x-"):
        d["x"] = d["x"] * {"mm": 1e3, "cm": 1e2, "km": 1e-3}[unit]
    elif name.startswith("range-"):
        if ax != "range":
            base = base.replace("fd", "td")
            d = {k2: np.array(v) for k2, v in mk.b.arrays[base].items()}
        d["range"] = d["range"] * {"mm": 1e3, "cm": 1e2}[unit]
    return {"input": mk.write(base, d), "base": base, "kind": "radar", "units": True}


UNITS = ("f-GHz", "f-MHz", "f-kHz", "x-mm", "x-cm", "x-km", "range-mm", "range-cm")


def m_zipbomb(mk, name):
    if name == "many-members":
        base = "td.npz"
        path = mk.dir / "in.npz"
        with zipfile.ZipFile(path, "w") as z:
            for k, v in mk.b.arrays[base].items():
                buf = io.BytesIO()
                np.lib.format.write_array(buf, np.asarray(v), allow_pickle=False)
                z.writestr(k + ".npy", buf.getvalue())
            member = npy_header((0,), "f8")
            for j in range(20000):
                z.writestr(f"junk{j}.npy", member)
        return {"input": path, "base": base, "kind": "radar"}
    if name == "zip-in-zip":
        inner = mk.b.bomb("unused").read_bytes()
        path = mk.dir / "in.npz"
        with zipfile.ZipFile(path, "w") as z:
            for k, v in mk.b.arrays["td.npz"].items():
                if k != "signal":
                    buf = io.BytesIO()
                    np.lib.format.write_array(buf, np.asarray(v), allow_pickle=False)
                    z.writestr(k + ".npy", buf.getvalue())
            z.writestr("signal.npy", inner)
        return {"input": path, "base": "td.npz", "kind": "radar"}
    path = mk.dir / "in.npz"
    shutil.copyfile(mk.b.bomb(name), path)
    return {"input": path, "base": name, "kind": "result" if name == "points" else "radar"}


ZIPBOMB = ("unused", "signal", "x", "spectrum", "points", "declared", "many-members", "zip-in-zip")


def m_hdf5(mk, name):
    import h5py

    base = ("td.h5", "fd.h5")[int(mk.rng.integers(2))]
    d = {k: np.array(v) for k, v in mk.b.arrays[base].items()}
    k = key_of(d)[0]
    path = mk.dir / "in.h5"
    outside = name.startswith(("external", "extlink", "virtual"))
    target = {"x": "x", "data": k, "scene": "truth_scene"}[name.split("-")[-1]] if outside else None
    special = {}
    if name == "chunked-1e9-x":
        special["x"] = ("chunked", (10**9,), "f8")
    elif name == "chunked-1e9-data":
        special[k] = ("chunked", (21, 5 * 10**7), "c16")
    elif name == "chunked-1e9-unused":
        special["truth_boundary"] = ("chunked", (10**9, 2), "f8")
    elif name == "chunked-maxshape":
        special["x"] = ("resizable", None, None)
    with h5py.File(path, "w") as f:
        for key, v in d.items():
            if key == target:
                continue
            if key in special:
                how, shape, dt = special[key]
                if how == "chunked":
                    f.create_dataset(
                        key, shape=shape, dtype=dt, chunks=tuple(min(n, 4096) for n in shape)
                    )
                else:
                    ds = f.create_dataset(key, data=v, maxshape=(None,), chunks=(4,))
                    ds.resize((10**9,))
                continue
            if name.startswith("group-") and key == {
                "group-data": k,
                "group-x": "x",
                "group-fc": "fc",
            }.get(name):
                g = f.create_group(key)
                g.create_dataset("value", data=v)
                continue
            if v.dtype.kind in "UO":
                f.create_dataset(key, data=str(v), dtype=h5py.string_dtype("utf-8"))
            else:
                f.create_dataset(key, data=v)
        if name == "group-root":
            pass
        if name == "softlink-loop":
            del f["x"]
            f["x"] = h5py.SoftLink("/x")
        if name == "softlink-dangling":
            del f["x"]
            f["x"] = h5py.SoftLink("/nowhere")
        if name == "null-fc":
            del f["fc"]
            f.create_dataset("fc", data=h5py.Empty("f8"))
        if outside:
            v = d[target]
            if target == "truth_scene":
                scene = json.loads(str(v))
                scene["name"] = mk.b.marker.decode()
                raw = np.array(json.dumps(scene).encode())
            else:
                raw = np.ascontiguousarray(v)
            if name.startswith("external"):
                sec = mk.outside(raw.tobytes())
                f.create_dataset(
                    target, shape=raw.shape, dtype=raw.dtype, external=[(str(sec), 0, raw.nbytes)]
                )
            elif name.startswith("extlink"):
                other = mk.dir / "outside" / "other.h5"
                other.parent.mkdir(exist_ok=True)
                with h5py.File(other, "w") as o:
                    o.create_dataset(target, data=raw)
                    o.attrs["marker"] = mk.b.marker
                f[target] = h5py.ExternalLink(str(other), "/" + target)
            else:
                other = mk.dir / "outside" / "vsource.h5"
                other.parent.mkdir(exist_ok=True)
                with h5py.File(other, "w") as o:
                    o.create_dataset(target, data=raw)
                    o.attrs["marker"] = mk.b.marker
                lay = h5py.VirtualLayout(shape=raw.shape, dtype=raw.dtype)
                lay[...] = h5py.VirtualSource(str(other), target, shape=raw.shape)
                f.create_virtual_dataset(target, lay)
    if name == "group-root":
        with h5py.File(path, "w") as f:
            g = f.create_group("data")
            for key, v in d.items():
                if v.dtype.kind not in "UO":
                    g.create_dataset(key, data=v)
    return {
        "input": path,
        "base": base,
        "kind": "radar",
        "outside": outside and target != "truth_scene",
    }


HDF5 = (
    "chunked-1e9-x",
    "chunked-1e9-data",
    "chunked-1e9-unused",
    "chunked-maxshape",
    "external-x",
    "external-data",
    "external-scene",
    "extlink-x",
    "extlink-data",
    "extlink-scene",
    "virtual-x",
    "virtual-data",
    "group-data",
    "group-x",
    "group-fc",
    "group-root",
    "softlink-loop",
    "softlink-dangling",
    "null-fc",
)


def m_special(mk, name):
    ext = (".npz", ".h5")[int(mk.rng.integers(2))]
    base = "td" + ext
    path = mk.dir / ("in" + ext)
    config = None
    if name == "fifo":
        os.mkfifo(path)
    elif name in ("dev-zero", "dev-urandom"):
        os.symlink("/dev/" + name[4:], path)
    elif name == "dev-null":
        os.symlink("/dev/null", path)
    elif name == "directory":
        path.mkdir()
    elif name == "dangling":
        os.symlink(mk.dir / "nowhere", path)
    elif name == "loop":
        os.symlink(path, path)
    elif name.startswith("config-"):
        shutil.copyfile(mk.b.path(base), path)
        config = mk.dir / "c.toml"
        what = name[7:]
        if what == "fifo":
            os.mkfifo(config)
        else:
            os.symlink("/dev/" + what, config)
    kind = "radar"
    if name == "view-fifo":
        path = mk.dir / "in.npz"
        os.mkfifo(path)
        kind = "result"
    return {"input": path, "base": base, "kind": kind, "config": config}


SPECIAL = (
    "fifo",
    "dev-zero",
    "dev-urandom",
    "dev-null",
    "directory",
    "dangling",
    "loop",
    "config-fifo",
    "config-zero",
    "config-urandom",
    "view-fifo",
)


def m_outputs(mk, name):
    base = RADAR[int(mk.rng.integers(4))]
    path = mk.copy(base)
    cmd = mk.command or ("image", "das", "params", "batch")[int(mk.rng.integers(4))]
    ext = Path(base).suffix
    if name == "same":
        out = path
    elif name == "symlink":
        out = mk.dir / ("link" + ext)
        os.symlink(path, out)
    elif name == "hardlink":
        out = mk.dir / ("hard" + ext)
        os.link(path, out)
    elif name == "relative":
        out = Path("..") / mk.dir.name / path.name
    elif name == "dir-symlink":
        alias = mk.dir / "alias"
        os.symlink(mk.dir, alias)
        out = alias / path.name
    elif name == "config":
        config = mk.dir / "c.toml"
        config.write_text("[rpm]\nsigma_x = 0.1\n")
        return {
            "input": path,
            "base": base,
            "kind": "radar",
            "config": config,
            "command": cmd if cmd != "batch" else "image",
            "out": config,
        }
    elif name == "view-png-input":
        res = mk.copy("res.npz")
        return {"input": res, "base": "res", "kind": "result", "command": "view", "out": res}
    elif name == "existing-dir":
        out = mk.dir / "adir"
        out.mkdir()
        (out / "keep.txt").write_text("keep")
        return {
            "input": path,
            "base": base,
            "kind": "radar",
            "out": out,
            "command": "image",
            "keep": out / "keep.txt",
        }
    if cmd == "batch":
        # the output folder is the input folder, or the frame itself
        return {
            "input": path,
            "base": base,
            "kind": "radar",
            "command": "batch",
            "out": "FRAMES" if name in ("same", "relative") else out,
        }
    return {"input": path, "base": base, "kind": "radar", "command": cmd, "out": out}


OUTPUTS = (
    "same",
    "symlink",
    "hardlink",
    "relative",
    "dir-symlink",
    "config",
    "view-png-input",
    "existing-dir",
)


def m_sigint(mk, name):
    cmd = name
    if cmd == "view":
        return {
            "input": mk.copy("res.npz"),
            "base": "res",
            "kind": "result",
            "command": "view",
            "sigint": float(mk.rng.uniform(0.0, 2.5)),
        }
    base = RADAR[int(mk.rng.integers(4))]
    late = 4.0 if cmd == "batch" else 2.0
    return {
        "input": mk.copy(base),
        "base": base,
        "kind": "radar",
        "command": cmd,
        "sigint": float(mk.rng.uniform(0.0, late)),
    }


SIGINT = ("image", "das", "params", "batch", "view")


def m_config(mk, name):
    base = RADAR[int(mk.rng.integers(4))]
    path = mk.copy(base)
    config = mk.dir / "c.toml"
    text = {
        "deep-arrays": "a = " + "[" * 50000 + "]" * 50000 + "\n",
        "deep-tables": "a = " + "{b = " * 3000 + "1" + "}" * 3000 + "\n",
        "huge-int": "[kspace]\npad = 100000000000000000000000000000\n",
        "nan": "[rpm]\nsigma_x = nan\n",
        "inf": "[rpm]\nsigma_r = inf\n",
        "negative": "[rpm]\nsigma_x = -1.0\n",
        "zero-pad": "[kspace]\npad = 0\n",
        "chunk-1": "[rpm]\nchunk_slots = 1\n",
        "string-number": '[rpm]\nsigma_x = "0.1"\n',
        "unknown": "[nope]\nx = 1\n",
        "binary": None,
        "long-line": "# " + "x" * 5_000_000 + "\n",
    }[name]
    if text is None:
        config.write_bytes(bytes(mk.rng.integers(0, 256, 4096, dtype=np.uint8)))
    else:
        config.write_text(text)
    return {"input": path, "base": base, "kind": "radar", "config": config}


CONFIG = (
    "deep-arrays",
    "deep-tables",
    "huge-int",
    "nan",
    "inf",
    "negative",
    "zero-pad",
    "chunk-1",
    "string-number",
    "unknown",
    "binary",
    "long-line",
)

MUTATIONS = {
    "bytes": (m_flip, ("bit", "byte", "few", "many")),
    "truncate": (m_truncate, ("empty", "tiny", "half", "random", "minus1")),
    "dtypes": (m_dtype_any, tuple(n for n, _ in DTYPES) + VIEW_DTYPES),
    "extreme": (m_extreme, EXTREME),
    "units": (m_units, UNITS),
    "zipbomb": (m_zipbomb, ZIPBOMB),
    "hdf5": (m_hdf5, HDF5),
    "special": (m_special, SPECIAL),
    "outputs": (m_outputs, OUTPUTS),
    "sigint": (m_sigint, SIGINT),
    "config": (m_config, CONFIG),
}


def make_case(cid, family, mutation, root, bases, rng, command=None):
    """Write case ``cid``'s files under ``root/cases/cid`` and build its
    command line.  ``command`` forces the command of a radar input."""
    cdir = Path(root) / "cases" / f"{cid:04d}"
    shutil.rmtree(cdir, ignore_errors=True)
    cdir.mkdir(parents=True)
    fn, _ = MUTATIONS[family]
    m = fn(Maker(rng, cdir, bases, command), mutation)
    inp = Path(m["input"])
    kind = m["kind"]
    if "command" in m:
        cmd = m["command"]
    elif kind != "radar":
        cmd = "view"
    else:
        cmd = command or ("image", "image", "das", "params", "batch")[int(rng.integers(5))]
    case = Case(
        cid,
        family,
        mutation,
        m["base"],
        cmd,
        dir=str(cdir),
        few=m.get("few", False),
        units=m.get("units", False),
        outside=m.get("outside", False),
        sigint=m.get("sigint"),
        detail=m.get("detail", {}),
    )
    outdir = cdir / "out"
    outdir.mkdir()
    out = m.get("out")
    if cmd == "batch":
        frames = cdir / "frames"
        frames.mkdir()
        clean = bases.path(m["base"] if m["base"] in RADAR else "td.npz")
        shutil.copyfile(clean, frames / ("a" + clean.suffix))
        moved = frames / ("b" + "".join(inp.suffixes[-1:]))
        os.rename(inp, moved)
        inp = moved
        if out == "FRAMES":
            out = frames
        target = out or outdir
        argv = ["batch", str(frames), "-o", str(target), "--workers", "1"]
        case.output = str(outdir / ("b.npz"))
    elif cmd == "view":
        png = out or outdir / "v.png"
        argv = ["view", str(inp), "--png", str(png)]
        case.output = str(png)
    else:
        suffix = {"params": ".toml", "das": ".npz"}.get(
            cmd, ".h5" if rng.random() < 0.3 else ".npz"
        )
        target = out or outdir / ("result" + suffix)
        argv = [cmd, str(inp)]
        if cmd == "das":
            argv += ["--grid", GRID]
        if cmd != "params" or out or rng.random() < 0.5:
            argv += ["-o", str(target)]
        case.output = str(target)
    if m.get("config"):
        argv += ["--config", str(m["config"])]
    case.argv = argv
    case.outdir = str(outdir)
    files = [
        p for p in cdir.rglob("*") if p.is_file() and not p.is_symlink() and p.parent != outdir
    ]
    case.inputs = [str(p) for p in files]
    case.data_bytes = sum(p.stat().st_size for p in files)
    if m.get("keep"):
        case.inputs.append(str(m["keep"]))
    return case


# ----------------------------------------------------------------- scoring


def score(case, truth):
    """Accuracy of a result file against the truth (None where unreadable)."""
    path = Path(case.output)
    if not path.is_file():
        return None
    try:
        d = load(path)
    except (OSError, ValueError, KeyError, zipfile.BadZipFile):
        return None
    if case.command == "das":
        img = np.abs(np.asarray(d["image"]))
        x, y = np.asarray(d["x"]), np.asarray(d["y"])
        if not img.size or not np.isfinite(img).all() or img.max() == 0:
            return {"recall": 0.0, "peak": False}
        top = img.max()
        gx, gy = np.meshgrid(x, y, indexing="ij")
        hit = [
            img[np.hypot(gx - t[0], gy - t[1]) <= 0.03].max(initial=0) >= 0.5 * top for t in truth
        ]
        i = np.unravel_index(np.argmax(img), img.shape)
        peak = bool(np.hypot(truth[:, 0] - x[i[0]], truth[:, 1] - y[i[1]]).min() <= TOL)
        return {"recall": float(np.mean(hit)), "peak": peak}
    pts = np.asarray(d.get("points", np.zeros((0, 2))), float)
    if pts.ndim != 2 or pts.shape[1] < 2 or not len(pts):
        return {"n": 0, "precision": 0.0, "recall": 0.0}
    dist = np.hypot(pts[:, None, 0] - truth[None, :, 0], pts[:, None, 1] - truth[None, :, 1])
    return {
        "n": len(pts),
        "precision": float(np.mean(dist.min(1) <= TOL)),
        "recall": float(np.mean(dist.min(0) <= TOL)),
    }


def collapsed(acc, clean):
    if acc is None or clean is None:
        return acc is None and clean is not None
    if "peak" in clean:
        return acc["recall"] < 0.5 * clean["recall"] or (clean["peak"] and not acc["peak"])
    return (
        acc["precision"] < 0.5 * clean["precision"]
        or acc["recall"] < 0.5 * clean["recall"]
        or acc["n"] > 10 * max(clean["n"], 1)
    )


def marker_in(case, marker, stdout):
    forms = [marker, marker.decode().encode("utf-16-le"), marker.decode().encode("utf-32-le")]
    blobs = [stdout.encode()]
    for p in Path(case.outdir).rglob("*"):
        if p.is_file():
            b = p.read_bytes()[: 64 << 20]
            blobs.append(b)
            if zipfile.is_zipfile(p):
                try:
                    with zipfile.ZipFile(p) as z:
                        blobs += [z.read(n)[: 64 << 20] for n in z.namelist()]
                except (OSError, zipfile.BadZipFile):
                    blobs.append(b"")
    return any(f in b for f in forms for b in blobs)


#: A traceback's frame: its file and its function.
FRAME = re.compile(r'^\s*File "([^"]+)", line \d+, in (\S+)')


def before_handlers(err: str, rc: int) -> bool:
    """True when a SIGINT ended the run before rpm-cl's handlers existed:
    death by SIGINT with nothing on stderr (before Python's own handler), or
    a KeyboardInterrupt (exit 1, or death by SIGINT) whose traceback holds
    no rpm_cl frame but module-level ones (Python's start-up, runpy, the
    imports of ``rpm_cl/__main__.py`` and ``rpm_cl/_entry.py``)."""
    lines = [ln for ln in err.splitlines() if ln.strip()]
    if rc == -2 and not lines:  # before Python set its own handler
        return True
    if rc not in (1, -2) or not lines or lines[-1].strip() != "KeyboardInterrupt":
        return False
    frames = [m.groups() for m in map(FRAME.match, lines) if m]
    ours = [fn for path, fn in frames if "/rpm_cl/" in path.replace("\\", "/")]
    return all(fn == "<module>" for fn in ours)


def classify(case, res, hashes, ref):
    """The flags that hold and the outcome (the first of OUTCOMES among them).

    ``ref``: ``base_rss`` {command: bytes}, ``clean`` {(base, command): {'wall',
    'acc'}}, ``marker`` bytes."""
    rc, err = res["rc"], res["stderr"]
    lines = [ln for ln in err.splitlines() if ln.strip()]
    warn = [ln for ln in lines if ln.startswith("rpm-cl: warning:")]
    flags = set()
    for p, h in hashes.items():
        if not os.path.isfile(p) or sha(p) != h:
            flags.add("overwritten")
    if marker_in(case, ref["marker"], res["stdout"]) or (case.outside and rc == 0):
        flags.add("outside-read")
    if res["killed"]:
        flags.add(res["killed"])
    elif case.sigint is not None and before_handlers(err, rc):
        flags.add("startup")
    elif "Traceback" in err or rc not in (0, 1, 2, 130):
        flags.add("traceback")
    if case.sigint is not None:
        names = {Path(case.output).name, ".stdout", ".stderr"}
        left = [
            p.name
            for p in Path(case.outdir).rglob("*")
            if p.is_file()
            and p.name not in names
            and ("tmp" in p.name.lower() or p.name.startswith(".") or case.command != "batch")
        ]
        if left:
            flags.add("leftover")
            res["leftover"] = left
    clean = ref["clean"].get((case.base, case.command))
    if rc == 0 and not res["killed"]:
        if case.few and case.command in ("image", "das", "batch") and clean:
            acc = score(case, ref["truth"])
            res["acc"] = acc
            if collapsed(acc, clean["acc"]):
                flags.add("garbage")
            if res["wall"] > ACCEPT_FACTOR * clean["wall"]:
                flags.add("slow-accept")
        if case.units and not warn:
            flags.add("garbage")
    if rc == 2 and not res["killed"]:
        if len(lines) - len(warn) != 1 or "Traceback" in err:
            flags.add("bad-refusal")
        base = ref["base_rss"].get(case.command, 0)
        if res["wall"] > REFUSE_S or res["rss"] > RSS_FACTOR * case.data_bytes + base:
            flags.add("slow-refusal")
    flags.add(
        res["killed"]
        if res["killed"]
        else "startup"
        if "startup" in flags
        else {0: "accepted", 1: "failed", 2: "refused", 130: "interrupted"}.get(rc, "traceback")
    )
    outcome = next(o for o in OUTCOMES if o in flags)
    return outcome, sorted(flags, key=OUTCOMES.index)


def run_case(case, ref, timeout, mem_cap):
    """Run one case; the wall-clock limit is ``timeout`` or 4 x the slowest
    clean run of the command (a batch starts a Dask cluster), the larger."""
    hashes = {p: sha(p) for p in case.inputs if os.path.isfile(p)}
    walls = [v["wall"] for (_, c), v in ref["clean"].items() if c == case.command]
    timeout = max([timeout, *(4 * w for w in walls)])
    res = run_cli(case.argv, case.dir, timeout, mem_cap, case.sigint)
    outcome, flags = classify(case, res, hashes, ref)
    rec = asdict(case)
    rec.update(
        outcome=outcome,
        flags=flags,
        rc=res["rc"],
        wall=round(res["wall"], 3),
        rss_mb=round(res["rss"] / 2**20, 1),
        stderr=res["stderr"][-2000:],
        acc=res.get("acc"),
        leftover=res.get("leftover"),
    )
    rec["cli"] = "rpm-cl " + " ".join(case.argv)
    return rec


# ----------------------------------------------------------------- campaign


def references(root, bases, timeout, mem_cap, repeats, commands, jobs):
    """Per command: the RSS of refusing a 10-byte file; per (base, command):
    the clean run's median time and accuracy."""
    rdir = Path(root) / "refs"
    rdir.mkdir(parents=True, exist_ok=True)
    # tiny bad files: bytes that are no archive, an empty zip, an HDF5 file
    # with nothing in it; the base is the largest of their refusals' RSS
    tinies = [rdir / "tiny.npz", rdir / "empty.npz", rdir / "empty.h5"]
    tinies[0].write_bytes(b"not a zip!")
    zipfile.ZipFile(tinies[1], "w").close()
    save_h5(tinies[2], {})
    ref = {
        "marker": bases.marker,
        "truth": bases.truth,
        "base_rss": {},
        "clean": {},
        "base_wall": {},
    }
    argvs = {
        "image": ["image", "{}", "-o", str(rdir / "t.npz")],
        "das": ["das", "{}", "-o", str(rdir / "t.npz"), "--grid", GRID],
        "params": ["params", "{}"],
        "view": ["view", "{}", "--png", str(rdir / "t.png")],
        "batch": ["batch", "{}", "-o", str(rdir / "tb"), "--workers", "1"],
    }
    # and a trivially bad request on a clean input, refused once the engine
    # is loaded: an out-of-range parameter (view takes none)
    bad_cfg = rdir / "bad.toml"
    bad_cfg.write_text('[engine]\nprecision = "float16"\n')
    for cmd in commands:
        runs = [run_cli([a.format(t) for a in argvs[cmd]], rdir, timeout, mem_cap) for t in tinies]
        if cmd != "view":
            runs.append(
                run_cli(
                    [a.format(bases.dir / RADAR[0]) for a in argvs[cmd]]
                    + ["--config", str(bad_cfg)],
                    rdir,
                    timeout,
                    mem_cap,
                )
            )
        ref["base_rss"][cmd] = BASE_SLACK * max(r["rss"] for r in runs)
        ref["base_wall"][cmd] = min(r["wall"] for r in runs)
    jobs_list = []
    cid = 0
    for base in RADAR:
        for cmd in ("image", "das", "batch"):
            if cmd not in commands:
                continue
            for _ in range(repeats):
                cid += 1
                jobs_list.append((base, cmd, cid))

    def one(item):
        base, cmd, cid = item
        cdir = rdir / f"clean{cid:03d}"
        shutil.rmtree(cdir, ignore_errors=True)
        (cdir / "out").mkdir(parents=True)
        case = Case(cid, "clean", "none", base, cmd, dir=str(cdir), outdir=str(cdir / "out"))
        inp = bases.path(base)
        if cmd == "batch":
            (cdir / "frames").mkdir()
            shutil.copyfile(inp, cdir / "frames" / ("a" + inp.suffix))
            shutil.copyfile(inp, cdir / "frames" / ("b" + inp.suffix))
            case.argv = ["batch", str(cdir / "frames"), "-o", case.outdir, "--workers", "1"]
            case.output = str(cdir / "out" / "b.npz")
        else:
            case.output = str(cdir / "out" / "r.npz")
            case.argv = [cmd, str(inp), "-o", case.output] + (
                ["--grid", GRID] if cmd == "das" else []
            )
        r = run_cli(case.argv, cdir, timeout, mem_cap)
        return base, cmd, r, (score(case, bases.truth) if r["rc"] == 0 else None)

    with ThreadPoolExecutor(jobs) as ex:
        done = list(ex.map(one, jobs_list))
    for base in RADAR:
        for cmd in ("image", "das", "batch"):
            rs = [(r, a) for b, c, r, a in done if b == base and c == cmd]
            if not rs:
                continue
            ok = [(r, a) for r, a in rs if r["rc"] == 0]
            if not ok:
                raise RuntimeError(f"clean {cmd} of {base} failed: {rs[0][0]['stderr']}")
            ref["clean"][(base, cmd)] = {
                "wall": float(np.median([r["wall"] for r, _ in ok])),
                "acc": ok[0][1],
            }
    return ref


def plan(n, seed, families=FAMILIES):
    """``n`` (family, mutation) pairs: families in turn, each family's
    mutations in a seeded shuffled order, repeated, so that every mutation
    comes before any repeats."""
    rng = np.random.default_rng(seed)
    orders = {f: [] for f in families}
    out = []
    while len(out) < n:
        for f in families:
            if not orders[f]:
                orders[f] = list(rng.permutation(MUTATIONS[f][1]))
            out.append((f, str(orders[f].pop())))
            if len(out) == n:
                break
    return out


def campaign(
    root,
    pairs,
    seed,
    timeout=20.0,
    mem_cap=4 << 30,
    bomb_bytes=2 << 30,
    jobs=1,
    repeats=3,
    log=None,
    commands=None,
):
    """Run the cases ``pairs`` [(family, mutation) or (family, mutation,
    command)] under ``root``; returns (records, ref)."""
    root = Path(root)
    bases = Bases(root, bomb_bytes, seed)
    commands = commands or ("image", "das", "params", "view", "batch")
    ref = references(root, bases, timeout, mem_cap, repeats, commands, jobs)
    cases = []
    for cid, pair in enumerate(pairs):
        rng = np.random.default_rng([seed, cid])
        cases.append(
            make_case(cid, pair[0], pair[1], root, bases, rng, pair[2] if len(pair) > 2 else None)
        )

    def one(case):
        rec = run_case(case, ref, timeout, mem_cap)
        if log:
            log(rec)
        return rec

    with ThreadPoolExecutor(jobs) as ex:
        recs = list(ex.map(one, cases))
    return recs, ref


def table(recs):
    fams = [f for f in (*FAMILIES,) if any(r["family"] == f for r in recs)]
    cols = [o for o in OUTCOMES if any(r["outcome"] == o for r in recs)]
    w = max(len(f) for f in (*fams, "family", "total"))
    cw = [max(len(c), 4) for c in cols]
    head = "family".ljust(w) + " | " + " | ".join(c.rjust(x) for c, x in zip(cols, cw)) + " | total"
    lines = [head, "-" * len(head)]
    for f in (*fams, "total"):
        rs = [r for r in recs if f in ("total", r["family"])]
        cells = [str(sum(r["outcome"] == c for r in rs) or ".").rjust(x) for c, x in zip(cols, cw)]
        lines.append(f.ljust(w) + " | " + " | ".join(cells) + f" | {len(rs)}")
    flags = {o: sum(o in r["flags"] for r in recs) for o in OUTCOMES}
    lines.append("")
    lines.append(
        "cases with each flag (a case may hold several): "
        + ", ".join(f"{o} {flags[o]}" for o in OUTCOMES if flags[o])
    )
    lines.append("targets (0 each): " + ", ".join(f"{o} {flags[o]}" for o in FAILURES))
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--n", type=int, default=None, help="cases (default 660; --quick 110)")
    ap.add_argument(
        "--out",
        default=None,
        help="working folder and cases.json (default: a "
        "temporary folder, removed; cases.json then in the current folder)",
    )
    ap.add_argument(
        "--quick",
        action="store_true",
        help="110 cases, 10 s limit, 512 MB zip bombs, 2 clean runs each",
    )
    ap.add_argument(
        "--jobs",
        type=int,
        default=1,
        help="cases run at once (timings compare "
        "within a run: clean references run with the same parallelism)",
    )
    ap.add_argument(
        "--timeout", type=float, default=None, help="s per case (default 20; --quick 10)"
    )
    ap.add_argument("--mem-cap", type=float, default=4.0, help="GB per case (default 4)")
    ap.add_argument(
        "--bomb-mb",
        type=int,
        default=None,
        help="bytes a zip bomb inflates, MB (default 2048; --quick 512)",
    )
    ap.add_argument("--families", default=",".join(FAMILIES))
    args = ap.parse_args(argv)
    n = args.n or (110 if args.quick else 660)
    timeout = args.timeout or (10.0 if args.quick else 20.0)
    bomb = (args.bomb_mb or (512 if args.quick else 2048)) << 20
    fams = tuple(args.families.split(","))
    keep = args.out is not None
    root = Path(args.out) if keep else Path(tempfile.mkdtemp(prefix="rpm-fuzz-"))
    root.mkdir(parents=True, exist_ok=True)
    pairs = plan(n, args.seed, fams)
    t0 = time.perf_counter()
    done = [0]

    stream = open(root / "cases.jsonl", "w")  # noqa: SIM115 (closed below)

    def log(rec):
        stream.write(json.dumps(rec, default=str) + "\n")
        stream.flush()
        done[0] += 1
        bad = rec["outcome"] in FAILURES
        print(
            f"[{done[0]:4d}/{n}] {rec['family']:9s} {rec['mutation']:22s} {rec['command']:6s} "
            f"-> {rec['outcome']:13s} rc={rec['rc']:4d} {rec['wall']:6.2f} s "
            f"{rec['rss_mb']:7.0f} MB" + ("  <<" if bad else ""),
            file=sys.stderr,
            flush=True,
        )

    recs, ref = campaign(
        root,
        pairs,
        args.seed,
        timeout,
        int(args.mem_cap * 2**30),
        bomb,
        args.jobs,
        2 if args.quick else 3,
        log,
    )
    stream.close()
    text = table(recs)
    print(text)
    summary = {
        "seed": args.seed,
        "n": n,
        "timeout_s": timeout,
        "mem_cap_gb": args.mem_cap,
        "bomb_mb": bomb >> 20,
        "jobs": args.jobs,
        "seconds": round(time.perf_counter() - t0, 1),
        "base_rss_mb": {k: round(v / 2**20, 1) for k, v in ref["base_rss"].items()},
        "base_refusal_s": {k: round(v, 3) for k, v in ref["base_wall"].items()},
        "clean": {f"{b} {c}": v for (b, c), v in ref["clean"].items()},
        "cases": recs,
    }
    dest = (root if keep else Path.cwd()) / "cases.json"
    dest.write_text(json.dumps(summary, indent=1, default=str))
    print(f"\n{len(recs)} cases in {summary['seconds']} s; wrote {dest}")
    if not keep:
        shutil.rmtree(root, ignore_errors=True)
    return 1 if any(r["outcome"] in FAILURES for r in recs) else 0


if __name__ == "__main__":
    sys.exit(main())
