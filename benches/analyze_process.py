"""Whole-process timing of `crossaudit analyze` on the paper-size per-cell
file (6,240 rows, B = 9,999): process start, CSV read, analysis and the
three report files, as a user runs it.

    cargo build --release && python3 benches/analyze_process.py [RUNS]
"""
import os
import statistics
import subprocess
import sys
import tempfile
import time

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
binary = os.path.join(root, "target", "release", "crossaudit")
runs = int(sys.argv[1]) if len(sys.argv) > 1 else 30
args = [binary, "analyze", os.path.join(root, "designs/nanobench_confirmatory.design"),
        "--cells", os.path.join(root, "examples/cells/nanobench_synthetic.csv")]
times = []
with tempfile.TemporaryDirectory() as out:
    for k in range(runs + 3):
        t0 = time.perf_counter()
        subprocess.run(args + ["--out", out], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        dt = time.perf_counter() - t0
        if k >= 3:  # warm the page cache first
            times.append(dt)
print(f"crossaudit analyze, 6240 rows, B = 9999, {runs} runs: "
      f"median {statistics.median(times):.3f} s, min {min(times):.3f} s, max {max(times):.3f} s")
