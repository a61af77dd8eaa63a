//! penumbra's renderer: glTF scenes on an obvhs BVH, Lambertian surfaces lit by rectangular
//! area lights, and the [`LightShadowing`] plugin interface with its built-in methods
//! ([`Traced`], the ground truth, and [`Unshadowed`]).
//!
//! Layering: this crate knows no plugin beyond its own two; `shadow_plugin` depends on it,
//! and the `penumbra` CLI is the one place that knows every method.

pub mod camera;
pub mod config;
pub mod error;
pub mod gltf_load;
pub mod light;
pub mod light_sampling;
pub mod material;
pub mod method;
pub mod output;
pub mod path;
pub mod precision;
#[cfg(test)]
mod precision_tests;
pub mod profile;
pub mod ray_origin;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod scene_load;
pub mod shadowing;
pub mod shaft;
pub mod traced;

pub use camera::Camera;
pub use config::SceneFile;
pub use error::SceneError;
pub use light::RectLight;
pub use method::{KeyError, MethodParams, ShadowMethod, parse_method};
pub use render::{Frame, RenderSettings, render};
pub use scene::{Scene, SurfaceHit};
pub use shadowing::{LightShadowing, PrepareContext, ShadowError, ShadowQuery, VisiblePoint};
pub use shaft::Shaft;
pub use traced::{MAX_TRACED_SAMPLES, Traced, TracedParams, Unshadowed};
