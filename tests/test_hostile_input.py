"""Inputs from strangers: nothing is read before the headers are checked,
nothing from outside the file, nothing from a file that is not a regular
file (rpm_cl/io/guard.py, rpm_cl/io/formats.py sources)."""

import os
import subprocess
import sys
import time
import zipfile

import h5py
import numpy as np
import pytest

from rpm_cl.io import formats, guard
from rpm_cl.io.data import InputError, data_arrays
from rpm_cl.io.formats import check_members, load_data
from rpm_cl.simulate import simulate_preset


@pytest.fixture(scope="module")
def arrays():
    return {
        k: v
        for k, v in data_arrays(simulate_preset("paper-2d")[0]).items()
        if not k.startswith("truth")
    }


def _h5(path, arrays, skip=()):
    with h5py.File(path, "w") as f:
        for k, v in arrays.items():
            if k not in skip:
                f[k] = v
    return path


def _refused(path, match, **kw):
    t0 = time.perf_counter()
    with pytest.raises(InputError, match=match):
        load_data(path, **kw)
    assert time.perf_counter() - t0 < 2.0


def test_fifo_and_devices_refused_without_opening(tmp_path):
    fifo = tmp_path / "in.npz"
    os.mkfifo(fifo)
    _refused(fifo, "regular file, this is a FIFO")  # opening it would block forever
    zero = tmp_path / "zero.h5"
    zero.symlink_to("/dev/zero")
    _refused(zero, "character device")
    with pytest.raises(InputError, match="FIFO"):
        check_members(fifo, ("points",))
    folder = tmp_path / "d.npz"
    folder.mkdir()
    _refused(folder, "folder")


def test_link_to_a_regular_file_is_read(tmp_path, arrays):
    real = tmp_path / "real.npz"
    np.savez(real, **arrays)
    link = tmp_path / "link.npz"
    link.symlink_to(real)
    assert load_data(link).signal.shape == arrays["signal"].shape


def test_axis_declaring_a_billion_values_refused_unread(tmp_path, arrays):
    """A chunked, compressed x of 1e9 float64 in a file of kilobytes: the
    header says so, and it does not match signal's first axis."""
    path = tmp_path / "big_x.h5"
    with h5py.File(path, "w") as f:
        for k, v in arrays.items():
            if k != "x":
                f[k] = v
        f.create_dataset("x", shape=(10**9,), dtype="f8", chunks=(1 << 20,), compression="gzip")
    assert os.path.getsize(path) < 1 << 20
    _refused(path, r"x .*1000000000|compression bomb")


def test_h5_data_outside_the_file_refused(tmp_path, arrays):
    secret = tmp_path / "secret.h5"
    with h5py.File(secret, "w") as f:
        f["x"] = arrays["x"] + 1.0
    # an external link in place of x
    path = _h5(tmp_path / "extlink.h5", arrays, skip=("x",))
    with h5py.File(path, "a") as f:
        f["x"] = h5py.ExternalLink(str(secret), "/x")
    _refused(path, "external link")
    # raw storage in another file
    raw = tmp_path / "raw.bin"
    arrays["x"].astype("<f8").tofile(raw)
    path = _h5(tmp_path / "extstore.h5", arrays, skip=("x",))
    with h5py.File(path, "a") as f:
        f.create_dataset(
            "x", shape=arrays["x"].shape, dtype="<f8", external=[(str(raw), 0, arrays["x"].nbytes)]
        )
    _refused(path, "external files")
    # a virtual dataset mapping another file's x
    path = _h5(tmp_path / "virtual.h5", arrays, skip=("x",))
    layout = h5py.VirtualLayout(shape=arrays["x"].shape, dtype="f8")
    layout[:] = h5py.VirtualSource(str(secret), "x", shape=arrays["x"].shape)
    with h5py.File(path, "a") as f:
        f.create_virtual_dataset("x", layout)
    _refused(path, "virtual dataset")


def _npz_member_header(path, name, shape):
    """Rewrite the .npy header of member ``name`` to declare ``shape``
    (same dtype), keeping its data: a corrupt or lying header."""
    with zipfile.ZipFile(path) as zf:
        members = {n: zf.read(n) for n in zf.namelist()}
    raw = members[name]
    import io

    fh = io.BytesIO(raw)
    np.lib.format.read_magic(fh)
    _, fortran, dtype = np.lib.format.read_array_header_1_0(fh)
    body = raw[fh.tell() :]
    out = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        out,
        {"descr": np.lib.format.dtype_to_descr(dtype), "fortran_order": fortran, "shape": shape},
    )
    members[name] = out.getvalue() + body
    with zipfile.ZipFile(path, "w") as zf:
        for n, b in members.items():
            zf.writestr(n, b)


