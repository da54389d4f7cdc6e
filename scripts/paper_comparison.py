"""Writes docs/paper_comparison.md: crossaudit's run of the paper's design
beside every number the paper publishes (../shared/paper/NUMBERS.md), the
column-preset decision and the data-hygiene table. Every number on the page
is read here from a committed file under results/.

    python3 scripts/paper_comparison.py > docs/paper_comparison.md
"""
import csv
import json
import os
import re

R = "results"


def load(path):
    return json.load(open(os.path.join(R, path)))


def unit(res, model, h):
    for u in res["units"]:
        if u["model"] == model and abs(u["horizon_s"] - h) < 1e-9 and u["metric"] == "fa_position_rmse":
            return u
    raise KeyError((model, h))


def inter(res, h):
    for i in res["interactions"]:
        if abs(i["horizon_s"] - h) < 1e-9:
            return i
    return None


def ci(e, d=4):
    return f"[{e['lower']:.{d}f}, {e['upper']:.{d}f}]"


def pct(x, d=1):
    return f"{x:.{d}f}%"


def wall(path):
    t = open(os.path.join(R, path)).read()
    m = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)", t)
    return m.group(1)


def absent(path):
    p = os.path.join(R, path)
    if not os.path.exists(p):
        return []
    return [(r["role"], r["recording"]) for r in csv.DictReader(open(p))]


def audit_rows(path):
    return list(csv.DictReader(open(os.path.join(R, path))))


paper = load("nanobench_paper/report/results.json")
treat = load("nanobench_paper/audit/treatment.json")
rows = audit_rows("nanobench_paper/audit/recordings.csv")
gone = absent("nanobench_paper/manifests/absent_recordings.csv")

PAPER_T2 = {  # NUMBERS.md, Table 2: contaminated, disjoint, optimism %, d CI
    ("world", 0.5): (0.096, 0.117, 17.8, "[-0.0310, -0.0106]"),
    ("world", 1.0): (0.262, 0.299, 12.1, "[-0.0735, 0.0011]"),
    ("world", 2.0): (0.662, 0.739, 10.4, "[-0.1385, -0.0156]"),
    ("relative", 0.5): (0.085, 0.102, 16.1, "[-0.0286, -0.0042]"),
    ("relative", 1.0): (0.251, 0.301, 16.8, "[-0.0910, -0.0103]"),
    ("relative", 2.0): (0.622, 0.739, 15.9, "[-0.1724, -0.0624]"),
}

def verdict(holds):
    return "CONFIRMED" if holds else "NOT CONFIRMED"


def twin_evidence():
    """Per draw of the two committed 20-draw per-seed sets: the evaluation
    flights a copy of which lies in the validation set (invariant 3's
    duplicate recordings, mapped through the paper run's duplicate
    groups), the reference (disjoint) world model's best validation epoch
    (its curve), and d of every evaluation recording at 1 s (its cells)."""
    groups = {r["name"]: r["duplicate_group"] for r in rows if r.get("duplicate_group")}
    draws = []
    for run in ("per_seed", "per_seed_uncoupled"):
        for k in range(1, 21):
            base = os.path.join(R, "multiverse", run, f"draw-{k}")
            inv = load(f"multiverse/{run}/draw-{k}/audit/invariants.json")["invariants"]
            val = next((i.get("numbers", {}) for i in inv if i["id"] == 3), {}).get("duplicate_recordings", [])
            with open(os.path.join(base, "curves", [c for c in os.listdir(os.path.join(base, "curves")) if c.startswith("world__disjoint__")][0])) as f:
                curve = list(csv.DictReader(f))
            best = int(min(curve, key=lambda r: float(r["val_loss"]))["epoch"])
            cells = {}
            with open(os.path.join(base, "cells.csv")) as f:
                for r in csv.DictReader(f):
                    if r["model"] == "world" and float(r["horizon_s"]) == 1.0:
                        cells.setdefault(r["recording"], {})[r["arm"]] = float(r["fa_position_rmse_m"])
            d = {rec: v["contaminated"] - v["disjoint"] for rec, v in cells.items() if len(v) == 2}
            twins = {e for e in d for v in val if groups.get(v) and groups.get(v) == groups.get(e)}
            draws.append({"twins": twins, "best": best, "d": d, "cells": cells})
    return draws


def fisher_two_sided(a, b, c, dd):
    """Fisher's exact test of the 2x2 table [[a, b], [c, dd]], two-sided
    (the sum of the probabilities no larger than the observed one)."""
    from math import comb
    n1, n2, k = a + b, c + dd, a + c
    prob = lambda x: comb(n1, x) * comb(n2, k - x) / comb(n1 + n2, k)
    obs = prob(a)
    lo, hi = max(0, k - n2), min(k, n1)
    return sum(prob(x) for x in range(lo, hi + 1) if prob(x) <= obs * (1 + 1e-9))


def twin_paragraph(p):
    """Which evaluation flight early stopping turns on, from the committed
    draws (issue 72): the draws whose validation set holds its copy."""
    draws = twin_evidence()
    counts = {}
    for dr in draws:
        for e in dr["twins"]:
            counts[e] = counts.get(e, 0) + 1
    early = lambda dr: dr["best"] <= 10
    # The flight whose twin in validation goes with an early-stopped reference.
    def split(e):
        inn = [dr for dr in draws if e in dr["twins"]]
        out = [dr for dr in draws if e not in dr["twins"]]
        return inn, out
    key = max(counts, key=lambda e: (sum(early(dr) for dr in split(e)[0]) - sum(early(dr) for dr in split(e)[1]), e))
    inn, out = split(key)
    a, b = sum(map(early, inn)), len(inn) - sum(map(early, inn))
    c, dd = sum(map(early, out)), len(out) - sum(map(early, out))
    pval = fisher_two_sided(a, b, c, dd)
    mean = lambda xs: sum(xs) / len(xs) if xs else float("nan")
    d_in = mean([dr["d"][key] for dr in inn if key in dr["d"]])
    d_out = mean([dr["d"][key] for dr in out if key in dr["d"]])
    with_copy = sum(1 for dr in draws if dr["twins"])
    # The headline set's optimism without that flight (ratio of the arms' means).
    head = draws[:20]
    t = [v["contaminated"] for dr in head for r, v in dr["cells"].items() if r != key and len(v) == 2]
    r_ = [v["disjoint"] for dr in head for r, v in dr["cells"].items() if r != key and len(v) == 2]
    without = 100 * (mean(r_) - mean(t)) / mean(r_)
    p(f"- **What early stopping turns on.** Validation holds a byte-identical copy")
    p(f"  of an evaluation flight in {with_copy} of the 40 committed draws (invariant 3).")
    p(f"  In the {len(inn)} draws whose validation set holds the copy of `{key}`, the")
    p(f"  reference model reaches its best validation loss by epoch 10 in {a}; in the")
    p(f"  other {len(out)} draws, in {c} (Fisher's exact test, two-sided, p = {pval:.1g}).")
    p(f"  d on `{key}` is {d_in:.2f} m where its copy steers validation and")
    p(f"  {d_out:.2f} m elsewhere: early stopping is steered by one evaluation")
    p(f"  flight through its twin, not by chance. Without `{key}` the headline")
    p(f"  set's optimism is {without:.1f}% (ratio of the arms' means over its cells).")


