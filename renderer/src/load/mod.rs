//! From files to a [`Scene`](crate::geometry::scene::Scene): the scene file typed ([`scene_file`]), glTF into
//! world-space triangles ([`gltf_load`]), and the scene built in render space
//! ([`scene_load`]).

mod emitter_lights;
pub mod gltf_load;
mod instance_proof;
mod kept_instances;
mod precision_tally;
pub mod scene_file;
pub mod scene_load;
