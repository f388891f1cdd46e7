//! Shared helpers for benchmarks: CSV and SVG chart writers.
