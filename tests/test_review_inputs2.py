"""Adversarial inputs to the CLI: each case could break the contract (a
traceback, a crash, a silent wrong result, a file left behind) and must be
one line ``rpm-cl: error: ...`` and exit code 2, or a correct result."""

import os
import signal
import subprocess
import sys
import time
import warnings

import numpy as np
import pytest
from test_review_inputs import _one_error

from rpm_cl.cli import main
from rpm_cl.io.data import InputError, RadarData, Waveform


def _warned_error(capsys, argv):
    """The error line of a run on x in mm read as m (a 5 km pitch), after
    the one warning line that says so (rpm_cl.io.data.check_plausible)."""
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and err[0].startswith("rpm-cl: warning: the antenna pitch 5000 m"), err
    assert "is x in mm or cm? give x in m" in err[0] and err[1].startswith("rpm-cl: error: "), err
    return err[1]


def _edited(tmp_path, p2, name, **changes):
    d = dict(np.load(p2))
    d.update(changes)
    out = tmp_path / name
    np.savez(out, **d)
    return out


@pytest.mark.parametrize(
    "key, value, words",
    [
        ("fc", np.array(True), "fc must be a real number"),  # not 1 Hz
        ("fc", np.array("20e9"), "fc must be a real number"),  # a string is not a number
        ("x", (np.arange(21) * 5).astype("timedelta64[ms]"), "x must be real numbers"),
        ("truth_boundary", None, "truth_boundary or truth_rp_range contains NaN"),  # no traceback
    ],
)
def test_wrong_kinds_and_non_finite_truth(tmp_path, capsys, p2, key, value, words):
    if key == "truth_boundary":
        value = np.array(np.load(p2)["truth_boundary"])
        value[0, 0] = np.nan
    src = _edited(tmp_path, p2, "bad.npz", **{key: value})
    out = tmp_path / "o.npz"
    assert words in _one_error(capsys, ["image", str(src), "-o", str(out)])
    assert not list(tmp_path.glob("o.npz")) and not list(tmp_path.glob(".tmp-*"))


def test_pad_bounded(tmp_path, capsys, p2):
    """A zero-padding factor of 1e20 is one error line, not a traceback (the
    FFT's size)."""
    line = _one_error(
        capsys, ["image", str(p2), "-o", str(tmp_path / "o.npz"), "--pad", "99999999999999999999"]
    )
    assert "pad must be an integer from 1 to 64" in line


def test_complex64_extreme_amplitudes_match_complex128(p2):
    """complex64 x 1e19 squared leaves float32's range (warnings, sigma_r 45
    -> 2.5 mm, points 52 mm off); such data are held as complex128, so the
    result must be that of the same data in complex128."""
    from rpm_cl.imaging import run_method
    from rpm_cl.io.formats import load_data
    from rpm_cl.rpm import reference
    from rpm_cl.rpm.params import default_params

    d = load_data(p2)
    for scale in (1e19, 1e-19):
        big = RadarData((d.signal * scale).astype(np.complex64), d.array, d.range, d.waveform)
        assert big.signal.dtype == np.complex128
        ref = RadarData(
            (d.signal * scale).astype(np.complex64).astype(np.complex128),
            d.array,
            d.range,
            d.waveform,
        )
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            a = run_method("kspace-rpm", big, default_params(big), reference)
        b = run_method("kspace-rpm", ref, default_params(ref), reference)
        np.testing.assert_array_equal(a.image.points, b.image.points)
    # ordinary amplitudes keep complex64 (half the memory)
    assert (
        RadarData(d.signal.astype(np.complex64), d.array, d.range, d.waveform).signal.dtype
        == np.complex64
    )


def test_das_float32_range_and_rma_complex64(tmp_path, capsys, p2):
    """A float32 DAS image of amplitudes 1e40 would be all NaN (1e-50: all
    zero): it is refused, pointing to float64.  RMA of complex64 data at
    1e37 would be non-finite: such data are held as complex128 (RadarData)."""
    d = dict(np.load(p2))
    for scale in (1e40, 1e-50):
        src = _edited(tmp_path, p2, "s.npz", signal=d["signal"] * scale)
        line = _one_error(
            capsys,
            ["das", str(src), "-o", str(tmp_path / "d.npz"), "--grid=-0.1:0.1:0.01,0.3:0.5:0.01"],
        )
        assert "float32" in line and "--precision float64" in line
        assert not list(tmp_path.glob("d.npz")) and not list(tmp_path.glob(".tmp-*"))
    src = _edited(tmp_path, p2, "r.npz", signal=(d["signal"] * 1e37).astype(np.complex64))
    assert main(["rma", str(src), "-o", str(tmp_path / "r_out.npz"), "-q"]) == 0
    img = np.load(tmp_path / "r_out.npz")["image"]
    assert np.all(np.isfinite(img)) and np.abs(img).max() > 0


