"""``time_zero = "auto"``: time zero at the antennas' own pulse
(rpm_cl.extract.preprocess.pick_time_zero), and the warning where a record
starts before it.

The scans are written out in the frequency domain here: a GPR-like line
whose record starts ``LEAD`` of range before the antennas' pulse, so that
the direct wave and every echo lie ``LEAD`` further than their true range.
"""

import warnings

import numpy as np
import pytest

from rpm_cl.cli import main
from rpm_cl.extract.preprocess import common_echo, pick_time_zero
from rpm_cl.imaging import run_method
from rpm_cl.io.compress import spectrum_data
from rpm_cl.io.data import Array, DataWarning
from rpm_cl.io.formats import save_data
from rpm_cl.io.model import C0
from rpm_cl.rpm import reference
from rpm_cl.rpm.params import default_params

X = np.arange(60) * 0.01
FREQ = np.linspace(1.0e9, 3.0e9, 81)
TARGETS = ((0.15, 0.25), (0.45, 0.35))  # (x, range at closest approach), m
LEAD = 0.1234  # the record starts this much range before the pulse, m


def _scan(lead=LEAD, direct=1.0, targets=TARGETS, jitter=0.0):
    """``jitter``: every trace ``delta_i`` late, normal with this rms, m."""
    k = 4 * np.pi * FREQ / C0
    late = lead + jitter * np.random.default_rng(5).standard_normal(X.size)
    values = direct * np.exp(-1j * np.outer(late, k))
    for xt, rt in targets:
        values = values + 0.05 * np.exp(-1j * np.outer(late + np.hypot(X - xt, rt), k))
    return spectrum_data(values, FREQ, Array(X))


def test_the_pulse_is_picked_at_its_envelope_peak():
    """The direct wave's range, within a twentieth of a gate; None and 0
    where the strongest echo is not the same at every antenna."""
    data = _scan()
    assert pick_time_zero(data) == pytest.approx(LEAD, abs=0.05 * data.dr)
    assert common_echo(data) == pytest.approx(LEAD, abs=data.dr)
    alone = _scan(direct=0.0)  # the targets' echoes walk: nothing common
    assert common_echo(alone) is None and pick_time_zero(alone) == 0.0


@pytest.mark.parametrize("share", [0.3, 0.45, 0.6])
def test_a_gained_deep_reflector_stronger_at_some_traces(share):
    """A recorder's range gain can make a deep reflector (here a flat one
    at 0.8 m, twice the direct wave's amplitude) the strongest echo at a
    share of the traces (GPRPy's real 400 MHz GSSI line: 27 %): the direct
    wave is still the common echo while it is the strongest at more than
    half of them; where it is not, nothing is picked."""
    data = _scan()
    k = 4 * np.pi * FREQ / C0
    gained = np.zeros(X.size)
    gained[: round(share * X.size)] = 2.0
    values = data.spectrum.values + gained[:, None] * np.exp(-1j * np.outer(LEAD + 0.8 + X, k))
    mixed = spectrum_data(values, FREQ, Array(X))
    if share < 0.5:
        assert common_echo(mixed) == pytest.approx(LEAD, abs=mixed.dr)
        assert pick_time_zero(mixed) == pytest.approx(LEAD, abs=0.05 * mixed.dr)
    else:
        assert common_echo(mixed) is None and pick_time_zero(mixed) == 0.0


def test_a_pulse_straddling_the_axis_start_is_at_zero_already():
    """Round a compressed spectrum's periodic axis a pulse 5 mm before the
    record's start peaks at its end: time zero stays 0, not the period."""
    data = _scan(lead=-0.005)
    assert data.range_period > 0
    assert common_echo(data) == pytest.approx(-0.005, abs=data.dr)
    assert pick_time_zero(data) == 0.0


def _points(data, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataWarning)
        params = default_params(data, **kw)
        return params, run_method("phase-rpm", data, params, reference).image.points


def test_auto_images_the_targets_where_they_are():
    """Resolved by default_params, auto is the picked range; imaged from it,
    each target has points within 5 mm, where time zero 0 puts every point
    ``LEAD`` too far."""
    data = _scan()
    params, pts = _points(data, time_zero=None)
    assert params.time_zero == pytest.approx(pick_time_zero(data))
    for xt, rt in TARGETS:
        assert np.min(np.hypot(pts[:, 0] - xt, pts[:, 1] - rt)) < 0.005
    _, late = _points(data)
    for xt, rt in TARGETS:
        near = np.hypot(late[:, 0] - xt, late[:, 1] - rt) < 0.02
        assert not near.any()


