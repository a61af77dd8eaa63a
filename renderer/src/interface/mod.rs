//! The ground floor: what a shadow method is to the renderer. [`shadowing`] is the
//! per-light plugin ([`LightShadowing`](shadowing::LightShadowing): `prepare`, then cheap
//! `&self` queries); [`method`] is how a method is configured and built from its
//! `[shadows.<name>]` table; [`entry`] is what the CLI and the key reference know
//! of a method. Nothing here imports the integrator or the loaders.

pub mod entry;
pub mod lobe;
pub mod method;
pub mod shadowing;
