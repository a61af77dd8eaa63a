//! The run report (`PATH.json`), as the contract defines it plus what users ask next.

use serde::Serialize;
use std::collections::BTreeMap;

/// Wall time of each phase, in seconds; the phases before `total` add up to it (to within
/// the report's own serialisation and the final renames).
#[derive(Debug, Clone, Serialize)]
pub struct Timings {
    /// Reading the scene file and the glTF files, to render space (everything before the BVH).
    pub load: f64,
    pub bvh: f64,
    /// Gathering the primary hits into the points every method's `prepare` reads.
    pub visible_points: f64,
    /// Every light's `prepare` (depth maps, masks).
    pub shadow_prepare: f64,
    /// The pixel loop: primary rays, shading and shadow queries.
    pub render: f64,
    /// Encoding and writing the outputs (the report itself excepted).
    pub write: f64,
    pub total: f64,
}

/// `--profile`'s sums over the image: the time of the pixels' shading (summed over threads,
/// so about `render` minus the primary rays, times the threads) and the shadow work.
#[derive(Debug, Clone, Serialize)]
pub struct ProfileTotals {
    pub shading_s: f64,
    pub rays: u64,
    pub shafts: u64,
    pub lookups: u64,
    /// Seconds inside the shadow queries, per path vertex (first: the primary hits), summed
    /// over threads.
    pub shadow_s_by_vertex: Vec<f64>,
}

impl ProfileTotals {
    pub fn of(
        costs: &[renderer::util::profile::PixelCost],
        vertices: &[renderer::integrator::path::VertexQueries],
    ) -> Self {
        let (shading_s, w) = renderer::util::profile::totals(costs);
        let shadow_s_by_vertex = vertices.iter().map(|v| v.seconds).collect();
        ProfileTotals { shading_s, rays: w.rays, shafts: w.shafts, lookups: w.lookups, shadow_s_by_vertex }
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct RunReport {
    pub scene: String,
    pub method: String,
    pub samples: u32,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// Longest path (2 = direct light only).
    pub max_depth: u32,
    pub threads: usize,
    pub seed: u64,
    pub lights: usize,
    pub triangles: u64,
    /// Triangles dropped at load, for any reason (`warnings` says which).
    pub degenerate_triangles: u64,
    pub timings_s: Timings,
    /// With `--profile` only.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub profile: Option<ProfileTotals>,
    pub counters: BTreeMap<String, u64>,
    /// Files written, relative to the working directory as given.
    pub outputs: Vec<String>,
    /// One line each, as printed on stderr after `warning: `: triangles dropped and why, a
    /// light that reaches no visible point, a camera that sees nothing (lit), geometry f32
    /// cannot keep precise and how precise the visible part is. Empty when all is well.
    pub warnings: Vec<String>,
}
