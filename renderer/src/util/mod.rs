//! Helpers every floor uses: the one error type, typed TOML with key paths, per-pixel
//! cost counters and deterministic random numbers.

pub mod error;
pub mod keys;
pub mod profile;
pub mod sampling;
