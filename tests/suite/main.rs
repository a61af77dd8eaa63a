//! The integration tests, one crate: each file a module, `common` shared by all. One binary
//! instead of one per file: the shared helpers and every generic they instantiate compile and
//! link once (the README's test command on a fresh clone, `CONTRIBUTING.md#build-and-test`).
//! Run one file's tests with a filter: `cargo test --release --test suite analytic::`.

#[macro_use]
#[path = "../common/mod.rs"]
mod common;

mod analytic;
mod bench;
mod blend_coverage;
mod cli;
mod exact_edge_table;
mod fuzz_regressions;
mod glossy_shadows;
mod gltf_loading;
mod gltf_shading;
mod hard_cases;
mod input_bounds;
mod instances;
mod material_cases;
mod material_shading;
mod materials;
mod memory_budget;
mod path_tracing;
mod pcss;
mod physical_visibility;
mod profile;
mod registry;
mod scene_keys;
mod scene_precision;
mod shading_normals;
mod shared_scenes;
mod silhouette;
mod tiles;
mod tiny_lights;
