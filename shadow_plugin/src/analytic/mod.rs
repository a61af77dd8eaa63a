//! `analytic`: noise-free soft shadows, the light's visible part integrated in closed form
//! from the occluders' silhouette edges.

pub mod arrangement;
pub mod lambert;
