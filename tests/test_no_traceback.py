"""Bad input never ends the command line in a traceback: one line
``rpm-cl: error: ...`` and exit status 2 (Ctrl-C: 130), and a unit that looks
wrong is named alike in the time- and the frequency-domain schema.

The inputs are built here with NumPy: two point targets seen by 21 antennas
of 5 mm pitch at 19.9-20.1 GHz (the paper's band), as range profiles or as
frequency samples.
"""

import io
import json
import os
import signal
import subprocess
import sys
import time
import zipfile

import numpy as np
import pytest

from rpm_cl.cli import main
from rpm_cl.io.data import C0, DataWarning, InputError, Waveform
from rpm_cl.io.formats import load_data

X = np.linspace(-0.05, 0.05, 21)
FREQ = np.linspace(19.9e9, 20.1e9, 101)
TARGETS = ((0.0, 0.3), (0.02, 0.4))


def _spectrum(x=X, f=FREQ):
    r = [np.hypot(x - tx, ty) for tx, ty in TARGETS]
    return sum(np.exp(-4j * np.pi * f[None, :] * ri[:, None] / C0) for ri in r)


def _time_domain(**override):
    """Range profiles of the same targets: a 0.2 GHz band at 20 GHz, 2.5 mm gates."""
    rng = np.arange(400) * 2.5e-3
    r = [np.hypot(X - tx, ty) for tx, ty in TARGETS]
    res = C0 / (2 * 0.2e9)
    sig = sum(
        np.sinc((rng[None, :] - ri[:, None]) / res) * np.exp(-4j * np.pi * 20e9 * ri[:, None] / C0)
        for ri in r
    )
    out = {"signal": sig, "x": X, "range": rng, "fc": 20e9, "bandwidth": 0.2e9}
    out.update(override)
    return out


def _freq_domain(**override):
    out = {"spectrum": _spectrum(), "frequency": FREQ, "x": X}
    out.update(override)
    return {k: v for k, v in out.items() if v is not None}


def _save(path, arrays):
    np.savez(path, **arrays)
    return str(path)


def _one_line_error(argv, capsys) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("rpm-cl: error:") and "\n" not in err, err
    assert "Traceback" not in err
    return err


# --- an implausible carrier ---------------------------------------------------
@pytest.mark.parametrize(
    "arrays",
    [
        _time_domain(fc=1e30),
        _freq_domain(fc=1e30),
        _freq_domain(frequency=FREQ * 1e20),
    ],
    ids=["time-fc", "freq-fc", "freq-axis"],
)
def test_carrier_above_10_thz_is_refused(tmp_path, capsys, arrays):
    """fc = 1e30 Hz would size the near-field search at 1e22 directions
    ("Maximum allowed size exceeded", a traceback): one error line instead."""
    src = _save(tmp_path / "in.npz", arrays)
    err = _one_line_error(["image", src, "-o", str(tmp_path / "out.npz")], capsys)
    assert "above 1e+13 Hz" in err and ("fc" in err or "frequency" in err), err
    assert not (tmp_path / "out.npz").exists()


def test_waveform_bounds_fc():
    with pytest.raises(InputError, match="fc = 2e\\+13 Hz is above"):
        Waveform(2e13, 1e9)
    assert Waveform(1e12, 1e9).fc == 1e12  # a terahertz imager's carrier is fine


# --- a config file nested too deep -------------------------------------------
@pytest.mark.parametrize(
    "text",
    [
        "a = " + "[" * 100_000 + "]" * 100_000 + "\n",
        "a = " + "{b = " * 5_000 + "1" + "}" * 5_000 + "\n",
    ],
    ids=["arrays", "tables"],
)
def test_deeply_nested_config(tmp_path, capsys, text):
    cfg = tmp_path / "deep.toml"
    cfg.write_text(text)
    err = _one_line_error(
        ["image", str(tmp_path / "in.npz"), "-o", str(tmp_path / "o.npz"), "--config", str(cfg)],
        capsys,
    )
    assert "nested too deep" in err and "deep.toml" in err


