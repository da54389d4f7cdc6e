//! The methodologists' commands and `mixed`: coverage studies, the
//! planner, the simulator and linear mixed models on any CSV.

use std::path::Path;

use crossaudit::design;
use crossaudit::run::lock_folder;
use crossaudit::{AnalyzeOptions, Error};

/// `coverage` of a `"kind": "decision"` spec: the interaction and the
/// optimism's intervals.
fn decision_coverage(spec_path: &Path, text: &str, reps: Option<usize>, out: &Path) -> Result<(), Error> {
    use crossaudit::methods::decision_coverage as dc;
    let mut spec = dc::DecisionCoverageSpec::from_text(spec_path, text)?;
    if let Some(r) = reps {
        spec.reps = r;
        spec.validate(spec_path)?;
    }
    let _lock = lock_folder(out, false)?;
    let started = std::time::Instant::now();
    let (interaction, ratio) = dc::run_decision_coverage(&spec, &mut |k, n, label| {
        note!("[{k}/{n}] {label} ({:.1} s)", started.elapsed().as_secs_f64());
    })?;
    for p in dc::write_decision_coverage(out, &spec, (&interaction, &ratio))? {
        note!("wrote {}", p.display());
    }
    Ok(())
}

pub(crate) fn coverage(spec_path: &Path, reps: Option<usize>, out: &Path, replications: bool) -> Result<(), Error> {
    use crossaudit::methods::draw_coverage as dc;
    let text = crossaudit::methods::coverage::read_spec_text(spec_path)?;
    let kind = dc::spec_kind(spec_path, &text)?;
    if let (Some(kind), true) = (&kind, replications) {
        return Err(crossaudit::methods::CoverageError::Invalid {
            path: spec_path.display().to_string(),
            message: format!("`--replications` writes the tidy replications of a coverage grid for rsimsum; a `\"kind\": \"{kind}\"` study has none to write. Leave the flag out"),
        }
        .into());
    }
    if kind.as_deref() == Some("decision") {
        return decision_coverage(spec_path, &text, reps, out);
    }
    if kind.is_some() {
        let mut spec = dc::DrawCoverageSpec::from_text(spec_path, &text)?;
        if let Some(r) = reps {
            spec.reps = r;
            spec.validate(spec_path)?;
        }
        let _lock = lock_folder(out, false)?;
        let started = std::time::Instant::now();
        let rows = dc::run_draw_coverage(&spec, &mut |k, n, label| {
            note!("[{k}/{n}] {label} ({:.1} s)", started.elapsed().as_secs_f64());
        });
        for p in dc::write_draw_coverage(out, &spec, &rows)? {
            note!("wrote {}", p.display());
        }
        return Ok(());
    }
    let mut spec = crossaudit::methods::CoverageSpec::load(spec_path)?;
    if let Some(r) = reps {
        spec.reps = r;
        spec.validate(spec_path)?;
    }
    let _lock = lock_folder(out, false)?;
    let started = std::time::Instant::now();
    let (rows, sims) = crossaudit::methods::coverage::run_coverage_replications(&spec, &mut |k, n, s| {
        note!("[{k}/{n}] {} ({:.1} s)", s.label(), started.elapsed().as_secs_f64());
    })?;
    if replications {
        let path = out.join("replications.csv");
        crossaudit::io::create_dir_all(out)?;
        let text = crossaudit::methods::coverage_tidy::replications_csv(&sims, &spec.means);
        crossaudit::io::write_atomic(&path, text.as_bytes())?;
        note!("wrote {}", path.display());
    }
    let written = crossaudit::methods::coverage::write(out, &spec, &rows)?;
    let zip = crossaudit::methods::coverage::write_zip(out, &spec, &sims)?;
    for p in written.into_iter().chain(zip) {
        note!("wrote {}", p.display());
    }
    Ok(())
}

/// What `plan` plans from: a pilot's `--cells`, or declared components
/// with the effect and the reference mean.
type PlanFrom = (Option<std::path::PathBuf>, Option<String>, Option<f64>, Option<f64>);

/// The sizes `plan` considers: recordings and seeds, and the splits and
/// draws the user gave (each only for a design with that factor).
type PlanSizes = (Vec<usize>, Vec<usize>, Option<Vec<usize>>, Option<Vec<usize>>);

