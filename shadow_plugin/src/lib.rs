//! Depth-map shadow methods for penumbra: `edge_table` (Egan & Neulander 2004), its per-ray
//! baseline and oracle `depth_march` (retired from the CLI's registry, kept as a library),
//! and the real-time baseline `pcss` (Fernando 2005), all on one light-space depth map.

pub mod bits;
pub mod depth_map;
pub mod depth_march;
pub mod edge_table;
pub mod fallback;
pub mod heightfield;
pub mod march;
pub mod pcss;
pub mod samples;
pub mod silhouette;

pub use depth_map::{DepthMap, DepthMapParams, LightFrame, MapSwitches};
pub use depth_march::{DepthMarch, DepthMarchParams};
pub use edge_table::{
    Blend, EdgeTable, EdgeTableParams, EdgeTableSwitches, Mask, Preset, PublishedParams, Reading,
};
pub use heightfield::Heightfield;
pub use pcss::{Pcss, PcssParams};
pub use silhouette::{Silhouette, SilhouetteParams};
