//! Tests of the shading room against f64 quadrature.

mod brdf_eval;
mod brdf_sampling;
mod quadrature_rules;
