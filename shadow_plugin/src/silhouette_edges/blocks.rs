//! Candidates shared by neighbouring points: one walk of the edge tree per block.
//!
//! Neighbouring pixels' points are close together (metal-rough-spheres: 36 um apart, under
//! a light 4 mm wide), and their shafts nearly coincide, so each walked the same nodes of
//! the edge tree and tested the same edges. Space is cut into cubes (a grid per level, the
//! level picked from the origin's distance to the light, so that a cube spans a few pixels'
//! worth of points at any scale); the first point of a cube walks the tree once with the
//! hull of the cube's circumscribed ball and the light ([`Shaft::around_ball`]), and every
//! point in it reads that list, filtered by its own shaft. An edge whose faces have every
//! origin in the ball on one side weighs the same for all of them: its weight is kept, and
//! if it is 0 the edge is dropped for the whole block (most of a smooth mesh's candidates).
//!
//! Exact whatever the cache holds: a block's list holds every edge that meets the hull of
//! any of its points (the ball's hull holds each point's, grown by its slack), which is all
//! the counting needs, and a kept weight is each point's own weight. (A point's own walk
//! may keep a few more edges its rounding margins cannot separate; which path a point takes
//! depends on its origin alone, so the answers do not depend on the order or the threads.)
//! The cache is per thread and direct-mapped, over a store of compact walks every thread
//! reads ([`WalkedBlocks`]); which points walk depends on the order queries arrive in, the
//! answers do not.

use super::candidate::{Candidate, GatherRefusal, block_weight};
use super::edge_tree::EdgeRecord;
use super::edges::EdgeSet;
use super::occluders::OccluderEdges;
use glam::{DVec3, Vec3, Vec3A};
use renderer::geometry::shaft::Shaft;
use renderer::util::random::mix64;
use renderer::{RectLight, Scene};
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// A cube's side is about the origin's distance to the light's centre over this. Measured
/// (silhouette's shadow seconds at 320x240, N = 1024, medians of 3 side by side;
/// flight-helmet, metal-rough-spheres, glass-vase-flowers): 16: 1.49, 1.18, 1.28; 32: 1.47,
/// 1.06, 1.27; 64: 1.57, 1.06, 1.28 (one walk per point before: 1.78, 1.04, 1.30). Larger
/// cubes walk less but hand each point more candidates to filter.
const BLOCK_DIVISOR: f64 = 32.0;

/// Cache entries per thread (direct-mapped): at 320 pixels a row, a cube of a few pixels and
/// a few rows per cube, a band's cubes fit.
const ENTRIES: usize = 256;

/// Most bytes one thread's entries hold in their lists (their allocations); past it, the
/// entries read longest ago are freed (read again from the store, or walked again). Ordinary
/// scenes never come near it: `silhouette` stops a list at twice its candidate limit. But
/// `analytic` reads a block's whole list: on a soup of a million loose 4 mm triangles
/// (`scenes/stress/triangle-soup.toml`) a block held up to 360k candidates (about 77 bytes
/// each), and 256 entries that never gave their memory back took the run to a 9.6 GB peak.
const MAX_CACHED_BYTES: usize = 256 << 20;

/// A block of space: the occluders' build it belongs to ([`OccluderEdges::id`]), its level (cube side 2^level)
/// and its cube.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) struct Key {
    occluders: u64,
    level: i32,
    cube: [i64; 3],
}

impl Key {
    fn slot(&self) -> usize {
        let h = [self.level as u64, self.cube[0] as u64, self.cube[1] as u64, self.cube[2] as u64]
            .iter()
            .fold(mix64(self.occluders), |h, &k| mix64(h ^ k));
        (h % ENTRIES as u64) as usize
    }
}

#[derive(Debug, Default)]
struct Entry {
    key: Option<Key>,
    /// The cache's read count when this entry was last read (the oldest are freed first).
    used: u64,
    /// Why no point reads this block's list: a tree deeper than the traversal's stack, or
    /// more candidates than the counting pays for (the walk stops there).
    refused: Option<GatherRefusal>,
    edges: Vec<u32>,
    candidates: Vec<Candidate>,
    triangles: Vec<u32>,
    /// The kept candidates' positions in the tree's records, and their weights.
    positions: Vec<u32>,
    weights: Vec<i8>,
}

/// One thread's blocks.
#[derive(Debug)]
pub(super) struct Blocks {
    entries: Vec<Entry>,
    /// Reads so far (the entries' `used`).
    reads: u64,
    /// The bound on the entries' bytes ([`MAX_CACHED_BYTES`]; tests set less).
    max_bytes: usize,
}

