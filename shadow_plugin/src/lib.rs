//! penumbra's shadow plugins. `silhouette`: exact soft shadows from the occluders' silhouette
//! edges, counted in `traced`'s own samples (soft shadow volumes for ray tracing, Laine et al.
//! 2005), from the edges `silhouette_edges` finds per light and gathers per point (shared
//! with other edge methods). On one light-space depth map ([`depth_map`], with the
//! family's shared DDA, readings, bit sets, mask samples and traced fallback): `edge_table`
//! (Egan & Neulander 2004), its per-ray baseline and oracle `depth_march` (retired from the
//! CLI's registry, kept as a library), and the real-time baseline `pcss` (Fernando 2005).

pub mod analytic;
pub mod depth_map;
pub mod depth_march;
pub mod edge_table;
pub mod pcss;
pub mod silhouette;
mod silhouette_edges;

pub use analytic::{Analytic, AnalyticParams};
pub use depth_map::heightfield::Heightfield;
pub use depth_map::{DepthMap, DepthMapParams, LightFrame, MapSwitches};
pub use depth_march::{DepthMarch, DepthMarchParams};
pub use edge_table::{
    Blend, EdgeTable, EdgeTableParams, EdgeTableSwitches, Mask, Preset, PublishedParams, Reading,
};
pub use pcss::{Pcss, PcssParams};
pub use silhouette::{Silhouette, SilhouetteParams};
