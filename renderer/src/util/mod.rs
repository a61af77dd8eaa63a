//! Helpers every floor uses: the one error type, all-or-nothing output files, per-pixel
//! cost counters and deterministic random numbers.

pub mod error;
pub mod keys;
pub mod profile;
pub mod sampling;
