//! The owned syntax tree of a `.design` file. Every node keeps the byte span
//! it came from, so the validator can point at it; no pest type escapes the
//! `design` module.

use std::ops::Range;

pub use super::rules::Cmp;

/// A byte range in the design source.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Span {
    /// First byte.
    pub start: usize,
    /// One past the last byte.
    pub end: usize,
}

impl Span {
    /// As a `Range` for slicing the source.
    pub fn range(self) -> Range<usize> {
        self.start..self.end
    }
}

/// A value and the span it was written at.
#[derive(Debug, Clone, PartialEq)]
pub struct Spanned<T> {
    pub node: T,
    pub span: Span,
}

impl<T> Spanned<T> {
    pub fn new(node: T, span: Span) -> Self {
        Spanned { node, span }
    }
}

pub type Ident = Spanned<String>;
pub type Int = Spanned<i64>;
pub type Number = Spanned<f64>;

/// A parsed design: its statements in source order.
#[derive(Debug, Clone, PartialEq)]
pub struct Ast {
    /// Statements in source order.
    pub statements: Vec<Spanned<Statement>>,
}

#[derive(Debug, Clone, PartialEq)]
pub enum Statement {
    Study(Spanned<String>),
    Data(DataBlock),
    FactorRecording(Vec<Spanned<RecordingItem>>),
    FactorSeed(SeedSpec),
    FactorSplit(SeedSpec),
    FactorDraw(SeedSpec),
    Draws(Ident),
    /// `draws per seed`.
    DrawsPerSeed,
    Choices(Vec<Spanned<ChoiceAst>>),
    PrimarySpec(Vec<(Ident, Spanned<Alternative>)>),
    Validation {
        windows: Int,
        recordings: ValRecordings,
        seed: Int,
    },
    Arm {
        name: Ident,
        body: ArmBody,
    },
    Model {
        name: Ident,
        kind: ModelSyntax,
    },
    Train(Vec<Spanned<TrainItem>>),
    Endpoint(EndpointStmt),
    Contrast {
        treated: Ident,
        reference: Ident,
    },
    Estimate {
        kind: Ident,
        items: Vec<Spanned<EstimateItem>>,
    },
    Sensitivity(Vec<Spanned<SensitivityItem>>),
    Interaction {
        left: Ident,
        right: Ident,
    },
    Decide {
        name: Ident,
        on: Option<Ident>,
        conditions: Vec<Spanned<ConditionAst>>,
        combine: Option<Spanned<CombineAst>>,
    },
    Generator(Ident),
    Published {
        /// The split file as written; `folders` for the data folder's
        /// subfolders (`folders` set).
        file: Spanned<String>,
        /// `split published folders`.
        folders: bool,
        items: Vec<Spanned<PublishedItem>>,
    },
}

/// `from 8 recordings`, `from recordings "A", "B"` or `from split`.
#[derive(Debug, Clone, PartialEq)]
pub enum ValRecordings {
    Count(Int),
    List(Vec<Spanned<String>>),
    Split(Span),
}

/// A clause of `split published "FILE" { ... }`.
#[derive(Debug, Clone, PartialEq)]
pub enum PublishedItem {
    Evaluation(Vec<Spanned<String>>),
    Validation(Vec<Spanned<String>>),
    Fit(Vec<Spanned<String>>),
    Ignore(Vec<Spanned<String>>),
    Leaked(Ident),
}

