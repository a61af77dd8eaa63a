//! What the integration tests share (`tests/suite/`): each module used by some of them.
#![allow(dead_code)] // each test module uses its own subset

pub mod checked;
pub mod folders;
pub mod gltf_writer;
pub mod material_quad;
pub mod quads;
pub mod shared;
pub mod soups;
pub mod sphere;
#[macro_use]
pub mod tiny_scene;
