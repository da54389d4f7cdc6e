#![doc = include_str!("../ARCHITECTURE.md")]

pub mod design;
pub mod stats;
