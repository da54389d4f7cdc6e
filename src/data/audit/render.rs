//! The audit as files and text: recordings.csv, its summary and where it
//! is written.

use super::*;

impl Audit {
    /// recordings.csv: one row per file.
    pub fn to_csv(&self) -> String {
        let mut w = csv::Writer::from_writer(Vec::new());
        let mut header: Vec<String> = [
            "name",
            "file",
            "rows",
            "active_rows",
            "duration_s",
            "trajectory",
            "speed",
            "controller",
            "repetition",
            "start_utc",
            "battery_start_v",
            "battery_end_v",
            "duplicate_group",
            "content_hash",
            "speed_mps",
            "onboard_tail_from_row",
            "onboard_tail_rows",
            "onboard_tail_active_rows",
            "rows_cut",
            "meta_estimator_rows",
            "meta_attitude_rows",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        // Only where a tolerance is declared, so that every other audit
        // keeps its columns.
        if self.quaternion_tolerance.is_some() {
            header.push("quaternion_max_deviation".to_string());
        }
        for (k, r) in self.rules.iter().enumerate() {
            header.push(format!("rule{}: {r}", k + 1));
        }
        header.extend(["status".to_string(), "reason".to_string()]);
        let _ = w.write_record(&header);
        for f in &self.files {
            let opt = |v: Option<f64>| v.map(|x| x.to_string()).unwrap_or_default();
            let mut rec = vec![
                f.name.clone(),
                f.file.clone(),
                f.rows.to_string(),
                f.active_rows.to_string(),
                format!("{:.2}", f.duration_s),
                f.trajectory.clone(),
                f.speed.clone(),
                f.controller.clone(),
                f.repetition.map(|r| r.to_string()).unwrap_or_default(),
                f.start_utc.clone().unwrap_or_default(),
                opt(f.battery_start_v),
                opt(f.battery_end_v),
                f.duplicate_group.clone().unwrap_or_default(),
                f.content_hash.clone(),
                opt(f.speed_mps),
                f.tail.map(|t| (t.start + 1).to_string()).unwrap_or_default(),
                f.tail.map(|t| t.rows.to_string()).unwrap_or_default(),
                f.tail.map(|t| t.active.to_string()).unwrap_or_default(),
                f.rows_cut.to_string(),
                f.onboard_row_counts.0.map(|c| c.to_string()).unwrap_or_default(),
                f.onboard_row_counts.1.map(|c| c.to_string()).unwrap_or_default(),
            ];
            if self.quaternion_tolerance.is_some() {
                rec.push(opt(f.quaternion_deviation));
            }
            for k in 0..self.rules.len() {
                rec.push(match f.verdicts.get(k) {
                    Some(v) => format!("{}: {}", if v.pass { "pass" } else { "fail" }, v.detail),
                    None => "not evaluated".into(),
                });
            }
            rec.push(format!("{:?}", f.status).to_lowercase());
            rec.push(f.reason.clone());
            let _ = w.write_record(&rec);
        }
        String::from_utf8(w.into_inner().unwrap_or_default()).unwrap_or_default()
    }

    /// The printed summary: counts by trajectory x speed, exclusions,
    /// duplicate groups.
    pub fn summary(&self) -> String {
        let mut s = String::new();
        let count = |st: Status| self.files.iter().filter(|f| f.status == st).count();
        let _ = writeln!(
            s,
            "{}: {} log files, {} included, {} excluded, {} listed in metadata but missing",
            self.data_dir,
            self.files.len() - count(Status::Missing),
            count(Status::Included),
            count(Status::Excluded),
            count(Status::Missing)
        );
        for (k, r) in self.rules.iter().enumerate() {
            let failed = self.files.iter().filter(|f| f.verdicts.get(k).is_some_and(|v| !v.pass)).count();
            let _ = writeln!(s, "rule {}: {r}: {failed} file(s) fail", k + 1);
        }
        self.condition_table(&mut s);
        if let Some(tolerance) = self.quaternion_tolerance {
            let largest = self
                .included()
                .filter_map(|f| f.quaternion_deviation.map(|d| (d, f.name.as_str())))
                .max_by(|a, b| a.0.total_cmp(&b.0));
            if let Some((d, name)) = largest {
                let _ = writeln!(
                    s,
                    "\nquaternion lengths (`norm within {tolerance}`): largest deviation from 1 among included recordings {d:.4} ({name}); every row renormalised"
                );
            }
        }
        for n in &self.not_read {
            let _ = writeln!(s, "\nnot read: {n}");
        }
        let noted = self.files.iter().filter(|f| f.reason.contains("note: ")).count();
        if noted > 0 {
            let _ = writeln!(s, "\n{noted} file(s) carry a note in recordings.csv (metadata disagreeing with the file name, unreadable metadata)");
        }
        let excluded: Vec<&FileRow> = self.files.iter().filter(|f| f.status != Status::Included).collect();
        if !excluded.is_empty() {
            let _ = writeln!(s, "\nexcluded or missing:");
            for f in excluded {
                let _ = writeln!(s, "  {}: {}", f.name, f.reason);
            }
        }
        self.tails_section(&mut s);
        if !self.duplicate_groups.is_empty() {
            let _ = writeln!(
                s,
                "\nduplicate groups (identical content; policy `{}`):",
                format!("{:?}", self.duplicates).to_lowercase()
            );
            for (id, names) in &self.duplicate_groups {
                let _ = writeln!(s, "  {id}: {}", names.join(", "));
            }
        }
        s
    }

    /// The summary's table of included recordings by trajectory x speed.
    fn condition_table(&self, s: &mut String) {
        let _ = writeln!(s, "\nincluded recordings by trajectory x speed:");
        let mut table: BTreeMap<(String, String), usize> = BTreeMap::new();
        for f in self.included() {
            *table.entry((f.trajectory.clone(), f.speed.clone())).or_default() += 1;
        }
        let speeds = ["slow", "medium", "fast", "unknown"];
        let _ = writeln!(
            s,
            "  {:<20} {:>6} {:>6} {:>6} {:>8} {:>6}",
            "trajectory", "slow", "medium", "fast", "unknown", "total"
        );
        let mut trajectories: Vec<&String> = table.keys().map(|(t, _)| t).collect();
        trajectories.dedup();
        for t in trajectories {
            let counts: Vec<usize> =
                speeds.iter().map(|sp| table.get(&(t.clone(), sp.to_string())).copied().unwrap_or(0)).collect();
            let _ = writeln!(
                s,
                "  {:<20} {:>6} {:>6} {:>6} {:>8} {:>6}",
                t,
                counts[0],
                counts[1],
                counts[2],
                counts[3],
                counts.iter().sum::<usize>()
            );
        }
    }

    /// The summary's list of extrapolated onboard tails, when any file has one.
    fn tails_section(&self, s: &mut String) {
        let tails: Vec<&FileRow> = self.files.iter().filter(|f| f.tail.is_some()).collect();
        if !tails.is_empty() {
            let policy = format!("{:?}", self.tails).to_lowercase();
            let _ = writeln!(s, "\nextrapolated onboard tails (policy `tails {policy}`):");
            for f in tails {
                let Some(t) = f.tail else { continue };
                let meta = |c: Option<u64>| c.map(|c| c.to_string()).unwrap_or_else(|| "?".into());
                let _ = writeln!(
                    s,
                    "  {}: from row {} of {}, {} rows ({} active); rows cut {}; metadata estimator/attitude rows {}/{}",
                    f.name,
                    t.start + 1,
                    t.start + t.rows,
                    t.rows,
                    t.active,
                    f.rows_cut,
                    meta(f.onboard_row_counts.0),
                    meta(f.onboard_row_counts.1)
                );
            }
        }
    }

    /// Writes recordings.csv (atomically) into `dir`.
    pub fn write(&self, dir: &Path) -> Result<PathBuf, AuditError> {
        crate::io::create_dir_all(dir)?;
        let path = dir.join("recordings.csv");
        crate::io::write_atomic(&path, self.to_csv().as_bytes())?;
        Ok(path)
    }
}