impl Default for Blocks {
    fn default() -> Self {
        Self { entries: Vec::new(), reads: 0, max_bytes: MAX_CACHED_BYTES }
    }
}

/// What one block gives a point: its candidate edges with their weights over the block, and
/// its flagged triangles.
pub(super) struct BlockList<'a> {
    pub(super) candidates: &'a [Candidate],
    pub(super) triangles: &'a [u32],
}

impl Blocks {
    /// The block holding `origin` for `occluders`, walked if the cache does not hold it;
    /// `None` where no block applies (an origin too near the light for its block's ball, or
    /// coordinates off any grid), `Some(Err)` where the walk could not finish or its list
    /// holds more than `max_candidates` (the same for every point of a preparation: the
    /// sample count's).
    pub(super) fn list(
        &mut self,
        occluders: &OccluderEdges,
        light: &RectLight,
        scene: &Scene,
        origin: Vec3,
        max_candidates: usize,
    ) -> Option<Result<BlockList<'_>, GatherRefusal>> {
        let (key, centre, radius) = block_of(occluders.id, light, origin)?;
        let tree = &occluders.tree;
        if self.entries.is_empty() {
            self.entries.resize_with(ENTRIES, Entry::default);
        }
        let slot = key.slot();
        let entry = &mut self.entries[slot];
        if entry.key != Some(key) {
            // A long list's allocation is not kept for the shorter ones after it.
            if entry.bytes() > self.max_bytes / ENTRIES {
                *entry = Entry::default();
            }
            if let Some(walked) = occluders.walked.get(&key) {
                entry.read(&walked, &tree.records);
            } else {
                entry.walk(occluders, light, scene, (centre, radius), max_candidates)?;
                occluders.walked.offer(key, entry);
            }
            entry.key = Some(key);
            self.free_over_budget(slot);
        }
        self.reads += 1;
        let entry = &mut self.entries[slot];
        entry.used = self.reads;
        Some(match entry.refused {
            None => Ok(BlockList { candidates: &entry.candidates, triangles: &entry.triangles }),
            Some(why) => Err(why),
        })
    }
}

impl Blocks {
    /// Frees the entries read longest ago, other than `keep`, while the lists hold more than
    /// `max_bytes` (`keep`'s alone may: the point reading it needs it whole). The answers do
    /// not depend on what the cache holds.
    fn free_over_budget(&mut self, keep: usize) {
        let mut total: usize = self.entries.iter().map(Entry::bytes).sum();
        while total > self.max_bytes {
            let oldest = (self.entries.iter().enumerate())
                .filter(|&(k, e)| k != keep && e.bytes() > 0)
                .min_by_key(|(_, e)| e.used)
                .map(|(k, _)| k);
            let Some(k) = oldest else { break };
            total -= self.entries[k].bytes();
            self.entries[k] = Entry::default();
        }
    }

    /// Bytes the entries' lists hold.
    #[cfg(test)]
    fn bytes(&self) -> usize {
        self.entries.iter().map(Entry::bytes).sum()
    }
}

impl Entry {
    /// Bytes its lists hold (their allocations).
    fn bytes(&self) -> usize {
        use std::mem::size_of;
        self.edges.capacity() * size_of::<u32>()
            + self.candidates.capacity() * size_of::<Candidate>()
            + self.triangles.capacity() * size_of::<u32>()
            + self.positions.capacity() * size_of::<u32>()
            + self.weights.capacity() * size_of::<i8>()
    }

