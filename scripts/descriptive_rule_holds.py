#!/usr/bin/env python3
"""Blanks `rule_holds` on every row of a single study's estimates.csv but
the primary endpoint's, as crossaudit writes it since the decision rule was
recorded only where it decides (issue 58). For committed results that
cannot be regenerated without retraining (full runs on the real logs):
`python3 scripts/descriptive_rule_holds.py FILE...` rewrites each in place,
and `--check OLD NEW` verifies that the transform of an old file is,
byte for byte, the file the binary now writes (run on every result that
scripts/regenerate.sh regenerates)."""
import csv
import io
import sys


def transform(text: str) -> str:
    rows = list(csv.reader(io.StringIO(text)))
    if not rows or "rule_holds" not in rows[0] or "role" not in rows[0]:
        return text  # not an estimates.csv (a family's, every row of the primary endpoint, passes through unchanged)
    role, holds = rows[0].index("role"), rows[0].index("rule_holds")
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    for k, r in enumerate(rows):
        if k > 0 and r[role] != "primary":
            r[holds] = ""
        w.writerow(r)
    return out.getvalue()


def main(argv):
    if argv[:1] == ["--check"]:
        old, new = open(argv[1]).read(), open(argv[2]).read()
        if transform(old) != new:
            sys.exit(f"{argv[1]} transformed is not {argv[2]}")
        return
    for path in argv:
        text = open(path).read()
        open(path, "w").write(transform(text))


if __name__ == "__main__":
    main(sys.argv[1:])