# --- a DAS image whose axes overflow -----------------------------------------
def _das_image(path, **override):
    arrays = {
        "image": np.ones((5, 7), np.complex64),
        "x": np.linspace(-0.1, 0.1, 5),
        "y": np.linspace(0.1, 0.4, 7),
        "meta": np.array('{"method": "das"}'),
    }
    arrays.update(override)
    np.savez(path, **arrays)
    return str(path)


@pytest.mark.parametrize(
    "axes",
    [
        {"y": np.linspace(0.1, 0.4, 7) * 1e308},  # finite, but x 1e3 (mm) overflows
        {"x": np.array([-1e308, -5e307, 0.0, 5e307, 1e308])},  # finite; its steps overflow
    ],
    ids=["huge-y", "huge-x"],
)
def test_view_refuses_overflowing_axes(tmp_path, capsys, axes):
    src = _das_image(tmp_path / "img.npz", **axes)
    err = _one_line_error(["view", src, "--png", str(tmp_path / "p.png")], capsys)
    assert "beyond the +-1e+06 m of an image grid" in err or "strictly increasing" in err, err
    assert not list(tmp_path.glob("*.png")) and not list(tmp_path.glob(".tmp-*"))


def test_das_grid_within_view_bounds(tmp_path, capsys):
    """`rpm-cl das` writes no grid that `rpm-cl view` would refuse."""
    src = _save(tmp_path / "in.npz", _time_domain())
    err = _one_line_error(
        ["das", src, "-o", str(tmp_path / "img.npz"), "--grid=0:1e300:1e297,0.1:0.4:0.01"], capsys
    )
    assert "within +-1e+06 m" in err


# --- a corrupt .npy header ------------------------------------------------------
def _with_header_shape(path, arrays, key, shape):
    """``arrays`` as an .npz whose member ``key`` declares ``shape`` (the
    header keeps its length; the data stay as they were)."""
    with zipfile.ZipFile(path, "w") as zf:
        for k, v in arrays.items():
            buf = io.BytesIO()
            np.lib.format.write_array(buf, np.asarray(v))
            raw = buf.getvalue()
            if k == key:
                end = raw.index(b"\n") + 1
                head = raw[: end - 1].replace(repr(np.shape(v)).encode(), repr(shape).encode())
                head = head.rstrip(b" ")
                assert len(head) < end - 1
                raw = head + b" " * (end - 1 - len(head)) + b"\n" + raw[end:]
            zf.writestr(k + ".npy", raw)
    return str(path)


def test_corrupt_header_is_not_out_of_memory(tmp_path, capsys):
    """A header declaring 2e15 bytes (more than a 47-bit address space, so
    the allocation fails whatever the overcommit policy) in a member of
    200 kB is a corrupt file, not a problem too large for the machine."""
    src = _with_header_shape(
        tmp_path / "bad.npz", _time_domain(), "signal", (21, 12_000_000_000_000)
    )
    err = _one_line_error(["image", src, "-o", str(tmp_path / "o.npz")], capsys)
    assert "out of memory" not in err
    assert "signal" in err and "header is corrupt" in err, err


def test_memory_error_names_a_corrupt_member(tmp_path):
    """Where a MemoryError escapes a reader, main() looks at the inputs'
    headers (rpm_cl.io.formats.check_members): a member declaring more than it
    holds is named, sound inputs leave the plain out-of-memory line."""
    import argparse

    from rpm_cl.cli import commands as cli

    bad = _with_header_shape(
        tmp_path / "bad.npz", _time_domain(), "signal", (21, 12_000_000_000_000)
    )
    line = cli._declared_too_large(argparse.Namespace(input=bad))
    assert line is not None and "signal" in line and "header is corrupt" in line
    good = tmp_path / "good.npz"
    np.savez(good, **_time_domain())
    assert cli._declared_too_large(argparse.Namespace(input=str(good))) is None


# --- Ctrl-C during start-up -----------------------------------------------------
_CHILD = (
    "import sys; sys.stderr.write('up\\n'); sys.stderr.flush(); "
    "from rpm_cl.cli import main; sys.exit(main())"
)


