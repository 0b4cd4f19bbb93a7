"""Error by time since the start, and how long the radio's error lasts.

usage: time_bins.py [--svg FILE] ROW [ROW ...]
       time_bins.py --autocorr ENGINE ROW [ROW ...]
ROW: SET|VARIANT|OUT|GLOB[|ENGINES], the `fpbp eval --seeds` folders
OUT/GLOB (each with seed-*/points.csv) of one set scored one way;
ENGINES (comma-separated) keeps only those engines' points.

Default: a Markdown table, one line per set, variant and engine, of the
mean error in each time bin since the log's first scored point (0-15,
15-30, 30-60, 60-120, 120 s or more), the overall mean and the coverage
(share of points with a pose). Each figure is the mean over the engine
seeds of that seed's mean over the pooled points of the bin. --svg also
draws the error against time since start, one line per table line.

--autocorr ENGINE: the error vectors (estimate - truth) of ENGINE along
each walk, as a normalised vector autocorrelation C = mean(e_i . e_j) /
mean(|e|^2) over pairs of points of one walk (and one seed), binned by
their time apart and by the metres the truth walked between them; and the
first lag at which C falls below 1/e. An error that lasts is one a filter
cannot average away by hearing more scans.
"""
import csv
import glob
import math
import os
import sys
from collections import defaultdict

BINS = [(0, 15), (15, 30), (30, 60), (60, 120), (120, math.inf)]
LAG_S = [(0, 5), (5, 10), (10, 20), (20, 40), (40, 80)]
LAG_M = [(0, 5), (5, 10), (10, 20), (20, 40), (40, 80)]


def bin_label(lo, hi):
    return f"{lo}+ s" if hi == math.inf else f"{lo}-{hi} s"


def read_walks(out, pat, engines=None):
    """{(engine, seed): [walk]}, a walk a list of (t since its first scored
    point s, error m or None, (est - truth) vector or None, truth xy) in
    time order; one walk per (fold folder, log)."""
    walks = defaultdict(list)
    for d in sorted(glob.glob(f"{out}/{pat}")):
        if not os.path.isdir(d):
            continue
        for sd in sorted(glob.glob(f"{d}/seed-*")):
            by_log = defaultdict(list)
            with open(f"{sd}/points.csv") as f:
                for r in csv.DictReader(f):
                    if engines and r["engine"] not in engines:
                        continue
                    by_log[(r["engine"], r["log"])].append(r)
            for (eng, _log), rows in by_log.items():
                rows.sort(key=lambda r: float(r["t_s"]))
                t0 = float(rows[0]["t_s"])
                walk = []
                for r in rows:
                    tx, ty = float(r["truth_x_m"]), float(r["truth_y_m"])
                    if r["error_m"]:
                        v = (float(r["est_x_m"]) - tx, float(r["est_y_m"]) - ty)
                        walk.append((float(r["t_s"]) - t0, float(r["error_m"]), v, (tx, ty)))
                    else:
                        walk.append((float(r["t_s"]) - t0, None, None, (tx, ty)))
                walks[(eng, os.path.basename(sd))].append(walk)
    return walks


def binned(walks):
    """{engine: {"bins": [per bin: [per-seed mean or None]], "mean": [...],
    "cov": [...]}} of read_walks' output."""
    res = {}
    for (eng, _seed), ws in sorted(walks.items()):
        r = res.setdefault(eng, {"bins": [[] for _ in BINS], "mean": [], "cov": []})
        pts = [p for w in ws for p in w]
        for k, (lo, hi) in enumerate(BINS):
            es = [p[1] for p in pts if lo <= p[0] < hi and p[1] is not None]
            r["bins"][k].append(sum(es) / len(es) if es else None)
        es = [p[1] for p in pts if p[1] is not None]
        r["mean"].append(sum(es) / len(es) if es else None)
        r["cov"].append(len(es) / len(pts) if pts else 0.0)
    return res


def avg(xs):
    xs = [x for x in xs if x is not None]
    return sum(xs) / len(xs) if xs else None


def fmt(x):
    return "-" if x is None else f"{x:.2f}"


def table(rows, svg=None):
    print("| set | variant | engine | " + " | ".join(bin_label(*b) for b in BINS)
          + " | mean (m) | coverage | seeds |")
    print("|---|---|---|" + "---|" * len(BINS) + "---|---|---|")
    lines, missing = [], []
    for row in rows:
        parts = row.split("|")
        set_, variant, out, pat = parts[:4]
        engines = set(parts[4].split(",")) if len(parts) > 4 and parts[4] else None
        res = binned(read_walks(out, pat, engines))
        if not res:
            missing.append(f"{set_} ({variant}): no points in {out}/{pat}")
            continue
        for eng, r in res.items():
            bins = [avg(b) for b in r["bins"]]
            print(f"| {set_} | {variant} | {eng} | " + " | ".join(fmt(b) for b in bins)
                  + f" | {fmt(avg(r['mean']))} | {100 * avg(r['cov']):.0f} % | {len(r['mean'])} |")
            lines.append((f"{set_}, {variant}, {eng}", bins))
    if svg:
        write_svg(svg, lines)
    for m in missing:
        print(f"MISSING {m}", file=sys.stderr)
    return 1 if missing else 0


