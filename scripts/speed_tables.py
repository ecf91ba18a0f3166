#!/usr/bin/env python3
"""The tables of scripts/evaluate_speed.sh from its runs (standard library only).

    speed_tables.py OUT_DIR COMMIT MACHINE LOAD > speed.md
"""
import csv
import glob
import json
import os
import statistics
import struct
import sys

OUT, COMMIT, MACHINE, LOAD = sys.argv[1:5]
SUITES = ("suite", "viewpoint")


def reports(threads, first=False):
    """Per scene, each stage's median over the rounds (report_rN.json; report.json alone
    when the scene ran once): of the last detection of each run (a running node's), or with
    `first` of the first (a fresh process's; the same when a run detected once)."""
    out = []
    for suite in SUITES:
        for scene in sorted(glob.glob(f"{OUT}/threads_{threads}/{suite}/scene_*")):
            paths = sorted(glob.glob(f"{scene}/report_r*.json")) or [f"{scene}/report.json"]
            rounds = []
            for path in paths:
                try:
                    with open(path) as f:
                        report = json.load(f)
                except (OSError, ValueError):
                    continue
                if "timings_ms" not in report:
                    continue
                timings = report["timings_ms"]
                if first and "repeated" in report:
                    timings = dict(report["repeated"]["first_timings_ms"],
                                   reference_model=timings.get("reference_model", 0.0))
                rounds.append(timings)
            if rounds:
                stages = {k for r in rounds for k in r}
                out.append({k: statistics.median([r[k] for r in rounds if k in r])
                            for k in stages})
    return out


def twice_simplified():
    """How many suite sweeps (one thread) had robot returns, and so were pre-processed, cut and
    measured against the map twice (with them, then without), out of how many."""
    found = total = 0
    for suite in SUITES:
        for scene in glob.glob(f"{OUT}/threads_1/{suite}/scene_*"):
            try:
                with open(f"{scene}/report.json") as f:
                    counts = json.load(f).get("point_counts", {})
            except (OSError, ValueError):
                continue
            total += 1
            found += counts.get("self_returns", 0) > 0
    return found, total


ROUNDS = max((len(glob.glob(f"{s}/report_r*.json"))
              for s in glob.glob(f"{OUT}/threads_1/*/scene_*")), default=1) or 1


def ms(v):
    return f"{v:.0f}" if v >= 10 else f"{v:.1f}"


def point_f1(labels_path, truth):
    with open(labels_path) as f:
        found = [int(line) > 0 for line in f]
    tp = sum(1 for a, b in zip(found, truth) if a and b)
    fp = sum(1 for a, b in zip(found, truth) if a and not b)
    fn = sum(1 for a, b in zip(found, truth) if b and not a)
    return 2 * tp / max(1, 2 * tp + fp + fn)


def lzf(data, size):
    """LZF decompression (PCD binary_compressed)."""
    out, i = bytearray(), 0
    while i < len(data) and len(out) < size:
        ctrl = data[i]
        i += 1
        if ctrl < 32:
            out += data[i:i + ctrl + 1]
            i += ctrl + 1
            continue
        length = ctrl >> 5
        if length == 7:
            length += data[i]
            i += 1
        ref = len(out) - ((ctrl & 0x1F) << 8) - data[i] - 1
        i += 1
        for k in range(length + 2):
            out.append(out[ref + k])
    return bytes(out)


