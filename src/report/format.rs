//! Number formatting shared by every table and summary line: the wording
//! the analysis itself uses for its guards ([`crate::analysis::words`]).

pub use crate::analysis::words::*;