def _env():
    """The environment of a child interpreter that imports the ``rpm_cl``
    these tests import: the folder holding that package first on its path
    (an installed copy's site-packages, or a checkout run from its root;
    not the checkout's root under an installed copy, whose ``rpm_cl`` lacks
    the kernels the installation puts in ``rpm_cl/kernels``)."""
    import rpm_cl

    env = dict(os.environ)
    root = os.path.dirname(os.path.dirname(os.path.abspath(rpm_cl.__file__)))
    env["PYTHONPATH"] = os.pathsep.join([root, env.get("PYTHONPATH", "")])
    return env


def _heavy_modules_after(code: str, names, cwd=None) -> list:
    """Which of the modules ``names`` (and their submodules) a fresh
    interpreter holds after running ``code`` (in the folder ``cwd``: one
    without a checkout's ``rpm_cl``, whose kernels an installed copy keeps
    elsewhere, where the code builds programs)."""
    probe = (
        f"{code}; import json, sys; print(json.dumps(sorted(m for m in sys.modules "
        f"if m.split('.')[0] in {tuple(names)!r})))"
    )
    out = subprocess.run(
        [sys.executable, "-c", probe],
        check=False,
        capture_output=True,
        text=True,
        env=_env(),
        timeout=60,
        cwd=cwd,
    )
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def test_cli_import_is_light():
    """``rpm_cl`` and ``rpm_cl.cli`` import neither NumPy nor OpenCL: the
    heavy imports run inside main()'s Ctrl-C handler."""
    assert _heavy_modules_after("import rpm_cl.cli", ("numpy", "scipy", "pyopencl")) == []


def test_parser_imports_no_scipy():
    """Every command builds the whole parser (the imaging parameters are its
    flags) before it can refuse a bad input: SciPy's 0.5-0.9 s of imports
    wait for the first computation (rpm_cl.lazy), so that a refusal takes
    about half a second."""
    code = "from rpm_cl.cli import build_parser; build_parser()"
    assert _heavy_modules_after(code, ("scipy",)) == []


def test_imaging_a_gpr_line_imports_no_scipy(tmp_path):
    """phase-rpm on a wide-band line of 300 traces (FFTs across the array,
    the range-walk alignment's spline prefilter, the coherent centres and
    the coherence test, which drops points here) runs on NumPy's
    equivalents of SciPy's FFT, spline filter and k-d tree query
    (rpm_cl.transforms, rpm_cl.filters, rpm_cl.rpm.coherence.marked), which
    give its numbers without its 0.3-0.5 s of imports."""
    from rpm_cl.io.data import Array, Waveform
    from rpm_cl.io.formats import save_data
    from rpm_cl.simulate import simulate
    from rpm_cl.simulate.scene import PointTarget, Scene

    scene = Scene(tuple(PointTarget(p) for p in [(0.8, 1.2), (1.5, 1.35), (2.2, 1.25)]))
    data = simulate(
        scene, Array(np.arange(300) * 0.01), Waveform(1.5e9, 1e9), np.arange(0, 2, 5e-3), 20.0, 0
    )
    path, out = tmp_path / "line.npz", tmp_path / "out.npz"
    save_data(path, data)
    code = (
        "from rpm_cl.cli import main; "
        f"assert main(['image', {str(path)!r}, '-o', {str(out)!r}, '-q']) == 0"
    )
    assert _heavy_modules_after(code, ("scipy",), cwd=tmp_path) == []
    assert np.load(out)["points"].shape[0] > 100