def test_a_late_pulse_is_warned_with_the_fix():
    """Time zero left at 0 before the pulse: one warning naming its range
    and the fix; none with auto, nor where the pulse is at 0."""
    from rpm_cl.imaging import prepared

    data = _scan()
    with pytest.warns(DataWarning, match=r"lies at range 0\.12.* --time-zero auto"):
        prepared(data, default_params(data))
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        prepared(data, default_params(data, time_zero=None))
        at_zero = _scan(lead=0.0)
        prepared(at_zero, default_params(at_zero))


def test_auto_from_flags_and_config(tmp_path, capsys):
    """``--time-zero auto`` and ``time_zero = "auto"`` in a config resolve
    to the picked range, which ``rpm-cl params`` prints."""
    data = _scan()
    path = tmp_path / "scan.npz"
    save_data(path, data)
    want = pick_time_zero(data)

    def printed(*argv):
        assert main(["params", str(path), *argv]) == 0
        line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("time_zero"))
        return float(line.split("=")[1])

    assert printed("--time-zero", "auto") == pytest.approx(want, rel=1e-6)
    cfg = tmp_path / "p.toml"
    cfg.write_text('[imaging]\ntime_zero = "auto"\n')
    assert printed("--config", str(cfg)) == pytest.approx(want, rel=1e-6)
    assert printed() == 0.0


@pytest.mark.parametrize("frac", np.linspace(0.0, 1.0, 11))
def test_profiles_alone_keep_their_coupling_at_the_picked_zero(frac):
    """Range profiles without their samples (an axis that is no period):
    wherever the pulse falls between two gates, the picked time zero
    leaves it a coupling there (within a gate before it), so the default
    background removes it."""
    from rpm_cl.extract.preprocess import coupling_dominates
    from rpm_cl.io.data import RadarData

    spec = _scan()
    lead = 0.1 + frac * spec.dr
    data = _scan(lead=lead)
    alone = RadarData(data.signal, data.array, data.range, data.waveform)
    zero = pick_time_zero(alone)
    assert zero == pytest.approx(lead, abs=0.5 * data.dr)
    assert coupling_dominates(alone, zero)


def test_above_a_half_space_the_surface_is_the_antenna_height_in():
    """With an antenna height the common echo is the surface's: time zero
    lies that height before it; and a record whose surface lies there is
    not warned of."""
    from rpm_cl.imaging import prepared

    data = _scan()
    assert pick_time_zero(data, 0.1) == pytest.approx(LEAD - 0.1, abs=0.05 * data.dr)
    assert pick_time_zero(data, 0.2) == 0.0
    params = default_params(data, time_zero=None, eps_r=4.0, antenna_height=0.1)
    assert params.time_zero == pytest.approx(LEAD - 0.1, abs=0.05 * data.dr)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        prepared(data, default_params(data, eps_r=4.0, antenna_height=0.12))


def test_none_is_no_time_zero_word(capsys):
    """The word "none" would read as "no time zero", which is 0, not a
    pick: refused, with one line (max_range's "none", keep every gate,
    stays)."""
    assert main(["params", "x.npz", "--time-zero", "none"]) == 2
    assert "must be a number or 'auto'" in capsys.readouterr().err
    assert main(["params", "x.npz", "--max-range", "none"]) != 0  # x.npz is absent
    assert "--max-range" not in capsys.readouterr().err


def test_batch_takes_auto():
    from rpm_cl.cli.batch_config import BatchConfig

    BatchConfig(overrides=((("imaging", "time_zero"), None),))


def test_a_late_pulse_under_heavy_jitter_is_warned_once_aligned():
    """40 ps (6 mm rms) blurs the pulse past the coupling test; with
    --align-traces the late pulse is sought on the aligned traces, and
    warned of."""
    from rpm_cl.imaging import prepared

    data = _scan(jitter=6e-3)
    assert common_echo(data) is None
    with pytest.warns(DataWarning, match=r"lies at range 0\.12"):
        prepared(data, default_params(data, align_traces=True))


def test_the_api_takes_auto_and_refuses_what_is_no_range():
    """``default_params(data, time_zero="auto")`` is the pick, as None is;
    a value that is no number (a word, a bool, a list, a complex) is one
    InputError naming it, not a TypeError from NumPy, and so for the gain
    and max_range."""
    from rpm_cl.io.data import InputError

    data = _scan()
    want = pick_time_zero(data)
    assert default_params(data, time_zero="auto").time_zero == pytest.approx(want, rel=1e-9)
    assert default_params(data, time_zero=None).time_zero == pytest.approx(want, rel=1e-9)
    for bad in ("later", True, [0.1], 0.1 + 0.1j, float("nan"), -0.1):
        with pytest.raises(InputError, match="time_zero must be a range"):
            default_params(data, time_zero=bad)
    with pytest.raises(InputError, match="gain_db_per_m must be"):
        default_params(data, gain_db_per_m="x")
    with pytest.raises(InputError, match="max_range must be"):
        default_params(data, max_range="far")
    assert default_params(data, time_zero=0.05).time_zero == 0.05
