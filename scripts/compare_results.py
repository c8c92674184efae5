"""Compare two jaxstiff result files (.npz) array by array, bit for bit, and list how their meta differ.

    python scripts/compare_results.py OLD.npz NEW.npz

Exit status 0 when every array is identical (same dtype, shape and bytes), else 1. Arrays of
wall-clock times (``--timing``, default ``time_s``) are listed but not judged.
Used to check that a refactor keeps results unchanged (meta may differ in versions, timing and
records that were added on purpose; those are listed, not judged).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np


def _flatten(obj: object, prefix: str = "") -> dict[str, object]:
    if isinstance(obj, dict):
        out: dict[str, object] = {}
        for k, v in obj.items():
            out.update(_flatten(v, f"{prefix}{k}."))
        return out
    return {prefix[:-1]: obj}


def compare(old: str, new: str, timing: tuple[str, ...] = ("time_s",)) -> int:
    a = np.load(old, allow_pickle=False)
    b = np.load(new, allow_pickle=False)
    bad = 0
    for key in sorted(set(a.files) | set(b.files)):
        if key == "meta":
            continue
        if key not in a.files or key not in b.files:
            print(f"array {key}: only in {'new' if key in b.files else 'old'}")
            bad += 1
            continue
        x, y = a[key], b[key]
        same = x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes()
        if not same and key in timing:
            print(f"array {key}: differs (wall-clock times; not compared)")
        elif not same:
            bad += 1
            diff = ""
            if x.shape == y.shape and np.issubdtype(x.dtype, np.number):
                diff = f", max |diff| {np.nanmax(np.abs(x.astype(float) - y.astype(float))):.3g}"
            print(f"array {key}: DIFFERS ({x.dtype}{x.shape} vs {y.dtype}{y.shape}{diff})")
    if "meta" in a.files and "meta" in b.files:
        from jaxstiff.runtime._io import meta_loads

        ma, mb = _flatten(meta_loads(str(a["meta"]))), _flatten(meta_loads(str(b["meta"])))
        for k in sorted(set(ma) | set(mb)):
            if ma.get(k, "<absent>") != mb.get(k, "<absent>"):
                print(f"meta {k}: {ma.get(k, '<absent>')!r} -> {mb.get(k, '<absent>')!r}"[:300])
    n = len([f for f in a.files if f != "meta"])
    print(f"{n - bad} of {n} arrays identical" + ("" if bad == 0 else f"; {bad} differ"))
    return 0 if bad == 0 else 1


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("old")
    p.add_argument("new")
    p.add_argument("--timing", default="time_s", help="comma-separated arrays of wall-clock times, not judged")
    args = p.parse_args()
    return compare(args.old, args.new, tuple(t for t in args.timing.split(",") if t))


if __name__ == "__main__":
    sys.exit(main())
