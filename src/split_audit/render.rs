//! The split audit as Markdown and as a per-recording CSV.

use std::fmt::Write as _;

use super::{Effect, Presence, SplitAudit};

fn role_label(role: &str) -> &str {
    if role.is_empty() {
        "(unlisted)"
    } else {
        role
    }
}

/// A name from input (a role, a recording, a path) as Markdown text.
fn t(s: &str) -> String {
    crate::io::md_text(s)
}

/// A name from input as a Markdown code span.
fn c(s: &str) -> String {
    crate::io::md_code(s)
}

/// Seconds with up to three decimals, trailing zeros dropped.
fn seconds(x: f64) -> String {
    let v = format!("{x:.3}");
    let v = v.trim_end_matches('0').trim_end_matches('.');
    if v == "-0" {
        "0".into()
    } else {
        v.to_string()
    }
}

fn distance(d: f64) -> String {
    if d.is_finite() {
        format!("{d:.3}")
    } else {
        "n/a".into()
    }
}

impl SplitAudit {
    /// split_audit.md: the findings, then the tables behind them.
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# Split audit: {}\n", t(&self.split_file));
        let _ = writeln!(
            s,
            "- split file: {} ({}), sha256 `{}`",
            c(&self.split_file),
            self.format.label(),
            self.split_sha256
        );
        for (k, v) in &self.notes {
            let _ = writeln!(s, "- split file {}: {}", c(k), t(v));
        }
        let _ = writeln!(s, "- data: {}", c(&self.data_dir));
        let _ = writeln!(s, "- rules ({}): {}", t(&self.rules_from), self.rules.join("; "));
        let _ = writeln!(
            s,
            "- identical: the same values in the columns read, whatever format or digits wrote them (XXH3-128 of those values, row by row); shared runs: at least {} consecutive identical rows (XXH3-64 of each row's values) between recordings that are not identical copies",
            self.options.min_run_rows
        );
        let _ = writeln!(s, "\n## Findings\n");
        self.findings(&mut s);
        self.membership(&mut s);
        self.leak_tables(&mut s);
        self.distance_table(&mut s);
        self.composition_tables(&mut s);
        s
    }

    /// The findings, as printed by `crossaudit audit split`: the Markdown's
    /// escapes undone for the terminal.
    pub fn summary(&self) -> String {
        let mut s = String::new();
        self.findings(&mut s);
        format!("{} against {}:\n{}", self.split_file, self.data_dir, crate::io::md_plain(&s))
    }

    fn findings(&self, s: &mut String) {
        let leaking: usize = self.exact.iter().map(|l| l.members.len()).sum();
        let effective = self.exact.iter().filter(|l| l.effective).count();
        let _ = writeln!(
            s,
            "- exact leakage: {} identity group(s) span two or more roles ({} recordings); {} of them still span roles after the rules.",
            self.exact.len(),
            leaking,
            effective
        );
        for p in self.pairs.iter().filter(|p| p.identical > 0) {
            let total = self.roles.iter().find(|r| r.role == p.role).map(|r| r.with_csv).unwrap_or(0);
            let _ = writeln!(
                s,
                "  - {} of {} {} recordings with a CSV have an identical copy in {} ({} with both copies kept).",
                p.identical,
                total,
                c(&p.role),
                c(&p.other),
                p.identical_effective
            );
        }
        for r in &self.roles {
            let _ = writeln!(
                s,
                "- {}: {} declared, {} effective ({} without a CSV, {} unknown, {} dropped by the rules).",
                c(&r.role),
                r.declared,
                r.effective,
                r.metadata_only,
                r.unknown,
                r.dropped
            );
        }
        let dropped: Vec<_> =
            self.recordings.iter().filter(|r| !r.role.is_empty() && r.effect == Effect::Dropped).collect();
        if !dropped.is_empty() {
            let _ = writeln!(s, "- dropped by the rules (a loader applying them silently shrinks the split):");
            for r in dropped {
                let _ = writeln!(s, "  - {} {}: {}", c(&r.role), t(&r.recording), t(&r.reason));
            }
        }
        // A run longer than every recording cannot be found: 0 would say
        // nothing about the split.
        let longest = self.recordings.iter().map(|r| r.rows).max().unwrap_or(0);
        let cannot = if longest < self.options.min_run_rows {
            format!(
                " (none can be found: the longest recording has {longest} rows, fewer than --min-run {}; lower it to look for runs)",
                self.options.min_run_rows
            )
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "- shared runs of identical rows between non-identical recordings across roles: {} pair(s){cannot}.",
            self.shared_runs.len()
        );
        self.distance_findings(s);
        let unlisted = self.recordings.iter().filter(|r| r.role.is_empty()).count();
        let _ = writeln!(s, "- recordings in the data directory that no role lists: {unlisted}.");
    }

    fn membership(&self, s: &mut String) {
        let _ = writeln!(s, "\n## Declared and effective membership\n");
        let _ = writeln!(s, "| role | declared | windows | with CSV | metadata only | unknown | dropped | effective | distinct contents | identical copy in another role | kept, with a kept copy elsewhere |");
        let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
        for r in &self.roles {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                t(&r.role),
                r.declared,
                if self.windowed { r.windows.to_string() } else { "whole".to_string() },
                r.with_csv,
                r.metadata_only,
                r.unknown,
                r.dropped,
                r.effective,
                r.effective_distinct,
                r.with_identical_elsewhere,
                r.effective_with_identical_elsewhere
            );
        }
        let absent: Vec<_> =
            self.recordings.iter().filter(|r| !r.role.is_empty() && r.presence != Presence::Csv).collect();
        if !absent.is_empty() {
            let _ = writeln!(s, "\nDeclared but not there:\n");
            for r in absent {
                let _ = writeln!(s, "- {} {} (line {}): {}", c(&r.role), t(&r.recording), r.line, t(&r.reason));
            }
        }
        let unlisted: Vec<_> = self.recordings.iter().filter(|r| r.role.is_empty()).collect();
        if !unlisted.is_empty() {
            let _ = writeln!(s, "\nIn the data directory but in no role:\n");
            for r in unlisted {
                let _ = writeln!(s, "- {}", t(&r.recording));
            }
        }
    }

    fn leak_tables(&self, s: &mut String) {
        let _ = writeln!(s, "\n## Across roles\n");
        let _ = writeln!(s, "Of the recordings of `role`, how many have, in `other`: an identical copy (CSV present; both kept), a shared run of identical rows, and (kept ones) the same trajectory and speed among its kept recordings.\n");
        let _ = writeln!(s, "| role | other | identical copy | both kept | shared run | same trajectory x speed |");
        let _ = writeln!(s, "|---|---|---:|---:|---:|---:|");
        for p in &self.pairs {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} |",
                t(&p.role),
                t(&p.other),
                p.identical,
                p.identical_effective,
                p.shared_run,
                p.same_condition
            );
        }
        if !self.exact.is_empty() {
            let _ = writeln!(s, "\n### Identity groups spanning roles\n");
            let _ = writeln!(s, "| content (XXH3-128, first 12) | members (role: recording, * = dropped or absent) | spans roles after the rules |");
            let _ = writeln!(s, "|---|---|---|");
            for l in &self.exact {
                let members: Vec<String> = l
                    .members
                    .iter()
                    .map(|(role, name, kept)| format!("{}: {}{}", t(role), t(name), if *kept { "" } else { " \\*" }))
                    .collect();
                let hash = l.content_hash.get(..12).unwrap_or(&l.content_hash);
                let _ = writeln!(s, "| {hash} | {} | {} |", members.join(", "), if l.effective { "yes" } else { "no" });
            }
        }
        if !self.shared_runs.is_empty() {
            let _ = writeln!(s, "\n### Shared runs of identical rows\n");
            let _ = writeln!(s, "| recording | from row | other | from row | rows |");
            let _ = writeln!(s, "|---|---:|---|---:|---:|");
            for r in &self.shared_runs {
                let _ = writeln!(
                    s,
                    "| {}: {} | {} | {}: {} | {} | {} |",
                    t(&r.a.0),
                    t(&r.a.1),
                    r.a.2,
                    t(&r.b.0),
                    t(&r.b.1),
                    r.b.2,
                    r.rows
                );
            }
        }
    }

    fn distance_findings(&self, s: &mut String) {
        let gap = self.options.gap_s;
        if !self.windowed {
            let shared: std::collections::BTreeSet<(&str, &str)> =
                self.windows.iter().map(|w| (w.role.as_str(), w.recording.as_str())).collect();
            let _ = writeln!(
                s,
                "- distance in time: the split assigns whole recordings, so roles meet only through identical copies, which overlap entirely: {} kept recording(s) have a kept copy in another role. A per-window split (`start_s`, `end_s`) is measured window by window.",
                shared.len()
            );
            return;
        }
        for d in &self.distances {
            let median = d.quantiles_s.map(|q| format!("; median distance {} s", seconds(q[2]))).unwrap_or_default();
            let _ = writeln!(
                s,
                "- distance in time, {} against {}: {} of {} windows share a recording with one of {}; {} overlap one (rows in both roles); {} lie within the {} s gap{median}.",
                c(&d.role),
                c(&d.other),
                d.in_shared_recording,
                d.windows,
                c(&d.other),
                d.overlapping,
                d.within_gap,
                seconds(gap),
            );
        }
        for r in self.roles.iter().filter(|r| r.windows_past_end > 0) {
            let _ = writeln!(
                s,
                "- {} {} window(s) end after their recording's last timestamp: they name time the log does not hold (split_windows.csv, `past_end`).",
                r.windows_past_end,
                c(&r.role)
            );
        }
    }

    fn distance_table(&self, s: &mut String) {
        let _ = writeln!(s, "\n## Distance in time between roles\n");
        let _ = writeln!(
            s,
            "For each window of `role`, the nearest window of `other` in the same recording or an identical copy of it: `max(0, b0 - a1, a0 - b1)` seconds between `[a0, a1)` and `[b0, b1)`, 0 where they touch; they overlap where they share time the log holds (before its last timestamp and half a sample interval). A whole-recording entry is the window from its first to its last timestamp. The gap is {} s (`--gap`): a window closer than that to one of `other` is within it. Quantiles are R's `quantile` type 7, over the windows in a shared recording; each window's nearest is in split_windows.csv.\n",
            seconds(self.options.gap_s)
        );
        let _ = writeln!(
            s,
            "| role | other | windows | in a shared recording | overlapping | within gap | min s | q1 s | median s | q3 s | max s |"
        );
        let _ = writeln!(s, "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
        for d in &self.distances {
            let q = match d.quantiles_s {
                Some(q) => q.map(seconds).join(" | "),
                None => ["n/a"; 5].join(" | "),
            };
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {q} |",
                t(&d.role),
                t(&d.other),
                d.windows,
                d.in_shared_recording,
                d.overlapping,
                d.within_gap
            );
        }
    }

    /// split_windows.csv: each window's nearest window in each other role
    /// that shares its recording (or a byte-identical copy).
    pub fn windows_csv(&self) -> String {
        let mut w = csv::Writer::from_writer(Vec::new());
        let _ = w.write_record([
            "role",
            "recording",
            "start_s",
            "end_s",
            "line",
            "other",
            "nearest_recording",
            "nearest_start_s",
            "nearest_end_s",
            "nearest_line",
            "distance_s",
            "overlaps",
            "within_gap",
            "past_end",
        ]);
        for d in &self.windows {
            let (rec, win, line) = &d.nearest;
            let _ = w.write_record(spreadsheet_cells([
                d.role.clone(),
                d.recording.clone(),
                d.window.start_s.to_string(),
                d.window.end_s.to_string(),
                d.line.to_string(),
                d.other.clone(),
                rec.clone(),
                win.start_s.to_string(),
                win.end_s.to_string(),
                line.to_string(),
                d.distance_s.to_string(),
                d.overlaps.to_string(),
                (d.distance_s < self.options.gap_s).to_string(),
                d.past_end.to_string(),
            ]));
        }
        String::from_utf8(w.into_inner().unwrap_or_default()).unwrap_or_default()
    }

    fn composition_tables(&self, s: &mut String) {
        let c = &self.composition;
        let _ = writeln!(s, "\n## Composition of the kept recordings (trajectory x speed)\n");
        let roles: Vec<String> = c.counts.iter().map(|(r, _)| t(r)).collect();
        let _ = writeln!(s, "| trajectory | speed | {} |", roles.join(" | "));
        let _ = writeln!(s, "|---|---|{}", "---:|".repeat(roles.len()));
        for (k, (tr, sp)) in c.cells.iter().enumerate() {
            let counts: Vec<String> = c.counts.iter().map(|(_, v)| v[k].to_string()).collect();
            let _ = writeln!(s, "| {} | {} | {} |", t(tr), t(sp), counts.join(" | "));
        }
        let totals: Vec<String> = c.counts.iter().map(|(_, v)| v.iter().sum::<usize>().to_string()).collect();
        let _ = writeln!(s, "| total | | {} |", totals.join(" | "));
        let _ =
            writeln!(s, "\nTotal-variation distance of the cell shares (0 = the same mix, 1 = no cell in common):\n");
        for (role, d) in &c.distance_from_rest {
            let _ = writeln!(s, "- {} against all other roles together: {}", self::c(role), distance(*d));
        }
        for (a, b, d) in &c.pairwise {
            let _ = writeln!(s, "- {} against {}: {}", self::c(a), self::c(b), distance(*d));
        }
    }

    /// split_recordings.csv: one row per declared entry, then one per
    /// recording no role lists.
    pub fn to_csv(&self) -> String {
        let mut w = csv::Writer::from_writer(Vec::new());
        let _ = w.write_record([
            "recording",
            "role",
            "listed_as",
            "line",
            "column",
            "presence",
            "effect",
            "reason",
            "trajectory",
            "speed",
            "rows",
            "active_rows",
            "content_hash",
            "identical_in_other_roles",
            "longest_shared_run_rows",
            "longest_shared_run_with",
            "same_condition_in_other_roles",
        ]);
        for r in &self.recordings {
            let lower = |v: &dyn std::fmt::Debug| format!("{v:?}").to_lowercase();
            let presence = match r.presence {
                Presence::MetadataOnly => "metadata_only".to_string(),
                p => lower(&p),
            };
            let (run, with) = match &r.longest_shared_run {
                Some((n, who)) => (n.to_string(), who.clone()),
                None => (String::new(), String::new()),
            };
            let _ = w.write_record(spreadsheet_cells([
                r.recording.clone(),
                role_label(&r.role).to_string(),
                r.listed_as.clone(),
                r.line.to_string(),
                r.column.to_string(),
                presence,
                lower(&r.effect),
                r.reason.clone(),
                r.trajectory.clone(),
                r.speed.clone(),
                r.rows.to_string(),
                r.active_rows.to_string(),
                r.content_hash.clone(),
                r.identical_in_other_roles.join(" "),
                run,
                with,
                r.same_condition_in_other_roles.to_string(),
            ]));
        }
        String::from_utf8(w.into_inner().unwrap_or_default()).unwrap_or_default()
    }
}

/// A row of a CSV that people open in a spreadsheet: every cell through
/// [`crate::io::spreadsheet_text`] (role names and listed entries come from
/// the split file as written; numbers pass unchanged).
fn spreadsheet_cells<const N: usize>(row: [String; N]) -> [String; N] {
    row.map(|c| crate::io::spreadsheet_text(&c).into_owned())
}