def settled_section(p):
    """What the data settle and what they do not, first: every number from
    a committed run with the draws included."""
    ps = load("multiverse/per_seed/report/results.json")
    u = unit(ps, "world", 1.0)
    unc = unit(load("multiverse/per_seed_uncoupled/report/results.json"), "world", 1.0)
    comb = load("multiverse/per_seed_combined/report/results.json")
    uc = unit(comb, "world", 1.0)
    bud = load("multiverse/per_seed_budget/report/results.json")
    ub = unit(bud, "world", 1.0)
    fb = bud["fixed_budget"]
    mvps = load("multiverse/paper_per_seed/report/multiverse.json")
    grouped = [sp for sp in mvps["specs"] if sp["values"][2] == "group"]
    g_lo = min(sp["optimism_pct"] for sp in grouped)
    g_hi = max(sp["optimism_pct"] for sp in grouped)
    g_all = all(sp["rule_holds"] for sp in grouped)
    early = next((w for w in bud["warnings"] if w.startswith("early best epochs")), "")
    share = re.search(r"those seeds carry ([0-9.]+)% of the summed primary d", early)

    def fci(x):
        iv = x.get("optimism_interval") or {}
        f = iv.get("fieller") or {}
        return f"[{f['lower']:.1f}%, {f['upper']:.1f}%]" if f.get("kind") == "bounded" else "unbounded"

    p("## What the data settle, and what they do not")
    p("")
    p("Primary endpoint: world model, failure-aware position RMSE at 1 s;")
    p("d = contaminated - disjoint; every interval below includes the")
    p("unpublished draws (each seed trains and is evaluated on its own draw).")
    p("")
    p("Settled:")
    p("")
    p(f"- **The effect is negative.** The paper's reading gives d = {u['estimate']['mean']:.4f} m {ci(u['estimate'])}")
    p(f"  with 20 per-seed draws (`results/multiverse/per_seed`), {unc['estimate']['mean']:.4f} m {ci(unc['estimate'])} with")
    p(f"  another 20 (`results/multiverse/per_seed_uncoupled`), and {uc['estimate']['mean']:.4f} m {ci(uc['estimate'])}")
    p(f"  with both as one 40-draw study (`results/multiverse/per_seed_combined`).")
    # A grouped reading settles the threshold only where its optimism's
    # interval (Fieller's) lies wholly above it.
    def above(sp):
        f = (sp.get("optimism_interval") or {}).get("fieller") or {}
        return f.get("kind") == "bounded" and f["lower"] > 10.0
    clear = [sp for sp in grouped if above(sp)]
    intervals = ", ".join(f"{sp['id']} {sp['optimism_pct']:.1f}% {fci(sp)}" for sp in grouped)
    disjoint_text = (
        f"grouping byte-identical files (`duplicates group`, the per-seed multiverse's"
        f" {', '.join(sp['id'] for sp in grouped)}) gives optimism {g_lo:.1f}% to {g_hi:.1f}%"
        f" (Fieller's intervals: {intervals}), and the rule "
        + ("holds in every one" if g_all else "does not hold in all of them") + "."
    )
    if len(clear) == len(grouped):
        p("- **With a truly disjoint reference arm it clears the threshold.**")
        p(f"  {disjoint_text[0].upper() + disjoint_text[1:]} Every one of these intervals lies above 10%.")
    p("")
    p("Not settled:")
    p("")
    if len(clear) < len(grouped):
        p("- **Whether a truly disjoint reference arm clears the threshold.** The point")
        p(f"  estimates do: {disjoint_text} But only {len(clear)} of the {len(grouped)} intervals")
        p(f"  lie wholly above 10% ({', '.join(sp['id'] for sp in clear) or 'none'}); the others clear it by their")
        p("  point estimates alone, and early stopping was not held fixed in any of them.")
    p(f"- **Which side of 10% the paper's own reading falls on.** Two equally valid")
    p(f"  sets of 20 draws give {u['optimism_pct']:.1f}% (NOT CONFIRMED) and {unc['optimism_pct']:.1f}% (CONFIRMED);")
    p(f"  the 40 together give {uc['optimism_pct']:.1f}%, with the optimism's 95% interval {fci(uc)}")
    p(f"  (Fieller's). The threshold lies inside every one of these intervals")
    p(f"  ({fci(ub)} for the headline set), and reports written since say beside")
    p(f"  the verdict that the data do not determine its side. The 40-draw analysis")
    p(f"  was written after both sets' results were known; its lock is marked post hoc")
    p(f"  (`lock --posthoc`), so its report says POST HOC.")
    m = re.search(r"\(epochs ([0-9.]+) to ([0-9.]+); contaminated (\d+) of \d+, disjoint (\d+) of \d+\)", early)
    d_with = re.search(r"mean primary d (-?[0-9.]+) over the (\d+) seed", early)
    d_without = re.search(r", (-?[0-9.]+) over the (\d+) without", early)
    p(f"- **How much of d is early stopping.** {m.group(4)} of the reference arm's and {m.group(3)} of the")
    p(f"  contaminated arm's models reach their best validation loss in the first")
    p(f"  tenth of training (epochs {m.group(1)} to {m.group(2)}), and are restored there. The")
    p(f"  {d_with.group(2)} seeds with such a model carry {share.group(1)}% of the summed primary d")
    p(f"  (mean d {d_with.group(1)} m against {d_without.group(1)} m over the other {d_without.group(2)}).")
    p(f"  With early stopping held fixed (the same network trained for the full")
    p(f"  {fb['epochs']} epochs in both arms and its last weights rolled out, model")
    p(f"  `{fb['model']}`, `results/multiverse/per_seed_budget`), d = {fb['estimate']['mean']:.4f} m {ci(fb['estimate'])}")
    p(f"  and optimism {fb['optimism_pct']:.1f}% {fci(fb)}; the rule " + ("holds" if fb["rule_holds"] else "does not hold") + " there.")
    p(f"  That run's primary model is the headline run's, cell for cell (its")
    p(f"  d is {ub['estimate']['mean']:.4f} m); its design was written after the per-seed results.")
    twin_paragraph(p)
    p("")


