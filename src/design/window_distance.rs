//! How far a contaminating window lies from the evaluated segments
//! (`at least G s from segments`, a band, or `after segments`).

use serde::Serialize;

/// How far from every evaluated segment of its recording (a registered
/// rollout start to its horizon) a contaminating window must lie: the
/// seconds between the window's nearest row and the segment's, at least
/// `min_s` and, in a band, less than `max_s`; or (`after segments`) only
/// after the last segment of its recording, in the part that holds no
/// rollout start.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WindowDistance {
    /// The least distance, s.
    pub min_s: f64,
    /// The band's end, s (exclusive); None: no upper bound.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_s: Option<f64>,
    /// `after segments`: every row of the window after every segment of
    /// its recording (`min_s` 0, `max_s` None).
    #[serde(skip_serializing_if = "std::ops::Not::not", default)]
    pub after_segments: bool,
    /// Byte offset of the clause in the design source.
    #[serde(skip)]
    pub offset: usize,
}

impl WindowDistance {
    /// Whether a distance of `samples` at `rate_hz` lies in the range.
    pub fn admits(&self, samples: usize, rate_hz: f64) -> bool {
        // Compared in samples, exactly: the bounds rounded up to whole samples.
        let at_least = (self.min_s * rate_hz - 1e-9).ceil().max(0.0) as usize;
        let below = self.max_s.map(|m| (m * rate_hz - 1e-9).ceil().max(0.0) as usize);
        samples >= at_least && below.is_none_or(|b| samples < b)
    }

    /// `at least 5 s`, `1 s to 5 s` or `after segments`, as written.
    pub fn describe(&self) -> String {
        match self.max_s {
            None if self.after_segments => "after segments".to_string(),
            None => format!("at least {} s from segments", self.min_s),
            Some(m) => format!("{} s to {m} s from segments", self.min_s),
        }
    }
}