def write_svg(path, lines):
    """Error against time since start: a line per (label, bin means)."""
    w, h, left, top, right, bottom = 900, 60 + 18 * len(lines) + 320, 60, 20, 20, 18 * len(lines) + 60
    ph = h - top - bottom
    xs = [7.5, 22.5, 45, 90, 150]  # bin centres, s
    ymax = max([b for _, bs in lines for b in bs if b is not None] + [1.0]) * 1.1
    X = lambda t: left + (t / 160) * (w - left - right)  # noqa: E731
    Y = lambda e: top + ph - (e / ymax) * ph  # noqa: E731
    colours = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b",
               "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"]
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="11">',
           f'<rect width="{w}" height="{h}" fill="white"/>',
           f'<line x1="{left}" y1="{top + ph}" x2="{w - right}" y2="{top + ph}" stroke="black"/>',
           f'<line x1="{left}" y1="{top}" x2="{left}" y2="{top + ph}" stroke="black"/>',
           f'<text x="{w / 2}" y="{top + ph + 30}" text-anchor="middle">time since start (s; bins 0-15, 15-30, 30-60, 60-120, 120+)</text>',
           f'<text x="14" y="{top + ph / 2}" transform="rotate(-90 14 {top + ph / 2})" text-anchor="middle">mean error (m)</text>']
    for t in (0, 15, 30, 60, 120):
        out.append(f'<text x="{X(t)}" y="{top + ph + 14}" text-anchor="middle">{t}</text>')
    step = max(1, round(ymax / 6))
    for e in range(0, int(ymax) + 1, step):
        out.append(f'<text x="{left - 6}" y="{Y(e) + 4}" text-anchor="end">{e}</text>')
        out.append(f'<line x1="{left}" y1="{Y(e)}" x2="{w - right}" y2="{Y(e)}" stroke="#eee"/>')
    for k, (label, bins) in enumerate(lines):
        c = colours[k % len(colours)]
        dash = ' stroke-dasharray="6 3"' if k >= len(colours) else ""
        pts = [(X(x), Y(b)) for x, b in zip(xs, bins) if b is not None]
        if len(pts) > 1:
            d = " ".join(f"{x:.1f},{y:.1f}" for x, y in pts)
            out.append(f'<polyline points="{d}" fill="none" stroke="{c}" stroke-width="2"{dash}/>')
        for x, y in pts:
            out.append(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="3" fill="{c}"/>')
        ly = top + ph + 50 + 18 * k
        out.append(f'<line x1="{left}" y1="{ly}" x2="{left + 30}" y2="{ly}" stroke="{c}" stroke-width="2"{dash}/>')
        out.append(f'<text x="{left + 36}" y="{ly + 4}">{label}</text>')
    out.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def autocorr(engine, rows):
    """Prints the error autocorrelation of ENGINE per row, by time and
    metres apart; returns 1 when a row has no points."""
    print("| set | variant | pairs by | " + " | ".join(f"{a}-{b}" for a, b in LAG_S)
          + " | falls below 1/e at |")
    print("|---|---|---|" + "---|" * len(LAG_S) + "---|")
    bad = 0
    for row in rows:
        set_, variant, out, pat = row.split("|")[:4]
        walks = read_walks(out, pat, {engine})
        if not walks:
            print(f"MISSING {set_} ({variant}): no {engine} points in {out}/{pat}", file=sys.stderr)
            bad = 1
            continue
        for unit, lags in (("s", LAG_S), ("m walked", LAG_M)):
            num = [0.0] * len(lags)
            cnt = [0] * len(lags)
            e2, n2 = 0.0, 0
            for ws in walks.values():
                for w in ws:
                    pts = [p for p in w if p[2] is not None]
                    # metres the truth walked up to each point
                    s, walked, prev = 0.0, [], None
                    for p in w:
                        if prev is not None:
                            s += math.dist(p[3], prev)
                        prev = p[3]
                        if p[2] is not None:
                            walked.append(s)
                    for i, p in enumerate(pts):
                        e2 += p[2][0] ** 2 + p[2][1] ** 2
                        n2 += 1
                        for j in range(i, len(pts)):
                            lag = pts[j][0] - p[0] if unit == "s" else walked[j] - walked[i]
                            for k, (lo, hi) in enumerate(lags):
                                if lo <= lag < hi:
                                    num[k] += p[2][0] * pts[j][2][0] + p[2][1] * pts[j][2][1]
                                    cnt[k] += 1
                                    break
            var = e2 / n2 if n2 else 0.0
            cs = [num[k] / cnt[k] / var if cnt[k] and var > 0 else None for k in range(len(lags))]
            below = next((f"{lo}-{hi} {unit}" for (lo, hi), c in zip(lags, cs)
                          if c is not None and c < 1 / math.e), f"beyond {lags[-1][1]} {unit}")
            print(f"| {set_} | {variant} | {unit} | " + " | ".join(fmt(c) for c in cs) + f" | {below} |")
    return bad


def main(argv):
    svg = None
    if argv and argv[0] == "--autocorr":
        return autocorr(argv[1], argv[2:])
    if argv and argv[0] == "--svg":
        svg, argv = argv[1], argv[2:]
    return table(argv, svg)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