def draws_section(p):
    """The answer with the unpublished draws included, first: the paper's
    design with a draw per seed, the estimate pooled over three whole draws,
    and the multiverse with per-seed draws, beside the paper's 12.1%."""
    ps = load("multiverse/per_seed/report/results.json")
    u = unit(ps, "world", 1.0)
    dr = load("multiverse/draws/report/multiverse.json")["draws"][0]
    pl = dr["pooled"]
    mv = load("multiverse/paper/report/multiverse.json")
    s1 = next(sp for sp in mv["specs"] if sp["primary"])
    mvps = load("multiverse/paper_per_seed/report/multiverse.json")
    s1ps = next(sp for sp in mvps["specs"] if sp["primary"])
    held = sum(1 for sp in mvps["specs"] if sp["rule_holds"])
    j = mvps["joint"]
    copies = next(n for n in mv["notes"] if n["id"] == "spec-s1")["reference_copies"]
    # Per draw of the per-seed runs: fit windows (invariant 5) and
    # validation windows (invariant 3) from copies of evaluation flights.
    fit_c, val_c = [], []
    for run in ("per_seed", "per_seed_uncoupled"):
        for k in range(1, 21):
            inv = load(f"multiverse/{run}/draw-{k}/audit/invariants.json")["invariants"]
            n = {i["id"]: i.get("numbers", {}) for i in inv}
            if run == "per_seed":
                fit_c.append(n.get(5, {}).get("from_duplicates", 0) + n.get(5, {}).get("from_evaluation", 0))
            val_c.append(n.get(3, {}).get("from_duplicates", 0))
    per_seed_copies = f"{min(fit_c):,} to {max(fit_c):,}"
    val_copies = max(val_c)
    p("## The answer with the draws included")
    p("")
    p("Every interval the paper prints, and every single-draw interval below, is")
    p("conditional on one draw of what the paper did not publish: the validation")
    p("recordings and windows, the fit and contamination windows and the rollout")
    p("starts. That draw moves the answer as much as anything else does, so the")
    p("answers that include it come first. Primary endpoint: world model,")
    p("failure-aware position RMSE at 1 s; d = contaminated - disjoint.")
    p("")
    p("| estimate | what varies | d (m) | 95% CI (m) | optimism | decision |")
    p("|---|---|---:|---|---:|---|")
    p("| the paper (Table 2) | recordings, seeds; one unpublished draw | -0.037 | [-0.0735, 0.0011] | 12.1% | NOT CONFIRMED |")
    p(f"| per-seed draws (`designs/multiverse/paper_per_seed.design`) | recordings, seeds, each seed its own draw | {u['estimate']['mean']:.4f} | {ci(u['estimate'])} | {u['optimism_pct']:.1f}% | {verdict(ps['decision']['holds'])} |")
    p(f"| pooled over 3 draws (`designs/multiverse/paper_draws.design`) | recordings, seeds, 3 whole draws; REML, Kenward-Roger df {pl['df']:.1f} | {pl['mean']:.4f} | [{pl['lower']:.4f}, {pl['upper']:.4f}] | {pl['optimism_pct']:.1f}% | {verdict(pl['rule_holds'])} |")
    p(f"| one draw: the multiverse's s1 | recordings, seeds | {s1['estimate']['mean']:.4f} | {ci(s1['estimate'])} | {s1['optimism_pct']:.1f}% | {verdict(s1['rule_holds'])} |")
    p("")
    p("All rows read the paper's design in its primary reading (motion-capture")
    p("columns, onboard tails and duplicate files kept) on the paper's own 26")
    p("evaluation recordings, of which 24 have a CSV in this snapshot of")
    p("NanoBench (two, among them the multisine recording, are absent). The")
    p("per-seed-draw interval is the one whose coverage holds for the protocol")
    p("rather than for one draw (docs/study-coverage.md, \"Coverage with a draw")
    p("component\"); the pooled estimate's draw variance rests on three draws,")
    p("which its report flags. Both estimate the protocol-level mean and both")
    # Optimism implied by each end of d's interval (over the reference mean).
    def opt_range(lo, hi, ref):
        return sorted((-100 * lo / ref, -100 * hi / ref))
    r1 = opt_range(u["estimate"]["lower"], u["estimate"]["upper"], u["mean_reference"])
    r2 = opt_range(pl["lower"], pl["upper"], pl["mean_reference"])
    inside = all(a <= 12.1 <= b for a, b in (r1, r2))
    p(f"put the optimism below the rule's 10% ({u['optimism_pct']:.1f}% and {pl['optimism_pct']:.1f}%), with")
    p("upper ends near zero. Divided by the reference mean, their intervals span")
    p(f"an optimism of {r1[0]:.1f}% to {r1[1]:.1f}% and {r2[0]:.1f}% to {r2[1]:.1f}%: the paper's 12.1% is")
    p(("inside both" if inside else "not inside both") + ", so the data do not contradict the paper's size of effect;")
    p("they do not establish it either. With the draws included, the headline")
    p("per-seed run does not confirm either, but which side of 10% the protocol")
    p("falls on is not settled (the section above).")
    unc = unit(load("multiverse/per_seed_uncoupled/report/results.json"), "world", 1.0)
    p("")
    p("How close to the threshold this is: a first version of the per-seed")
    p("design (locked and run without `draws coupled`, so its 20 draws are")
    p("other draws of the same protocol; `results/multiverse/per_seed_uncoupled/`)")
    p(f"gave optimism {unc['optimism_pct']:.1f}% and d {unc['estimate']['mean']:.4f} m {ci(unc['estimate'])}, which meets the")
    p("rule. Two honest sets of 20 draws land on either side of 10%; both")
    p("intervals exclude zero. The coupled design that gives the headline was")
    p("locked after that first set's result had been committed, so it is not")
    p("cleaner evidence than the first set; the two together are the fairer")
    p("reading (the section above).")
    p("")
    p(f"**The reference arm is not disjoint in this reading.** Under `duplicates")
    p(f"keep`, {copies['most']:,} of the disjoint arm's 16,000 fit windows in the single draw s1")
    p(f"come from byte-identical copies of evaluation flights ({per_seed_copies}")
    p(f"over the 20 per-seed draws), and so do up to {val_copies:,} of the 2,000 validation")
    p("windows in a per-seed draw (invariants 5 and 3 record them). The per-seed")
    p("and combined reports say so beside their verdicts; the single-draw")
    p("reports committed before that (`results/nanobench_paper` among them)")
    p("list it only among their warnings. Both arms see those flights, which")
    p("shrinks the contrast; the `duplicates group` specifications have a")
    p("disjoint reference arm.")
    p("")
    p(f"**The multiverse with per-seed draws** (`designs/multiverse/paper_multiverse_per_seed.design`,")
    p(f"320 jobs, draws coupled across specifications, `results/multiverse/paper_per_seed/`):")
    p(f"the rule holds in {held} of {len(mvps['specs'])} specifications with intervals that include the")
    p(f"draw variance; the primary s1: optimism {s1ps['optimism_pct']:.1f}%, d {s1ps['estimate']['mean']:.4f} m {ci(s1ps['estimate'])},")
    p(f"{verdict(s1ps['rule_holds'])}. {j['bands_excluding_zero']} of {len(j['bands'])} simultaneous bands exclude zero. Under the null")
    p(f"(each specification's d centred at zero, {j['replicates']} shared resamples) the median d,")
    p(f"the count of specifications meeting the rule and Stouffer's combined t all have")
    p(f"p = {j['null']['median'][1]:.4f}, {j['null']['holding'][1]:.4f} and {j['null']['stouffer'][1]:.4f}: the floor 1 / ({j['replicates']} + 1), no replicate as extreme")
    p("(`scripts/reference/null_test_check.py` agrees, with its own random numbers).")
    p("")
    p("| spec | state | tails | duplicates | optimism, one draw | optimism, per-seed draws | d 95% CI, per-seed draws (m) | rule, one draw | rule, per-seed draws |")
    p("|---|---|---|---|---:|---:|---|---|---|")
    for a, b in zip(mv["specs"], mvps["specs"]):
        st, tl, du = b["values"]
        name = b["id"] + (" (primary)" if b["primary"] else "")
        p(f"| {name} | {st} | {tl} | {du} | {a['optimism_pct']:.1f}% | {b['optimism_pct']:.1f}% | {ci(b['estimate'])} | {'met' if a['rule_holds'] else 'not met'} | {'met' if b['rule_holds'] else 'not met'} |")
    p("")
    p("A count of specifications meeting the rule from single-draw runs (the")
    p("section below) does not include the draw variance; the per-seed column")
    p("does.")
    p("")