/// `crossaudit plan`: the sizes to consider (`--splits` and `--draws` only
/// for a design with that factor), then the plan from a pilot or from
/// declared components.
pub(crate) fn plan_command(
    design: &Path,
    from: PlanFrom,
    (recordings, seeds, splits, draws): PlanSizes,
    out: &Path,
) -> Result<(), Error> {
    plan_factors(design, splits.is_some(), draws.is_some())?;
    let default = || vec![3, 5, 10];
    let (splits, draws) = (splits.unwrap_or_else(default), draws.unwrap_or_else(default));
    match from {
        (Some(cells), ..) => power(design, &cells, (&splits, &recordings, &seeds, &draws), out),
        (None, Some(components), Some(effect), Some(reference_mean)) => {
            declared_power(design, (&components, effect, reference_mean), (&recordings, &seeds), out)
        }
        // clap requires --cells, or --components with both values.
        _ => unreachable!("clap requires --cells or --components with --effect and --reference-mean"),
    }
}

/// `plan --splits` or `--draws` on a design without that factor would be
/// ignored without a word: refused, naming what the design plans.
fn plan_factors(design: &Path, splits: bool, draws: bool) -> Result<(), Error> {
    if !splits && !draws {
        return Ok(());
    }
    let file = design::load(design)?;
    let study = crossaudit::compile_study(&file.design);
    let why = if splits && study.plan.splits.is_empty() {
        Some("--splits plans a design with a split factor (`factor split = ...`), and this one has none")
    } else if draws && file.design.draws.is_empty() {
        Some("--draws plans a design with `factor draw`, and this one has none")
    } else {
        None
    };
    match why {
        Some(why) => Err(crossaudit::methods::PowerError::Declared(format!(
            "{}: {why}; it plans its recordings and seeds (--recordings, --seeds): leave the option out",
            design.display()
        ))
        .into()),
        None => Ok(()),
    }
}

pub(crate) fn power(
    design: &Path,
    cells: &Path,
    (splits, recordings, seeds, draws): (&[usize], &[usize], &[usize], &[usize]),
    out: &Path,
) -> Result<(), Error> {
    let file = design::load(design)?;
    crossaudit::run::check_output_dir(out, &file.sha256)?;
    crossaudit::run::check_not_runs_own(out, None)?;
    let study = crossaudit::compile_study(&file.design);
    let plan = &study.plan;
    if !file.design.draws.is_empty() {
        // A draw-replicated pilot: `--cells` is its run directory, analysed
        // as `analyze` analyses it, and d pooled over draws is planned.
        let a = crossaudit::run::outer::analyze_dir(&file, &study, cells)?;
        let power = crossaudit::methods::draw_power_plan(plan, &a, recordings, seeds, draws)?;
        let _lock = lock_folder(out, false)?;
        power.write(out)?;
        out!("{}", power.to_markdown());
        return Ok(());
    }
    if !plan.splits.is_empty() {
        let family = crossaudit::analyze_family_files(design, cells, AnalyzeOptions::default())?;
        let power = crossaudit::methods::split_power_plan(plan, &family, splits, recordings, seeds)?;
        let _lock = lock_folder(out, false)?;
        power.write(out)?;
        out!("{}", power.to_markdown());
        return Ok(());
    }
    let power = if plan.is_family() {
        // A dose-response design: the trend's slope is planned.
        let family = crossaudit::analyze_family_files(design, cells, AnalyzeOptions::default())?;
        crossaudit::methods::dose_power_plan(plan, &family, recordings, seeds)?
    } else {
        let analysis = crossaudit::analyze_with(&file, plan, cells, AnalyzeOptions::default())?;
        let mut p = crossaudit::methods::power_plan(plan, &analysis, recordings, seeds)?;
        p.draws_per_seed = file.design.per_seed_draws;
        p
    };
    let _lock = lock_folder(out, false)?;
    power.write(out)?;
    out!("{}", power.to_markdown());
    Ok(())
}

/// `plan --components`: the crossed planner from declared components, for
/// a design whose primary is a single crossed contrast.
pub(crate) fn declared_power(
    design: &Path,
    (components, effect, reference_mean): (&str, f64, f64),
    (recordings, seeds): (&[usize], &[usize]),
    out: &Path,
) -> Result<(), Error> {
    let file = design::load(design)?;
    crossaudit::run::check_output_dir(out, &file.sha256)?;
    crossaudit::run::check_not_runs_own(out, None)?;
    let study = crossaudit::compile_study(&file.design);
    let plan = &study.plan;
    let kind = if !file.design.draws.is_empty() {
        Some("`factor draw`")
    } else if !plan.splits.is_empty() {
        Some("a split factor")
    } else if plan.is_family() {
        Some("doses")
    } else {
        None
    };
    if let Some(kind) = kind {
        return Err(crossaudit::methods::PowerError::Declared(format!(
            "{}: the design has {kind}; --components plans a single crossed contrast (recording x seed). Plan this design from a pilot with --cells",
            design.display()
        ))
        .into());
    }
    let declared = crossaudit::methods::Declared {
        components: crossaudit::methods::parse_components(components)?,
        effect,
        reference_mean,
    };
    let mut power = crossaudit::methods::declared_power_plan(plan, &declared, recordings, seeds)?;
    power.draws_per_seed = file.design.per_seed_draws;
    let _lock = lock_folder(out, false)?;
    power.write(out)?;
    out!("{}", power.to_markdown());
    Ok(())
}

