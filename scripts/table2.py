"""Prints a Table-2-style Markdown comparison of run reports.

    python3 scripts/table2.py results/nanobench_confirmatory/report/results.json \
        results/nanobench_audited/report/results.json

Paper values quoted in crossaudit's issues (the paper's full Table 2 is not
in this repository) are shown where known; "n/a" elsewhere.
"""
import json
import sys

PAPER = {
    ("world", 1.0, "reference"): "0.299",
    ("world", 1.0, "shares"): "95.9 / 1.1 / 3.0",
}

runs = [(p, json.load(open(p))) for p in sys.argv[1:]]


def unit(a, model, h):
    for u in a["units"]:
        if u["model"] == model and abs(u["horizon_s"] - h) < 1e-9:
            return u
    return None


def f(x, d=4):
    return "n/a" if x is None else f"{x:.{d}f}"


heads = ["quantity", "paper"] + [a["study"] for _, a in runs]
print("| " + " | ".join(heads) + " |")
print("|" + "---|" * len(heads))


def row(name, paper, values):
    print(f"| {name} | {paper} | " + " | ".join(values) + " |")


models = []
for _, a in runs:
    for u in a["units"]:
        if (u["model"], u["horizon_s"]) not in models:
            models.append((u["model"], u["horizon_s"]))
for model, h in models:
    us = [unit(a, model, h) for _, a in runs]
    tag = f"{model} {h:g} s"
    row(f"{tag}: contaminated RMSE (m)", "n/a", [f(u and u["mean_treated"]) for u in us])
    row(f"{tag}: disjoint RMSE (m)", PAPER.get((model, h, "reference"), "n/a"), [f(u and u["mean_reference"]) for u in us])
    row(f"{tag}: optimism (%)", "n/a", [f(u and u["optimism_pct"], 1) for u in us])
    row(f"{tag}: d mean [95% CI]", "n/a",
        [u and f"{u['estimate']['mean']:.4f} [{u['estimate']['lower']:.4f}, {u['estimate']['upper']:.4f}]" or "n/a" for u in us])
    row(f"{tag}: SE^2 shares rec / seed / res (%)", PAPER.get((model, h, "shares"), "n/a"),
        [u and f"{100*u['estimate']['share_recording']:.1f} / {100*u['estimate']['share_seed']:.1f} / {100*u['estimate']['share_residual']:.1f}" or "n/a" for u in us])
    row(f"{tag}: grouped d [95% CI]", "n/a",
        [u and u.get("grouped") and f"{u['grouped']['estimate']['mean']:.4f} [{u['grouped']['estimate']['lower']:.4f}, {u['grouped']['estimate']['upper']:.4f}] ({len(u['grouped']['groups'])} groups)" or "n/a" for u in us])
for k in range(max(len(a["interactions"]) for _, a in runs)):
    vals = []
    name = None
    for _, a in runs:
        ix = a["interactions"][k] if k < len(a["interactions"]) else None
        if ix:
            name = f"interaction {ix['left']} - {ix['right']} at {ix['horizon_s']:g} s [95% CI]"
            vals.append(f"{ix['estimate']['mean']:.4f} [{ix['estimate']['lower']:.4f}, {ix['estimate']['upper']:.4f}]")
        else:
            vals.append("n/a")
    row(name, "n/a", vals)
row("decision", "n/a", [a["decision"]["rule"] + ": " + ("holds" if a["decision"]["holds"] else "does not hold") for _, a in runs])