@pytest.mark.parametrize("delay", [0.15, 0.3, 0.5, 0.8, 1.2])
def test_ctrl_c_during_start_up(tmp_path, delay):
    """SIGINT ``delay`` s after Python's own start-up (site, measured from
    the child's 'up' line; before it nothing of rpm-cl runs): exit 130 and
    one line, or a finished run; never a traceback nor a partial file.  The
    delays span the imports behind `rpm-cl` (measured: 0.8 s before main()
    runs); on a loaded machine the signal may land after the file's atomic
    rename and before main() returns: "interrupted", and the file whole."""
    out = tmp_path / "hb.npz"
    p = subprocess.Popen(
        [sys.executable, "-c", _CHILD, "simulate", "human-body", "-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=_env(),
        cwd=tmp_path,
    )
    assert p.stderr.readline() == b"up\n"
    time.sleep(delay)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=120)
    err = err.decode()
    assert "Traceback" not in err, err
    # -SIGINT: the signal came after main() returned, in the interpreter's
    # shutdown (the run had finished: its file is whole)
    assert p.returncode in (0, 130, -signal.SIGINT), (p.returncode, err)
    if p.returncode == 130:
        assert err.strip().splitlines()[-1] == "rpm-cl: interrupted"
    if p.returncode != 130 or out.exists():
        assert load_data(out).signal.shape == (11, 17, 400)
    assert not list(tmp_path.glob(".tmp-*"))


_SIGNAL_AT = """
import os, signal, sys
from rpm_cl._entry import run
sig = getattr(signal, sys.argv.pop(1))
where = compile(sys.argv.pop(1), "where", "eval")
def hook(f, event, arg):
    if event == "call" and f.f_back is not None and eval(where):
        sys.setprofile(None)
        sys.stderr.write("sent\\n")
        os.kill(os.getpid(), sig)
sys.setprofile(hook)
sys.exit(run())
"""

#: Moments (the first Python call for which the expression holds, ``f`` its
#: frame) where a signal's exception once escaped the command's one line.
FRAGILE = {
    # pyopencl's extension (nanobind) building its enumerations: an
    # exception there aborts the process ("Critical nanobind error")
    "pyopencl-enums": 'f.f_code.co_filename.endswith("enum.py")'
    ' and f.f_back.f_code.co_name == "_call_with_frames_removed"',
    # the console script calling main(), before main's handler is in place
    "main-called": 'f.f_code.co_name == "main" and f.f_code.co_filename.endswith("commands.py")',
    # main's handler installed, inside signal.signal, before main's try
    "handler-installed": 'f.f_code.co_name == "_int_to_enum"'
    ' and f.f_back.f_code.co_name == "signal"'
    ' and f.f_back.f_back.f_code.co_name == "_catch_signals"',
    # main's clean-up after the command (its output written), in its finally
    "main-finally": 'f.f_code.co_name == "removeHandler" and f.f_back.f_code.co_name == "main"',
}


@pytest.mark.parametrize("moment", sorted(FRAGILE))
@pytest.mark.parametrize(
    "name,code,line", [("SIGINT", 130, "interrupted"), ("SIGTERM", 143, "terminated")]
)
def test_signal_at_a_fragile_moment(tmp_path, moment, name, code, line):
    """A Ctrl-C or SIGTERM landing at each moment of :data:`FRAGILE` ends
    the command with its one line and exit code: no traceback, no abort, no
    file.  The signal is sent from inside the moment's own first call, so
    the timing is exact."""
    src = _save(tmp_path / "in.npz", _freq_domain())
    out = tmp_path / "out.npz"
    argv = [name, FRAGILE[moment], "image", src, "-o", str(out)]
    p = subprocess.run(
        [sys.executable, "-c", _SIGNAL_AT, *argv],
        capture_output=True,
        text=True,
        env=_env(),
        cwd=tmp_path,
        timeout=120,
        check=False,
    )
    assert p.stderr.startswith("sent\n"), p.stderr  # the hook fired
    assert "Traceback" not in p.stderr and "nanobind" not in p.stderr, p.stderr
    assert p.returncode == code, (p.returncode, p.stderr)
    assert p.stderr.strip().splitlines()[-1] == f"rpm-cl: {line}"
    if moment == "main-finally":  # the command had finished: its file is whole
        from rpm_cl.viz.results import load_result

        assert load_result(out)["points"].shape[1] == 2
    else:
        assert not out.exists()
    assert not list(tmp_path.glob(".tmp-*"))


