pub mod gltf_writer;