    /// Walks the tree (and the kept instances) for the block of ball (`centre`, `radius`);
    /// `None` where no shaft holds the ball.
    fn walk(
        &mut self,
        occluders: &OccluderEdges,
        light: &RectLight,
        scene: &Scene,
        (centre, radius): (DVec3, f64),
        max_candidates: usize,
    ) -> Option<()> {
        let (set, tree, kept) = (&occluders.edges, &occluders.tree, &occluders.kept);
        // The ball in f32 for the shaft: the centre's rounding added to the radius.
        let c32 = centre.as_vec3();
        let r32 = ((radius + (centre - c32.as_dvec3()).length()) * (1.0 + 1e-6)) as f32;
        let shaft = Shaft::around_ball(light, c32, r32)?;
        self.edges.clear();
        self.candidates.clear();
        self.triangles.clear();
        self.positions.clear();
        self.weights.clear();
        // About half the edges walked keep a weight over a block (flight-helmet: 45%):
        // twice the candidates allowed ends a walk that cannot give a usable list.
        let max_walked = max_candidates.saturating_mul(2);
        let (edges, triangles) = (&mut self.edges, &mut self.triangles);
        let complete = tree.gather(set, &shaft, (centre, radius), edges, triangles, max_walked);
        self.refused = if edges.len() > max_walked {
            Some(GatherRefusal::TooManyCandidates)
        } else if !complete {
            Some(GatherRefusal::NoShaft)
        } else {
            None
        };
        // The weights over the block; edges that weigh 0 for every point are dropped.
        for &pos in self.edges.iter().take_while(|_| self.refused.is_none()) {
            let r = &tree.records[pos as usize];
            let w = block_weight(r, centre, radius);
            if w != 0 {
                self.candidates.push(Candidate::new(r, w));
                self.positions.push(pos);
                self.weights.push(w);
            }
        }
        // The kept instances' edges, weighed as they are found.
        if self.refused.is_none() {
            let mut walked = self.edges.len();
            let ball = (centre, radius);
            self.refused =
                match kept.gather(scene, &shaft, ball, true, &mut self.candidates, (&mut walked, max_walked))
                {
                    Err(why) => Some(why),
                    Ok(_) if walked > max_walked => Some(GatherRefusal::TooManyCandidates),
                    Ok(false) => Some(GatherRefusal::NoShaft),
                    Ok(true) => None,
                };
        }
        if self.refused.is_none() && self.candidates.len() > max_candidates {
            self.refused = Some(GatherRefusal::TooManyCandidates);
        }
        Some(())
    }

    /// The list a walk stored: the same candidates in the same order.
    fn read(&mut self, walked: &Walked, records: &[EdgeRecord]) {
        self.refused = walked.refused;
        self.candidates.clear();
        self.candidates.extend(
            walked
                .positions
                .iter()
                .zip(&walked.weights)
                .map(|(&p, &w)| Candidate::new(&records[p as usize], w)),
        );
        self.triangles.clear();
        self.triangles.extend_from_slice(&walked.triangles);
    }
}

/// A walk's list, compact (5 bytes a candidate against a [`Candidate`]'s 64).
#[derive(Debug)]
pub(super) struct Walked {
    refused: Option<GatherRefusal>,
    positions: Vec<u32>,
    weights: Vec<i8>,
    triangles: Vec<u32>,
}

/// Stored walks shared by every thread, up to [`MAX_STORED_BYTES`]: a block walked once is
/// read again by any thread whose own cache lost it. The path tracer's bounce points fall
/// all over a scene: under the softbox (160x120, max_depth 5, spp 4) the threads walked
/// 2,882 times for 987 blocks, 21% of the time.
#[derive(Debug, Default)]
pub(crate) struct WalkedBlocks {
    map: Mutex<HashMap<Key, Arc<Walked>>>,
    bytes: AtomicU64,
}

/// The stored walks' memory bound per light (the walks that do not fit are walked again).
const MAX_STORED_BYTES: u64 = 128 << 20;

impl WalkedBlocks {
    fn get(&self, key: &Key) -> Option<Arc<Walked>> {
        self.map.lock().unwrap_or_else(|e| e.into_inner()).get(key).cloned()
    }

    /// Stores `entry`'s walk if it fits and every candidate came from the tree (a kept
    /// instance's are not records).
    fn offer(&self, key: Key, entry: &Entry) {
        if entry.candidates.len() != entry.positions.len() {
            return;
        }
        let bytes = 5 * entry.positions.len() as u64 + 4 * entry.triangles.len() as u64 + 64;
        if self.bytes.load(Ordering::Relaxed) + bytes > MAX_STORED_BYTES {
            return;
        }
        self.bytes.fetch_add(bytes, Ordering::Relaxed);
        let walked = Walked {
            refused: entry.refused,
            positions: entry.positions.clone(),
            weights: entry.weights.clone(),
            triangles: entry.triangles.clone(),
        };
        self.map.lock().unwrap_or_else(|e| e.into_inner()).insert(key, Arc::new(walked));
    }

    /// Bytes held.
    pub(crate) fn bytes(&self) -> u64 {
        self.bytes.load(Ordering::Relaxed)
    }
}

