"""The runnable examples in examples/, each at a small size, checked against
the scene they image (known targets), not only for running."""

import os
import runpy
import subprocess
import sys
from pathlib import Path

import numpy as np

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def _main(name):
    return runpy.run_path(str(EXAMPLES / name))["main"]


def test_sparse_array_rpm_finds_the_targets_and_das_shows_grating_lobes(capsys):
    out = _main("sparse_array.py")(quick=True)
    rpm = out["rpm"]
    # 3 point targets seen by 21 antennas: 63 true RPs (the paper's count);
    # the paper reaches 94 % of the RPM points within 50 mm, we demand 95 %
    assert rpm["rpm_total"] >= 60 and rpm["rpm_within_50mm"] >= 0.95 * rpm["rpm_total"]
    # a 20 mm pitch (1.33 wavelengths) puts DAS grating lobes within the field
    # of view: bright peaks far from every target, more of them than targets
    far = np.sum(out["das"]["distance"] > 0.05)
    assert far > len(out["targets"])
    # yet the true targets are in the image: a DAS peak within 20 mm of each
    # target would need a finer grid than --quick's 4 mm, so look at the
    # peaks' nearest distance per target instead
    peaks = out["das"]["peaks"]
    d = np.linalg.norm(out["targets"][:, None, :] - peaks[None, :, :], axis=2).min(axis=1)
    assert np.all(d < 0.03), d
    assert "k-space RPM: " in capsys.readouterr().out


def test_human_body_3d_quick_scores_every_part():
    result, per_part = _main("human_body_3d.py")(quick=True)
    assert set(per_part) == {"head", "upper-torso", "lower-torso"}
    for name, (n, median, within_50) in per_part.items():
        # every part is seen (187 antennas each) and imaged onto its surface
        assert n >= 100, (name, n)
        assert median < 0.010 and within_50 >= 0.95, (name, median, within_50)
    assert result.image.points.shape[1] == 3


def test_measured_data_hand_made_scan_images_its_targets(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    mod = runpy.run_path(str(EXAMPLES / "measured_data.py"))
    result = mod["main"](quick=True, output="r.npz")
    targets = np.array(mod["TARGETS"])
    pts = result.image.points
    assert len(pts) >= 2 * 15
    # each target's points (those nearest it) lie within 10 mm of it in the
    # median: 21 antennas at 5 mm give a 0.1 m aperture at 0.4 m
    d = np.linalg.norm(pts[:, None, :] - targets[None, :, :], axis=2)
    near = d.argmin(axis=1)
    for t in range(len(targets)):
        assert np.median(d[near == t, t]) < 0.010, (t, np.median(d[near == t, t]))
    # the result was saved and reads back as a result file
    from rpm_cl.viz.view import load_result

    assert len(load_result(tmp_path / "r.npz")["points"]) == len(pts)
    # swapping in another file is one argument: image the scan just written
    again = mod["main"]("hand_made_scan.npz", output="r2.npz")
    assert np.allclose(again.image.points, pts)


def test_example_main_block_runs(tmp_path):
    """The __main__ block of an example (the others share its shape)."""
    env = dict(os.environ, POCL_MAX_PTHREAD_COUNT=os.environ.get("POCL_MAX_PTHREAD_COUNT", "1"))
    p = subprocess.run(
        [sys.executable, str(EXAMPLES / "measured_data.py"), "--quick"],
        check=False,
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert p.returncode == 0, p.stderr
    assert "2 clusters" in p.stdout and (tmp_path / "measured_result.npz").exists()


def test_paper_2d_example_meets_the_paper_at_20db():
    from rpm_cl.metrics import summary
    from rpm_cl.simulate import simulate_preset

    result = _main("paper_2d.py")(snr_db=20.0, seed=0)
    data, _ = simulate_preset("paper-2d", 20.0, 0, noise="receiver")  # the same noise realisation
    s = summary(result.rps, result.image, data.truth)
    # the paper's Table II at 20 dB: 95 % of the RPs within 10 mm, 97 % of the
    # points within 100 mm; one noise realisation, so a few points of slack
    assert s["rp_within_10mm"] >= 0.85 * s["rp_total"]
    assert s["rpm_within_100mm"] >= 0.90 * s["rpm_total"]


def test_gpr_bscan_images_the_bars_and_draws_three_panels(tmp_path):
    """The rebar fixture without its background run, as a real B-scan comes:
    at least 85 % of phase-rpm's points within 20 mm of a bar's outline,
    at least 5 points on each of the five shallow bars, and the picture
    written."""
    png = tmp_path / "gpr.png"
    out = _main("gpr_bscan.py")(png=str(png))
    bars, pts = out["bars"], out["rpm"].image.points
    assert np.mean(out["distance"] <= 0.02) >= 0.85
    d = np.abs(
        np.hypot(pts[:, None, 0] - bars[None, :, 0], pts[:, None, 1] - bars[None, :, 1])
        - bars[None, :, 2]
    )
    assert np.all((d[:, :5] <= 0.02).sum(axis=0) >= 5)
    assert png.stat().st_size > 10_000


def test_gpr_bscan_takes_a_jittered_gssi_line(tmp_path):
    """A GSSI line whose traces jitter by 20 ps and whose record starts
    before the pulse (benchmarks/gpr_jitter.py's line a, written sample by
    sample), converted at the window's start: with --time-zero auto and
    --align-traces every one of the twelve bars has a point within 30 mm
    of its top and 40 % of the points lie within 30 mm of a bar, with its
    eps_r given or read from the line (``--eps-r auto``); with neither
    step, time zero and the jitter put all but a fifth of them off."""
    import os
    import sys
    import warnings

    sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))
    from gpr_jitter import LINES, score, traces, write_dzt

    from rpm_cl.io.checks import DataWarning
    from rpm_cl.io.dzt import convert

    line = LINES["a"]
    dzt = tmp_path / "a.dzt"
    write_dzt(dzt, traces(line, 20e-12)[0], line)
    path = tmp_path / "a.npz"
    np.savez(path, **convert(dzt))
    main = _main("gpr_bscan.py")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataWarning)
        good = main(str(path), line["eps"], None, None, True)["rpm"].image.points
        read = main(str(path), "auto", None, None, True)["rpm"].image.points
        plain = main(str(path), line["eps"])["rpm"].image.points
    for pts in (good, read):
        found, share, _ = score(pts, line)
        assert found == 12 and share >= 0.4, (found, share)
    assert score(plain, line)[1] < 0.2, score(plain, line)
