//! The frame: primary rays, `prepare` per light, shading (direct light through the shadow
//! plugin) and diffuse paths with next-event estimation at every vertex; the surface AOVs.

pub mod aov;
pub mod gltf_path;
pub mod path;
pub mod reflect;
pub mod render;
pub mod tally;