/// The block of `origin`: its key, its ball's centre and radius (f64). The cube's side is
/// the power of two at or under the distance to the light's centre over [`BLOCK_DIVISOR`].
fn block_of(occluders: u64, light: &RectLight, origin: Vec3) -> Option<(Key, DVec3, f64)> {
    let o = origin.as_dvec3();
    let dist = (o - light.center.as_dvec3()).length();
    // floor(log2(x)) from the exponent's bits (normal numbers only; no libm call).
    let x = dist / BLOCK_DIVISOR;
    if !(x.is_normal() && x > 0.0) {
        return None;
    }
    let level = ((x.to_bits() >> 52) & 0x7ff) as i32 - 1023;
    let side = 2f64.powi(level);
    let scaled = o / side;
    // Off any grid we can index (or not a number): no block.
    if !scaled.is_finite() || scaled.abs().max_element() >= 2f64.powi(52) {
        return None;
    }
    let floor = |v: f64| {
        let t = v as i64 as f64;
        if t > v { t - 1.0 } else { t }
    };
    let cell = DVec3::new(floor(scaled.x), floor(scaled.y), floor(scaled.z));
    let centre = (cell + 0.5) * side;
    // Half the cube's diagonal, a rounding over.
    let radius = 0.5 * side * 3f64.sqrt() * (1.0 + 1e-12);
    let cube = [cell.x as i64, cell.y as i64, cell.z as i64];
    Some((Key { occluders, level, cube }, centre, radius))
}

/// Vertex `i` of `set` as the shaft tests read it.
#[inline(always)]
pub(super) fn vertex_a(set: &EdgeSet, i: u32) -> Vec3A {
    Vec3A::from(set.vertices[i as usize])
}

#[cfg(test)]
mod tests {
    use super::*;
    use renderer::Camera;
    use renderer::load::gltf_load::Geometry;
    use std::time::Duration;

    /// A cache bounded far under its blocks' lists holds at most its bound (or the one list
    /// being read, alone), frees the entries read longest ago, and gives every point the
    /// same list as an unbounded cache: 1,600 tilted 2 cm quads under a 1 m light, read from
    /// 225 blocks twice over.
    #[test]
    fn the_cache_holds_its_bound_and_the_same_lists() {
        let mut g = Geometry::default();
        for k in 0..1600 {
            let (i, j) = ((k % 40) as f64, (k / 40) as f64);
            let centre = DVec3::new(-0.6 + 0.03 * i, 1.2 + 0.01 * (k % 7) as f64, -0.6 + 0.03 * j);
            let tilt = 0.3 * ((k % 5) as f64 - 2.0);
            g.add_quad(centre, DVec3::new(0.02, 0.02 * tilt, 0.0), DVec3::new(0.0, 0.0, -0.02), [0.5; 3]);
        }
        let light = RectLight::new(Vec3::new(0.0, 2.0, 0.0), Vec3::X, Vec3::Z, Vec3::ONE);
        let camera = Camera::look_at(Vec3::new(0.0, 1.5, 2.5), Vec3::ZERO, Vec3::Y, 40.0);
        let scene = Scene::build(g, vec![light], camera, DVec3::ZERO, Duration::ZERO);
        let (bounded_set, reference_set) =
            (OccluderEdges::build(&scene, &light), OccluderEdges::build(&scene, &light));
        let mut bounded = Blocks { max_bytes: 256 << 10, ..Blocks::default() };
        let mut reference = Blocks { max_bytes: usize::MAX, ..Blocks::default() };
        let origins: Vec<Vec3> = (0..225)
            .map(|k| Vec3::new(-0.5 + 0.07 * (k % 15) as f32, 0.0, -0.5 + 0.07 * (k / 15) as f32))
            .collect();
        let list = |b: &mut Blocks, set: &OccluderEdges, o: Vec3| {
            let got = b.list(set, &light, &scene, o, usize::MAX).expect("a block").expect("a list");
            let edges: Vec<_> = got.candidates.iter().map(|c| (c.edge, c.weight, c.a, c.b)).collect();
            (edges, got.triangles.to_vec())
        };
        let mut longest = 0;
        for &o in origins.iter().chain(&origins) {
            let want = list(&mut reference, &reference_set, o);
            assert_eq!(list(&mut bounded, &bounded_set, o), want, "origin {o}");
            longest = longest.max(want.0.len());
            let largest = bounded.entries.iter().map(Entry::bytes).max().unwrap_or(0);
            assert!(bounded.bytes() <= bounded.max_bytes.max(largest), "{} bytes", bounded.bytes());
        }
        // The bound was met: the unbounded cache holds several times it.
        assert!(longest > 1000, "{longest} candidates in the longest list");
        assert!(reference.bytes() > 4 * bounded.max_bytes, "{} bytes unbounded", reference.bytes());
    }
}
