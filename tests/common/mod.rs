pub mod checked;
pub mod gltf_writer;
pub mod material_quad;
pub mod shared;
pub mod soups;
pub mod sphere;