def test_a_signal_that_a_library_drops_still_ends_the_command(monkeypatch, capsys):
    """A handler's exception caught and dropped on its way (Python 3.11
    wraps one raised in ``__set_name__`` in a RuntimeError, which
    matplotlib's import of its 3-D axes catches with ``except Exception``):
    the command, once back in main(), ends as the signal asks."""
    from rpm_cl.cli import commands, errors

    def swallowing(args):
        try:
            errors._on_sigint(signal.SIGINT, sys._getframe())
        except Exception:  # noqa: BLE001 - what such a library does
            raise AssertionError("KeyboardInterrupt is no Exception") from None
        except KeyboardInterrupt as exc:
            try:
                raise RuntimeError("Error calling __set_name__") from exc
            except Exception:  # noqa: BLE001, S110 - dropped, as the library does
                pass
        return 0

    monkeypatch.setattr(commands, "_run", swallowing)
    assert main(["info"]) == 130
    assert capsys.readouterr().err.strip().splitlines()[-1] == "rpm-cl: interrupted"
    errors._SIGNALS_SEEN.clear()


@pytest.mark.parametrize("dtype", [np.clongdouble, np.complex64])
def test_spectrum_of_any_complex_precision_images(tmp_path, capsys, dtype):
    """Frequency samples stored as complex long double (or complex64) image
    as complex128 ones do: the engine holds them as complex128 (complex64
    kept), since NumPy's linear algebra has no long-double type (the
    coherent level's parabola fit raised TypeError on them)."""
    arrays = _freq_domain()
    arrays["spectrum"] = arrays["spectrum"].astype(dtype)
    src = _save(tmp_path / "in.npz", arrays)
    data = load_data(src)
    assert data.spectrum.values.dtype == (np.complex64 if dtype == np.complex64 else np.complex128)
    assert main(["image", src, "-o", str(tmp_path / "o.npz"), "-q"]) == 0
    assert "Traceback" not in capsys.readouterr().err


# --- units, both input domains ----------------------------------------------------
def _scaled(domain, unit):
    """Input of ``domain`` with its frequencies (fc, bandwidth / frequency)
    divided by ``unit``'s factor."""
    k = {"kHz": 1e3, "MHz": 1e6, "GHz": 1e9}[unit]
    if domain == "time":
        return _time_domain(fc=20e9 / k, bandwidth=0.2e9 / k)
    return _freq_domain(frequency=FREQ / k)


@pytest.mark.parametrize("domain", ["time", "freq"])
@pytest.mark.parametrize("unit", ["MHz", "GHz"])
def test_frequencies_in_mhz_or_ghz_numbers_refused(tmp_path, domain, unit):
    src = _save(tmp_path / "in.npz", _scaled(domain, unit))
    with pytest.raises(
        InputError, match=f"looks like {unit} numbers \\(x 1e{unit[0] == 'G' and 9 or 6}\\); give"
    ):
        load_data(src)


@pytest.mark.parametrize("domain", ["time", "freq"])
def test_frequencies_in_khz_numbers_warned(tmp_path, domain):
    """kHz numbers pass the 1 MHz floor; the pitch against the wavelength
    shows them."""
    src = _save(tmp_path / "in.npz", _scaled(domain, "kHz"))
    with pytest.warns(DataWarning, match="kHz numbers\\? give them in Hz \\(x 1e3\\)"):
        load_data(src)


@pytest.mark.parametrize("domain", ["time", "freq"])
def test_x_in_mm_warned(tmp_path, domain):
    make = _time_domain if domain == "time" else _freq_domain
    src = _save(tmp_path / "in.npz", make(x=X * 1e3))
    with pytest.warns(DataWarning, match="is x in mm or cm\\? give x in m"):
        load_data(src)


def _bandwidth_only(domain, k):
    """fc in Hz, bandwidth divided by ``k``."""
    return (
        _time_domain(bandwidth=0.2e9 / k)
        if domain == "time"
        else _freq_domain(fc=20e9, bandwidth=0.1e9 / k)
    )


