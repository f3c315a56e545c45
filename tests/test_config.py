"""Parameters from TOML and flags (rpm_cl.cli.config, `rpm-cl params`, --config)."""

import dataclasses
import json
import typing

import numpy as np
import pytest

from rpm_cl.cli import build_parser, main
from rpm_cl.cli.config import EngineParams, dump_toml, load_config, resolve, settings
from rpm_cl.extract.kspace import KSpaceParams
from rpm_cl.io.data import InputError, load_npz
from rpm_cl.io.medium import Medium
from rpm_cl.rpm.params import WINDOW_PLANAR_DEFAULT, ImagingParams, RPMParams, default_params

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("cfg")
    lin, pla = d / "p2.npz", d / "hb.npz"
    assert (
        main(["simulate", "paper-2d", "-o", str(lin), "--snr", "20", "--noise", "receiver", "-q"])
        == 0
    )
    assert main(["simulate", "human-body", "-o", str(pla), "-q"]) == 0
    return lin, pla


def params_toml(capsys, *argv) -> dict:
    assert main(["params", *map(str, argv)]) == 0
    out = capsys.readouterr().out
    return tomllib.loads(out)


def test_every_dataclass_field_is_a_setting():
    """Enumerated independently of rpm_cl.cli.config: a field added to any of
    the parameter dataclasses must show up as a TOML key and a flag."""
    have = {(s.section, s.name) for s in settings()}
    want = {("kspace", f.name) for f in dataclasses.fields(KSpaceParams)}
    want |= {("rpm", f.name) for f in dataclasses.fields(RPMParams)}
    want |= {("medium", f.name) for f in dataclasses.fields(Medium)}
    want |= {
        ("imaging", f.name)
        for f in dataclasses.fields(ImagingParams)
        if f.name not in ("kspace", "rpm", "medium")
    }
    want |= {("engine", f.name) for f in dataclasses.fields(EngineParams)}
    assert want == have
    image = build_parser()._subparsers._group_actions[0].choices["image"]
    flags = set(image._option_string_actions)
    assert {s.flag for s in settings()} <= flags


def _other_value(s):
    """A valid value different from the field's default: by type, a number 0.75 of
    it (1.5 for eps_r, whose default is its lower bound; reach_deg's is near
    its upper one)."""
    if s.choices:
        return next(c for c in s.choices if c != s.default)
    if s.kind is bool:
        return True if s.default is None else not s.default
    if s.kind is str:
        return "some-device"
    if s.default is None:
        return 123 if s.kind is int else 123.0
    if s.kind is int:
        return s.default + 1
    if s.name in ("eps_r",):  # bounded below by its default (air): above it
        return s.default * 1.5
    return s.default * 0.75 if s.default != 0 else 0.5


def test_every_field_settable_from_toml(files, tmp_path):
    """Each field set to a non-default value in one file comes back as set."""
    data = load_npz(files[1])  # planar: window_z allowed
    want = {(s.section, s.name): _other_value(s) for s in settings()}
    lines, section = [], None
    for (sec, name), v in want.items():
        if sec != section:
            lines.append(f"[{sec}]")
            section = sec
        lines.append(f"{name} = {json.dumps(v)}")
    path = tmp_path / "all.toml"
    path.write_text("\n".join(lines) + "\n")
    values = load_config(path)
    assert values == want
    p = resolve(data, values)
    for (sec, name), v in want.items():
        if sec == "imaging":
            assert getattr(p, name) == v, name
        elif sec != "engine":
            assert getattr(getattr(p, sec), name) == v, (sec, name)


@pytest.mark.parametrize("which", [0, 1])
def test_params_round_trip(files, tmp_path, capsys, which):
    """`rpm-cl params` output read back with --config gives the same
    parameters exactly, and printing them again gives the same text."""
    src = files[which]
    out1 = tmp_path / "a.toml"
    assert (
        main(
            [
                "params",
                str(src),
                "-o",
                str(out1),
                "--sigma-r",
                "0.0123456789012345",
                "--near-neighbours",
                "auto",
                "--pair-cutoff",
                "inf",
                "--meanshift-iters",
                "0",
                "--meanshift-point",
                "nearest",
            ]
        )
        == 0
    )
    capsys.readouterr()
    assert main(["params", str(src), "--config", str(out1)]) == 0
    text2 = capsys.readouterr().out
    assert text2.split("\n", 1)[1] == out1.read_text().split("\n", 1)[1]  # all but the file name
    data = load_npz(src)
    p1 = resolve(data, load_config(out1))
    want = default_params(
        data,
        sigma_r=0.0123456789012345,
        pair_cutoff=float("inf"),
        meanshift_iters=0,
        meanshift_point="nearest",
    )
    want = dataclasses.replace(want, rpm=dataclasses.replace(want.rpm, near_neighbours=None))
    assert p1 == want
    assert p1.rpm.near_neighbours is None and p1.rpm.pair_cutoff == np.inf
    assert p1.rpm.sigma_r == 0.0123456789012345  # every digit survives


