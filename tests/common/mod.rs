pub mod checked;
pub mod gltf_writer;
pub mod soups;
