"""Two sets of per-seed draws of one protocol as one 40-seed study.

results/multiverse/per_seed (designs/multiverse/paper_per_seed.design,
coupled draws) and results/multiverse/per_seed_uncoupled
(designs/multiverse/paper_per_seed_uncoupled.design, the first version,
per-seed draws from the design's generator) each train seeds 100..119, each
seed on its own draw of the validation, fit and contamination windows, with
the same pinned evaluation recordings, models, training and endpoints. They
are two sets of 20 draws of the paper's protocol. This script writes their
cells as one file with the uncoupled set's seeds relabelled 120..139 (seed
s -> s + 20; the relabelling only names the 40 seed-and-draw levels apart,
as a crossed analysis needs), for designs/multiverse/paper_per_seed_combined.design.

    python3 scripts/combine_seed_sets.py > results/multiverse/per_seed_combined/cells.csv
"""
import csv
import sys

SETS = [
    ("results/multiverse/per_seed/cells.csv", 0),
    ("results/multiverse/per_seed_uncoupled/cells.csv", 20),
]


def main():
    out = csv.writer(sys.stdout, lineterminator="\n")
    header = None
    for path, shift in SETS:
        with open(path, newline="") as f:
            rows = csv.reader(f)
            h = next(rows)
            if header is None:
                header = h
                out.writerow(h)
            assert h == header, f"{path}: another header"
            k = h.index("seed")
            for r in rows:
                r[k] = str(int(r[k]) + shift)
                out.writerow(r)


if __name__ == "__main__":
    main()