@pytest.mark.parametrize("domain", ["time", "freq"])
@pytest.mark.parametrize("unit,k", [("MHz", 1e6), ("GHz", 1e9)])
def test_bandwidth_alone_in_mhz_or_ghz_numbers_refused(tmp_path, capsys, domain, unit, k):
    """Refused naming the unit in both domains (unrefused, the time domain's
    MHz case runs out of memory)."""
    src = _save(tmp_path / "in.npz", _bandwidth_only(domain, k))
    with pytest.raises(
        InputError,
        match=f"bandwidth = .* looks like {unit} numbers .*; give fc and bandwidth in Hz",
    ):
        load_data(src)
    err = _one_line_error(["image", src, "-o", str(tmp_path / "o.npz")], capsys)
    assert f"{unit} numbers" in err


@pytest.mark.parametrize("domain", ["time", "freq"])
def test_bandwidth_alone_in_khz_numbers_warned(tmp_path, domain):
    src = _save(tmp_path / "in.npz", _bandwidth_only(domain, 1e3))
    with pytest.warns(
        DataWarning,
        match="bandwidth = .* looks like kHz numbers \\(x 1e3\\); give fc and bandwidth in Hz",
    ):
        load_data(src)


@pytest.mark.parametrize(
    "fc,freq",
    [(20e9, FREQ / 1e3), (20e9 / 1e3, FREQ), (20.0, FREQ)],
    ids=["band-khz", "fc-khz", "fc-ghz"],
)
def test_fc_and_band_in_different_units(tmp_path, fc, freq):
    src = _save(tmp_path / "in.npz", _freq_domain(frequency=freq, fc=fc))
    unit = "GHz" if fc == 20.0 else "kHz"
    with pytest.raises(InputError, match=f"looks like {unit} numbers"):
        load_data(src)


@pytest.mark.parametrize("domain", ["time", "freq"])
def test_control_hz_loads_quietly(tmp_path, domain, recwarn):
    """The inputs above in the right units load without a warning, so each
    refusal and warning comes from the one unit spoiled."""
    src = _save(tmp_path / "in.npz", _time_domain() if domain == "time" else _freq_domain())
    data = load_data(src)
    assert data.waveform.fc == pytest.approx(20e9)
    assert not [w for w in recwarn if issubclass(w.category, DataWarning)]


@pytest.fixture
def handled(monkeypatch):
    """The command line's handling of signals installed in this process
    (its hooks and SIGTERM handler; SIGINT stays pytest's), with each
    delivery made again recorded instead of made: ``(errors, sent, done)``."""
    import _thread
    import threading

    from rpm_cl.cli import errors

    sent = []
    done = threading.Event()

    def interrupt(sig):
        sent.append(sig)
        done.set()

    held = {}
    errors._catch_signals(True, held)
    try:
        monkeypatch.setattr(_thread, "interrupt_main", interrupt)
        mine = {signal.SIGINT: errors._on_sigint, signal.SIGTERM: errors._on_sigterm}
        monkeypatch.setattr(signal, "getsignal", mine.get)
        yield errors, sent, done
    finally:
        errors._release_signals(held)


def test_sigint_in_a_finalizer_is_delivered_again_after_it(handled, capsys):
    """A KeyboardInterrupt raised inside ``__del__`` cannot leave it: Python
    would print it as "Exception ignored" with a traceback and go on (a
    progress bar collected as Ctrl-C lands).  There the handler does not
    raise; it delivers SIGINT to the main thread again a moment later (while
    it is still the handler); anywhere else it raises."""
    errors, sent, done = handled

    class Finalized:
        def __del__(self):
            errors._on_sigint(signal.SIGINT, sys._getframe())

    def deep():
        return Finalized()

    obj = deep()
    del obj  # runs __del__: no exception escapes, a second SIGINT is on its way
    assert done.wait(5.0)
    assert sent == [signal.SIGINT] and errors._SIGNALS_SEEN == [signal.SIGINT]
    with pytest.raises(KeyboardInterrupt):
        errors._on_sigint(signal.SIGINT, sys._getframe())
    assert capsys.readouterr().err == ""


def _weakref_callback(errors, handler, signum):
    import weakref

    class Obj:
        pass

    obj = Obj()
    ref = weakref.ref(obj, lambda r: handler(signum, sys._getframe()))
    del obj  # the callback runs: the handler raises in it
    return ref


