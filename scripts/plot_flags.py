#!/usr/bin/env python3
"""Draws what the detector flags on a real pair (figure in docs/evaluation.md).

Input: a file written by test_real_pairs with NOVELTY_REAL_OUT set (scripts/evaluate_real.sh
does so): "o x y z" per sensor origin (reference, current), "r x y z" per reference point,
"c x y z label" per current point. Left: top view; right: side view (x, z), both 1 m around
what is flagged and the sensors. Reference grey, current cyan, each novel segment in its own
colour with its point count, sensor origins as stars (black: reference, red: current).

usage: plot_flags.py FLAGS.txt OUT.png [TITLE]
"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    origins, ref, cur = [], [], []
    with open(sys.argv[1]) as f:
        for line in f:
            v = line.split()
            if not v:
                continue
            xyz = tuple(float(t) for t in v[1:4])
            if v[0] == "o":
                origins.append(xyz)
            elif v[0] == "r":
                ref.append(xyz)
            elif v[0] == "c":
                cur.append(xyz + (int(v[4]),))
    fig, axes = plt.subplots(1, 2, figsize=(16, 6.5))
    labels = sorted({p[3] for p in cur if p[3] > 0})
    for ax, (i, j, names) in zip(axes, ((0, 1, "xy"), (0, 2, "xz"))):
        ax.scatter([p[i] for p in ref], [p[j] for p in ref], s=0.2, c="0.75", label="reference")
        ax.scatter([p[i] for p in cur], [p[j] for p in cur], s=0.2, c="c", label="current")
        for k in labels:
            seg = [p for p in cur if p[3] == k]
            ax.scatter([p[i] for p in seg], [p[j] for p in seg], s=4,
                       label=f"segment {k}: {len(seg)} points")
        for o, colour in zip(origins, ("k", "r")):
            ax.plot(o[i], o[j], "*", c=colour, ms=14)
        # Around what is flagged and the sensors, 1 m beyond.
        focus = [p for p in cur if p[3] > 0] + [o + (0,) for o in origins]
        if focus:
            ax.set_xlim(min(p[i] for p in focus) - 1, max(p[i] for p in focus) + 1)
            ax.set_ylim(min(p[j] for p in focus) - 1, max(p[j] for p in focus) + 1)
        ax.set_xlabel(f"{names[0]} [m]")
        ax.set_ylabel(f"{names[1]} [m]")
        ax.set_aspect("equal")
    axes[0].legend(loc="upper left", markerscale=4, fontsize=8)
    axes[0].set_title("top view")
    axes[1].set_title("side view")
    if len(sys.argv) > 3:
        fig.suptitle(sys.argv[3])
    fig.tight_layout()
    fig.savefig(sys.argv[2], dpi=70)


if __name__ == "__main__":
    main()
