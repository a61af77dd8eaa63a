//! Helpers every floor uses: the input error ([`error::SceneError`]), typed TOML with key
//! paths, per-pixel cost counters ([`pixel_cost`]) and deterministic random numbers
//! ([`random`]).

pub mod error;
pub mod keys;
pub mod pixel_cost;
pub mod random;