pub(crate) fn simulate(design: &Path, out: &Path) -> Result<(), Error> {
    let file = design::load(design)?;
    crossaudit::run::check_output_dir(out, &file.sha256)?;
    let Some(sim) = file.design.data.simulated else {
        return Err(crossaudit::run::RunError::NotSimulated { path: design.display().to_string() }.into());
    };
    let _lock = lock_folder(out, false)?;
    let record = crossaudit::sim::simulate(&sim, out)?;
    note!(
        "wrote {} simulated recordings (CSV + metadata) and {} to {}",
        record.files.len() / 2,
        crossaudit::sim::RECORD,
        out.display()
    );
    Ok(())
}

pub(crate) fn simulate_lab(out: &Path, seed: u64) -> Result<(), Error> {
    let _lock = lock_folder(out, false)?;
    let files = crossaudit::sim::simulate_lab(out, seed)?;
    note!("wrote {} Parquet logs to {} (train/ and test/)", files.len(), out.display());
    Ok(())
}

fn mixed(
    data: &Path,
    formula: &str,
    (ml, df, profile, weights): (bool, &str, Option<f64>, Option<&str>),
    json: bool,
) -> Result<(), Error> {
    use crossaudit::stats::mixed::{formula::DfMethod, Criterion};
    // The fit is written to standard output and nowhere else.
    if crate::output::stdout_closed() {
        return Err(Error::Stdout(std::io::Error::other(
            "standard output is closed, so the fit would be written nowhere; redirect it to a file (`> fit.txt`)",
        )));
    }
    let criterion = if ml { Criterion::Ml } else { Criterion::Reml };
    let df = if df == "kenward-roger" { DfMethod::KenwardRoger } else { DfMethod::Satterthwaite };
    let fit = crossaudit::methods::formula_file::fit_file(data, formula, criterion, df, profile, weights)?;
    if json {
        out!("{}", crossaudit::io::pretty_json(&fit));
    } else {
        out!("{}", fit.summary());
    }
    if !fit.fit.certified() {
        note!("warning: the optimizer could not certify its point as the optimum (see the optimizer line)");
    }
    Ok(())
}

/// `crossaudit mixed`: a linear mixed model (or two compared), or a
/// generalized one (`--family binomial|poisson`).
pub(crate) fn mixed_command(a: crate::args::MixedArgs) -> Result<(), Error> {
    use crossaudit::stats::mixed::formula::{parse, FileError, FormulaError, GlmmOptions};
    let data = a.data.as_path();
    let refuse = |message: String| -> Error {
        FileError { file: data.display().to_string(), error: FormulaError::Unsupported(message) }.into()
    };
    // --offset COL is offset(`COL`) in the formula (and in the second).
    let with_offset = |formula: &str| -> Result<String, Error> {
        let Some(column) = &a.offset else { return Ok(formula.to_string()) };
        if parse(formula).is_ok_and(|f| f.offset.is_some()) {
            return Err(refuse(format!(
                "--offset {column} and an offset( ) in the formula `{formula}`: give the offset once"
            )));
        }
        if column.contains('`') {
            return Err(refuse(format!(
                "--offset {column}: a column name with a backquote cannot be named in a formula"
            )));
        }
        Ok(format!("{formula} + offset(`{column}`)"))
    };
    let formula = with_offset(&a.formula)?;
    let compare = a.compare.as_deref().map(with_offset).transpose()?;
    let formula = formula.as_str();
    if a.nagq != 1 && a.family == "gaussian" {
        return Err(refuse(format!(
            "--nagq {}: quadrature is for a generalized model (--family binomial or poisson); a linear mixed model's likelihood is exact",
            a.nagq
        )));
    }
    if a.weights.is_some() && a.compare.is_some() {
        return Err(refuse("--weights with --compare: the likelihood-ratio test is of unweighted models".into()));
    }
    match (a.family.as_str(), compare) {
        ("gaussian", Some(other)) => mixed_compare(data, formula, &other, a.json),
        ("gaussian", None) => mixed(data, formula, (a.ml, &a.df, a.profile, a.weights.as_deref()), a.json),
        (family, other) => {
            let refused = if other.is_some() {
                Some("--compare")
            } else if a.df == "kenward-roger" {
                Some("--df kenward-roger")
            } else {
                None
            };
            let options = GlmmOptions { weights: a.weights.clone(), nagq: a.nagq };
            mixed_glmm(data, formula, (family, a.profile, &options), refused, a.json)
        }
    }
}

