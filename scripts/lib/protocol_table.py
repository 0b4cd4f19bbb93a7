"""The table of scripts/route-held-out.sh: one row per set, start and engine.

usage: protocol_table.py ROW [ROW ...]
ROW: SET|ROUTE|START|OUT|GLOB, the eval folders OUT/GLOB of one set and
start (ROUTE: "held out" or "surveyed"). Prints a Markdown table (mean
over the engine seeds of each seed's mean error over the pooled points,
coverage, share within the accuracy radius, p80, each seed's mean), then
per engine and start the mean of the set means over the held-out sets
and over the surveyed ones: the figure a default is chosen on, and the
one beside it.
"""
import os
import sys
from collections import defaultdict

sys.path.insert(0, os.path.dirname(__file__))
from pool_points import avg, pool  # noqa: E402


def main():
    print("| set | route | start | engine | mean (m) | coverage | within accuracy | p80 (m) | seeds |")
    print("|---|---|---|---|---|---|---|---|---|")
    by_kind = defaultdict(list)
    missing = []
    for row in sys.argv[1:]:
        set_, route, start, out, pat = row.split("|")
        res = pool(out, pat)
        if not res:
            missing.append(f"{set_} ({start}): no eval folders {out}/{pat}")
            continue
        for eng, r in res.items():
            m = avg(r["means"])
            seeds = " ".join(f"{x:.2f}" for x in r["means"])
            print(f"| {set_} | {route} | {start} | {eng} | {m:.2f} | {100 * avg(r['cov']):.0f} % "
                  f"| {100 * avg(r['inacc']):.0f} % | {avg(r['p80']):.2f} | {seeds} |")
            by_kind[(eng, start, route)].append(m)
    print()
    for (eng, start, route), ms in sorted(by_kind.items()):
        print(f"{eng}, {start} start, routes {route}: mean of {len(ms)} set means {avg(ms):.2f} m")
    for m in missing:
        print(f"MISSING {m}", file=sys.stderr)
    if missing:
        sys.exit(1)


if __name__ == "__main__":
    main()