def test_rma_crop_outside_the_range_axis(tmp_path, capsys, p2):
    """y 100-200 m of a 1.5 m range axis is refused: the image there would
    show the target's periodic copy at 108.28 m as a target."""
    for lo, hi in (("100", "200"), ("-5", "-1")):
        line = _one_error(
            capsys,
            ["rma", str(p2), "-o", str(tmp_path / "r.npz"), f"--y-min={lo}", f"--y-max={hi}"],
        )
        assert "must lie within -1.5 .. 1.5 m" in line


def test_two_sample_spectrum_window(tmp_path, capsys):
    """A Hann window over 2 frequency samples is all zero: the error says so
    (not 'signal contains NaN or Inf'), and a rect window images."""
    src = tmp_path / "s.npz"
    np.savez(
        src,
        spectrum=np.ones((21, 2), complex),
        frequency=np.array([19.9e9, 20.1e9]),
        x=np.arange(21) * 5e-3,
    )
    line = _one_error(capsys, ["image", str(src), "-o", str(tmp_path / "o.npz")])
    assert "hann range window over 2 frequency samples is all zero" in line
    assert (
        main(["image", str(src), "-o", str(tmp_path / "o.npz"), "--range-window", "rect", "-q"])
        == 0
    )


def test_messages_name_the_problem(tmp_path, capsys, p2):
    """view on a TOML file says it is no zip archive (not a word of pickles),
    on an input file 'image it first' (not 'points is not a file in the
    archive'); chunk_slots 0 names its own condition alone; a sigma_x derived
    from the array (x in the wrong unit) points at the units of x, not at
    sigma_x alone."""
    toml = tmp_path / "c.toml"
    toml.write_text("[kspace]\npad = 2\n")
    assert "not a zip archive" in _one_error(
        capsys, ["view", str(toml), "--png", str(tmp_path / "v.png")]
    )
    assert "image it first" in _one_error(
        capsys, ["view", str(p2), "--png", str(tmp_path / "v.png")]
    )
    line = _one_error(
        capsys, ["image", str(p2), "-o", str(tmp_path / "o.npz"), "--chunk-slots", "0"]
    )
    assert "chunk_slots must be >= 1, got 0" in line and "max_cluster_rps" not in line
    src = _edited(tmp_path, p2, "xbig.npz", x=np.load(p2)["x"] * 1e6)
    line = _warned_error(capsys, ["image", str(src), "-o", str(tmp_path / "o.npz")])
    assert "derived from the array" in line and "units of x" in line


def test_error_is_one_line_whatever_the_message(capsys, monkeypatch):
    """A library message with newlines (h5py's) is printed on one line."""
    from rpm_cl.cli import commands as cli

    def boom(args):
        raise InputError("first part\n  second part")

    monkeypatch.setattr(cli, "cmd_info", boom)
    assert _one_error(capsys, ["info"]).endswith("first part second part")


def test_vtk_write_failure_is_an_oserror(tmp_path):
    """VTK prints a failed write and carries on (exit 0, a truncated .vti),
    or crashes on a full disk (a point cloud): its error code must raise, and
    a point cloud is written by Python from VTK's string."""
    pv = pytest.importorskip("pyvista")
    from rpm_cl.io.formats import _vtk_write

    cloud = pv.PolyData(np.random.default_rng(0).random((50, 3)))
    missing = tmp_path / "no" / "such" / "folder"
    for name, in_memory in (("a.vtp", True), ("a.vtp", False)):
        with pytest.raises(OSError):
            _vtk_write(cloud, str(missing / name), in_memory=in_memory)
    vol = pv.ImageData(dimensions=(4, 5, 1))
    vol.point_data["v"] = np.arange(20.0)
    with pytest.raises(OSError):
        _vtk_write(vol, str(missing / "a.vti"))
    _vtk_write(cloud, str(tmp_path / "a.vtp"), in_memory=True)
    assert pv.read(tmp_path / "a.vtp").n_points == 50


