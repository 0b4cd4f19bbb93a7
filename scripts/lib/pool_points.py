"""Pooled figures of several `fpbp eval --seeds` folders (one per fold).

usage: pool_points.py OUT LABEL=GLOB [LABEL=GLOB ...]

For each LABEL, the eval folders OUT/GLOB: per engine and seed the mean
error, p80 and share within the accuracy radius over the pooled points
with a pose, and the coverage (share of points with a pose); printed as
the mean over the seeds, with each seed's mean.
"""
import csv
import glob
import os
import sys
from collections import defaultdict


def pool(out, pat):
    """Per engine over the eval folders OUT/PAT: the per-seed means, p80
    and shares within the accuracy radius, the per-seed coverage and the
    number of points of one seed; {engine: dict}."""
    by = defaultdict(list)
    for d in sorted(glob.glob(f"{out}/{pat}")):
        if not os.path.isdir(d):
            continue
        for sd in glob.glob(f"{d}/seed-*"):
            with open(f"{sd}/points.csv") as f:
                for r in csv.DictReader(f):
                    e, a = r["error_m"], r["accuracy_m"]
                    by[(r["engine"], os.path.basename(sd))].append(
                        (float(e), float(a) if a else None) if e else None)
    res = {}
    for eng in sorted({e for e, _ in by}):
        means, cov, p80, inacc, n = [], [], [], [], 0
        for (e, _seed), es in sorted(by.items()):
            if e != eng:
                continue
            ok = sorted(x[0] for x in es if x is not None)
            acc = [x for x in es if x is not None and x[1] is not None]
            if ok:
                means.append(sum(ok) / len(ok))
                p80.append(ok[min(len(ok) - 1, int(0.8 * len(ok)))])
            cov.append(len(ok) / len(es))
            inacc.append(sum(x[0] <= x[1] for x in acc) / max(1, len(acc)))
            n = len(es)
        res[eng] = dict(means=means, p80=p80, cov=cov, inacc=inacc, points=n)
    return res


def avg(xs):
    return sum(xs) / len(xs) if xs else float("nan")


def main():
    out = sys.argv[1]
    for arg in sys.argv[2:]:
        label, pat = arg.split("=", 1)
        for eng, r in pool(out, pat).items():
            prefix = f"{label} " if label else ""
            print(f"{prefix}{eng}: mean {avg(r['means']):.2f} m, p80 {avg(r['p80']):.2f} m, coverage "
                  f"{100 * avg(r['cov']):.0f} %, in_acc {100 * avg(r['inacc']):.0f} %, "
                  f"seeds {' '.join(f'{m:.2f}' for m in r['means'])}, {r['points']} points")


if __name__ == "__main__":
    main()
