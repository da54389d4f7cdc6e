//! A multiverse: the open choices of a design, declared before the run.
//!
//! `choices { state motion_capture | onboard; tails keep | truncate }` lists
//! settings the language already has, each with its alternatives; every
//! combination is a *specification*, a complete design of its own (the
//! design text with that alternative written in place of each choice).
//! `primary specification ...` names the one whose estimate the decision
//! reads, and `decide ... in every specification` (or `in at least P% of
//! specifications`) says how the others enter it.
//!
//! Specifications are expanded at validation (`validate::outer::expand`) so that each one
//! is checked exactly as a single-specification design with those lines
//! would be, and every error points at the choice that produced it.

mod settings;
mod spec;

pub use crate::design::types::{run_key, Choice, ChoiceRole, Combine, Multiverse, Specification, MAX_SPECS};
pub(in crate::design) use settings::{declared, Declared};
pub(in crate::design) use spec::{combinations, spec_ast, spec_id};