def kinect_truth(pcd, novel_ids):
    """Novel points of an OSD cloud: its label field / 10 in novel_ids (see its SOURCE.md)."""
    try:
        f = open(pcd, "rb")
    except OSError:
        return None
    with f:
        header = {}
        while True:
            words = f.readline().decode().split()
            if words:
                header[words[0]] = words[1:]
                if words[0] == "DATA":
                    break
        fields, sizes = header["FIELDS"], [int(s) for s in header["SIZE"]]
        counts = [int(c) for c in header.get("COUNT", ["1"] * len(fields))]
        n = int(header["POINTS"][0])
        if "label" not in fields or header["TYPE"][fields.index("label")] != "U":
            return None
        k = fields.index("label")
        kind = header["DATA"][0]
        if kind == "binary":
            record = sum(s * c for s, c in zip(sizes, counts))
            offset = sum(s * c for s, c in zip(sizes[:k], counts[:k]))
            data = f.read(n * record)
            at = [i * record + offset for i in range(n)]
        elif kind == "binary_compressed":  # field after field
            packed, size = struct.unpack("<II", f.read(8))
            data = lzf(f.read(packed), size)
            offset = n * sum(s * c for s, c in zip(sizes[:k], counts[:k]))
            at = [offset + 4 * i for i in range(n)]
        else:
            return None
    return [struct.unpack_from("<I", data, a)[0] // 10 in novel_ids for a in at]


def scored(path):
    """Success rate and mean point F1 over the scenes with a result and with novel points."""
    try:
        with open(path) as f:
            scenes = [s for s in json.load(f)["scenes"] if s.get("has_result")]
    except (OSError, ValueError, KeyError):
        return None
    with_novel = [s for s in scenes if s["tp"] + s["fn"] > 0]
    if not scenes:
        return None
    return {"scenes": len(scenes),
            "success_rate": sum(1 for s in scenes if s["success"]) / len(scenes),
            "mean_f1": statistics.mean(s["f1"] for s in with_novel) if with_novel else 0.0}


def stage_table(first):
    runs = {t: reports(t, first) for t in (1, 2)}
    stages = sorted({k for t in runs for r in runs[t] for k in r},
                    key=lambda k: -statistics.median([r.get(k, 0.0) for r in runs[2]] or [0.0]))
    stages = ["detect_total"] + [s for s in stages if s != "detect_total"]
    print("| stage | 1 thread: median | worst | 2 threads: median | worst |")
    print("|---|---:|---:|---:|---:|")
    for stage in stages:
        if first and stage == "reference_model":
            continue  # the same model: given once, in the first table
        cells = []
        for t in (1, 2):
            v = [r[stage] for r in runs[t] if stage in r]
            cells += [ms(statistics.median(v)), ms(max(v))] if v else ["-", "-"]
        name = {"detect_total": "**detection, all stages**",
                "reference_model": "reference model (once per map; not part of detection)"}.get(
                    stage, stage)
        print(f"| {name} | " + " | ".join(cells) + " |")
    print()


print(f"Commit {COMMIT}, {MACHINE}, load {LOAD} at the end; Release build; "
      "`bash scripts/evaluate_speed.sh`.")
print()
print("**Per stage, over the 30-scene suite and the 36-scene viewpoint suite (66 simulated "
      f"30k sweeps, seed 1)**, from each run's `report.json`, each scene's median of {ROUNDS} "
      "rounds (one thread and two in turn): median and worst scene [ms]. Each run detects its "
      "sweep twice (`--repeat 2`). **In a running node**, the second detection: the "
      "nodelet detects sweep after sweep in one process. "
      "The reference model is built once per map (the nodelet keeps it; "
      "`--reference-cache` keeps it between runs of the command line). A sweep whose robot "
      "returns were found (%d of %d: the sensor moved) is pre-processed, cut and measured "
      "against the map again without them; its stage times count both runs." % twice_simplified())
print()
stage_table(first=False)
print("**In a fresh process**, the first detection (the command line, one sweep a run): the "
      "process touches its memory for the first time (page faults), and the robot-return "
      "test indexes the map's near points once per map.")
print()
stage_table(first=True)
print("| suite | threads | scenes | success | point F1 (scenes with new points) |")
print("|---|---:|---:|---:|---:|")
for suite in SUITES:
    for t in (1, 2):
        s = scored(f"{OUT}/threads_{t}/{suite}.json")
        if s:
            label = "30-scene suite" if suite == "suite" else "viewpoint suite"
            print(f"| {label} | {t} | {s['scenes']} | {100 * s['success_rate']:.1f} % | "
                  f"{s['mean_f1']:.3f} |")
print()

rows = []
if os.path.exists(f"{OUT}/processes.csv"):
    with open(f"{OUT}/processes.csv") as f:
        rows = [r for r in csv.reader(f) if len(r) == 5]
if rows:
    cold = statistics.median(int(r[2]) for r in rows)
    warm = statistics.median(int(r[3]) for r in rows)
    octree = statistics.median(int(r[4]) for r in rows)
    ours = scored(f"{OUT}/process/scored_cold.json")
    base = scored(f"{OUT}/process/scored_octree.json")

    def acc(s):
        return f"success {100 * s['success_rate']:.0f} %, F1 {s['mean_f1']:.3f}" if s else "-"

    print(f"**Whole processes** (start to exit: loading, modelling, detection, writing), "
          f"the first 10 suite scenes, 3 interleaved rounds, medians of {len(rows)} runs each:")
    print()
    print("| command | wall | against the octree detector | accuracy on these scenes |")
    print("|---|---:|---:|---|")
    print(f"| `novelty_detect` (models the map) | {cold:.0f} ms | {cold / octree:.2f}x | "
          f"{acc(ours)} |")
    print(f"| `novelty_detect --reference-cache` (model read back) | {warm:.0f} ms | "
          f"{warm / octree:.2f}x | the same outputs |")
    print(f"| `baseline_detect` (octree change detector, 0.1 m, Euclidean clusters) | "
          f"{octree:.0f} ms | 1x | {acc(base)} |")
    print()

large = {}
if os.path.exists(f"{OUT}/large.csv"):
    with open(f"{OUT}/large.csv") as f:
        for name, run, rss in csv.reader(f):
            with open(f"{OUT}/large/{name}.report_{run}.json") as g:
                t = json.load(g)["timings_ms"]
            large.setdefault(name, []).append((t["detect_total"], int(rss) / 1024.0))
if large:
    print("**Large clouds** (medians of 3 runs, the reference model read back):")
    print()
    print("| cloud | points | detection | peak memory of the process | accuracy |")
    print("|---|---:|---:|---:|---|")
    for name, runs_ in large.items():
        det = statistics.median(r[0] for r in runs_)
        rss = statistics.median(r[1] for r in runs_)
        labels = f"{OUT}/large/{name}/labels.txt"
        with open(labels) as f:
            points = sum(1 for _ in f)
        if name.startswith("office"):
            with open(f"{OUT}/scenes/large/gt_labels.txt") as f:
                truth = [int(line) > 0 for line in f]
            what = "simulated office, 278 tilt lines"
        else:
            kinect = os.path.join(os.environ.get("NOVELTY_REAL_DATA", ""),
                                  "osd_tabletop_changes", "learn12.pcd")
            truth = kinect_truth(kinect, {3})
            what = "Kinect learn11 -> learn12, organised 640x480"
        f1 = f"point F1 {point_f1(labels, truth):.3f}" if truth else "-"
        print(f"| {what} | {points:,} | {det:.0f} ms | {rss:.0f} MB | {f1} |")
