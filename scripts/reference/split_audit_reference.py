"""Independent reference for the split audit of NanoBench's upstream task-2
split (tests/split_audit.rs compares crossaudit's audit with this output).

    python3 scripts/reference/split_audit_reference.py > scripts/reference/split_audit_reference.out

Standard library only, written from shared/nanobench/README.md, not from
crossaudit's code: a file is kept when it has an active row
(motor_motor_m1 > 1000) and, over its active rows, the 0.5th and 99.5th
percentiles (numpy's linear interpolation) of battery voltage (zeros
forward/back-filled), setpoint z and the four motors' PWM pooled lie inside
[2.5, 4.5] V, [-0.2, 3.0] m and [0, 65535]. Identical means the same bytes
after the header line (SHA-256). Shared runs: two non-identical recordings
in different roles with 100 consecutive identical lines.
"""
import gzip
import hashlib
import json
import os

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
NB = os.path.join(ROOT, "..", "shared", "nanobench")
REC = os.path.join(NB, "recordings")
RUN = 100


def percentile(sorted_values, q):
    pos = q * (len(sorted_values) - 1)
    lo = int(pos)
    hi = min(lo + 1, len(sorted_values) - 1)
    return sorted_values[lo] + (sorted_values[hi] - sorted_values[lo]) * (pos - lo)


def load(name):
    path = os.path.join(REC, name + ".csv.gz")
    if not os.path.exists(path):
        return None
    data = gzip.open(path, "rb").read()
    header, _, body = data.partition(b"\n")
    cols = header.decode().strip().split(",")
    lines = [l for l in body.split(b"\n") if l.strip()]
    idx = {c: k for k, c in enumerate(cols)}
    rows = [l.split(b",") for l in lines]
    m = [[float(r[idx["motor_motor_m%d" % j]]) for j in range(1, 5)] for r in rows]
    vbat = [float(r[idx["pwr_pm_vbat"]]) for r in rows]
    first = next((v for v in vbat if v != 0.0), None)
    if first is not None:
        last = first
        for k, v in enumerate(vbat):
            if v == 0.0:
                vbat[k] = last
            else:
                last = v
    spz = [float(r[idx["sp_ctrltarget_z"]]) for r in rows]
    active = [k for k in range(len(rows)) if m[k][0] > 1000]
    keep, why = True, ""
    if not active:
        keep, why = False, "no active rows"
    else:
        for label, values, lo, hi in [("battery", [vbat[k] for k in active], 2.5, 4.5),
                                      ("setpoint z", [spz[k] for k in active], -0.2, 3.0),
                                      ("pwm", [x for k in active for x in m[k]], 0.0, 65535.0)]:
            v = sorted(values)
            if percentile(v, 0.005) < lo or percentile(v, 0.995) > hi:
                keep, why = False, why + label + " "
    return {"sha": hashlib.sha256(body).hexdigest(), "keep": keep, "why": why.strip(),
            "lines": [hash(l.rstrip(b"\r")) for l in lines]}


def trajectory(name):
    meta = os.path.join(REC, name + "_metadata.yaml")
    for line in open(meta):
        if line.startswith("trajectory_type:"):
            return line.split(":", 1)[1].strip()
    return None


def speed(name):
    for s in ("slow", "medium", "fast"):
        if "_" + s + "_" in name + "_":
            return s
    return "unknown"


def main():
    split = json.load(open(os.path.join(NB, "upstream_task2_split_metadata.json")))
    roles = {r[:-len("_files")]: [os.path.basename(p)[:-len(".csv")] for p in split[r]]
             for r in split if r.endswith("_files")}
    loaded = {n: load(n) for names in roles.values() for n in names}
    role_of = {n: r for r, names in roles.items() for n in names}
    out = {"roles": {}, "identical_pairs": [], "shared_run_pairs": [], "tv_distance": {}}
    for r, names in roles.items():
        present = [n for n in names if loaded[n] is not None]
        out["roles"][r] = {
            "declared": len(names),
            "with_csv": len(present),
            "metadata_only": sorted(n for n in names if loaded[n] is None
                                    and os.path.exists(os.path.join(REC, n + "_metadata.yaml"))),
            "dropped": sorted(n for n in present if not loaded[n]["keep"]),
            "effective": sum(1 for n in present if loaded[n]["keep"]),
        }
    names = sorted(n for n in loaded if loaded[n] is not None)
    windows = {}
    for n in names:
        h = loaded[n]["lines"]
        for p in range(len(h) - RUN + 1):
            windows.setdefault(hash(tuple(h[p:p + RUN])), set()).add(n)
    shared = set()
    for members in windows.values():
        for a in members:
            for b in members:
                if a < b and role_of[a] != role_of[b] and loaded[a]["sha"] != loaded[b]["sha"]:
                    shared.add((a, b))
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if role_of[a] != role_of[b] and loaded[a]["sha"] == loaded[b]["sha"]:
                out["identical_pairs"].append(sorted([[role_of[a], a], [role_of[b], b]]))
    out["shared_run_pairs"] = sorted(list(p) for p in shared)


    def cells(r):
        c = {}
        for n in roles[r]:
            if loaded[n] is not None and loaded[n]["keep"]:
                key = trajectory(n) + "/" + speed(n)
                c[key] = c.get(key, 0) + 1
        return c


    for a in roles:
        for b in roles:
            if a < b:
                ca, cb = cells(a), cells(b)
                na, nb = sum(ca.values()), sum(cb.values())
                keys = set(ca) | set(cb)
                out["tv_distance"][a + "/" + b] = 0.5 * sum(abs(ca.get(k, 0) / na - cb.get(k, 0) / nb) for k in keys)
    print(json.dumps(out, indent=1, sort_keys=True))


if __name__ == "__main__":
    main()
