//! Shared helpers for the benchmark binaries.

pub mod mitsuba_runner;
