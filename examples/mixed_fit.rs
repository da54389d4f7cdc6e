//! Fits y ~ 1 + (1 | a) + (1 | b) [+ ...] by REML with `stats::mixed` on a
//! CSV whose first column is the response and whose other columns are the
//! random factors, `reps` times, and prints the estimates and the median
//! wall time of one fit (used by benches/mixed/compare.sh beside lme4).
//! `--estimates` fits as `lme4::lmer` does (estimates, SEs, criterion; no
//! df), `--satterthwaite` adds the Satterthwaite df only, `--columns a,b`
//! uses only those factor columns.
//!
//!     cargo run --release --example mixed_fit -- FILE.csv [reps] [--estimates|--satterthwaite] [--columns a,b]

use std::collections::HashMap;

use crossaudit::stats::mixed::{fit_with, Criterion, Inference, MixedData};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().collect();
    let mut inference = Inference::Full;
    for (flag, kind) in [("--estimates", Inference::Estimates), ("--satterthwaite", Inference::Satterthwaite)] {
        if let Some(i) = args.iter().position(|a| a == flag) {
            args.remove(i);
            inference = kind;
        }
    }
    let columns: Option<Vec<String>> = match args.iter().position(|a| a == "--columns") {
        Some(i) => {
            let c = args.get(i + 1).ok_or("--columns needs a list")?.split(',').map(String::from).collect();
            args.drain(i..i + 2);
            Some(c)
        }
        None => None,
    };
    let path = args.get(1).ok_or("usage: mixed_fit FILE.csv [reps] [--estimates|--satterthwaite] [--columns a,b]")?;
    let reps: usize = args.get(2).map(|r| r.parse()).transpose()?.unwrap_or(50);
    let text = std::fs::read_to_string(path)?;
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().ok_or("empty file")?.split(',').map(String::from).collect();
    let mut y = Vec::new();
    let mut codes: Vec<Vec<usize>> = vec![Vec::new(); header.len() - 1];
    let mut maps: Vec<HashMap<String, usize>> = vec![HashMap::new(); header.len() - 1];
    for (k, line) in lines.enumerate() {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != header.len() {
            return Err(format!("{path}: line {}: {} fields, the header has {}", k + 2, f.len(), header.len()).into());
        }
        y.push(f[0].parse::<f64>().map_err(|e| format!("{path}: line {}: {e}", k + 2))?);
        for j in 1..f.len() {
            let next = maps[j - 1].len();
            codes[j - 1].push(*maps[j - 1].entry(f[j].to_string()).or_insert(next));
        }
    }
    let mut factors: Vec<(String, Vec<usize>)> = header[1..].iter().cloned().zip(codes).collect();
    if let Some(c) = &columns {
        if let Some(bad) = c.iter().find(|c| !header[1..].contains(c)) {
            return Err(format!("{path}: no column {bad}").into());
        }
        factors.retain(|(name, _)| c.contains(name));
    }
    let data = MixedData::new(y, factors)?;
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..reps {
        let t = std::time::Instant::now();
        last = Some(fit_with(&data, Criterion::Reml, inference)?);
        times.push(t.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    let f = last.ok_or("reps must be at least 1")?;
    println!("crossaudit rows {} intercept {:.10} se {:.8} residual {:.8e}", f.n, f.intercept, f.se, f.residual);
    println!("crossaudit theta {}", f.theta.iter().map(|t| format!("{t:.10}")).collect::<Vec<_>>().join(" "));
    println!("crossaudit criterion {:.10} evaluations {}", f.deviance, f.evaluations);
    if let Some(s) = f.df_satterthwaite {
        println!("crossaudit satterthwaite_df {s:.10}");
    }
    if let Some(kr) = f.kenward_roger {
        println!("crossaudit kr_df {:.10} kr_se {:.10}", kr.df, kr.se);
    }
    for (name, v) in f.factors.iter().zip(&f.variances) {
        println!("crossaudit var {name} {v:.8e}");
    }
    println!("crossaudit median_fit_seconds {:.6} over {reps} fits", times[times.len() / 2]);
    Ok(())
}
