"""Independent reference for the distance rows of `crossaudit audit split`
on the committed per-window splits of NanoBench
(results/nanobench_window_split/splits/*.csv; tests/split_windows.rs
compares the committed audits with this output).

    python3 scripts/reference/window_split_reference.py > scripts/reference/window_split_reference.out

Standard library only, written from the definition in docs/usage.md, not
from crossaudit's code: a window [a0, a1) of one role, in a recording the
upstream loader keeps (split_audit_reference.load), is compared with every
window of another role in a recording with the same data bytes (SHA-256
after the header, so itself or a byte-identical copy), by brute force.
Its distance to one is max(0, b0 - a1, a0 - b1); they overlap where
b0 < a1 and b1 > a0. Per ordered pair of roles: the windows, those with
any such window, those overlapping one, those nearer than 1 s, and the
minimum, quartiles (statistics.quantiles, method "inclusive": R's type 7)
and maximum of the nearest distances.
"""
import csv
import json
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import split_audit_reference as upstream  # noqa: E402

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
SPLITS = os.path.join(ROOT, "results", "nanobench_window_split", "splits")
GAP_S = 1.0


def audit(path, loaded):
    windows = []
    for row in csv.DictReader(open(path, newline="")):
        name = row["recording"]
        if name not in loaded:
            loaded[name] = upstream.load(name)
        rec = loaded[name]
        if rec is None or not rec["keep"]:
            continue
        windows.append((row["role"], rec["sha"], float(row["start_s"]), float(row["end_s"])))
    roles = sorted({w[0] for w in windows})
    out = {}
    for role in roles:
        for other in roles:
            if other == role:
                continue
            mine = [w for w in windows if w[0] == role]
            nearest = []
            overlapping = 0
            for _, sha, a0, a1 in mine:
                theirs = [w for w in windows if w[0] == other and w[1] == sha]
                if not theirs:
                    continue
                nearest.append(min(max(0.0, b0 - a1, a0 - b1) for _, _, b0, b1 in theirs))
                overlapping += any(b0 < a1 and b1 > a0 for _, _, b0, b1 in theirs)
            q = None
            if nearest:
                quartiles = statistics.quantiles(nearest, n=4, method="inclusive") if len(nearest) > 1 else [nearest[0]] * 3
                q = [min(nearest)] + quartiles + [max(nearest)]
            out[role + "/" + other] = {
                "windows": len(mine),
                "in_shared_recording": len(nearest),
                "overlapping": overlapping,
                "within_gap": sum(1 for d in nearest if d < GAP_S),
                "quantiles_s": q,
            }
    return out


def main():
    loaded = {}
    out = {}
    for name in ("random", "chronological", "embargo"):
        out[name] = audit(os.path.join(SPLITS, name + ".csv"), loaded)
    print(json.dumps(out, indent=1, sort_keys=True))


if __name__ == "__main__":
    main()
