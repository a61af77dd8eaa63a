//! What the rays meet and how they are cast: the runtime scene and its BVH queries, the
//! shading point, shafts, the one rule for ray origins and f32 precision, the camera, lights
//! and their sampling, materials and the surface they give a hit.

pub mod attributes;
pub mod camera;
pub mod coverage;
pub mod horizon_warp;
pub mod instanced;
pub mod instances;
pub mod irradiance_strata;
pub mod light;
pub mod material;
pub mod point;
pub mod precision;
#[cfg(test)]
mod precision_tests;
pub mod ray_origin;
pub mod scene;
pub mod scene_bvh;
pub mod shaft;
mod shaft_plane;
pub mod surface;
pub mod watertight;
