"""Finds the extrapolated onboard tails in the NanoBench logs, independently
of crossaudit (plain csv + gzip, no numpy): for each log, the longest final
run of rows on which every onboard estimator velocity and attitude
quaternion column is a linear function of time (successive slopes equal to
a relative 1e-6); a tail when that run is at least 50 rows long and holds an
active row (motor_motor_m1 > 1000). Prints one line per log with a tail:

    name first_tail_row(1-based) tail_rows active_tail_rows

    python3 scripts/reference/onboard_tails.py ../shared/nanobench/recordings \
        > tests/data/onboard_tails.txt
"""
import csv
import glob
import gzip
import os
import sys

ONBOARD = ["est_stateEstimate_vx", "est_stateEstimate_vy", "est_stateEstimate_vz",
           "att_stateEstimate_qw", "att_stateEstimate_qx", "att_stateEstimate_qy", "att_stateEstimate_qz"]

for f in sorted(glob.glob(os.path.join(sys.argv[1], "*.csv.gz"))):
    name = os.path.basename(f)[:-len(".csv.gz")]
    reader = csv.reader(gzip.open(f, "rt"))
    header = next(reader)
    rows = [list(map(float, r)) for r in reader]
    ix = {c: i for i, c in enumerate(header)}
    n = len(rows)
    t = [r[0] for r in rows]
    start = 0
    for col in ONBOARD:
        v = [r[ix[col]] for r in rows]
        last = (v[n - 1] - v[n - 2]) / (t[n - 1] - t[n - 2])
        k = n - 2
        while k > 0:
            s = (v[k] - v[k - 1]) / (t[k] - t[k - 1])
            if abs(s - last) > 1e-6 * max(abs(last), 1.0):
                break
            k -= 1
        start = max(start, k)
    active = sum(1 for r in rows[start:] if r[ix["motor_motor_m1"]] > 1000)
    if n - start >= 50 and active > 0:
        print(name, start + 1, n - start, active)