def _closed_generator(errors, handler, signum):
    def gen():
        try:
            yield 1
        finally:
            handler(signum, sys._getframe())

    g = gen()
    next(g)
    del g  # closed as it is collected: the handler raises in its finally


def _printed_by_c(errors, handler, signum):
    import ctypes

    # PyRun_SimpleString prints an exception with PyErr_Print, as NumPy's
    # import_array does in another extension's initialisation
    code = f"from rpm_cl.cli import errors; errors.{handler.__name__}({int(signum)}, None)"
    assert ctypes.pythonapi.PyRun_SimpleString(code.encode()) == -1


@pytest.mark.parametrize("where", [_weakref_callback, _closed_generator, _printed_by_c])
@pytest.mark.parametrize("name", ["SIGINT", "SIGTERM"])
def test_signal_whose_exception_cannot_leave_is_delivered_again(handled, capsys, where, name):
    """Where a handler's exception cannot leave (a weakref callback, such
    as importlib's module locks; a generator closed by the collector; a C
    extension that prints the error itself and raises another): the hooks
    deliver the signal again instead of printing a traceback and losing it."""
    errors, sent, done = handled
    signum = getattr(signal, name)
    handler = {"SIGINT": errors._on_sigint, "SIGTERM": errors._on_sigterm}[name]
    where(errors, handler, signum)
    assert done.wait(5.0)
    assert sent == [signum] and errors._SIGNALS_SEEN == [signum]
    assert capsys.readouterr().err == ""


def test_redelivery_is_bounded_and_other_errors_are_shown(handled, monkeypatch):
    """After SIGNAL_RETRIES deliveries in one command an exception that
    cannot leave goes on to the hook that was there before (Python's prints
    it); so does any other exception, and one of a signal no handler of ours
    raised.  A released handler is not delivered again."""
    import types

    errors, sent, _ = handled
    shown = []
    unraisable = errors._unraisable_hook(shown.append)
    excepthook = errors._except_hook(lambda *a: shown.append(a[0]))
    ki = types.SimpleNamespace(exc_type=KeyboardInterrupt)
    unraisable(ki)  # SIGINT not seen: a KeyboardInterrupt of someone else's
    assert shown == [ki] and sent == []
    errors._SIGNALS_SEEN.append(signal.SIGINT)
    errors._REDELIVERED[0] = errors.SIGNAL_RETRIES
    unraisable(ki)
    excepthook(KeyboardInterrupt, KeyboardInterrupt(), None)
    assert shown == [ki, ki, KeyboardInterrupt] and sent == []
    errors._REDELIVERED[0] = 0
    ve = types.SimpleNamespace(exc_type=ValueError)
    unraisable(ve)
    excepthook(ValueError, ValueError(), None)
    assert shown[3:] == [ve, ValueError] and sent == []
    # released: the delayed delivery does nothing
    monkeypatch.setattr(signal, "getsignal", lambda sig: signal.default_int_handler)
    errors._interrupt_again(signal.SIGINT)
    assert sent == []


def test_an_error_after_a_signal_ends_as_that_signal(monkeypatch, capsys):
    """An ImportError (or any error) that follows a handler's exception, as
    when an import is interrupted inside a C extension, ends the command as
    the signal does: SIGTERM 143 "terminated", SIGINT 130 "interrupted"."""
    from rpm_cl.cli import errors

    monkeypatch.setattr(errors, "_SIGNALS_SEEN", [signal.SIGTERM])
    assert errors._error_exit(ImportError("partly initialised"), True) == 143
    assert capsys.readouterr().err == "rpm-cl: terminated\n"
    monkeypatch.setattr(errors, "_SIGNALS_SEEN", [signal.SIGINT, signal.SIGTERM])
    assert errors._error_exit(ImportError("partly initialised"), True) == 130
    assert capsys.readouterr().err == "rpm-cl: interrupted\n"
    monkeypatch.setattr(errors, "_SIGNALS_SEEN", [])
    assert errors._error_exit(ImportError("a missing module"), True) is None
