"""Whether the reports a bench wrote at each thread count are the same
files, byte for byte: WORK/report-N for each N given, against the first.

    python3 benches/scale/same_reports.py WORK N1 N2 ...
"""
import filecmp
import sys

work, threads = sys.argv[1], sys.argv[2:]
first = f"{work}/report-{threads[0]}"
for n in threads[1:]:
    other = f"{work}/report-{n}"
    d = filecmp.dircmp(first, other)
    same = not d.left_only and not d.right_only and all(
        filecmp.cmp(f"{first}/{f}", f"{other}/{f}", shallow=False) for f in d.common_files)
    print(f"  report at {threads[0]} and {n} thread(s): {'byte-identical' if same else 'DIFFERENT'}")
