//! penumbra's renderer: glTF scenes on an obvhs BVH, Lambertian surfaces lit by rectangular
//! area lights, and the [`LightShadowing`] plugin interface with its built-in methods
//! ([`Traced`], the ground truth, and [`Unshadowed`]).
//!
//! Layering: this crate knows no plugin beyond its own two; `shadow_plugin` depends on it,
//! and the `penumbra` CLI is the one place that knows every method.

pub mod geometry;
pub mod integrator;
pub mod interface;
pub mod load;
pub mod methods;
pub mod shading;
pub mod util;

pub use geometry::camera::Camera;
pub use geometry::light::RectLight;
pub use geometry::material::Shading;
pub use geometry::point::ShadingPoint;
pub use geometry::scene::{Scene, SurfaceHit};
pub use geometry::shaft::Shaft;
pub use geometry::surface::Surface;
pub use integrator::aov::{SurfaceAovs, surface_aovs};
pub use integrator::render::{Frame, RenderSettings, render, render_rows};
pub use integrator::tally::FrameTally;
pub use interface::entry::MethodEntry;
pub use interface::method::{KeyError, MethodParams, ShadowMethod, parse_method};
pub use interface::shadowing::{LightShadowing, PrepareContext, ShadowError, ShadowQuery};
pub use load::scene_file::SceneFile;
pub use load::scene_load::{KeepInstances, LoadOptions};
pub use methods::traced::{MAX_TRACED_SAMPLES, Traced, TracedParams, Unshadowed};
pub use util::error::SceneError;
