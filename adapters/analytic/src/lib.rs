//! Analytic geometry adapter (being written).
