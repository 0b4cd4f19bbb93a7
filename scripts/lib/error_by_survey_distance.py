"""Error by the truth's distance from the survey, over `fpbp eval` folders.

usage: error_by_survey_distance.py [--map MAP | --map-root DIR] EVAL_DIR...

Each EVAL_DIR is an `fpbp eval --seeds` output folder (seed-*/points.csv).
Where the survey walked is read from a radio map's reference scans (one
per second of survey walk): `--map MAP` for every folder, or `--map-root
DIR` for fold folders (DIR/<folder name>/radio-map.json, as
scripts/tuning-folds.sh and scripts/survey-coverage.sh lay them out).
Each truth point is binned by its distance from the nearest reference
scan on its floor (< 2, 2-5, 5-10, >= 10 m; no scan on the floor counts
as >= 10 m); per engine and bin: points, coverage, mean error (mean of
the per-seed means) and the share within the accuracy radius.
"""
import argparse
import csv
import glob
import json
import math
import os
from collections import defaultdict

EDGES = [0.0, 2.0, 5.0, 10.0, math.inf]
BUCKET_M = 4.0


class Footprint:
    """Reference-scan positions per floor, bucketed for nearest search."""

    def __init__(self, map_path):
        with open(map_path) as f:
            scans = json.load(f)["reference_scans"]["scans"]
        self.buckets = defaultdict(lambda: defaultdict(list))
        for s in scans:
            p = (s["x_m"], s["y_m"])
            self.buckets[s["floor"]][self.key(p)].append(p)

    @staticmethod
    def key(p):
        return (math.floor(p[0] / BUCKET_M), math.floor(p[1] / BUCKET_M))

    def distance(self, floor, p, limit=60.0):
        b = self.buckets.get(floor)
        if not b:
            return math.inf
        kx, ky = self.key(p)
        best = math.inf
        for r in range(int(limit / BUCKET_M) + 2):
            if (r - 1) * BUCKET_M > best:
                break
            for dx in range(-r, r + 1):
                for dy in range(-r, r + 1):
                    if max(abs(dx), abs(dy)) != r:
                        continue
                    for q in b.get((kx + dx, ky + dy), ()):
                        best = min(best, math.hypot(q[0] - p[0], q[1] - p[1]))
        return best


def bin_of(d):
    for i in range(len(EDGES) - 1):
        if EDGES[i] <= d < EDGES[i + 1]:
            return i
    return len(EDGES) - 2


def main():
    ap = argparse.ArgumentParser()
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--map")
    g.add_argument("--map-root")
    ap.add_argument("dirs", nargs="+")
    a = ap.parse_args()
    # (engine, bin) -> seed -> [(error or None, accuracy)]
    by = defaultdict(lambda: defaultdict(list))
    maps = {}
    for d in a.dirs:
        if not os.path.isdir(d):
            continue
        mp = a.map or os.path.join(a.map_root, os.path.basename(d.rstrip("/")), "radio-map.json")
        if mp not in maps:
            maps[mp] = Footprint(mp)
        fp = maps[mp]
        for sd in sorted(glob.glob(f"{d}/seed-*")):
            seed = os.path.basename(sd)
            with open(f"{sd}/points.csv") as f:
                for r in csv.DictReader(f):
                    p = (float(r["truth_x_m"]), float(r["truth_y_m"]))
                    fl = int(r["truth_floor"]) if r["truth_floor"] else 0
                    k = bin_of(fp.distance(fl, p))
                    e = float(r["error_m"]) if r["error_m"] else None
                    acc = float(r["accuracy_m"]) if r["accuracy_m"] else None
                    by[(r["engine"], k)][seed].append((e, acc))
    names = [f"[{EDGES[i]:g}, {EDGES[i + 1]:g}) m" for i in range(len(EDGES) - 1)]
    for eng in sorted({e for e, _ in by}):
        for k, name in enumerate(names):
            seeds = by.get((eng, k))
            if not seeds:
                continue
            means, cov, inacc = [], [], []
            for pts in seeds.values():
                ok = [x for x in pts if x[0] is not None]
                cov.append(len(ok) / len(pts))
                if ok:
                    means.append(sum(x[0] for x in ok) / len(ok))
                    w = [x for x in ok if x[1] is not None]
                    if w:
                        inacc.append(sum(x[0] <= x[1] for x in w) / len(w))
            n = len(next(iter(seeds.values())))
            mean = sum(means) / len(means) if means else float("nan")
            ia = 100 * sum(inacc) / len(inacc) if inacc else float("nan")
            print(f"{eng} {name}: {n} points, coverage {100 * sum(cov) / len(cov):.0f} %, "
                  f"mean {mean:.2f} m, within radius {ia:.0f} %, seeds {len(seeds)}")


if __name__ == "__main__":
    main()
