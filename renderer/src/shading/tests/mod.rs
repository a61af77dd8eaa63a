//! Tests of the shading room against f64 quadrature.

mod brdf_eval;
mod brdf_sampling;
mod ltc_accuracy;
mod ltc_geometry;
mod quadrature_rules;