/// `crossaudit mixed --family binomial|poisson`: lme4's `glmer`. An option
/// computed for linear models only (`refused`) is refused by name.
fn mixed_glmm(
    data: &Path,
    formula: &str,
    (family, profile, options): (&str, Option<f64>, &crossaudit::stats::mixed::formula::GlmmOptions),
    refused: Option<&str>,
    json: bool,
) -> Result<(), Error> {
    use crossaudit::stats::mixed::formula::{FileError, FormulaError};
    use crossaudit::stats::mixed::glmm::Family;
    if let Some(option) = refused {
        return Err(FileError {
            file: data.display().to_string(),
            error: FormulaError::Unsupported(format!(
                "{option} is computed for linear mixed models only; a {family} model reports Wald z tests of its fixed effects"
            )),
        }
        .into());
    }
    if crate::output::stdout_closed() {
        return Err(Error::Stdout(std::io::Error::other(
            "standard output is closed, so the fit would be written nowhere; redirect it to a file (`> fit.txt`)",
        )));
    }
    let family = if family == "binomial" { Family::Binomial } else { Family::Poisson };
    let fit = crossaudit::methods::formula_file::fit_glmm_file(data, formula, family, profile, options)?;
    if json {
        out!("{}", crossaudit::io::pretty_json(&fit));
    } else {
        out!("{}", fit.summary());
    }
    if !fit.fit.certificate.certified {
        note!("warning: the optimizer could not certify its point as the optimum (see the optimizer line)");
    }
    Ok(())
}

/// `crossaudit mixed --compare`: lme4's `anova(m1, m2)`.
fn mixed_compare(data: &Path, formula: &str, other: &str, json: bool) -> Result<(), Error> {
    if crate::output::stdout_closed() {
        return Err(Error::Stdout(std::io::Error::other(
            "standard output is closed, so the test would be written nowhere; redirect it to a file (`> test.txt`)",
        )));
    }
    let comparison = crossaudit::methods::formula_file::compare_file(data, formula, other)?;
    if json {
        out!("{}", crossaudit::io::pretty_json(&comparison));
    } else {
        out!("{}", comparison.summary());
    }
    if comparison.models.iter().any(|m| !m.certified) {
        note!("warning: the optimizer could not certify an ML fit (see the table's warning)");
    }
    Ok(())
}

/// `crossaudit simsum`: reads, scores and writes a replications file.
pub(crate) fn simsum(a: crate::args::SimsumArgs) -> Result<(), Error> {
    use crossaudit::methods::simsum as ss;
    use crossaudit::methods::simsum_report as sr;
    let (file, out) = (a.file.as_path(), a.out.as_path());
    let mut cols = ss::Columns {
        estimate: a.estimate,
        se: a.se,
        method: a.method,
        rep: a.rep,
        by: a.by,
        truth: a.truth,
        level: a.level,
        ci: None,
        df: a.df,
        reference: a.reference,
        targets: match a.target_mcse.as_deref() {
            Some(t) => ss::parse_targets(t)?,
            None => Vec::new(),
        },
    };
    if let Some(ci) = a.ci.as_deref() {
        match ci.split_once(',') {
            Some((l, u)) if !l.trim().is_empty() && !u.trim().is_empty() && !u.contains(',') => {
                cols.ci = Some((l.trim().to_string(), u.trim().to_string()))
            }
            _ => {
                return Err(ss::SimsumFileError::Read {
                    path: file.display().to_string(),
                    message: format!("--ci \"{ci}\": give the two interval-limit columns as LOWER,UPPER"),
                }
                .into())
            }
        }
    }
    let _lock = lock_folder(out, false)?;
    let (groups, unused) = ss::summarise(file, &cols)?;
    out!("{}", sr::summary(&groups));
    for n in sr::truth_notes(&groups, &cols.by).iter().chain(&unused) {
        note!("note: {}", crossaudit::io::one_line(n));
    }
    for p in sr::write(&groups, &cols, &file.display().to_string(), &unused, out)? {
        note!("wrote {}", p.display());
    }
    Ok(())
}
