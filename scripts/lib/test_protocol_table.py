"""Tests of pool_points.py and protocol_table.py on hand-made eval folders.

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
from pool_points import pool  # noqa: E402


def write_points(path, rows):
    """rows: (engine, error_m or None, accuracy_m or None)."""
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        # the columns of `fpbp eval`'s points.csv
        f.write("engine,log,t_s,truth_x_m,truth_y_m,truth_floor,est_x_m,est_y_m,est_floor,"
                "error_m,ipin_error_m,accuracy_m\n")
        for eng, e, a in rows:
            e, a = "" if e is None else e, "" if a is None else a
            f.write(f"{eng},x.txt,0,0,0,0,0,0,0,{e},{e},{a}\n")


class PoolTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.out = self.tmp.name
        # two folds of one set, two seeds; fold A-2 has a point without a pose
        write_points(f"{self.out}/A-1/seed-1/points.csv", [("tcpf", 1.0, 2.0), ("tcpf", 3.0, 2.0)])
        write_points(f"{self.out}/A-1/seed-2/points.csv", [("tcpf", 2.0, 2.0), ("tcpf", 4.0, 5.0)])
        write_points(f"{self.out}/A-2/seed-1/points.csv", [("tcpf", 5.0, None), ("tcpf", None, None)])
        write_points(f"{self.out}/A-2/seed-2/points.csv", [("tcpf", 6.0, 7.0), ("tcpf", None, None)])
        write_points(f"{self.out}/B-1/seed-1/points.csv", [("tcpf", 10.0, 1.0)])

    def tearDown(self):
        self.tmp.cleanup()

    def test_pools_the_folds_per_seed(self):
        r = pool(self.out, "A-*")["tcpf"]
        # seed 1: errors 1, 3, 5 (one point without a pose); seed 2: 2, 4, 6
        self.assertEqual(r["means"], [3.0, 4.0])
        self.assertEqual(r["cov"], [0.75, 0.75])
        # within the radius: seed 1 1 of 2 with a radius, seed 2 3 of 3
        self.assertEqual(r["inacc"], [0.5, 1.0])
        self.assertEqual(r["points"], 4)

    def test_the_table_separates_held_out_and_surveyed(self):
        out = subprocess.run(
            [sys.executable, f"{HERE}/protocol_table.py",
             f"set a|held out|own|{self.out}|A-*", f"set b|surveyed|own|{self.out}|B-*"],
            capture_output=True, text=True, check=True).stdout
        self.assertIn("| set a | held out | own | tcpf | 3.50 | 75 % | 75 % |", out)
        self.assertIn("| set b | surveyed | own | tcpf | 10.00 | 100 % | 0 % |", out)
        self.assertIn("tcpf, own start, routes held out: mean of 1 set means 3.50 m", out)
        self.assertIn("tcpf, own start, routes surveyed: mean of 1 set means 10.00 m", out)

    def test_a_set_without_eval_folders_fails(self):
        p = subprocess.run(
            [sys.executable, f"{HERE}/protocol_table.py", f"set c|held out|own|{self.out}|C-*"],
            capture_output=True, text=True)
        self.assertEqual(p.returncode, 1)
        self.assertIn("MISSING set c (own)", p.stderr)


if __name__ == "__main__":
    unittest.main()
