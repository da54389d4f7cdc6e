#!/usr/bin/env python3
"""Edits one number (or byte) of a run folder's files at a time and runs a
crossaudit command on the folder, looking for panics, hangs and silent
changes.

    python3 fuzz/mutate/run_folder.py RUN_DIR WORK N SEED WATCH -- COMMAND...

RUN_DIR is copied to WORK, which COMMAND reads (and may write into).
Each of N edits takes a file of the folder (not weights, figures, reports
or the simulated logs), replaces one number in it with 0, -1, 1.5, 2, 3,
1e308, NaN, inf, 99999999999999999999 or nothing, runs COMMAND, and puts
the file back. Printed: a panic, an abort or a run past 60 s; and SILENT,
a run that answered 0 while a file in WATCH (comma-separated, relative to
WORK; build lines aside) came out different and its standard error did
not name the edited file: a changed answer nobody was told about. Ends
with the counts of (folder entry, exit code, output changed)."""
import collections, glob, os, random, re, shutil, subprocess, sys

from answered import answered, failed

args = sys.argv[1:]
sep = args.index("--")
(src, work, n, seed, watch), cmd = args[:5], args[sep + 1:]

rng = random.Random(int(seed))
shutil.rmtree(work, ignore_errors=True)
shutil.copytree(src, work)
subprocess.run(cmd, capture_output=True)
def outputs():
    out = {}
    for w in watch.split(","):
        p = os.path.join(work, w)
        out[w] = re.sub(rb"\(commit [^)]*\)", b"", open(p, "rb").read()) if os.path.exists(p) else b""
    return out
base = outputs()
skip = (".safetensors", ".svg", ".parquet", ".tex", ".html", ".md")
files = [f for f in glob.glob(work + "/**/*", recursive=True)
         if os.path.isfile(f) and not f.endswith(skip) and "/report/" not in f and "/simulated_data/" not in f]
NUMBERS = [b"0", b"-1", b"1.5", b"2", b"3", b"1e308", b"NaN", b"inf", b"99999999999999999999", b""]
counts = collections.Counter()
for i in range(int(n)):
    f = rng.choice(files)
    rel = os.path.relpath(f, work)
    orig = open(f, "rb").read()
    found = list(re.finditer(rb"-?\d+(\.\d+)?([eE][-+]?\d+)?", orig))
    if not found:
        continue
    m = rng.choice(found)
    edited = orig[:m.start()] + rng.choice(NUMBERS) + orig[m.end():]
    if edited == orig:
        continue
    open(f, "wb").write(edited)
    rc, err = answered(cmd, 60)
    now = outputs()
    open(f, "wb").write(orig)
    changed = [w for w in now if now[w] != base[w]]
    counts[(rel.split("/")[0], rc, bool(changed))] += 1
    if rc == 0 and changed and os.path.basename(f) not in err:
        print("SILENT", i, rel, "at", m.start(), m.group(0), "->", edited[m.start():m.start() + 24], changed, flush=True)
    if failed(rc, err):
        print("FAILED", i, rel, "at", m.start(), rc, err[:300].replace("\n", " | "), flush=True)
    if changed:
        subprocess.run(cmd, capture_output=True)
for k, v in sorted(counts.items(), key=str):
    print(k, v)
