"""The benchmarks page's figure, from the numbers recorded in docs/notes/speed.md (no run here).

pgd on B = 1000 random reachable LWR paths x P = 100 waypoints (``python scripts/bench_batch.py
--B 1000 --P 100``): waypoints per second, and the speed-up against the seed's own method (SLSQP
with numpy and finite differences) on the same paths, each measurement with its date and machine.
A range is several runs of the same code. Writes docs/images/benchmark_batch.png.

    python scripts/plot_benchmarks.py [--out FILE.png]
"""

from __future__ import annotations

import argparse
import os

#: (label: date and machine, waypoints/s low-high, speed-up low-high); docs/notes/speed.md
RECORDED = [
    ("2026-12-03\n2-core CPU\n(first)", (2307, 2307), (433, 433)),
    ("2026-12-03\n2-core CPU\n(chunk per core)", (4226, 4881), (821, 930)),
    ("2026-12-03\n2-core CPU\n(loaded)", (3293, 4029), (734, 905)),
    ("2026-12-03\n2-core CPU\n(one LM start)", (4103, 4103), (985, 985)),
    ("2026-12-04\nXeon AVX-512\n(joint scan)", (3758, 3758), (931, 931)),
    ("2026-12-05\nXeon AVX-512\n(one vmap)", (4011, 4041), (1005, 1051)),
]


def main() -> None:
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=os.path.join(here, "..", "docs", "images", "benchmark_batch.png"))
    args = ap.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = [r[0] for r in RECORDED]
    x = range(len(RECORDED))
    fig, (a, b) = plt.subplots(1, 2, figsize=(13, 4.2))
    for ax, k, ylabel, title in (
        (a, 1, "waypoints per second", "pgd, 1000 paths x 100 waypoints, float64, CPU"),
        (b, 2, "speed-up (x)", "against the seed's method (SLSQP, numpy + finite differences)"),
    ):
        lo = [r[k][0] for r in RECORDED]
        hi = [r[k][1] for r in RECORDED]
        mid = [(p + q) / 2 for p, q in zip(lo, hi, strict=True)]
        ax.bar(x, mid, color="#3f51b5", alpha=0.8)
        ax.errorbar(
            x,
            mid,
            yerr=[[m - p for m, p in zip(mid, lo, strict=True)], [q - m for m, q in zip(mid, hi, strict=True)]],
            fmt="none",
            ecolor="k",
            capsize=4,
        )
        for i, (p, q) in enumerate(zip(lo, hi, strict=True)):
            ax.annotate(
                f"{p:g}" if p == q else f"{p:g}-{q:g}",
                (i, q),
                ha="center",
                va="bottom",
                fontsize=8,
                xytext=(0, 2),
                textcoords="offset points",
            )
        ax.set_xticks(list(x), labels, fontsize=6.5)
        ax.set(ylabel=ylabel, title=title)
        ax.grid(axis="y", alpha=0.3)
    b.axhline(1000, color="C3", ls=":", lw=1)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(args.out)


if __name__ == "__main__":
    main()
