"""Tests of time_bins.py on hand-made eval folders.

Run: python3 -m unittest discover -s scripts/lib -p 'test_*.py'
(scripts/test.sh runs it).
"""
import os
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from time_bins import binned, read_walks  # noqa: E402


def write_points(path, rows):
    """rows: (engine, log, t_s, truth (x, y), estimate (x, y) or None)."""
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        f.write("engine,log,t_s,truth_x_m,truth_y_m,truth_floor,est_x_m,est_y_m,est_floor,"
                "error_m,ipin_error_m,accuracy_m\n")
        for eng, log, t, (tx, ty), est in rows:
            if est is None:
                f.write(f"{eng},{log},{t},{tx},{ty},0,,,,,,\n")
            else:
                e = ((est[0] - tx) ** 2 + (est[1] - ty) ** 2) ** 0.5
                f.write(f"{eng},{log},{t},{tx},{ty},0,{est[0]},{est[1]},0,{e},{e},2\n")


class TimeBinsTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.out = self.tmp.name
        # one walk starting at t = 100 s: errors 1 (0 s), 3 (10 s), 5 (20 s),
        # no pose at 40 s, 7 at 70 s; another log starts at 0 with error 2
        a = [("tcpf", "a", 100, (0, 0), (1, 0)), ("tcpf", "a", 110, (0, 0), (3, 0)),
             ("tcpf", "a", 120, (0, 0), (5, 0)), ("tcpf", "a", 140, (0, 0), None),
             ("tcpf", "a", 170, (0, 0), (7, 0)), ("pdr", "a", 100, (0, 0), (9, 0))]
        write_points(f"{self.out}/odd/seed-1/points.csv", a + [("tcpf", "b", 0, (0, 0), (2, 0))])
        write_points(f"{self.out}/odd/seed-2/points.csv", [("tcpf", "a", 100, (0, 0), (3, 0))])

    def tearDown(self):
        self.tmp.cleanup()

    def test_bins_count_from_each_logs_first_point(self):
        r = binned(read_walks(self.out, "odd", {"tcpf"}))["tcpf"]
        # seed 1: 0-15 s: 1, 3, 2 -> 2; 15-30: 5; 30-60: none with a pose; 60-120: 7
        self.assertEqual([b[0] for b in r["bins"]], [2.0, 5.0, None, 7.0, None])
        # seed 2: 3 in the first bin only
        self.assertEqual(r["bins"][0], [2.0, 3.0])
        self.assertEqual(r["cov"], [5 / 6, 1.0])

    def test_the_table_and_the_plot(self):
        svg = f"{self.out}/plot.svg"
        out = subprocess.run(
            [sys.executable, f"{HERE}/time_bins.py", "--svg", svg, f"set|known|{self.out}|odd|tcpf"],
            capture_output=True, text=True, check=True).stdout
        self.assertIn("| set | known | tcpf | 2.50 | 5.00 | - | 7.00 | - |", out)
        self.assertNotIn("pdr", out)
        with open(svg) as f:
            self.assertIn("<polyline", f.read())

    def test_a_lasting_error_correlates_and_a_flipping_one_does_not(self):
        # the same 4 m east error along a walk: C = 1 at every lag; errors
        # flipping east / west every 6 s: C falls below 1/e at 5-10 s
        steady = [("knn", "s", t, (t, 0), (t + 4, 0)) for t in range(0, 60, 3)]
        flip = [("knn", "f", t, (t, 0), (t + (4 if (t // 6) % 2 == 0 else -4), 0))
                for t in range(0, 60, 3)]
        write_points(f"{self.out}/steady/seed-1/points.csv", steady)
        write_points(f"{self.out}/flip/seed-1/points.csv", flip)
        out = subprocess.run(
            [sys.executable, f"{HERE}/time_bins.py", "--autocorr", "knn",
             f"s|x|{self.out}|steady", f"f|x|{self.out}|flip"],
            capture_output=True, text=True, check=True).stdout
        self.assertIn("| s | x | s | 1.00 | 1.00 | 1.00 | 1.00 | 1.00 | beyond 80 s |", out)
        flip_s = [line for line in out.splitlines() if line.startswith("| f | x | s |")][0]
        self.assertIn("| 5-10 s |", flip_s)

    def test_a_row_without_points_fails(self):
        p = subprocess.run([sys.executable, f"{HERE}/time_bins.py", f"x|y|{self.out}|none"],
                           capture_output=True, text=True)
        self.assertEqual(p.returncode, 1)
        self.assertIn("MISSING x (y)", p.stderr)


if __name__ == "__main__":
    unittest.main()
