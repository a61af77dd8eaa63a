//! The run report (`PATH.json`), as the contract defines it plus what users ask next.

use serde::Serialize;
use std::collections::BTreeMap;

#[derive(Debug, Clone, Serialize)]
pub struct Timings {
    pub load: f64,
    pub bvh: f64,
    pub shadow_prepare: f64,
    pub render: f64,
    pub total: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct RunReport {
    pub scene: String,
    pub method: String,
    pub samples: u32,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub threads: usize,
    pub seed: u64,
    pub lights: usize,
    pub triangles: u64,
    /// Triangles dropped at load, for any reason (`warnings` says which).
    pub degenerate_triangles: u64,
    pub timings_s: Timings,
    pub counters: BTreeMap<String, u64>,
    /// Files written, relative to the working directory as given.
    pub outputs: Vec<String>,
    /// One line each, as printed on stderr after `warning: `: triangles dropped and why, a
    /// light that reaches no visible point, a camera that sees nothing (lit), geometry f32
    /// cannot keep precise and how precise the visible part is. Empty when all is well.
    pub warnings: Vec<String>,
}
