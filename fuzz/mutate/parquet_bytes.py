#!/usr/bin/env python3
"""Mutates a Parquet file and runs a crossaudit command on each mutant.

    python3 fuzz/mutate/parquet_bytes.py SOURCE CASE N SEED [--footer | --head=B] -- COMMAND...

Each of N mutants of SOURCE (random bytes changed, flipped, zeroed, set to
0xff, or the file cut short; with --footer, 1 to 4 bytes of a Parquet
file's Thrift footer only; with --head=B, 1 to 4 of its first B bytes, as
a .npy file's header) is written to CASE, which COMMAND reads (COMMAND names CASE
itself). A panic, an abort, a signal or a run past 30 s is printed (the
first of each kind, its mutant kept as CASE.bad-I); SOURCE is written back
to CASE at the end. Exit codes 0, 1 and 2 are answers; anything else is
not."""
import random, re, sys

from answered import answered, failed

args = sys.argv[1:]
sep = args.index("--")
(src, case, n, seed), flags, cmd = args[:4], args[4:sep], args[sep + 1:]
data = open(src, "rb").read()
footer = len(data) - 8 - int.from_bytes(data[-8:-4], "little")
rng = random.Random(int(seed))
seen = {}
for i in range(int(n)):
    b = bytearray(data)
    head = next((int(f.split("=")[1]) for f in flags if f.startswith("--head=")), None)
    if "--footer" in flags or head:
        lo, hi = (0, min(head, len(b))) if head else (footer, len(b) - 8)
        for _ in range(rng.randint(1, 4)):
            k = rng.randrange(lo, hi)
            b[k] = rng.choice([b[k] ^ (1 << rng.randrange(8)), rng.randrange(256), 0x00, 0x7F, 0x80, 0xFF])
    else:
        kind = rng.choice(["cut", "flip", "flip", "bytes", "zero", "ff"])
        k = rng.randrange(len(b))
        if kind == "cut":
            b = b[:k]
        elif kind == "flip":
            for _ in range(rng.randint(1, 8)):
                j = rng.randrange(len(b)); b[j] ^= 1 << rng.randrange(8)
        elif kind == "bytes":
            for _ in range(rng.randint(1, 4)):
                b[rng.randrange(len(b))] = rng.randrange(256)
        else:
            span = rng.randint(1, 64 if kind == "zero" else 8)
            b[k:k + span] = (b"\x00" if kind == "zero" else b"\xff") * len(b[k:k + span])
    open(case, "wb").write(b)
    rc, err = answered(cmd, 30)
    if failed(rc, err):
        said = [l for l in err.splitlines() if "panicked" in l]
        key = (rc, re.sub(r"\(\d+\)", "", said[0]) if said else "")
        if key not in seen:
            seen[key] = i
            open(f"{case}.bad-{i}", "wb").write(b)
            print(i, rc, err[:400].replace("\n", " | "), flush=True)
open(case, "wb").write(data)
print(f"{n} mutants, {len(seen)} kinds of failure")
