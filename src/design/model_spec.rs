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

/// The most hidden layers an `mlp(...)` may have.
pub const MLP_MAX_LAYERS: usize = 8;

/// The widest hidden layer an `mlp(...)` may have.
pub const MLP_MAX_WIDTH: usize = 4096;

/// The most weights between hidden layers (the sum of the products of
/// consecutive widths): `mlp(4096, 4096)` is the largest two-layer network.
/// With Adam's two moments and the gradient, training holds four copies.
pub const MLP_MAX_HIDDEN_WEIGHTS: usize = 1 << 24;

/// Why `widths` is not an architecture the language accepts, or `None`:
/// one to [`MLP_MAX_LAYERS`] hidden ReLU layers, each 1 to
/// [`MLP_MAX_WIDTH`] wide, at most [`MLP_MAX_HIDDEN_WEIGHTS`] weights
/// between them. Part of the language, so that validation needs no model
/// code.
pub fn mlp_unsupported(widths: &[usize]) -> Option<String> {
    if widths.is_empty() || widths.len() > MLP_MAX_LAYERS {
        return Some(format!("{} hidden layers; an mlp has 1 to {MLP_MAX_LAYERS}", widths.len()));
    }
    if let Some(w) = widths.iter().find(|w| **w == 0 || **w > MLP_MAX_WIDTH) {
        return Some(format!("a hidden layer {w} wide; each is 1 to {MLP_MAX_WIDTH} wide"));
    }
    let between: usize = widths.windows(2).map(|p| p[0] * p[1]).sum();
    if between > MLP_MAX_HIDDEN_WEIGHTS {
        return Some(format!("{between} weights between hidden layers; at most {MLP_MAX_HIDDEN_WEIGHTS}"));
    }
    None
}

/// Whether `widths` is an architecture the language accepts.
pub fn mlp_supported(widths: &[usize]) -> bool {
    mlp_unsupported(widths).is_none()
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
