#!/usr/bin/env python3
"""Plots bench/results/scaling.csv (written by the scaling tool) as a log-log PNG:
end-to-end detection time and peak RSS against sweep points, reference-model build time
against map points, with the speed targets marked.

    /usr/bin/python3 scripts/plot_scaling.py bench/results/scaling.csv bench/results/scaling.png
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(src, dst):
    det, ref = [], []
    with open(src) as f:
        for row in csv.DictReader(f):
            (det if row["kind"] == "detect" else ref).append(row)
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.6), dpi=90)
    if det:
        x = [float(r["points"]) for r in det]
        a.loglog(x, [float(r["wall_ms"]) / 1e3 for r in det], "o-", label="detect, wall")
        a.loglog(x, [float(r["cpu_ms"]) / 1e3 for r in det], "x--", label="detect, CPU")
        a.loglog(x, [float(r["peak_rss_mb"]) / 1e3 for r in det], "s:",
                 label="peak RSS in detect [GB]")
        tx = [3000, 30000, 300000]
        a.loglog(tx, [0.02, 0.2, 1.5], "r*", ms=10, label="time targets")
        a.loglog([300000], [0.3], "rP", ms=9, label="RSS target (0.3 GB)")
        a.set_xlabel("points per sweep")
        a.set_ylabel("seconds  /  GB")
        a.set_title("novelty detection")
        a.grid(True, which="both", alpha=0.3)
        a.legend(fontsize=7)
    if ref:
        x = [float(r["points"]) for r in ref]
        b.loglog(x, [float(r["wall_ms"]) / 1e3 for r in ref], "o-", label="build, wall")
        b.loglog(x, [float(r["cpu_ms"]) / 1e3 for r in ref], "x--", label="build, CPU")
        b.loglog([1e6], [5.0], "r*", ms=10, label="target (1M points, 5 s)")
        b.set_xlabel("map points")
        b.set_ylabel("seconds")
        b.set_title("reference model")
        b.grid(True, which="both", alpha=0.3)
        b.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(dst)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