def multiverse_section(p):
    """The per-specification comparison: the paper's design as a multiverse
    over its open data choices, the draw replication as the yardstick, and
    the trajectory holdout."""
    mv = load("multiverse/paper/report/multiverse.json")
    dr = load("multiverse/draws/report/multiverse.json")
    ho = load("multiverse/holdout/report/multiverse.json")
    draws = dr["draws"][0]
    opts = [d[4] for d in draws["per_draw"]]
    spread = max(opts) - min(opts)
    ds = [d[1] for d in draws["per_draw"]]
    p("## The open choices decide the result")
    p("")
    p("The paper leaves three data choices open: which columns give velocity and")
    p("attitude (it names Vicon for position only), what to do with the rows after")
    p("a log's onboard streams end, and whether byte-identical recordings count as")
    p("separate flights. `designs/multiverse/paper_multiverse.design` (locked)")
    p("declares all three as choices and runs every combination: 8 specifications,")
    p("the world model, both arms, 20 seeds, on the paper's own 26 evaluation")
    p("recordings (24 with a CSV). Every later draw is coupled, so specifications")
    p("share each start and window that exists in both (`results/multiverse/paper/`,")
    p("command in its `COMMAND`; [docs/multiverse.md](multiverse.md) explains the machinery).")
    p("The design was first locked with the paper's numpy draw of the evaluation")
    p("set. Under `duplicates group` that draw runs over a smaller universe and")
    p("kept only 10 of the 24 evaluation recordings with a CSV. The first run")
    p("showed this, so the design was amended to pin the paper's 26 names and")
    p("re-locked before any result was committed; the same amendment removed the")
    p("`generator numpy_legacy` line, which the pinned names made moot. The")
    p("combined report says so too (its lock records the amendment).")
    p("")
    p("| spec | state | tails | duplicates | contaminated, 1 s (m) | disjoint, 1 s (m) | optimism | d 95% CI (m) | rule |")
    p("|---|---|---|---|---:|---:|---:|---|---|")
    p("| paper | ? | ? | ? | 0.262 | 0.299 | 12.1% | [-0.0735, 0.0011] | not met |")
    for sp in mv["specs"]:
        st, tl, du = sp["values"]
        name = sp["id"] + (" (primary)" if sp["primary"] else "")
        p(f"| {name} | {st} | {tl} | {du} | {sp['mean_treated']:.3f} | {sp['mean_reference']:.3f} | {sp['optimism_pct']:.1f}% | {ci(sp['estimate'])} | {'met' if sp['rule_holds'] else 'not met'} |")
    met = sum(1 for sp in mv["specs"] if sp["rule_holds"])
    p("")
    p(f"The rule (optimism >= 10% and upper < 0) holds in {met} of {len(mv['specs'])} specifications. The")
    p("preregistered decision is the primary specification's: "
      + ("CONFIRMED." if mv["decision"]["holds"] else "NOT CONFIRMED."))
    p("")
    p("**Which specification reproduces the paper's Table 2.** The yardstick for")
    p("\"within noise\" is the draw replication below: the primary specification")
    p(f"run three times with the evaluation set fixed gives primary optimism from {min(opts):.1f}% to {max(opts):.1f}%")
    p(f"(a spread of {spread:.1f} points) and d from {min(ds):.4f} to {max(ds):.4f} m. Against")
    p("the paper's world-model levels at 0.5, 1 and 2 s (mean absolute relative")
    p("difference of its six arm means) and its primary optimism of 12.1%:")
    p("")
    p("| spec | choices | mean abs. relative difference of the six levels | optimism minus the paper's (points) | within the draw spread | same decision as the paper |")
    p("|---|---|---:|---:|---|---|")
    # Per specification: (spec, mean abs. relative difference of the six
    # world-model arm means from the paper's, optimism within the spread).
    rows_ = []
    for sp in mv["specs"]:
        res = load(f"multiverse/paper/spec-{sp['id']}/report/results.json")
        rel = []
        for h in (0.5, 1.0, 2.0):
            u = unit(res, "world", h)
            pc, pd_, _, _ = PAPER_T2[("world", h)]
            rel += [abs(u["mean_treated"] - pc) / pc, abs(u["mean_reference"] - pd_) / pd_]
        rows_.append((sp, sum(rel) / len(rel), abs(sp["optimism_pct"] - 12.1) <= spread))
    for sp, rel, within in rows_:
        gap = sp["optimism_pct"] - 12.1
        p(f"| {sp['id']} | {', '.join(sp['values'])} | {100*rel:.1f}% | {gap:+.1f} | {'yes' if within else 'no'} | {'yes' if not sp['rule_holds'] else 'no'} |")
    both = [r[0]["id"] for r in rows_ if r[2] and not r[0]["rule_holds"]]
    size_only = [r[0]["id"] for r in rows_ if r[2] and r[0]["rule_holds"]]
    closest = min(rows_, key=lambda r: r[1])[0]
    eff = {e["setting"]: e["estimate"] for e in mv["choice_effects"]}
    p("")
    p(f"Within the draw spread of the paper's optimism and with its decision (NOT CONFIRMED): {', '.join(both) or 'none'}.")
    p(f"Within the spread but confirmed, where the paper is not: {', '.join(size_only) or 'none'}. Closest on the six")
    p(f"arm levels: {closest['id']} ({', '.join(closest['values'])}), whose optimism is {closest['optimism_pct']:.1f}%.")
    p(f"The spread is measured on s1 itself: its draws reach {max(opts):.1f}%, so a \"no\" above means that")
    p("this specification's own draw is outside the spread, not that another draw of it could not reach")
    p("the paper's optimism.")
    p(f"Why they differ: grouping the duplicate files moves d by {eff['duplicates']['mean']:.4f} m {ci(eff['duplicates'])}.")
    p("Under `duplicates keep` the disjoint arm trains on byte-identical copies of")
    p("evaluation flights, so both arms see them. The onboard columns move d by")
    p(f"{eff['state']['mean']:.4f} m {ci(eff['state'])}, and truncating the tails by {eff['tails']['mean']:.4f} m {ci(eff['tails'])}.")
    p(f"The paper's whole d is -0.037 m. In this single draw two of the three open")
    p(f"choices each move d by a large part of that, and the unpublished draws alone")
    p(f"move the primary optimism over {spread:.1f} points.")
    ps_eff = {e["setting"]: e["estimate"] for e in load("multiverse/paper_per_seed/report/multiverse.json")["choice_effects"]}
    p(f"With the draws included (the multiverse with per-seed draws) only the")
    p(f"duplicates choice keeps its effect ({ps_eff['duplicates']['mean']:.4f} m {ci(ps_eff['duplicates'])}); the state")
    p(f"choice's single-draw effect does not hold up ({ps_eff['state']['mean']:+.4f} m {ci(ps_eff['state'])}), nor")
    p(f"does the tails choice's ({ps_eff['tails']['mean']:+.4f} m {ci(ps_eff['tails'])}).")
    p("")
    p("No specification reproduces the paper's result exactly, and none")
    p("can. The paper's multisine evaluation recording is missing from this")
    p("snapshot, and the paper's starts and windows are unpublished (below).")
    p("The table shows which readings land where. The paper reports")
    p("optimism of 12.1% with an interval that crosses zero. Specifications")
    p("whose optimism is within the draw spread of 12.1% are consistent with")
    p("the paper's size of effect; the decision column says whether they also")
    p("reach the paper's NOT CONFIRMED, that is, whether the upper bound stays")
    p("at or above zero or the optimism below 10%.")
    p("")
    p("**Each choice's paired effect on d** (per recording and seed, the mean over the")
    p("specifications taking the alternative minus the mean over those taking the")
    p("primary's; crossed MoM interval with t(19); negative: contamination looks")
    p("more helpful):")
    p("")
    p("| choice | primary's | alternative | effect on d (m) | 95% CI (m) |")
    p("|---|---|---|---:|---|")
    for e in mv["choice_effects"]:
        x = e["estimate"]
        p(f"| {e['setting']} | {e['reference']} | {e['alternative']} | {x['mean']:.4f} | {ci(x)} |")
    j = mv.get("joint")
    if j:
        lo, hi = j["share_negative"][1], j["share_negative"][2]
        p("")
        p(f"Jointly (one pigeonhole resample of recordings and seeds shared by all eight")
        p(f"specifications, {j['replicates']} replicates), d < 0 in {100*j['share_negative'][0]:.0f}% of specifications")
        p(f"(bootstrap 95% interval {100*lo:.0f}% to {100*hi:.0f}%); simultaneous bands are d +/- {j['critical']:.2f} bootstrap SE")
        p("(`results/multiverse/paper/report/specs.csv`, figure `spec_curve.svg`).")
    p("")
    p("### How far the unpublished draws move it")
    p("")
    p("`designs/multiverse/paper_draws.design`: the primary specification with")
    p("`factor draw = 1..3`. The evaluation recordings are fixed, and each draw")
    p("redraws the starts, the validation recordings and windows, and the fit and")
    p("contamination windows. Draw 1 is the multiverse's s1, cell for cell.")
    p("")
    p("| draw | d (m) | 95% CI (m) | optimism | rule |")
    p("|---:|---:|---|---:|---|")
    for k, m, lo, hi, o, held in draws["per_draw"]:
        p(f"| {k} | {m:.4f} | [{lo:.4f}, {hi:.4f}] | {o:.1f}% | {'met' if held else 'not met'} |")
    if draws.get("components"):
        parts = ", ".join(f"{n} {100*sh:.1f}%" for n, v, sh in draws["components"])
        pl = draws["pooled"]
        p("")
        p(f"REML over recording x seed x draw: pooled d = {pl['mean']:.4f} m, Kenward-Roger SE {pl['se']:.4f} m")
        p(f"with {pl['df']:.1f} df, 95% CI [{pl['lower']:.4f}, {pl['upper']:.4f}] m, optimism {pl['optimism_pct']:.1f}%; shares of the pooled")
        p(f"mean's variance: {parts} (checked against lme4 and pbkrtest by `scripts/reference/multiverse_check.R`).")
        p("The draw variance rests on three draws, so it is poorly determined; the per-seed")
        p("draws above give it 20 levels.")
    p("")
    p("### A stricter holdout")
    p("")
    p("`designs/multiverse/holdout_trajectory.design`: the audited design")
    p("evaluated on its 12 trefoil recordings, with a third arm that holds out")
    p("the whole trefoil family (`hold out trajectory`). One trained grid, three")
    p("contrasts (an analysis-only choice):")
    p("")
    p("| contrast | treated (m) | reference (m) | optimism | d 95% CI (m) | rule |")
    p("|---|---:|---:|---:|---|---|")
    for sp in ho["specs"]:
        p(f"| {sp['values'][0]} | {sp['mean_treated']:.3f} | {sp['mean_reference']:.3f} | {sp['optimism_pct']:.1f}% | {ci(sp['estimate'])} | {'met' if sp['rule_holds'] else 'not met'} |")
    p("")
    p("`disjoint - family` measures how much better the recording-disjoint arm")
    p("(the audited design's: duplicates grouped, plausibility rule, tails truncated)")
    p("does than a family-level holdout on the same evaluation flights. The")
    p("validation recordings hold no trefoil flight, so no arm's early stopping")
    p("sees the family. A negative d means that other trefoil flights in the fit set help the model")
    p("on the held-out ones. Part of that is information a recording-level split")
    p("lets through, and part is plain coverage: the family arm never trains on")
    p("the trefoil manoeuvre. The paper defines its target as a new recording from")
    p("a related distribution, not an unseen manoeuvre, so this contrast measures")
    p("how much its split relies on that definition. It does not measure a leak")
    p("the paper denies.")
    p("")
    p("The sections below are the earlier single-specification comparison (the")
    p("paper design as first locked, with numpy's draws) and the hygiene ladder.")
    p("They stay as what they are. Read them with the table above: which of")
    p("them agrees with the paper depends on the open choices.")


