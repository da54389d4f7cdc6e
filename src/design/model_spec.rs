//! The design's models: MLPs, linear models, external models and
//! baselines, with the input maps, action scalings and targets they use.

use serde::Serialize;

/// A dynamics model to evaluate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Model {
    /// Model name, e.g. `world`.
    pub name: String,
    /// What the model is.
    pub kind: ModelKind,
}

/// The kinds of model the language knows.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum ModelKind {
    /// A trained MLP with hidden `widths`, fed through `inputs`.
    Mlp {
        /// Hidden-layer widths.
        widths: Vec<usize>,
        /// The input map.
        inputs: InputMap,
        /// How the actions enter.
        actions: ActionScaling,
        /// `restore final`: trained for the full budget of epochs without
        /// early stopping, the last epoch's weights rolled out.
        #[serde(skip_serializing_if = "std::ops::Not::not")]
        restore_final: bool,
    },
    /// Fitted outside crossaudit on the windows `crossaudit export` writes;
    /// its rollouts come back as predictions to `crossaudit score`.
    External {
        /// The input map of the exported inputs.
        inputs: InputMap,
        /// How the actions enter the exported inputs.
        actions: ActionScaling,
        /// Samples before every window and start exported as its history
        /// (0: none).
        history: usize,
    },
    /// Ridge regression on the MLP's standardized inputs and target, in
    /// closed form (`model::linear`).
    Linear {
        /// The input map.
        inputs: InputMap,
        /// How the actions enter.
        actions: ActionScaling,
        /// The penalty; `None`: chosen on the validation windows.
        ridge: Option<f64>,
    },
    /// Predicts no change.
    Persistence,
    /// Integrates the current velocity.
    ConstantVelocity,
}

/// Hidden-layer widths the language accepts: an `mlp(w, w, w)` of three
/// equal widths from this list. Part of the language so that validation
/// needs no model code; `model::net` has one network type per entry.
pub const MLP_WIDTHS: [usize; 3] = [32, 64, 256];

/// Whether `widths` is an architecture the language accepts.
pub fn mlp_supported(widths: &[usize]) -> bool {
    widths.len() == 3 && widths.iter().all(|w| *w == widths[0]) && MLP_WIDTHS.contains(&widths[0])
}

impl ModelKind {
    /// Whether the model has parameters to fit (one training job per arm x seed).
    pub fn trains(&self) -> bool {
        matches!(self, ModelKind::Mlp { .. } | ModelKind::External { .. } | ModelKind::Linear { .. })
    }

    /// Whether the model is trained by epochs (an MLP): it has a training
    /// curve and weights in safetensors.
    pub fn has_curve(&self) -> bool {
        matches!(self, ModelKind::Mlp { .. })
    }

    /// Whether the model is fitted outside crossaudit (`external`).
    pub fn is_external(&self) -> bool {
        matches!(self, ModelKind::External { .. })
    }
}

/// The input map of an MLP.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InputMap {
    /// Absolute world-frame state.
    World,
    /// Position-free, body-relative state.
    Relative,
}

impl InputMap {
    /// The language's word for it.
    pub fn name(self) -> &'static str {
        match self {
            InputMap::World => "world",
            InputMap::Relative => "relative",
        }
    }
}

/// How the actions u in [0, 1] enter a network.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ActionScaling {
    /// As they are (the paper).
    Raw,
    /// Through the model's input standardizer.
    Standardized,
}

impl ActionScaling {
    /// The language's word for it.
    pub fn name(self) -> &'static str {
        match self {
            ActionScaling::Raw => "raw",
            ActionScaling::Standardized => "standardized",
        }
    }
}

/// What the network predicts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TargetKind {
    /// The paper's dz = S(x_{t+1}) - S(x_t) = (x_{t+1} - x_t) / sd_x.
    StateScaled,
    /// The increment through its own mean and SD.
    Standardized,
}
