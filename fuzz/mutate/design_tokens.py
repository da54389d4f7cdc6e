#!/usr/bin/env python3
"""Edits a design file a token at a time and runs a crossaudit command on
it, looking for panics and hangs past the parser (the libFuzzer target
`parse_design` covers the parser alone): the compiled plan, the data
audit and split that `check` builds, a run's first steps.

    python3 fuzz/mutate/design_tokens.py DESIGN WORK N SEED -- COMMAND...

DESIGN is copied to WORK (a file path, which COMMAND names) and each of N
edits is made to that copy: a number replaced (0, -1, 1, 2, 0.5, 1e9,
1e308, 99999999999999999999, nothing), a word replaced by another word
of the design, a line deleted or repeated, or two lines swapped. A
relative `path` in the design is made absolute first, so the copy reads
the same data. Printed: FAILED for a panic, an abort, a signal or a run
past 60 s. Ends with the counts of (kind of edit, exit code)."""
import collections, os, random, re, sys

from answered import answered, failed

args = sys.argv[1:]
sep = args.index("--")
(design, work, n, seed), cmd = args[:4], args[sep + 1:]
rng = random.Random(int(seed))

base = os.path.dirname(os.path.abspath(design))


def absolute(m):
    p = m.group(2)
    beside = os.path.join(base, p)
    return m.group(1) + (beside if os.path.isdir(beside) else os.path.abspath(p)) + m.group(3)


text = re.sub(r'(path\s+")([^"/][^"]*)(")', absolute, open(design).read())
words = sorted(set(re.findall(r"[A-Za-z_][A-Za-z_0-9]*", text)))
NUMBERS = ["0", "-1", "1", "2", "0.5", "1e9", "1e308", "99999999999999999999", ""]


def edit(t):
    kind = rng.choice(["number", "number", "word", "delete", "repeat", "swap"])
    lines = t.split("\n")
    if kind == "number":
        found = list(re.finditer(r"(?<![A-Za-z_])\d+(\.\d+)?", t))
        if not found:
            return kind, t
        m = rng.choice(found)
        return kind, t[:m.start()] + rng.choice(NUMBERS) + t[m.end():]
    if kind == "word":
        found = list(re.finditer(r"[A-Za-z_][A-Za-z_0-9]*", t))
        m = rng.choice(found)
        return kind, t[:m.start()] + rng.choice(words) + t[m.end():]
    i = rng.randrange(len(lines))
    if kind == "delete":
        del lines[i]
    elif kind == "repeat":
        lines.insert(i, lines[i])
    else:
        j = rng.randrange(len(lines))
        lines[i], lines[j] = lines[j], lines[i]
    return kind, "\n".join(lines)


counts = collections.Counter()
for i in range(int(n)):
    kind, edited = edit(text)
    if edited == text:
        continue
    open(work, "w").write(edited)
    rc, err = answered(cmd, 60)
    counts[(kind, rc)] += 1
    if failed(rc, err):
        keep = f"{work}.failed-{i}"
        open(keep, "w").write(edited)
        print("FAILED", i, kind, rc, keep, err[-300:].replace("\n", " | "), flush=True)
for k, v in sorted(counts.items(), key=str):
    print(k, v)
