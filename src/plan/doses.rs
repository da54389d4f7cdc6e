//! The doses of a dose-response contrast: the arm that carries each, and
//! what the family varies (a share, or a distance from the segments).

use serde::Serialize;

use super::{DoseAxis, Plan};

/// One dose of a dose-response contrast: the arm that carries it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DoseArm {
    /// The arm's name (`contaminated_5pct`, or `contaminated_5s` in a
    /// distance-dose family).
    pub arm: String,
    /// Percentage of the reference arm's windows replaced.
    pub percent: f64,
    /// In a distance-dose family, the dose: the least distance in s of
    /// every contaminating window from the evaluated segments.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub distance_s: Option<f64>,
}

/// The axis of a family's doses: distances where any dose has one.
pub fn dose_axis(doses: &[DoseArm]) -> DoseAxis {
    DoseAxis::of_doses(doses.iter().map(|d| d.distance_s))
}

impl DoseArm {
    /// The dose on its axis: the distance in s in a distance-dose family,
    /// the percent otherwise.
    pub fn dose(&self) -> f64 {
        self.distance_s.unwrap_or(self.percent)
    }

    /// `25%`, or `at least 5 s`.
    pub fn label(&self) -> String {
        match self.distance_s {
            Some(g) => format!("at least {g} s"),
            None => format!("{}%", self.percent),
        }
    }
}

impl Plan {
    /// The dose line of `render_text`: the doses, nested, or the distances.
    pub(super) fn doses_text(&self) -> String {
        let list: Vec<String> = self.doses.iter().map(|d| format!("{} ({})", d.label(), d.arm)).collect();
        let (treated, list) = (&self.contrast.treated, list.join(", "));
        match dose_axis(&self.doses) {
            DoseAxis::Percent => format!("doses of {treated} (nested): {list}"),
            DoseAxis::Distance => format!(
                "distances of {treated} from the evaluated segments, {}% replaced in each (one draw order): {list}",
                self.doses[0].percent
            ),
        }
    }
}