out = []
p = out.append
p("# The paper's experiment, run by crossaudit, beside the paper")
p("")
p("<!-- generated by `python3 scripts/paper_comparison.py > docs/paper_comparison.md`; every number below is read from a committed file under results/ -->")
p("")
p("The design is `designs/nanobench_paper.design` (locked; every choice the")
p("paper leaves open is commented there). Its run, 2 models x 2 arms x 20")
p("seeds, is `results/nanobench_paper/` (command in its `COMMAND`); the paper's")
p("numbers are those transcribed in `../shared/paper/NUMBERS.md`.")
p("")
settled_section(p)
draws_section(p)
multiverse_section(p)
p("")
p("## Which state columns")
p("")
p("The paper names Vicon position and says nothing of velocity and attitude.")
p("Both column presets were run on the world model (2 arms x 20 seeds, the")
p("paper's evaluation set) before the paper design was run; the declared rule")
p("(`scripts/paper_columns.py`) picks the one closer to the paper's Table 2:")
p("")
p(open(os.path.join(R, "paper_columns/decision.md")).read().strip())
p("")
# Which of the six levels each preset is closer on (the locked designs'
# comment says motion-capture was closer on every one).
levels = {}
for line in open(os.path.join(R, "paper_columns/decision.md")):
    cells_ = [c.strip() for c in line.strip().strip("|").split("|")]
    if len(cells_) == 6 and cells_[0] in ("onboard", "motion_capture"):
        levels[(cells_[0], cells_[1])] = [float(x) for x in cells_[2:]]
