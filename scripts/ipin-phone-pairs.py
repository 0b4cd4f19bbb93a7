#!/usr/bin/env python3
"""How far apart two IPIN 2023 logs read the same place, by phone model and
by walking direction (docs/lab/tcpf-radio-trust.md "Two phone models, two
radios").

Every log is cut into WINDOW-second windows (default 4) of the stretch
between its first and last POSI truth point; each window gets the walker's
position (truth interpolated in time), the direction of its truth segment
and the mean RSSI per transmitter (BLE4 rows by MAC, WIFI rows by BSSID).
Windows of two logs of different trials on one floor within 2 m of each
other are compared over the transmitters of one radio both heard (at least
3): the mean difference (the offset between the two logs) and the RMS
difference about it. Reads the gzipped logs in place.

usage: scripts/ipin-phone-pairs.py [DATASETS] [WINDOW_S]
"""
import collections
import glob
import gzip
import math
import re
import statistics
import sys

root = sys.argv[1] if len(sys.argv) > 1 else "../shared/datasets"
window_s = float(sys.argv[2]) if len(sys.argv) > 2 else 4.0
LAT0, LON0 = 49.4613, 11.1115


def xy(lat, lon):
    return ((lon - LON0) * math.cos(math.radians(LAT0)) * 111320.0, (lat - LAT0) * 110540.0)


def windows(path):
    m = re.search(r"Trial(\d+)_repetition(\d+)", path)
    trial = int(m.group(1))
    posi, readings, model = [], [], None
    for line in gzip.open(path, "rt", errors="replace"):
        if line.startswith("% Model:"):
            model = line.split(":", 1)[1].strip()
        f = line.strip().split(";")
        if f[0] == "POSI":
            x, y = xy(float(f[3]), float(f[4]))
            posi.append((float(f[1]), x, y, int(f[5])))
        elif f[0] == "BLE4":
            readings.append((float(f[1]), "ble", f[3], float(f[4])))
        elif f[0] == "WIFI":
            readings.append((float(f[1]), "wifi", f[4], float(f[6])))
    t = posi[0][0] if posi else 0.0
    while len(posi) >= 2 and t + window_s <= posi[-1][0]:
        mid = t + window_s / 2
        a, b = next((a, b) for a, b in zip(posi, posi[1:]) if a[0] <= mid <= b[0])
        length = math.hypot(b[1] - a[1], b[2] - a[2])
        if a[3] == b[3] and length >= 2.0:
            u = (mid - a[0]) / max(b[0] - a[0], 1e-9)
            acc = collections.defaultdict(list)
            for tt, kind, tx, r in readings:
                if t <= tt < t + window_s:
                    acc[(kind, tx)].append(r)
            yield dict(
                trial=trial,
                model=model,
                x=a[1] + u * (b[1] - a[1]),
                y=a[2] + u * (b[2] - a[2]),
                floor=a[3],
                heading=math.atan2(b[2] - a[2], b[1] - a[1]),
                rssi={k: sum(v) / len(v) for k, v in acc.items()},
            )
        t += window_s


ws = [w for p in sorted(glob.glob(f"{root}/ipin2023/logs/*.txt.gz")) for w in windows(p)]
models = sorted({w["model"] for w in ws})
print(f"{len(ws)} windows of {window_s:g} s; models {models}")
by_phone = collections.defaultdict(list)
by_heading = collections.defaultdict(list)
for i, a in enumerate(ws):
    for b in ws[i + 1:]:
        if a["trial"] == b["trial"] or a["floor"] != b["floor"]:
            continue
        if math.hypot(a["x"] - b["x"], a["y"] - b["y"]) > 2.0:
            continue
        for kind in ("ble", "wifi"):
            d = [a["rssi"][k] - b["rssi"][k] for k in a["rssi"] if k[0] == kind and k in b["rssi"]]
            if len(d) < 3:
                continue
            mean = sum(d) / len(d)
            centred = math.sqrt(sum((x - mean) ** 2 for x in d) / len(d))
            if a["model"] == b["model"]:
                by_phone[(kind, "same model")].append(mean)
            else:
                # first model minus second
                by_phone[(kind, f"{models[0]} - {models[-1]}")].append(
                    mean if a["model"] == models[0] else -mean
                )
            dh = abs((a["heading"] - b["heading"] + math.pi) % (2 * math.pi) - math.pi)
            h = "same direction" if dh < math.pi / 4 else "opposite" if dh > 3 * math.pi / 4 else "across"
            by_heading[(kind, h)].append(centred)
print("mean difference between the two windows, dB (pairs, mean, sd):")
for k, v in sorted(by_phone.items()):
    print(f"  {k[0]:4} {k[1]:22} {len(v):4} {statistics.mean(v):+6.2f} {statistics.pstdev(v):5.2f}")
print("RMS difference about the mean, dB, by walking direction (pairs, median):")
for k, v in sorted(by_heading.items()):
    print(f"  {k[0]:4} {k[1]:15} {len(v):4} {statistics.median(v):5.2f}")