def test_npz_header_larger_than_its_member_refused(tmp_path, arrays):
    """signal's header declares 10^6 x 600 samples; the member holds 21 x 600:
    refused from the sizes, before a read (not 'out of memory')."""
    path = tmp_path / "lying.npz"
    np.savez(path, **arrays)
    _npz_member_header(path, "signal.npy", (10**6, 600))
    _refused(path, "truncated or its header is corrupt")


def test_npz_zip_bomb_refused_unread(tmp_path, arrays):
    """A member of 400 MB of zeros stored in ~400 kB (1000:1): refused from the
    zip's sizes, without inflating it, in well under a second."""
    path = tmp_path / "bomb.npz"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        for k, v in arrays.items():
            if k != "signal":
                with zf.open(k + ".npy", "w") as fh:
                    np.lib.format.write_array(fh, np.asarray(v))
        n = 25 * 10**6  # complex128: 400 MB
        with zf.open("signal.npy", "w", force_zip64=True) as fh:
            np.lib.format.write_array_header_1_0(
                fh, {"descr": "<c16", "fortran_order": False, "shape": (n // 600, 600)}
            )
            zeros = bytes(1 << 24)
            for _ in range(16 * n // len(zeros)):
                fh.write(zeros)
            fh.write(bytes(16 * n - (16 * n // len(zeros)) * len(zeros)))
    assert os.path.getsize(path) < 2 << 20
    _refused(path, "compression bomb")


def test_unused_truth_member_never_read(tmp_path, arrays):
    """A truth_boundary bomb is refused by what reads truth; das does not."""
    path = tmp_path / "truth_bomb.npz"
    np.savez(path, **arrays)
    with (
        zipfile.ZipFile(path, "a", zipfile.ZIP_DEFLATED) as zf,
        zf.open("truth_boundary.npy", "w", force_zip64=True) as fh,
    ):
        np.lib.format.write_array_header_1_0(
            fh, {"descr": "<f8", "fortran_order": False, "shape": (50 * 10**6 // 2, 2)}
        )
        for _ in range(25):
            fh.write(bytes(16 * 10**6))
    _refused(path, "truth_boundary .*compression bomb")
    t0 = time.perf_counter()
    data = load_data(path, with_truth=False)
    assert data.truth is None and time.perf_counter() - t0 < 2.0


def test_run_over_the_memory_limit_refused_with_sizes(tmp_path, arrays):
    path = tmp_path / "ok.npz"
    np.savez(path, **arrays)
    need = guard.run_bytes(
        arrays["signal"].size, sum(v.nbytes for k, v in arrays.items() if k != "signal")
    )
    with pytest.raises(
        InputError,
        match=r"signal \(21, 600\) would need about .* above the "
        r"limit of",
    ):
        load_data(path, max_memory=need - 1)
    assert load_data(path, max_memory=need).signal.shape == (21, 600)


def test_memory_limit_sources(monkeypatch):
    monkeypatch.delenv("RPM_CL_MAX_MEMORY", raising=False)
    assert guard.memory_limit() == int(guard.MEMORY_SHARE * guard._physical_memory())
    monkeypatch.setenv("RPM_CL_MAX_MEMORY", "3G")
    assert guard.memory_limit() == 3 * 10**9
    assert guard.memory_limit("512M") == 512 * 10**6
    # the units --frame-memory takes too (one parser for both flags)
    assert guard.parse_bytes("3GB") == 3 * 10**9
    assert guard.parse_bytes("1.5GiB") == 3 * 2**29
    assert guard.parse_bytes(8e9) == 8 * 10**9
    for bad in ("0", "-1G", "abc", "nan", "", "5XB"):
        with pytest.raises(InputError, match="memory size"):
            guard.parse_bytes(bad)


def test_h5_dataset_helpers(tmp_path, arrays):
    path = _h5(tmp_path / "g.h5", arrays)
    with h5py.File(path, "a") as f:
        f.create_group("grp")
    with h5py.File(path, "r") as f:
        assert guard.h5_has(f, "x") and not guard.h5_has(f, "nope")
        with pytest.raises(InputError, match="not a group"):
            guard.h5_dataset(f, "grp")


def test_cli_refuses_in_one_line(tmp_path):
    fifo = tmp_path / "in.npz"
    os.mkfifo(fifo)
    for cmd in (["image", str(fifo), "-o", str(tmp_path / "o.npz")], ["view", str(fifo)]):
        res = subprocess.run(
            [sys.executable, "-m", "rpm_cl", *cmd],
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
        assert res.returncode == 2
        lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
        assert len(lines) == 1 and "FIFO" in lines[0], res.stderr


def test_axis_length_checked_against_the_data_header(tmp_path, arrays):
    """An axis too long for the data and too large to read harmlessly is
    refused from its header; a small mismatch is read and reported by the
    validators (the data's shape named)."""
    n = formats.BESIDE_READ_BYTES // 8 + 1
    path = _h5(tmp_path / "xbig.h5", dict(arrays, x=np.linspace(-1, 1, n)))
    _refused(
        path,
        rf"x must hold 21 values \(signal has shape \(21, 600\)\), its header "
        rf"declares shape \({n},\)",
    )
    path = _h5(tmp_path / "fcbig.h5", dict(arrays, fc=np.full(n, 20e9)))
    _refused(path, "fc must hold one number")
    path = _h5(tmp_path / "x1000.h5", dict(arrays, x=np.linspace(-1, 1, 1000)))
    _refused(path, "signal must have shape")


def test_garbled_npy_header_named_as_such(tmp_path, arrays):
    path = tmp_path / "garbled.npz"
    np.savez(path, **arrays)
    with zipfile.ZipFile(path) as zf:
        members = {n: zf.read(n) for n in zf.namelist()}
    raw = bytearray(members["signal.npy"])
    raw[10:40] = b"{'descr': <c16, 'shape': ((((("  # not a Python literal any more
    members["signal.npy"] = bytes(raw)
    with zipfile.ZipFile(path, "w") as zf:
        for n, b in members.items():
            zf.writestr(n, b)
    _refused(path, "corrupt .npy header")


def test_bandwidth_in_wrong_units_refused(tmp_path, arrays):
    """200 Hz (a number meant as MHz): a resolution of 750 km over a 1.5 m
    range axis takes minutes and gigabytes to image; refused with the fix."""
    path = tmp_path / "bw.npz"
    np.savez(path, **dict(arrays, bandwidth=np.float64(200.0)))
    _refused(path, "bandwidth = 200 Hz gives a range resolution .* give fc and bandwidth in Hz")


def test_peak_window_wider_than_the_map_gives_the_same_maxima():
    """kspace._centres clamps its window to the map (wrap: the axis length,
    edges repeated along R: twice it plus one); the maxima are those of the
    unclamped filter, so a resolution far beyond the range axis costs no more."""
    from scipy import ndimage

    from rpm_cl.extract import kspace

    rng = np.random.default_rng(11)
    det = rng.random((9, 40))
    for size in ([3, 5], [9, 81], [30, 500], [10, 2]):
        idx, vals = kspace._centres(det, size, 1, 0.0, 0, 40)
        local = det == ndimage.maximum_filter(det, size=size, mode=["wrap", "nearest"])
        strict = np.zeros_like(local)
        strict[:, 1:-1] = (det[:, 1:-1] > det[:, :-2]) & (det[:, 1:-1] >= det[:, 2:])
        want = np.argwhere(local & strict & (det > 0))
        want = want[(want[:, -1] > 0) & (want[:, -1] < 39)]
        np.testing.assert_array_equal(idx, want)
        np.testing.assert_array_equal(vals, det[tuple(want.T)])


def test_range_axis_in_cm_numbers_warned(tmp_path, arrays):
    """range x 100 keeps its gates finer than the resolution, so nothing
    refused it: the echoes' width (about 0.7 resolutions, rpm_cl.io.data.echo_width)
    says it, 100 times too wide."""
    from rpm_cl.io.data import ECHO_WIDTH_MAX, DataWarning, echo_width

    path = tmp_path / "cm.npz"
    np.savez(path, **dict(arrays, range=arrays["range"] * 100))
    with pytest.warns(DataWarning, match="is range in cm numbers"):
        load_data(path)
    data = simulate_preset("paper-2d")[0]
    ratio = echo_width(data) / data.waveform.range_resolution
    assert 0.3 < ratio < ECHO_WIDTH_MAX / 10  # an echo: about 0.7 resolutions
    rng = np.random.default_rng(5)
    noise = rng.standard_normal((21, 600)) + 1j * rng.standard_normal((21, 600))
    from rpm_cl.io.data import RadarData

    white = RadarData(noise, data.array, data.range, data.waveform)
    assert echo_width(white) < 2 * data.dr  # white noise: a gate or so


def test_convert_refuses_special_files(tmp_path):
    """`rpm-cl convert` reads its inputs through the same door: a FIFO is
    refused at once (the readers would block on it)."""
    from rpm_cl.io.readers import convert

    fifo = tmp_path / "line.dzt"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match="regular file, this is a FIFO"):
        convert(fifo)


def test_h5_deflate_chunk_inflating_past_its_size_refused(tmp_path, arrays):
    """A signal declaring 21 x 600 complex128 (200 kB) whose one deflated
    chunk inflates to 64 MB: HDF5's filter grows its buffer to the whole
    stream, so the chunk is inflated here first, at most a chunk's bytes."""
    import zlib

    path = tmp_path / "gz.h5"
    with h5py.File(path, "w") as f:
        for k, v in arrays.items():
            if k != "signal":
                f[k] = v
        d = f.create_dataset(
            "signal", (21, 600), np.complex128, chunks=(21, 600), compression="gzip"
        )
        c = zlib.compressobj(1)
        payload = b"".join(c.compress(bytes(1 << 22)) for _ in range(16)) + c.flush()
        d.id.write_direct_chunk((0, 0), payload)
    _refused(path, "inflates beyond the chunk")
    ok = _h5(tmp_path / "ok.h5", arrays)  # an honest compressed file reads
    with h5py.File(ok, "a") as f:
        del f["signal"]
        f.create_dataset(
            "signal",
            data=arrays["signal"],
            chunks=(7, 200),
            compression="gzip",
            shuffle=True,
            fletcher32=True,
        )
    np.testing.assert_array_equal(load_data(ok).signal, arrays["signal"])


def test_h5_soft_link_through_an_external_link_never_opens_it(tmp_path, arrays):
    """A soft link whose path runs through an external link to a FIFO: h5py
    would open the FIFO (and block) following the chain; each link is looked
    at first."""
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    path = _h5(tmp_path / "soft.h5", arrays, skip=("signal",))
    with h5py.File(path, "a") as f:
        f["ext"] = h5py.ExternalLink(str(fifo), "/")
        f["signal"] = h5py.SoftLink("/ext/signal")
    _refused(path, "leads through an external link")
    loop = _h5(tmp_path / "loop.h5", arrays, skip=("signal",))
    with h5py.File(loop, "a") as f:
        f["a"] = h5py.SoftLink("/b")
        f["b"] = h5py.SoftLink("/a")
        f["signal"] = h5py.SoftLink("/a")
    _refused(loop, "soft links")
    inner = _h5(tmp_path / "inner.h5", arrays, skip=("signal",))
    with h5py.File(inner, "a") as f:
        f["g/s"] = arrays["signal"]
        f["signal"] = h5py.SoftLink("/g/s")  # a soft link inside the file is followed
    assert load_data(inner).signal.shape == (21, 600)


def test_npy_header_length_checked_before_numpy_reads_it(tmp_path, arrays):
    """A v2 header declaring 400 MB of header text: NumPy reads it all before
    its own limit; refused from the length field."""
    import struct

    path = tmp_path / "hdr.npz"
    np.savez(path, **{k: v for k, v in arrays.items() if k != "signal"})
    with zipfile.ZipFile(path, "a", zipfile.ZIP_DEFLATED) as zf, zf.open("signal.npy", "w") as fh:
        fh.write(b"\x93NUMPY\x02\x00" + struct.pack("<I", 400_000_000))
        fh.write(b" " * (1 << 20))
    _refused(path, "corrupt .npy header .*header length 400000000")


def test_bare_member_checked_as_numpy_load_reads_it(tmp_path):
    """np.load reads a member named 'points' before 'points.npy': the checks
    look at the same one (a lying bare member is refused, not inflated)."""
    import io

    path = tmp_path / "res.npz"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, v in (
            ("points.npy", np.zeros((2, 3))),
            ("cluster.npy", np.zeros(2, int)),
            ("rp_x.npy", np.zeros(2)),
        ):
            b = io.BytesIO()
            np.save(b, v)
            zf.writestr(name, b.getvalue())
        zf.writestr("points", b"not an array at all")
    with pytest.raises(InputError, match="points: corrupt .npy header"):
        check_members(path, ("points", "cluster", "rp_x"))


def test_fortran_ordered_stack_refused_frame_by_frame(tmp_path, arrays):
    stack = np.asfortranarray(np.stack([arrays["signal"]] * 3))
    path = tmp_path / "fort.npz"
    np.savez(path, **dict(arrays, signal=stack))
    _refused(path, "Fortran-ordered stack", frame=1)


def test_check_members_budgets_only_the_members_held_at_once(tmp_path):
    """One opening checks every member; ``budget`` names those that count
    against memory (a viewer reads the image slab by slab)."""
    from rpm_cl.io.guard import RUN_BASE_BYTES

    path = tmp_path / "img.npz"
    np.savez(path, image=np.zeros((512, 512)), x=np.zeros(512), meta=np.array("{}"))
    limit = RUN_BASE_BYTES + 2**20  # the axes fit, the 2 MiB image does not
    found = check_members(path, ("image", "x", "meta"), budget=("x", "meta"), max_memory=limit)
    assert found["image"] == ((512, 512), np.dtype(np.float64))
    with pytest.raises(InputError, match="memory"):
        check_members(path, ("image", "x", "meta"), max_memory=limit)
    check_members(path, ("image", "x"), budget=False, max_memory=1)