exceptions = []
for (preset, h), (c, d, pc, pd_) in levels.items():
    if preset != "motion_capture":
        continue
    oc, od, _, _ = levels[("onboard", h)]
    if abs(oc - pc) < abs(c - pc):
        exceptions.append(f"the contaminated arm at {h} (onboard {oc:.3f} m, motion capture {c:.3f} m, paper {pc:.3f} m)")
    if abs(od - pd_) < abs(d - pd_):
        exceptions.append(f"the disjoint arm at {h} (onboard {od:.3f} m, motion capture {d:.3f} m, paper {pd_:.3f} m)")
if exceptions:
    st = {e["setting"]: e["estimate"] for e in load("multiverse/paper/report/multiverse.json")["choice_effects"]}["state"]
    ps_st = {e["setting"]: e["estimate"] for e in load("multiverse/paper_per_seed/report/multiverse.json")["choice_effects"]}["state"]
    p(f"Correction: the locked designs' comment says the motion-capture columns came closer \"on every level\"; they did on {6 - len(exceptions)} of the six, not on {'; '.join(exceptions)}. The locked designs keep their words; this is the correction. In the single-draw multiverse above the column choice's paired effect on d is {st['mean']:.4f} m {ci(st)}, against the paper's whole d of -0.037 m; with per-seed draws it is {ps_st['mean']:+.4f} m {ci(ps_st)}, so that effect belongs to one draw.")
    p("")
p("## Table 2")
p("")
p("Failure-aware position RMSE; d = contaminated - disjoint, crossed MoM")
p("interval with t(19).")
p("")
p("| model | horizon | contaminated (paper / ours) | disjoint (paper / ours) | optimism (paper / ours) | d 95% CI paper | d 95% CI ours |")
p("|---|---|---|---|---|---|---|")
for (m, h), (pc, pd, po, pci) in PAPER_T2.items():
    u = unit(paper, m, h)
    p(f"| {m} | {h:g} s | {pc:.3f} / {u['mean_treated']:.3f} | {pd:.3f} / {u['mean_reference']:.3f} | {po:.1f}% / {u['optimism_pct']:.1f}% | {pci} | {ci(u['estimate'])} |")
prim = unit(paper, "world", 1.0)
dec = paper["decision"]
p("")
p(f"Primary (world, 1 s): the paper has optimism 12.1% (threshold met) and an interval crossing zero, NOT confirmed; ours has optimism {prim['optimism_pct']:.1f}% and upper bound {prim['estimate']['upper']:.4f} m: {'CONFIRMED' if dec['holds'] else 'NOT confirmed'} ({'; '.join(c['condition'] + (' met' if c['holds'] else ' not met') for c in dec['conditions'])}).")
p("")
p("## Every other published number")
p("")
p("| quantity | paper | ours |")
p("|---|---|---|")
i1, i2 = inter(paper, 1.0), inter(paper, 2.0)
def inter_text(i):
    if i is None:
        return "n/a"
    e = i["estimate"]
    return f"{e['mean']:.4f} {ci(e)} m"
p(f"| interaction world - relative, 1 s | 0.0145 [-0.0035, 0.0324] m | {inter_text(i1)} |")
p(f"| interaction world - relative, 2 s | 0.0404 [-0.0010, 0.0817] m | {inter_text(i2)} |")
g = prim["grouped"]
p(f"| grouped (trajectory x speed) primary interval | [-0.1396, 0.0170] m | {ci(g['estimate'])} m ({len(g['groups'])} groups) |")
e = prim["estimate"]
p(f"| variance shares of SE^2, primary (recording / seed / residual) | 95.9 / 1.1 / 3.0 % | {100*e['share_recording']:.1f} / {100*e['share_seed']:.1f} / {100*e['share_residual']:.1f} % |")
ps = [s["optimism_pct"] for s in prim["per_seed_optimism"]]
p(f"| per-seed optimism range, primary | 0.4 to 18.7 % | {min(ps):.1f} to {max(ps):.1f} % |")
loo = {l["factor"]: l for l in prim["leave_one_out"]}
p(f"| leave-one-seed-out optimism range | 11.7 to 12.7 % | {loo['seed']['optimism_min']:.1f} to {loo['seed']['optimism_max']:.1f} % |")
p(f"| leave-one-recording-out optimism range | 8.0 to 15.0 % | {loo['recording']['optimism_min']:.1f} to {loo['recording']['optimism_max']:.1f} % |")
c = prim["conditional"]
p(f"| conditional-on-finite RMSE, 1 s, contaminated / disjoint | 0.253 / 0.295 m | {c['mean_conditional_treated']:.3f} / {c['mean_conditional_reference']:.3f} m |")
p(f"| conditional difference interval | [-0.0728, -0.0104] m | {ci(c['difference'])} m |")
p(f"| mean divergence rate, contaminated / disjoint (1 s) | 0.2 % / 0.1 % | {100*c['divergent_treated']/c['starts_treated']:.2f} % / {100*c['divergent_reference']/c['starts_reference']:.2f} % |")
pt = {t["trajectory"]: t for t in prim["per_trajectory"]}
def traj(name):
    t = pt.get(name)
    return "no recording with a CSV" if t is None else f"{t['mean_difference']:+.3f} m ({t['recordings']})"
