#!/usr/bin/env python3
"""Checks that a family's estimates.csv in the single study's names (since
issue 58: kinds endpoint / optimism / trend / trend_optimism, estimators
crossed_mom / reml / pooled_reml / fixed_reference, `optimism_pct`,
`rule_holds`) holds every number of the same family's table in the older
names (kinds contrast / trend / pooled, `optimism`, `optimism_lower`,
`optimism_upper`, `optimism_unit`), each in its place, and nothing else.

Usage: python3 scripts/family_estimates_columns.py OLD.csv NEW.csv
(exit 0 when every old value is found where it belongs, 1 otherwise).
With `--carry OLD.csv NEW.csv OUT.csv` it writes NEW with every mapped
value taken from OLD: for a committed run whose analysis an earlier build
made, so that its table keeps that build's numbers (those of its
results.json and report.md) in the new names.
The committed family tables were rewritten by
`crossaudit analyze DESIGN --cells RUN/cells.csv`, and this check was run
on each old and new pair (results/INDEX.md).
"""
import csv
import sys


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def main(old_path, new_path, carry=False):
    old, new = rows(old_path), rows(new_path)
    dose_col = "distance_s" if "distance_s" in old[0] else "dose_pct"
    problems = []

    def find(kind, split, dose, contrast_prefix, pooled):
        hits = [
            r for r in new
            if r["kind"] == kind and r["split"] == split and r[dose_col] == dose
            and r["contrast"].startswith(contrast_prefix)
            and (r["estimator"].startswith("pooled_") == pooled)
        ]
        if len(hits) != 1:
            problems.append(f"{kind} split={split!r} dose={dose!r} {contrast_prefix!r} pooled={pooled}: {len(hits)} rows")
            return None
        return hits[0]

    def same(what, a, b):
        if a != b:
            problems.append(f"{what}: {a!r} != {b!r}")


    for r in old:
        pooled = r["kind"] == "pooled"
        slope = r["estimand"] == "slope"
        kind = "trend" if slope else "endpoint"
        prefix = "" if slope else r["arm"] + " - "
        e = find(kind, r["split"], r[dose_col], prefix, pooled)
        o = find(kind + "_optimism" if slope else "optimism", r["split"], r[dose_col], prefix, pooled)
        if e is None or o is None:
            continue
        if carry:
            for c in ["level", "treated_mean", "reference_mean", "estimate", "se", "df", "lower", "upper"]:
                e[c] = r[c]
            o["estimate"], o["lower"], o["upper"] = r["optimism"], r["optimism_lower"], r["optimism_upper"]
            o["df"], o["level"] = r["df"], r["level"]
            if not slope:
                e["optimism_pct"] = r["optimism"]
        for c in ["level", "treated_mean", "reference_mean", "estimate", "se", "df", "lower", "upper", "unit"]:
            same(f"{kind} {c}", r[c], e[c])
        same("optimism", r["optimism"], o["estimate"])
        same("optimism's df", r["df"], o["df"])
        if not slope:
            same("optimism_pct", r["optimism"], e["optimism_pct"])
        same("optimism_lower", r["optimism_lower"], o["lower"])
        same("optimism_upper", r["optimism_upper"], o["upper"])
        same("optimism_unit", r["optimism_unit"], o["unit"])
    if len(new) != 2 * len(old):
        problems.append(f"{len(new)} rows, expected {2 * len(old)}")
    decided = [r for r in new if r["rule_holds"] != ""]
    if len(decided) != 1:
        problems.append(f"rule_holds on {len(decided)} rows, expected 1")
    for p in problems:
        print(f"{new_path}: {p}")
    if carry and not problems:
        with open(carry, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(new[0]), lineterminator="\n")
            w.writeheader()
            w.writerows(new)
    return 1 if problems else 0


if __name__ == "__main__":
    if sys.argv[1] == "--carry":
        sys.exit(main(sys.argv[2], sys.argv[3], carry=sys.argv[4]))
    sys.exit(main(sys.argv[1], sys.argv[2]))
