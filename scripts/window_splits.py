#!/usr/bin/env python3
"""Writes three per-window splits of a folder of flight logs, the ways
papers that fit dynamics models on windows commonly split them, for
`crossaudit audit split` to measure (results/nanobench_window_split):

- random.csv: every recording cut into 2 s windows, each window assigned
  to train or test at random (80/20, seed 59);
- chronological.csv: the same windows, the first 80% of each recording's
  windows in train and the rest in test;
- embargo.csv: chronological, with the train windows within 5 s of the
  first test window left out (a "purged" split).

Times are seconds from each recording's first timestamp (the `t` column),
as the audit reads them. Only the standard library is used.

Usage: python3 scripts/window_splits.py RECORDINGS_DIR OUT_DIR
"""

import csv
import gzip
import io
import os
import random
import sys

WINDOW_S = 2.0
TRAIN_SHARE = 0.8
EMBARGO_S = 5.0


def duration(path):
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rt", newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        k = header.index("t")
        times = [float(row[k]) for row in reader if row]
    return times[-1] - times[0]


def stem(name):
    for suffix in (".gz", ".csv"):
        if name.endswith(suffix):
            name = name[: -len(suffix)]
    return name


def write(path, rows):
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(["recording", "role", "start_s", "end_s"])
    for r in rows:
        w.writerow(r)
    with open(path, "w", newline="") as f:
        f.write(out.getvalue())


def main(recordings, out_dir):
    names = sorted(n for n in os.listdir(recordings) if n.endswith(".csv") or n.endswith(".csv.gz"))
    rng = random.Random(59)
    random_rows, chrono_rows, embargo_rows = [], [], []
    for name in names:
        d = duration(os.path.join(recordings, name))
        count = int(d // WINDOW_S)
        if count < 2:
            continue
        windows = [(round(k * WINDOW_S, 3), round((k + 1) * WINDOW_S, 3)) for k in range(count)]
        rec = stem(name)
        for a, b in windows:
            random_rows.append((rec, "train" if rng.random() < TRAIN_SHARE else "test", a, b))
        cut = max(1, int(round(count * TRAIN_SHARE)))
        first_test = windows[cut][0] if cut < count else None
        for k, (a, b) in enumerate(windows):
            role = "train" if k < cut else "test"
            chrono_rows.append((rec, role, a, b))
            if role == "train" and first_test is not None and first_test - b < EMBARGO_S:
                continue
            embargo_rows.append((rec, role, a, b))
    os.makedirs(out_dir, exist_ok=True)
    for file, rows in (("random.csv", random_rows), ("chronological.csv", chrono_rows), ("embargo.csv", embargo_rows)):
        write(os.path.join(out_dir, file), rows)
        print(f"{file}: {len(rows)} windows")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