p(f"| per-trajectory 1 s difference: multisine (1 recording) | -0.376 m | {traj('multisine_sysid')} |")
p(f"| per-trajectory 1 s difference: star (1) | +0.022 m | {traj('star')} |")
p(f"| per-trajectory 1 s difference: trefoil (12) | +0.002 m | {traj('trefoil')} |")
a = treat["arms"][0]
p(f"| treatment audit: contaminating windows inside an evaluated 2 s segment | 3,620 of 4,000 (90.5%) | {a['inside_evaluated_segment']:,} of {a['contaminating_windows']:,} ({100*a['share_inside']:.1f}%) |")
p(f"| treatment audit: median distance to the nearest registered start | 26 samples | {a['median_distance_samples']:g} samples |")
csvs = [r for r in rows if r["status"] != "missing"]
inc = [r for r in rows if r["status"] == "included"]
miss = [r for r in rows if r["status"] == "missing"]
p(f"| data | 107 CSVs; 106 pass the inclusion rule (B7_oval_slow_rep1 has no active row) | {len(csvs)} CSVs and {len(miss)} names with metadata only; {len(inc)} CSVs pass (B7_oval_slow_rep1 fails as in the paper) |")
p(f"| evaluation recordings | 26 | 26 drawn, {26 - sum(1 for r in gone if r[0] == 'evaluation')} with a CSV |")
p(f"| run time | about 18 min on one NVIDIA T4 (PyTorch 2.7.1) | {wall('nanobench_paper/time.txt')} on 2 CPU cores |")
p("")
p("## Evaluation composition")
p("")
counts = {}
for t, sp in treat["composition"]["counts"].items():
    for s, n in sp.items():
        counts[(t, s)] = counts.get((t, s), 0) + n
labels = {r["name"]: (r["trajectory"], r["speed"]) for r in rows}
for role, name in gone:
    if role == "evaluation":
        k = labels[name]
        counts[k] = counts.get(k, 0) + 1
PAPER_COMP = {("circle", "slow"): 3, ("figure_eight", "slow"): 2, ("helix", "slow"): 3, ("helix", "medium"): 1,
              ("multisine_sysid", "unknown"): 1, ("oval", "slow"): 2, ("random_waypoints", "slow"): 1,
              ("star", "medium"): 1, ("trefoil", "slow"): 7, ("trefoil", "medium"): 5}
p("| trajectory | slow (paper / ours) | medium (paper / ours) | unknown (paper / ours) |")
p("|---|---|---|---|")
for t in sorted({k[0] for k in PAPER_COMP} | {k[0] for k in counts}):
    cells = [f"{PAPER_COMP.get((t, s), 0)} / {counts.get((t, s), 0)}" for s in ("slow", "medium", "unknown")]
    p(f"| {t} | " + " | ".join(cells) + " |")
p("")
p("Ours counts the 26 names the split drew, the two without a CSV ("
  + ", ".join(n for r, n in gone if r == "evaluation") + ") by their metadata labels;"
  " `tests/split_paper.rs` checks that the table is equal to the paper's.")
p("")
# Evidence for the differences, from the committed manifests of the run.
tails = {l.split()[0]: int(l.split()[1]) for l in open("tests/data/onboard_tails.txt")}
def tail_windows(path):
    n = t = 0
    for r in csv.DictReader(open(os.path.join(R, path))):
        n += 1
        if r["recording"] in tails and int(r["sample_index"]) + 1 >= tails[r["recording"]]:
            t += 1
    return t, n
ct, cn = tail_windows("nanobench_paper/manifests/contaminating_contaminated.csv")
dt, dn = tail_windows("nanobench_paper/manifests/fit_disjoint.csv")
inv = load("nanobench_paper/audit/invariants.json")
def detail(i):
    return next(x["detail"] for x in inv["invariants"] if x["id"] == i)
