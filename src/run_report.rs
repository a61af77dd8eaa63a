//! The run report (`PATH.json`), as the contract defines it plus what users ask next.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Wall time of each phase, in seconds; the phases before `total` add up to it (to within
/// the report's own serialisation and the final renames).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
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

impl Timings {
    /// Adds `other`'s phases to these (tiles' timings, summed).
    pub fn add(&mut self, other: &Timings) {
        self.load += other.load;
        self.bvh += other.bvh;
        self.visible_points += other.visible_points;
        self.shadow_prepare += other.shadow_prepare;
        self.render += other.render;
        self.write += other.write;
        self.total += other.total;
    }
}

/// `--profile`'s sums over the image: the time of the pixels' shading (summed over threads,
/// so about `render` minus the primary rays, times the threads) and the shadow work.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
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
        costs: &[renderer::util::pixel_cost::PixelCost],
        vertices: &[renderer::integrator::path::VertexQueries],
    ) -> Self {
        let (shading_s, w) = renderer::util::pixel_cost::totals(costs);
        let shadow_s_by_vertex = vertices.iter().map(|v| v.seconds).collect();
        ProfileTotals { shading_s, rays: w.rays, shafts: w.shafts, lookups: w.lookups, shadow_s_by_vertex }
    }

    /// Adds another tile's totals to these.
    pub fn add(&mut self, other: &ProfileTotals) {
        self.shading_s += other.shading_s;
        self.rays += other.rays;
        self.shafts += other.shafts;
        self.lookups += other.lookups;
        let v = &mut self.shadow_s_by_vertex;
        v.resize(v.len().max(other.shadow_s_by_vertex.len()), 0.0);
        v.iter_mut().zip(&other.shadow_s_by_vertex).for_each(|(a, b)| *a += b);
    }
}

/// The shading of reports written before `shading` was reported.
fn gltf_shading() -> String {
    "gltf".into()
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunReport {
    pub scene: String,
    pub method: String,
    pub samples: u32,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// Longest path (2 = direct light only).
    pub max_depth: u32,
    /// How materials were shaded: `"gltf"` or `"diffuse"` (`[materials] shading`,
    /// `--shading`).
    #[serde(default = "gltf_shading")]
    pub shading: String,
    pub threads: usize,
    pub seed: u64,
    pub lights: usize,
    /// Triangles rendered: every instance's, flattened.
    pub triangles: u64,
    /// Triangles of the distinct meshes (each counted once however many nodes place it),
    /// and the placements: glTF nodes with a mesh, and quads.
    #[serde(default)]
    pub unique_triangles: u64,
    #[serde(default)]
    pub instances: u64,
    /// Instances kept unflattened (a scene too big to flatten: each mesh stored once).
    #[serde(default)]
    pub kept_instances: u64,
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
    /// A tile's report only (`render --tile`): which tile, and what the merge needs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tile: Option<TileInfo>,
    /// A merged report only (`merge`): each tile's run. `timings_s` is then their sum (the
    /// machine time the farm spent, not the time it took), `threads` the most any tile used.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tiles: Option<Vec<TileRun>>,
}

/// What a tile's report holds beyond a render's: which rows it is, of what, and what the
/// merge needs to give the whole frame's report.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TileInfo {
    /// Tile `index` (0-based) of `count`.
    pub index: u32,
    pub count: u32,
    /// The rows it holds, `[first, end)`, of the frame's `height`.
    pub rows: [u32; 2],
    /// A hash of the scene's files, the settings that change pixels and the program's
    /// version: tiles merge only with tiles of the same fingerprint.
    pub fingerprint: String,
    /// A hash of its pixels as its files hold them ([`crate::tile::PixelDigest`]).
    pub pixels: String,
    /// Whether its visibility AOVs and cost layers were written.
    pub aov: bool,
    pub profile: bool,
    /// The counters as they stood after `prepare` (the same in every tile).
    pub prepare_counters: BTreeMap<String, u64>,
    /// What the frame's warnings are made of, over its rows.
    pub tally: renderer::FrameTally,
    /// The scene's and the shadow methods' warnings (the same in every tile); `warnings`
    /// holds these too, but none of the frame's, which only the whole frame can say.
    pub scene_warnings: Vec<String>,
    pub method_warnings: Vec<String>,
}

/// One tile's run, as a merged report keeps it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TileRun {
    pub index: u32,
    pub rows: [u32; 2],
    pub threads: usize,
    pub timings_s: Timings,
}
