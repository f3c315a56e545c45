"""docs/results.md is what `rpm-cl reproduce NAME --markdown` writes: running
it again gives the same structure (sections, columns, one row per case,
method and S/N), and the paper's method's noise-free rows the same counts."""

from pathlib import Path

from rpm_cl.cli import main
from rpm_cl.imaging import RPM_METHODS

DOC = Path(__file__).resolve().parents[1] / "docs" / "results.md"


def _sections(text: str) -> dict:
    out = {}
    for part in text.split("\n## ")[1:]:
        title, body = part.split("\n", 1)
        rows = [
            [c.strip() for c in line.strip().strip("|").split("|")]
            for line in body.splitlines()
            if line.startswith("|")
        ]
        out[title] = rows
    return out


def test_regenerated_paper_2d_section_has_the_committed_structure(tmp_path, capsys):
    committed = _sections(DOC.read_text(encoding="utf-8"))
    assert {"paper-2d", "paper-3d"} <= set(committed)
    out = tmp_path / "results.md"
    argv = ["reproduce", "paper-2d", "--trials", "1", "--no-das", "--no-rma", "--markdown"]
    assert main([*argv, str(out)]) == 0
    capsys.readouterr()
    fresh = _sections(out.read_text(encoding="utf-8"))
    assert list(fresh) == ["paper-2d"]
    new, old = fresh["paper-2d"], committed["paper-2d"]
    assert new[0] == old[0] and new[1] == old[1]  # the columns
    keys = lambda rows: [tuple(r[:3]) for r in rows[2:] if r[1] in RPM_METHODS]
    assert keys(new) == keys(old)
    assert {r[1] for r in old[2:]} >= {"das", "rma"}
    # the paper's method, noise-free: no noise realisation, the same counts
    pick = lambda rows: [r[3:6] for r in rows[2:] if r[1] == "kspace-rpm" and r[2] == "inf"]
    assert pick(new) == pick(old) and pick(new)
    # running it again replaces the section, does not add one
    assert main([*argv, str(out)]) == 0
    assert list(_sections(out.read_text(encoding="utf-8"))) == ["paper-2d"]