def test_zero_image_view_has_no_warnings(tmp_path, capsys, p2):
    """A target-free DAS image (all zero) shows in view without RuntimeWarnings."""
    src = _edited(tmp_path, p2, "z.npz", signal=np.zeros_like(np.load(p2)["signal"]))
    out = tmp_path / "d.npz"
    assert main(["das", str(src), "-o", str(out), "--grid=-0.1:0.1:0.01,0.3:0.5:0.01", "-q"]) == 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert main(["view", str(out), "--png", str(tmp_path / "v.png")]) == 0


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_sigterm_cleans_up(tmp_path):
    """SIGTERM during a DAS run must clean up like Ctrl-C (no .tmp-*.npy of
    255 MB, no empty .tmp-*.npz left behind) and exit 143."""
    src = tmp_path / "p.npz"
    assert main(["simulate", "paper-2d", "-o", str(src), "-q"]) == 0
    out = tmp_path / "o.npz"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "rpm_cl.cli",
            "das",
            str(src),
            "-o",
            str(out),
            "--grid=-2:2:0.001,0.01:4:0.001",
            "--backend",
            "numpy",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "POCL_MAX_PTHREAD_COUNT": "1"},
    )
    try:
        deadline = time.time() + 60
        while time.time() < deadline and proc.poll() is None and not list(tmp_path.glob(".tmp-*")):
            time.sleep(0.05)
        assert proc.poll() is None and list(tmp_path.glob(".tmp-*")), (
            f"the run ended or never started writing: {proc.poll()}"
        )
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 143 and "terminated" in err
    assert not out.exists() and not list(tmp_path.glob(".tmp-*"))


def test_absurd_pitch_is_refused_quickly(tmp_path, capsys, p2):
    """x in mm read as m (5 km pitch) with sigma_x given: the range-walk
    alignment would try 1.3 M alias directions for 5 minutes, so it is one
    line naming the pitch, and ``--align false`` images it."""
    src = _edited(tmp_path, p2, "xbig.npz", x=np.load(p2)["x"] * 1e6)
    t0 = time.perf_counter()
    line = _warned_error(
        capsys, ["image", str(src), "-o", str(tmp_path / "o.npz"), "--sigma-x", "0.1"]
    )
    assert "alias directions" in line and "5000 m" in line and time.perf_counter() - t0 < 30
    # without the alignment, phase-rpm's walk tries the starting alias and its
    # neighbours, not the million physical ones (2.5 minutes)
    t0 = time.perf_counter()
    assert (
        main(
            [
                "image",
                str(src),
                "-o",
                str(tmp_path / "o.npz"),
                "--sigma-x",
                "0.1",
                "--align",
                "false",
                "-q",
            ]
        )
        == 0
    )
    assert time.perf_counter() - t0 < 30


def test_extreme_amplitudes_image_or_are_refused(tmp_path, capsys, p2):
    """A signal x 1e300 must not image to nothing with overflow warnings
    (squaring the samples in the derived sigma_r or the noise floor would):
    they work on amplitudes relative to the largest, so 1e-290 .. 1e300 give
    the unscaled image (the contract asks for 1e-6 .. 1e6); beyond what a sum of all
    samples or a product with a small weight holds in float64, one line."""
    d = dict(np.load(p2))
    base = tmp_path / "base.npz"
    assert main(["image", str(p2), "-o", str(base), "-q"]) == 0
    want = np.load(base)["points"]
    for scale in (1e-290, 1e300):
        src = _edited(tmp_path, p2, "s.npz", signal=d["signal"] * scale)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            assert main(["image", str(src), "-o", str(tmp_path / "o.npz"), "-q"]) == 0
        np.testing.assert_allclose(np.load(tmp_path / "o.npz")["points"], want, atol=1e-4)
    for scale in (1e305, 1e-305):
        src = _edited(tmp_path, p2, "s.npz", signal=d["signal"] * scale)
        line = _one_error(capsys, ["image", str(src), "-o", str(tmp_path / "o.npz")])
        assert "a sum of them all stays within float64's range" in line


def test_numbers_and_pad_edge_values():
    """A Fraction or Decimal fc (numbers.Real) is a number; pad = inf is
    refused like any bad pad, not an OverflowError from int()."""
    from decimal import Decimal
    from fractions import Fraction

    from rpm_cl.extract.kspace import KSpaceParams

    assert Waveform(Fraction(20_000_000_000), Decimal("2e8")).fc == 20e9
    for pad in (float("inf"), float("nan"), 65, 0, 2.5):
        with pytest.raises(InputError, match="pad must be an integer from 1 to 64"):
            KSpaceParams(pad=pad)
