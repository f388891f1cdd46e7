//! Exports to other renderers.

pub mod mitsuba;
mod ply;