impl Statement {
    /// The keyword that starts the statement, used in "declared twice" messages.
    pub fn keyword(&self) -> &'static str {
        match self {
            Statement::Study(_) => "study",
            Statement::Data(_) => "data",
            Statement::FactorRecording(_) => "factor recording",
            Statement::FactorSeed(_) => "factor seed",
            Statement::FactorSplit(_) => "factor split",
            Statement::FactorDraw(_) => "factor draw",
            Statement::Draws(_) => "draws",
            Statement::DrawsPerSeed => "draws per seed",
            Statement::Choices(_) => "choices",
            Statement::PrimarySpec(_) => "primary specification",
            Statement::Validation { .. } => "validation",
            Statement::Arm { .. } => "arm",
            Statement::Model { .. } => "model",
            Statement::Train(_) => "train",
            Statement::Endpoint(_) => "endpoint",
            Statement::Contrast { .. } => "contrast",
            Statement::Estimate { .. } => "estimate",
            Statement::Sensitivity(_) => "sensitivity",
            Statement::Interaction { .. } => "interaction",
            Statement::Decide { .. } => "decide",
            Statement::Generator(_) => "generator",
            Statement::Published { .. } => "split published",
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct DataBlock {
    pub source: Ident,
    pub items: Vec<Spanned<DataItem>>,
}

#[derive(Debug, Clone, PartialEq)]
pub enum DataItem {
    Path(Spanned<String>),
    Rate(Number),
    IncludeActive {
        column: Ident,
        cmp: Spanned<Cmp>,
        threshold: Number,
        min_samples: Int,
    },
    ExcludeImplausible(Option<Ident>),
    /// `exclude recordings "NAME", ...`.
    ExcludeRecordings(Vec<Spanned<String>>),
    /// `exclude frozen position for T s`.
    ExcludeFrozen(Number),
    /// `exclude beyond position L m`, `speed L m/s` or `rate L rad/s`.
    ExcludeBeyond {
        quantity: crate::design::Bound,
        limit: Number,
    },
    Tails(Ident),
    Speed(SpeedAst),
    Universe {
        kind: Ident,
        order: Option<Ident>,
    },
    MissingCsv(Ident),
    Duplicates(Spanned<String>),
    Strict,
    State(Vec<Ident>),
    Action {
        columns: Vec<Ident>,
        scale: Option<Number>,
    },
    Time(Ident),
    Position(Vec<Ident>),
    Velocity(Vec<Ident>),
    /// `kind`: the grammar rule's name (`quaternion_wxyz`, `euler_degrees`, ...).
    Attitude {
        kind: Ident,
        columns: Vec<Ident>,
        /// `norm within T`: the quaternion's tolerance, renormalised.
        norm_within: Option<Number>,
    },
    Rates(Vec<Ident>),
    Predicted(Vec<Ident>),
    Reference(Vec<Ident>),
    Extra {
        columns: Vec<Ident>,
        fill_zeros: bool,
    },
    Extrapolated(Vec<Ident>),
    Controller(Ident),
    /// `folders nested`.
    FoldersNested,
    /// `conditions table "FILE"`, with `columns ROLE = COLUMN, ...` as written.
    ConditionsTable {
        file: Spanned<String>,
        columns: Vec<(Ident, Ident)>,
    },
    ConditionsName(Spanned<String>),
    /// `conditions folder trajectory|speed`.
    ConditionsFolder(Ident),
    /// `missing values refuse|exclude|segment`.
    MissingValues(Ident),
    /// `gaps over T s refuse|exclude|segment`.
    Gaps {
        over: Number,
        policy: Ident,
    },
    /// `require at least N recordings`.
    RequireKept(Int),
    SimRecordings(Int),
    SimSeed(Int),
    SimStrength(Number),
    SimDuration(Number),
}

/// `speed from name` or `speed from metadata slow < 1.0 <= medium`.
#[derive(Debug, Clone, PartialEq)]
pub enum SpeedAst {
    Name,
    Metadata { first: Ident, steps: Vec<(Number, Ident)> },
}

#[derive(Debug, Clone, PartialEq)]
pub enum RecordingItem {
    Evaluation(Int),
    EvaluationList(Vec<Spanned<String>>),
    SplitSeed(Int),
    /// `starts N`, and `within first P%`.
    Starts(Int, Option<Number>),
    Horizon(Int),
    Conditions(Vec<Ident>),
    Stratify {
        conditions: Vec<Ident>,
        keep: Option<Int>,
    },
}

#[derive(Debug, Clone, PartialEq)]
pub enum SeedSpec {
    Range { first: Int, last: Int },
    List(Vec<Int>),
}

#[derive(Debug, Clone, PartialEq)]
pub enum ArmBody {
    Fit {
        windows: Int,
        seed: Option<Int>,
        hold_out: Vec<Ident>,
    },
    /// `percents` holds one share, or several for a dose-response family.
    Derived {
        from: Ident,
        percents: Vec<Number>,
        exclude_starts: bool,
        distance: Option<DistanceClause>,
        seed: Int,
    },
}

/// `at least G s from segments` (`most` None), `G1 s to G2 s from
/// segments`, or `after segments`, as written; several gaps (`at least 0
/// s, 5 s`) declare a distance-dose family.
#[derive(Debug, Clone, PartialEq)]
pub struct DistanceClause {
    /// The least distances (empty for `after segments`).
    pub least: Vec<Number>,
    /// A band's end.
    pub most: Option<Number>,
    /// `after segments`.
    pub after: bool,
    /// The clause.
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub enum ModelSyntax {
    Mlp {
        widths: Vec<Int>,
        inputs: Spanned<String>,
        actions: Option<Ident>,
        restore: Option<Ident>,
    },
    External {
        inputs: Spanned<String>,
        actions: Option<Ident>,
        history: Option<Int>,
    },
    /// `ridge`: `None` for auto.
    Linear {
        inputs: Spanned<String>,
        actions: Option<Ident>,
        ridge: Option<Number>,
    },
    Baseline(Spanned<String>),
}

#[derive(Debug, Clone, PartialEq)]
pub enum TrainItem {
    Optimizer { kind: Ident, lr: Number },
    Batch(Int),
    Epochs(Int),
    Schedule(Ident),
    Patience(Int),
    ActionNoise(Number),
    Target(Ident),
    Actions(Ident),
}

#[derive(Debug, Clone, PartialEq)]
pub struct EndpointStmt {
    pub role: Ident,
    pub metric: Ident,
    pub horizons: Vec<Number>,
    pub cap: Option<Number>,
    pub models: Vec<Ident>,
    /// `glmm binomial`: the family of the endpoint's GLMM.
    pub glmm: Option<Ident>,
}

#[derive(Debug, Clone, PartialEq)]
pub enum EstimateItem {
    Level(Number),
    DfFactorMinus { factor: Ident, minus: Int },
    DfNamed(Ident),
    Missing(Ident),
}

#[derive(Debug, Clone, PartialEq)]
pub enum SensitivityItem {
    Bootstrap { kind: Ident, replicates: Int, seed: Int },
    Grouped,
    LeaveOneOut(Vec<Ident>),
}

#[derive(Debug, Clone, PartialEq)]
pub struct ConditionAst {
    pub quantity: Ident,
    pub cmp: Spanned<Cmp>,
    pub value: Number,
    pub percent: bool,
}

/// One open choice: a setting and its alternatives as written.
#[derive(Debug, Clone, PartialEq)]
pub struct ChoiceAst {
    pub setting: Ident,
    pub alternatives: Vec<Spanned<Alternative>>,
}

/// An alternative of a choice: a name or a number, as written.
#[derive(Debug, Clone, PartialEq)]
pub enum Alternative {
    Name(String),
    Number(f64, String),
}

impl Alternative {
    /// As written in the design.
    pub fn text(&self) -> &str {
        match self {
            Alternative::Name(s) | Alternative::Number(_, s) => s,
        }
    }
}

/// `in primary`, `in every specification`, `in at least P% of specifications`.
#[derive(Debug, Clone, PartialEq)]
pub enum CombineAst {
    Primary,
    Every,
    AtLeast(Number),
}
