"""Fingerprints of every method's output on every paper scene, to show that
a change of the code's shape left the numbers bit for bit as they were.

    python benchmarks/compare_outputs.py --write before.json   # on the old code
    python benchmarks/compare_outputs.py --check before.json   # on the new code

Each case runs the command line in this process (``rpm-cl simulate`` of a
preset, noise-free and at 20 dB in-band with a fixed seed; then ``rpm-cl
image --method M`` for every imaging method, ``rpm-cl das`` and, for linear
arrays, ``rpm-cl rma``) and records the SHA-256 of every array the output
file holds, ``meta`` (times, version) left out.  ``--check`` exits 1 and
names the cases whose arrays differ.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

#: (preset, S/N in dB or None, DAS grid)
SCENES = [
    ("paper-2d", None, "-0.3:0.3:0.004,0.2:0.7:0.004"),
    ("paper-2d", 20.0, "-0.3:0.3:0.004,0.2:0.7:0.004"),
    ("paper-2d-sparse", None, "-0.3:0.3:0.004,0.2:0.7:0.004"),
    ("paper-2d-sparse", 20.0, "-0.3:0.3:0.004,0.2:0.7:0.004"),
    ("human-body", None, "-0.3:0.3:0.02,0.2:0.8:0.02,-0.3:0.3:0.02"),
    ("human-body", 20.0, "-0.3:0.3:0.02,0.2:0.8:0.02,-0.3:0.3:0.02"),
]


def _digest(path: Path) -> dict[str, str]:
    out = {}
    with np.load(path, allow_pickle=False) as z:
        for key in sorted(z.files):
            if key == "meta":
                continue
            a = np.ascontiguousarray(z[key])
            h = hashlib.sha256(f"{a.dtype.str}{a.shape}".encode())
            h.update(a.tobytes())
            out[key] = h.hexdigest()
    return out


def fingerprints(methods: list[str] | None = None) -> dict[str, dict[str, str]]:
    from rpm_cl.cli import main
    from rpm_cl.imaging import RPM_METHODS

    methods = methods or list(RPM_METHODS)
    got: dict[str, dict[str, str]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for preset, snr, grid in SCENES:
            tag = f"{preset}@{'inf' if snr is None else f'{snr:g}dB'}"
            data = tmp / f"{tag}.npz"
            argv = ["simulate", preset, "-o", str(data), "-q", "--seed", "7"]
            if snr is not None:
                argv += ["--snr", str(snr)]
            if main(argv) != 0:
                raise SystemExit(f"simulate {tag} failed")
            runs = [(m, ["image", str(data), "--method", m]) for m in methods]
            runs.append(("das", ["das", str(data), "--grid", grid]))
            if preset != "human-body":
                runs.append(("rma", ["rma", str(data), "--y-min", "0.2", "--y-max", "0.7"]))
            for name, cmd in runs:
                out = tmp / f"{tag}-{name}.npz"
                if main([*cmd, "-o", str(out), "-q"]) != 0:
                    raise SystemExit(f"{name} on {tag} failed")
                got[f"{tag} {name}"] = _digest(out)
                out.unlink()
                print(f"{tag} {name}", file=sys.stderr)
    return got


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--write", type=Path, help="write the fingerprints to this JSON file")
    g.add_argument("--check", type=Path, help="compare with the fingerprints in this file")
    args = ap.parse_args(argv)
    got = fingerprints()
    if args.write:
        args.write.write_text(json.dumps(got, indent=1, sort_keys=True) + "\n")
        print(f"{len(got)} cases written to {args.write}")
        return 0
    want = json.loads(args.check.read_text())
    bad = sorted(k for k in set(want) | set(got) if want.get(k) != got.get(k))
    for k in bad:
        keys = sorted(
            a
            for a in set(want.get(k, {})) | set(got.get(k, {}))
            if want.get(k, {}).get(a) != got.get(k, {}).get(a)
        )
        print(f"differs: {k}: {', '.join(keys) or 'missing'}")
    print(f"{len(got) - len(bad)} of {len(set(want) | set(got))} cases bit-identical")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
