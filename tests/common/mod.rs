pub mod checked;
pub mod gltf_writer;
pub mod shared;
pub mod soups;
