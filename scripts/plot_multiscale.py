#!/usr/bin/env python3
"""Plots the multi-scale sampling of a simulated corridor sweep (figure in docs/algorithm.md).

Input: files written by `bench_preprocess --dump_multiscale=PREFIX`, one per noise level:
"r x y z size" per representative (cluster centroid) and "p x y z size edge" per
pre-processed point (size of its cluster; true distance to the nearest edge of the scene).
Left: the first file's points coloured by their cluster's size (flat walls yellow: large
clusters; edges, corners and objects dark: small clusters). Right: the sampling rate (one
representative per `size` points) against the distance to the nearest edge, per file.

usage: plot_multiscale.py OUT.png PREFIX_0.0050.txt [PREFIX_0.0316.txt ...]
"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.colors import LogNorm  # noqa: E402


def load(path):
    info, reps, pts = {}, [], []
    with open(path) as f:
        for line in f:
            if line.startswith("#"):
                words = line[1:].split()
                info = dict(zip(words[::2], words[1::2]))
            elif line.strip():
                kind, *vals = line.split()
                (reps if kind == "r" else pts).append([float(v) for v in vals])
    return info, reps, pts


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    out, paths = sys.argv[1], sys.argv[2:]
    fig = plt.figure(figsize=(12, 4.4), dpi=72)
    bins = [0.0, 0.02, 0.04, 0.06, 0.08, 0.1, 0.13, 0.16, 0.2, 0.25, 0.3, 0.4, 0.5, 0.7, 1.0]
    curve = fig.add_subplot(1, 2, 2)
    for k, path in enumerate(paths):
        info, reps, pts = load(path)
        label = "range noise %.1f cm: %s -> %s points" % (
            100 * float(info["noise"]), info["preprocessed"], info["representatives"])
        if k == 0:
            # Large clusters first, so that the small ones (edges) are drawn on top.
            xs, ys, zs, sizes, _ = zip(*sorted(pts, key=lambda p: -p[3]))
            ax = fig.add_subplot(1, 2, 1, projection="3d")
            sc = ax.scatter(xs, ys, zs, c=sizes, s=1.2, cmap="viridis", depthshade=False,
                            norm=LogNorm(vmin=1, vmax=max(sizes)), linewidths=0)
            ax.view_init(elev=35, azim=-150)
            ax.set_box_aspect((max(xs) - min(xs), max(ys) - min(ys), max(zs) - min(zs)))
            ax.set_xlabel("x [m]", fontsize=8)
            ax.set_ylabel("y [m]", fontsize=8)
            ax.set_zticks([0, 1, 2])
            ax.tick_params(labelsize=7)
            ax.set_title("each point coloured by its cluster's size\n(" + label + ")",
                         fontsize=9)
            fig.colorbar(sc, ax=ax, shrink=0.6, pad=0.0, label="points per cluster")
        centres, rates = [], []
        for lo, hi in zip(bins[:-1], bins[1:]):
            inside = [1.0 / p[3] for p in pts if lo <= p[4] < hi]
            if inside:
                centres.append(0.5 * (lo + hi))
                rates.append(sum(inside) / len(inside))
        curve.plot(centres, rates, "o-", label=label)
    curve.set_xlabel("distance to the nearest edge or corner [m]")
    curve.set_ylabel("representatives per input point")
    curve.set_ylim(bottom=0)
    curve.grid(alpha=0.3)
    curve.legend(fontsize=8)
    curve.set_title("sampling rate of the default cut (n_max 24, sigma_max 0.01)", fontsize=9)
    fig.tight_layout()
    fig.savefig(out)


if __name__ == "__main__":
    main()