def test_derived_defaults_follow_the_array(files, capsys):
    """sigma_x: the aperture (21 antennas at 5 mm: 0.1 m) for a linear
    array, 2.5 spacings (7.5 mm) for a planar one; window_z = window_x for a
    planar array only."""
    lin = params_toml(capsys, files[0])
    pla = params_toml(capsys, files[1])
    assert lin["rpm"]["sigma_x"] == pytest.approx(0.10)
    assert pla["rpm"]["sigma_x"] == pytest.approx(2.5 * 7.5e-3)
    assert lin["kspace"]["window_z"] == "auto"
    assert pla["kspace"]["window_z"] == pla["kspace"]["window_x"] == WINDOW_PLANAR_DEFAULT
    # sigma_r = 10 mm x range / aperture: targets at 0.42-0.49 m, 0.1 m aperture;
    # the body's front about 1 m from a 0.12 m tall array
    assert 0.040 <= lin["rpm"]["sigma_r"] <= 0.050
    assert 0.075 <= pla["rpm"]["sigma_r"] <= 0.090
    assert pla["engine"] == {"device": "auto", "precision": "float32"}


def test_flag_beats_file_beats_default(files, tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text(
        "[rpm]\nsigma_r = 0.03\nmax_neighbours = 30\n[kspace]\nwindow_x = 300.0\n"
        'align = false\n[engine]\nprecision = "float64"\n'
    )
    got = params_toml(
        capsys,
        files[0],
        "--config",
        cfg,
        "--sigma-r",
        "0.02",
        "--precision",
        "float32",
        "--align",
        "auto",
    )
    assert got["rpm"]["sigma_r"] == 0.02  # flag over file
    assert got["engine"]["precision"] == "float32"
    assert got["kspace"]["align"] == "auto"  # a flag may set None back
    assert got["kspace"]["window_x"] == 300.0  # file over default (417)
    assert got["rpm"]["max_neighbours"] == 30
    assert got["rpm"]["sigma_x"] == pytest.approx(0.10)  # derived default
    got = params_toml(capsys, files[0], "--config", cfg)
    assert got["engine"]["precision"] == "float64" and got["kspace"]["align"] is False


BAD = [
    ("[rpm]\nsigma_q = 1.0\n", "sigma_q"),  # unknown key
    ("[rpmm]\nsigma_r = 1.0\n", "rpmm"),  # unknown section
    ("sigma_r = 0.05\n", "sigma_r"),  # outside a section
    ('[rpm]\nsigma_r = "wide"\n', "sigma_r"),  # wrong type
    ("[rpm]\nsigma_r = true\n", "sigma_r"),  # bool is not a number
    ("[kspace]\npad = 2.5\n", "pad"),  # float for an int
    ("[kspace]\ndetect_taper = 1\n", "detect_taper"),  # int for a bool
    ('[kspace]\nnear_field = "maybe"\n', "near_field"),
    ("[rpm]\nsigma_r = -0.01\n", "sigma_r"),  # out of range
    ("[rpm]\nsigma_x = 5000.0\n", "sigma_x"),
    ("[kspace]\npad = 0\n", "pad"),
    ("[kspace]\npeak_threshold_db = 3.0\n", "peak_threshold_db"),
    ("[rpm]\nnear_neighbours = 99\n", "near_neighbours"),
    ("[rpm]\nmeanshift_iters = -2\n", "meanshift_iters"),
    ('[rpm]\nmeanshift_point = "centre"\n', "meanshift_point"),
    ("[rpm]\nmeanshift_max_rps = -1\n", "meanshift_max_rps"),
    ("[imaging]\nrp_threshold_db = 0.0\n", "rp_threshold_db"),
    ("[kspace]\nwindow_z = 100.0\n", "window_z"),  # linear array
    ('[engine]\nprecision = "float16"\n', "precision"),
    ("[rpm]\nsigma_r = 0.05\nsigma_r = 0.06\n", "TOML"),  # invalid TOML
    ("[rpm\n", "TOML"),
]


@pytest.mark.parametrize("text, key", BAD)
def test_bad_config_one_line_exit_2(files, tmp_path, capsys, text, key):
    cfg = tmp_path / "bad.toml"
    cfg.write_text(text)
    for cmd in (["params", str(files[0])], ["image", str(files[0]), "-o", str(tmp_path / "o.npz")]):
        assert main([*cmd, "--config", str(cfg)]) == 2
        out, err = capsys.readouterr()
        assert out == "" and err.count("\n") == 1 and err.startswith("rpm-cl: error: ")
        assert key in err and "bad.toml" in err, err
    assert not (tmp_path / "o.npz").exists()


@pytest.mark.parametrize(
    "argv, key",
    [
        (["--sigma-r", "wide"], "--sigma-r"),
        (["--sigma-r", "-1"], "sigma_r"),
        (["--pad", "2.5"], "--pad"),
        (["--align", "perhaps"], "--align"),
        (["--near-neighbours", "4096"], "near_neighbours"),
        (["--meanshift-iters", "1.5"], "--meanshift-iters"),
        (["--window-z", "90"], "window_z"),
        (["--precision", "float16"], "--precision"),
    ],
)
def test_bad_flag_one_line_exit_2(files, capsys, argv, key):
    assert main(["params", str(files[0]), *argv]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and key in err, err


def test_missing_config_file(files, tmp_path, capsys):
    assert main(["params", str(files[0]), "--config", str(tmp_path / "none.toml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "none.toml" in err


def test_dump_toml_loads_as_toml_with_every_key(files):
    data = load_npz(files[1])
    p = default_params(data)
    doc = tomllib.loads(dump_toml(p, EngineParams()))
    assert set(doc) == {"kspace", "rpm", "medium", "imaging", "engine"}
    assert sum(len(v) for v in doc.values()) == len(settings())


def test_type_hints_resolve_to_setting_kinds():
    """Every field type is one rpm_cl.cli.config can parse (a field of another
    type added later fails here, not at a user's command line)."""
    for cls in (KSpaceParams, RPMParams, ImagingParams, EngineParams):
        for name, hint in typing.get_type_hints(cls).items():
            if not dataclasses.is_dataclass(hint):
                assert any(s.name == name for s in settings()), (cls, name)


def test_library_errors_name_the_key(files):
    data = load_npz(files[0])
    with pytest.raises(InputError, match=r"x\.toml: \[rpm\] sigma_r"):
        resolve(data, {("rpm", "sigma_r"): -1.0}, sources={("rpm", "sigma_r"): "x.toml"})
    with pytest.raises(InputError, match="unknown imaging parameter 'sigma_q'"):
        default_params(data, sigma_q=1.0)


def test_quiet_image_prints_nothing(files, tmp_path, capsys):
    out = tmp_path / "o.npz"
    assert main(["image", str(files[0]), "-o", str(out), "--quiet"]) == 0
    assert capsys.readouterr() == ("", "")
    assert out.exists()


def test_verbose_image_logs_params_and_stages(files, tmp_path, capsys):
    out = tmp_path / "o.npz"
    assert main(["image", str(files[0]), "-o", str(out), "-v", "--sigma-r", "0.04"]) == 0
    o, err = capsys.readouterr()
    assert "wrote" in o
    assert "resolved parameters" in err and "sigma_r = 0.04" in err
    stages = next(line for line in err.splitlines() if "stage timings" in line)
    for word in ("decompose", "range_points", "rpm ", "rpm.intersect", "rpm.score", "write"):
        assert word in stages
    with np.load(out) as f:
        assert json.loads(str(f["meta"]))["params"]["rpm"]["sigma_r"] == 0.04


def test_das_takes_engine_from_config(files, tmp_path, capsys, cl_env):
    if not cl_env.has_double:
        pytest.skip("device has no float64")
    cfg = tmp_path / "e.toml"
    cfg.write_text('[engine]\nprecision = "float64"\n')
    out = tmp_path / "das.npz"
    base = [
        "das",
        str(files[0]),
        "-o",
        str(out),
        "--grid",
        "-0.05:0.05:0.01,0.4:0.5:0.01",
        "--config",
        str(cfg),
        "-q",
    ]
    assert main(base) == 0
    with np.load(out) as f:
        assert json.loads(str(f["meta"]))["precision"] == "float64"
        assert f["image"].dtype == np.complex128
    assert main([*base, "--precision", "float32"]) == 0
    with np.load(out) as f:
        assert f["image"].dtype == np.complex64
    assert capsys.readouterr() == ("", "")


def test_verbose_and_quiet_on_every_subcommand():
    sub = build_parser()._subparsers._group_actions[0]
    for name, sp in sub.choices.items():
        opts = sp._option_string_actions
        assert {"-v", "--verbose", "-q", "--quiet"} <= set(opts), name


def test_example_config_is_valid(files):
    from pathlib import Path

    path = Path(__file__).parent.parent / "examples" / "config.toml"
    values = load_config(path)
    assert values and resolve(load_npz(files[1]), values)


@pytest.mark.parametrize("coupling", [0.0, 1.0, 10.0])
def test_derived_sigma_r_ignores_an_echo_at_zero_range(coupling):
    """An antenna-coupling echo at 1 mm (as strong as the target's, or ten
    times) set sigma_r to the gate spacing (2.5 mm); it must come from the
    target: 10 mm x R / L for the target's range R = |(0.02, 0.51)| at the
    centre antenna and the 0.1 m aperture, 51.0 mm.  Tolerance 0.3 mm: the
    strongest gate lies within 1.25 mm (half a gate) of the echo's range, and
    the echo ranges across the array differ by 1.5 mm; 10 mm x 2.75 mm / 0.1 m
    = 0.28 mm."""
    from rpm_cl.io.data import Array, Waveform
    from rpm_cl.rpm.params import default_params
    from rpm_cl.simulate import simulate, synthesize
    from rpm_cl.simulate.scene import PointTarget, Scene

    arr = Array((np.arange(21) - 10) * 5e-3)
    axis = np.arange(0.0, 1.0, 2.5e-3)
    data = simulate(Scene((PointTarget((0.02, 0.51)),)), arr, Waveform(20e9, 3e9), axis)
    peak = np.abs(data.signal).max()
    leak = synthesize(
        np.arange(21), np.full(21, 1e-3), np.full(21, coupling * peak), 21, data.waveform, axis
    )
    data = dataclasses.replace(data, signal=data.signal + leak)
    assert default_params(data).rpm.sigma_r == pytest.approx(
        0.01 * np.hypot(0.02, 0.51) / 0.1, abs=3e-4
    )


def test_derived_sigma_r_of_a_narrow_band_scene_inside_half_a_resolution():
    """A 0.25 GHz sweep at 4 GHz (Hann: a resolution of 1.2 m) and a target at
    0.45 m, closer than half a resolution: sigma_r still comes from the
    target, 10 mm x R / L = 14 mm for the 0.32 m aperture, raised to the gate
    spacing (c / (2 df N) = 37 mm, the floor default_params
    documents), not from whatever lies beyond 0.6 m (which gives the 1 m
    clip)."""
    from rpm_cl.io.data import C0, Array, RadarData, Waveform
    from rpm_cl.io.formats import range_compress
    from rpm_cl.rpm.params import default_params

    x = 0.29 + np.arange(41) * 8e-3
    f = np.linspace(3.875e9, 4.125e9, 64)
    r = np.hypot(x - 0.45, 0.45)
    s, rng_axis = range_compress(np.exp(-4j * np.pi * f[None] * r[:, None] / C0), f, 4e9)
    data = RadarData(s, Array(x), rng_axis, Waveform(4e9, 0.125e9))
    want = max(0.01 * 0.45 / 0.32, data.dr)
    assert data.dr == pytest.approx(C0 / (2 * (f[1] - f[0]) * rng_axis.size))
    assert default_params(data).rpm.sigma_r == pytest.approx(want, abs=3e-4)


def test_derived_sigma_x_of_a_long_scan_is_the_echo_reach():
    """A 4 m GPR-like line (200 positions at 2 cm) over targets 0.30-0.34 m
    deep: sigma_x is SIGMA_X_PER_RANGE x the strongest echo's range (the
    profile power summed over the line peaks between the shallowest depth
    and 0.4 m, where the oblique echoes of neighbouring targets pile up),
    not the scan length (3.98 m) that weighed antennas metres apart as
    neighbours.  The paper's 0.1 m aperture (targets at ~0.4 m) keeps
    sigma_x = the aperture, its own choice."""
    from rpm_cl.io.data import Array, Waveform
    from rpm_cl.rpm.params import SIGMA_X_PER_RANGE, default_params
    from rpm_cl.simulate import simulate, simulate_preset
    from rpm_cl.simulate.scene import PointTarget, Scene

    xs = np.arange(200) * 0.02 - 2.0
    scene = Scene(
        tuple(
            PointTarget((t, 0.30 + 0.02 * (i % 3)))
            for i, t in enumerate((-1.5, -0.9, -0.3, 0.4, 1.0, 1.6))
        )
    )
    data = simulate(scene, Array(xs), Waveform(1.5e9, 1.0e9), np.arange(0, 1.5, 0.005))
    sx = default_params(data).rpm.sigma_x
    assert SIGMA_X_PER_RANGE * 0.295 <= sx <= SIGMA_X_PER_RANGE * 0.4
    paper = simulate_preset("paper-2d")[0]
    assert default_params(paper).rpm.sigma_x == pytest.approx(np.ptp(paper.array.x))
