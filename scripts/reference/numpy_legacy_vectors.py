"""Test vectors for crossaudit's `numpy_legacy` split generator.

numpy's legacy `RandomState(seed)` (MT19937 seeded by init_genrand, bounded
integers by mask-and-reject in `random_interval`) is what the paper's split
used: `RandomState(42).permutation(106)[:26]` over the sorted usable names
gives its evaluation composition table. This script writes what numpy
returns for permutation, choice without replacement and shuffle, over
several seeds and sizes, and for calls made one after another on the same
state, so that tests/split_numpy.rs can check the Rust port bit for bit.

    .venv-torch/bin/python scripts/reference/numpy_legacy_vectors.py \
        > tests/data/numpy_legacy_vectors.json

(any Python with numpy; the committed file was made with numpy 2.4.6).
"""
import json

import numpy as np


def checksum(a):
    """sum of (i + 1) * a[i] mod 2^61 - 1: order-sensitive, cheap to recompute."""
    m = (1 << 61) - 1
    return int(sum((i + 1) * int(v) for i, v in enumerate(a)) % m)


def entry(kind, seed, args, values):
    values = [int(v) for v in values]
    out = {"kind": kind, "seed": seed, "args": args, "len": len(values), "checksum": checksum(values)}
    out["head"] = values[:200]
    return out


cases = []
for seed in [0, 1, 7, 42, 143, 2**31 - 1, 2**32 - 1]:
    for n in [0, 1, 2, 3, 10, 26, 106, 1000, 65537]:
        cases.append(entry("permutation", seed, [n], np.random.RandomState(seed).permutation(n)))
for seed, n, k in [(42, 106, 26), (143, 80, 8), (143, 78, 8), (7, 16000, 4000), (42, 120000, 16000), (3, 5, 5), (9, 1, 0)]:
    cases.append(entry("choice", seed, [n, k], np.random.RandomState(seed).choice(n, k, replace=False)))
for seed, n in [(5, 10), (42, 106), (2**32 - 1, 300)]:
    a = list(range(100, 100 + n))
    np.random.RandomState(seed).shuffle(a)
    cases.append(entry("shuffle", seed, [n], a))
# Calls one after another on one state: the split draws E, then the starts
# of each evaluation recording, from the split seed's one RandomState.
rs = np.random.RandomState(42)
seq = list(rs.permutation(106)[:26])
for n in [3900, 2500, 4100]:
    seq.extend(rs.choice(n, 50, replace=False))
cases.append(entry("sequence", 42, [106, 26, 3900, 2500, 4100, 50], seq))

print(json.dumps({"numpy": np.__version__, "cases": cases}, indent=1))
