#!/usr/bin/env python3
"""What a choice made on the tuning protocol is worth on trials it did not see.

The route-held-out protocol (scripts/route-held-out.sh) chooses a default
among variants on the same IPIN trials it then reports, so its figures for
the chosen variant are tuning figures. This script estimates the choice
itself on unseen trials (nested selection): for every split of the IPIN
trials into two halves, it picks a variant on the first half with a fixed
rule and scores the pick on the second half. The rule: the lowest mean of
the held-out sets' means (T-A, coverage A) among the variants whose mean of
the surveyed sets' means (T-B, coverage B, odd half) exceeds the baseline's
by at most --max-surveyed-cost metres.

It reads the points.csv of runs already made by `scripts/route-held-out.sh
eval NAME ...` (out/{folds,coverage,odd}/ipin-eval/NAME-START/), and the
reference (e.g. `pdr`) the same way. Only the IPIN sets are split (their
folds are trials); ILC F1 is not read. The trials are those of the
held-out sets: the odd half's points of other trials (trial 52) are left
out, so its means differ from the protocol's.

Usage (repository root):
    scripts/nested-selection.py --baseline defaults --variants a,b,c \
        [--reference pdrref] [--start truth] [--max-surveyed-cost 0.25]

It prints each variant's set means over all trials, the rule's pick on all
trials, and over every split: how often each variant was picked, the
pick's mean on the unseen half's sets beside the baseline's and the
reference's, and the ratio to the reference (mean over the splits).
"""

import argparse
import collections
import csv
import glob
import itertools
import re
import sys

HELD_OUT = ["T-A", "coverage A"]
SURVEYED = ["T-B", "coverage B", "odd"]
SETS = {
    "T-A": "out/folds/ipin-eval/{run}/*-A",
    "T-B": "out/folds/ipin-eval/{run}/*-B",
    "coverage A": "out/coverage/ipin-eval/{run}/A-*",
    "coverage B": "out/coverage/ipin-eval/{run}/B-*",
    "odd": "out/odd/ipin-eval/{run}/odd",
}
TRIAL = re.compile(r"Trial(\d+)")


def load(run):
    """Per set and trial: [sum of errors, points] over every seed's points."""
    sums = {s: collections.defaultdict(lambda: [0.0, 0]) for s in SETS}
    for s, pattern in SETS.items():
        base = pattern.format(run=run)
        files = glob.glob(base + "/seed-*/points.csv") or glob.glob(base + "/points.csv")
        if not files:
            sys.exit(f"no points.csv under {base} (run scripts/route-held-out.sh eval first)")
        for f in files:
            with open(f, newline="") as fh:
                for row in csv.DictReader(fh):
                    if row["error_m"] == "":
                        continue
                    m = TRIAL.search(row["log"])
                    if not m:
                        sys.exit(f"{f}: log name without a trial number: {row['log']}")
                    acc = sums[s][int(m.group(1))]
                    acc[0] += float(row["error_m"])
                    acc[1] += 1
    return sums


def set_means(sums, sets, trials):
    out = []
    for s in sets:
        total = sum(sums[s][t][0] for t in trials if t in sums[s])
        n = sum(sums[s][t][1] for t in trials if t in sums[s])
        out.append(total / n if n else float("nan"))
    return out


def mean(xs):
    return sum(xs) / len(xs)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", required=True, help="run NAME of the defaults before the choice")
    ap.add_argument("--variants", required=True, help="comma-separated run NAMEs of the candidates")
    ap.add_argument("--reference", default="pdrref", help="run NAME of the reference engine")
    ap.add_argument("--start", default="truth", choices=["truth", "own"])
    ap.add_argument("--max-surveyed-cost", type=float, default=0.25, metavar="M")
    a = ap.parse_args()

    names = [a.baseline] + [v for v in a.variants.split(",") if v and v != a.baseline]
    runs = {n: load(f"{n}-{a.start}") for n in names}
    ref = load(f"{a.reference}-truth")
    trials = sorted(set().union(*(runs[a.baseline][s].keys() for s in HELD_OUT)))
    if len(trials) < 4:
        sys.exit(f"only {len(trials)} trials: nothing to split")

    def pick(ts):
        limit = mean(set_means(runs[a.baseline], SURVEYED, ts)) + a.max_surveyed_cost
        ok = [n for n in names if mean(set_means(runs[n], SURVEYED, ts)) <= limit]
        return min(ok, key=lambda n: (mean(set_means(runs[n], HELD_OUT, ts)), names.index(n)))

    fmt = lambda xs: " / ".join(f"{x:.2f}" for x in xs)
    print(f"IPIN trials {trials}; start {a.start}; sets {', '.join(HELD_OUT)} | {', '.join(SURVEYED)}")
    for n in names:
        print(f"  {n}: {fmt(set_means(runs[n], HELD_OUT, trials))} | {fmt(set_means(runs[n], SURVEYED, trials))}")
    print(f"  {a.reference}: {fmt(set_means(ref, HELD_OUT, trials))} | {fmt(set_means(ref, SURVEYED, trials))}")
    print(f"picked on all trials: {pick(trials)} (its figures above are tuning figures)")

    picks = collections.Counter()
    rows = []
    for half in itertools.combinations(trials, len(trials) // 2):
        rest = [t for t in trials if t not in half]
        p = pick(list(half))
        picks[p] += 1
        rows.append(
            (
                set_means(runs[p], HELD_OUT + SURVEYED, rest),
                set_means(runs[a.baseline], HELD_OUT + SURVEYED, rest),
                set_means(ref, HELD_OUT + SURVEYED, rest),
            )
        )
    print(f"{len(rows)} splits; picks: " + ", ".join(f"{n} {c}" for n, c in picks.most_common()))
    print("on the unseen half (mean over the splits): pick / baseline / reference, pick / reference")
    for j, s in enumerate(HELD_OUT + SURVEYED):
        p, b, r = (mean([row[k][j] for row in rows]) for k in range(3))
        ratio = mean([row[0][j] / row[2][j] for row in rows])
        print(f"  {s}: {p:.2f} / {b:.2f} / {r:.2f} m, {ratio:.3f} x")


if __name__ == "__main__":
    main()
