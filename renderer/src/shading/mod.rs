//! Shading math: the glTF 2.0 metallic-roughness BRDF ([`brdf`]), Linearly Transformed
//! Cosines for its specular lobe ([`ltc`]) and the f64 quadrature both are checked against
//! ([`quadrature`]).
//!
//! A room of its own: it imports only `glam` (and may use `crate::util`), nothing from
//! `geometry/`, `integrator/`, `methods/` or `load/`, so that any of them can shade with it.
//! Everything works in the local shading frame, +z the shading normal.

pub mod brdf;
pub mod lobe_integral;
pub mod ltc;
mod ltc_table;
pub mod quadrature;
#[cfg(test)]
mod tests;

pub use brdf::{BrdfSample, BrdfValue, GltfBrdf, ROUGHNESS_MIN, ggx_d, schlick_weight, smith_visibility};
pub use ltc::{LtcLobe, lambert_edge, ltc_lobe};
pub use quadrature::directional_albedo;