copies_fit = int(re.search(r"(\d+) from duplicates of them", detail(5)).group(1))
copies_val = int(re.search(r"(\d+) from duplicates of them", detail(3)).group(1))
e_tails = sorted(n for n in tails if any(n == r["recording"] for r in csv.DictReader(open(os.path.join(R, "nanobench_paper/manifests/evaluation_recordings.csv")))))
paper_d = 0.262 - 0.299
p("## Why the numbers differ")
p("")
p(f"1. **The paper's multisine recording is not in this snapshot.** Its 1 s")
p(f"   difference (-0.376 m) over 26 recordings contributes {-0.376 / 26:.4f} m of the")
p(f"   paper's mean difference of {paper_d:.3f} m ({100 * (-0.376 / 26) / paper_d:.0f}%). Without it the paper's")
p(f"   own mean difference would be {(paper_d * 26 + 0.376) / 25:.4f} m, an optimism of about")
p(f"   {100 * -((paper_d * 26 + 0.376) / 25) / 0.299:.0f}%: that is what its leave-one-recording-out minimum of 8.0%")
p("   shows, and it is below the 10% threshold. The random-waypoint recording")
p("   is missing too; 24 of the 26 evaluation recordings remain.")
p(f"2. **The disjoint arm is not disjoint under `duplicates keep`.** Byte-identical")
p(f"   copies of evaluation recordings supply {copies_fit:,} of the disjoint arm's {dn:,} fit")
p(f"   windows ({100 * copies_fit / dn:.1f}%) and {copies_val} of the 2,000 validation windows")
p("   (invariants 3 and 5 warn; `audit/invariants.json`). Both arms therefore")
p("   see the evaluation flights, and the contrast measures little. The")
dup_files = [r for r in rows if r["duplicate_group"]]
p(f"   paper's 107 files include these 100 (`../shared/paper/NUMBERS.md`), so")
p(f"   the same {len(dup_files)} copies in {len({r['duplicate_group'] for r in dup_files})} identity groups were in its data and its")
p("   disjoint arm was exposed in the same way, to a degree its unpublished")
p("   window draws decide.")
p(f"3. **Extrapolated onboard tails.** {', '.join(e_tails)} are evaluation")
p(f"   recordings whose onboard streams end early; the rows after carry motor")
p(f"   commands far beyond full scale (clipped to 1) and setpoints up to 13 m.")
p(f"   {ct} of the {cn:,} contaminating windows ({100 * ct / cn:.1f}%) and {dt} of the disjoint arm's")
p(f"   {dn:,} ({100 * dt / dn:.1f}%) come from such rows. With motion-capture state the")
p("   rollouts stay finite (divergence 0.02%), but the contaminated arm trains")
p("   on windows whose inputs contradict their dynamics.")
p("4. **Different window draws.** The paper publishes its evaluation")
p("   composition but not its validation, fit or contamination windows, nor")
p("   its training code; crossaudit draws them with numpy's legacy generator")
p("   in a declared order (`src/split/mod.rs`), so they are a draw of the same")
p("   protocol, not the paper's windows. The construction differs slightly")
p("   too: the paper draws 20,000 windows from the non-evaluation recordings")
p("   and discards the 2,000 that fall in its validation recordings beyond the")
p("   2,000 it validates on; crossaudit draws the 16,000 fit windows from the")
p("   recordings outside evaluation and validation directly (same counts,")
p("   same recording-level separation). Its validation set here has 7")
p("   recordings with a CSV (the eighth drawn, A1b_multisine_sysid_rep2, has none).")
p("")
p("## Data hygiene")
p("")
p("The paper's evaluation and validation sets pinned, one hygiene step at a")
p("time (world model, primary endpoint at 1 s). Pinning keeps the recordings,")
p("not the draw: each step redraws its starts and windows with numpy's")
p("generator over its own data, so few starts and windows survive from one step")
p("to the next, and each step's change mixes the data effect with a new draw.")
p("The designs' comment \"changes the data, not the draw\" overstates this (the")
p("locked designs keep their words; this is the correction). The multiverse")
p("above separates the two with coupled draws:")
p("")
p("| step | design | I | contaminated (m) | disjoint (m) | optimism | d 95% CI | divergent at 1 s (contam. / disjoint) | decision |")
p("|---|---|---:|---:|---:|---:|---|---|---|")
steps = [
    ("paper design", "nanobench_paper"),
    ("+ duplicates grouped", "paper_hygiene/world_grouped"),
    ("+ plausibility (motors pooled)", "paper_hygiene/world_grouped_plausible"),
    ("+ tails truncated (the audited design)", "nanobench_paper_audited"),
]
for label, path in steps:
    design = f"designs/{path}.design"
    f = os.path.join(R, path, "report/results.json")
    if not os.path.exists(f):
        p(f"| {label} | `{design}` | not run | | | | | | |")
        continue
    r = load(path + "/report/results.json")
    u = unit(r, "world", 1.0)
    c = u["conditional"]
    p(f"| {label} | `{design}` | {u['estimate']['rows']} | {u['mean_treated']:.3f} | {u['mean_reference']:.3f} | {u['optimism_pct']:.1f}% | {ci(u['estimate'])} | {100*c['divergent_treated']/c['starts_treated']:.2f}% / {100*c['divergent_reference']/c['starts_reference']:.2f}% | {'confirmed' if r['decision']['holds'] else 'not confirmed'} |")
hy = {path: load(path + "/report/results.json") for _, path in steps if os.path.exists(os.path.join(R, path, "report/results.json"))}
if len(hy) == 4:
    w = {k: unit(v, "world", 1.0) for k, v in hy.items()}
    g0, g1, g2, g3 = (w[p_] for _, p_ in steps)
    p("")
    p("What each step changes:")
    p("")
    p(f"- Grouping identical files moves the evaluation recordings' copies out of")
    p(f"  the disjoint fit and validation sets: the disjoint arm loses its view of")
    p(f"  the evaluation flights and its error rises from {g0['mean_reference']:.3f} to {g1['mean_reference']:.3f} m; optimism")
    p(f"  goes from {g0['optimism_pct']:.1f}% to {g1['optimism_pct']:.1f}%, but the interval still reaches {g1['estimate']['upper']:+.4f} m.")
    p(f"- The plausibility rule removes every file with an extrapolated onboard")
    p(f"  tail but B6_linear_ramp_rep4, four of them evaluation recordings, leaving I = {g2['estimate']['rows']}:")
    p(f"  optimism {g2['optimism_pct']:.1f}%, interval {ci(g2['estimate'])} m, confirmed.")
    p(f"- Truncating the tails instead keeps each of those flights up to where its")
    p(f"  onboard streams end (I = {g3['estimate']['rows']} again): optimism {g3['optimism_pct']:.1f}%, interval {ci(g3['estimate'])} m,")
    p(f"  confirmed. This is `designs/nanobench_paper_audited.design`, run for both")
    p("  models. It is a different experiment from the paper's, not a reproduction")
    p("  of it: other data (duplicates grouped, the plausibility rule, tails")
    p("  truncated) and every draw after the evaluation set different; its")
    p("  world - relative interaction even has the opposite sign. Its numbers beside")
    p("  the paper's:")
    p("")
    aud = hy["nanobench_paper_audited"]
    p("| model | horizon | contaminated (paper / audited) | disjoint (paper / audited) | optimism (paper / audited) | d 95% CI paper | d 95% CI audited |")
    p("|---|---|---|---|---|---|---|")
    for (m, h), (pc, pd, po, pci) in PAPER_T2.items():
        u = unit(aud, m, h)
        p(f"| {m} | {h:g} s | {pc:.3f} / {u['mean_treated']:.3f} | {pd:.3f} / {u['mean_reference']:.3f} | {po:.1f}% / {u['optimism_pct']:.1f}% | {pci} | {ci(u['estimate'])} |")
    ia = inter(aud, 1.0)
    ua = unit(aud, "world", 1.0)
    p("")
    p(f"Its interaction world - relative at 1 s is {inter_text(ia)} (paper 0.0145 [-0.0035, 0.0324] m); its")
    p(f"SE^2 shares are {100*ua['estimate']['share_recording']:.1f} / {100*ua['estimate']['share_seed']:.1f} / {100*ua['estimate']['share_residual']:.1f} % (recording / seed / residual; paper 95.9 / 1.1 / 3.0 %).")
    p("Each run's `report/report.md` has the rest (conditional RMSE, sensitivities,")
    p("figures).")
print("\n".join(out))
