//! `edge_table`: soft shadows by ray tracing a depth map with precomputed edge tables
//! (Egan & Neulander, "Ray Tracing Depth Maps Using Precomputed Edge Tables", SIGGRAPH 2004
//! sketch), with trilinear blending across masks.
//!
//! Because the depth map's centre of projection lies on the (planar) light and its axis is
//! the light's normal, the normalised height at which a shadow ray crosses a pixel-frustum
//! side depends only on the side's position relative to P's pixel, P's offset inside its
//! pixel, P's depth and the light sample, not on P's absolute pixel (the shear invariance).
//! So a *mask* built for one (sub-pixel offset, depth, light-sample set) serves every pixel:
//! for each pixel of its filter region it stores the crossings of its N rays into that
//! pixel, sorted by height, with cumulative bitmasks (bit r cleared once ray r has entered
//! at or below that height). A query then costs one binary search and one N-bit AND per
//! pixel of the region instead of N separate marches.
//!
//! The per-pixel table is the union of the pixel's (one or two) in-edges: under the
//! solid-heightfield reading, "AND every wall and floor" reduces exactly to "AND over pixels
//! of Below(floor height)" (technical note, section 5.4), so one search per pixel suffices.
//!
//! | key (`[shadows.edge_table]`) | type | default | meaning |
//! |---|---|---|---|
//! | `depth_map` | int | 256 | depth-map pixels per side |
//! | `preset` | "paper" / "balanced" / "fine" | "balanced" | the starting point the other keys override |
//! | `grid` | [int; 3] | [2, 2, 8] | masks over (sub-pixel x, sub-pixel y, depth) |
//! | `blend` | "nearest" / "trilinear" | "nearest" | take the nearest mask, or blend the 8 (4 with one depth level) nearest masks' visibilities |
//! | `heightfield` | "plates" / "shells" / "solid" | "plates" | how the depth map is read ([`Heightfield`]) |
//! | `slope_bias` | float | 1.0 | slope-scaled depth bias, in pixels |
//! | `slab_thickness` | float | 2.0 | `plates`: each floor is a slab this many pixel footprints thick |
//! | `normal_offset` | float | 0.5 | lookups move along the normal by this many pixel footprints times (1 - cos) of the light's axis |
//! | `hidden_layer` | bool | true | `plates`: a second depth layer, the first surface under each pixel's slab, read like the first (a ray is blocked by a slab of either) |
//! | `closed_volumes` | bool | true | `plates`: a closed mesh is solid from its front face down to its back face (a second depth layer) |
//! | `grazing_cos` | float | 0.5 | receivers whose geometric normal's cosine to the direction of the light's centre is below this are answered by traced rays (counted as `fallbacks_grazing`); 0 turns it off |
//! | `fit_shadowed` | bool | true | fit the map to the receivers whose shaft to the light is not clear; the others are traced (a clear shaft answers at once) |
//! | `mirrored` | bool | true | build only the masks at sub-pixel offsets up to 1/2 and read the others as their mirror images (the same crossings, bit for bit; `paper`: false) |
//!
//! `samples` (`[shadows]`) is the number of rays per mask (at most 4096).
//!
//! ```toml
//! [shadows]
//! method = "edge_table"
//! samples = 1024
//! [shadows.edge_table]
//! depth_map = 256
//! grid = [2, 2, 8]
//! blend = "nearest"
//! heightfield = "plates"
//! ```

use crate::bits::{self, MAX_SAMPLES, MAX_WORDS};
use crate::depth_map::{DepthMap, DepthMapParams};
use crate::fallback::{Located, MapFallback, OnMap};
pub use crate::heightfield::Heightfield;
use crate::march::{floor_height, for_each_crossing, stop_height};
use crate::samples;
use glam::Vec2;
use rayon::prelude::*;
use renderer::sampling::{Rng, stream_seed};
use renderer::{LightShadowing, PrepareContext, Scene, ShadowError, ShadowQuery};
use std::sync::atomic::{AtomicU64, Ordering};

/// How visibilities of neighbouring masks combine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Blend {
    /// The mask nearest in sub-pixel offset and (log) depth.
    Nearest,
    /// Trilinear weights over the 8 surrounding masks (4 with a single depth level); the
    /// visibility fractions are blended, never the bits (each mask has its own samples).
    Trilinear,
}

/// Parameters of the edge-table method. See the module doc for the scene-file keys.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeTableParams {
    pub depth_map: DepthMapParams,
    /// Masks over (sub-pixel x, sub-pixel y, depth). Sub-pixel samples are cell-centred,
    /// (a + 1/2) / n; depth levels are at the (k + 1/2) / n quantiles of the depths of the
    /// receivers the light reaches.
    pub grid: [u32; 3],
    pub blend: Blend,
    /// How the depth map's heightfield is read (variant A or B).
    pub heightfield: Heightfield,
    /// Build only the masks with sub-pixel offsets at most 1/2 and read the others as their
    /// mirror images (technical note 10.2): a point at offset (1 - fx, fy) seen through the
    /// mask at (fx, fy) with pixel columns and the samples' x reflected gets the same
    /// crossings, bit for bit. 4x fewer masks on a 4 x 4 grid (less memory, less to build,
    /// more of it in cache); a mirrored pair shares its (reflected) samples.
    pub mirrored: bool,
}

impl EdgeTableParams {
    /// The paper's configuration: 256^2 map, 4 x 4 x 1 masks, nearest mask, walls and floors;
    /// the map itself is this crate's (closed volumes and the hidden layer, which `shells`
    /// does not read, and grazed receivers traced).
    pub const fn paper() -> Self {
        Self {
            depth_map: DepthMapParams::new(256),
            grid: [4, 4, 1],
            blend: Blend::Nearest,
            heightfield: Heightfield::Shells,
            mirrored: false,
        }
    }
    /// The default, chosen by measurement (docs/edge_table_accuracy.md, ARCHITECTURE.md):
    /// 256^2 map, 2 x 2 x 8 masks, nearest mask, thin plates. Depth levels matter more than
    /// sub-pixel ones (a mask read at another depth sees the light scaled); against 4 x 4 x 4
    /// it has the same RMSE to within 0.0004 on six of seven scenes at under half the mask
    /// memory, and error^2 x cost 0.75x-1.0x of that grid's in the accuracy run and
    /// 0.76x-1.03x in the bench (ARCHITECTURE.md); 8 x 8 x 4 grids and trilinear blending
    /// lower the error less per unit of cost.
    pub const fn balanced() -> Self {
        Self {
            depth_map: DepthMapParams::new(256),
            grid: [2, 2, 8],
            blend: Blend::Nearest,
            heightfield: Heightfield::Plates,
            mirrored: true,
        }
    }
    /// Finer and slower: 512^2 map, 8 x 8 x 4 masks, trilinear.
    pub const fn fine() -> Self {
        Self {
            depth_map: DepthMapParams::new(512),
            grid: [8, 8, 4],
            blend: Blend::Trilinear,
            heightfield: Heightfield::Plates,
            mirrored: true,
        }
    }
}

impl Default for EdgeTableParams {
    fn default() -> Self {
        Self::balanced()
    }
}

/// A table of crossings sorted by height with cumulative bitmasks: crossings
/// `start..start + len` of the mask's `heights` / `masks`.
#[derive(Debug, Clone, Copy)]
struct Table {
    start: u32,
    len: u32,
    /// Partial bitmasks (the sketch's "grouping nearby rays"): rays are sorted by angle, so
    /// the rays crossing into or out of one pixel occupy a short run of words. Only words
    /// `word0..word0 + span` are stored (at `masks[mask_start + k * span..]` for crossing
    /// k); bits outside them are 1. Measured (with one table per side, then): 4x fewer
    /// words than full masks on the default scene's masks.
    word0: u32,
    span: u32,
    mask_start: u32,
    /// The lowest crossing height: a floor below it blocks nothing here.
    first: f32,
}

/// One pixel-frustum side of a mask's region, as the rays cross it from pixel `from` into
/// pixel `to` (indices into `Mask::cells`): only the `shells` reading's walls need a side
/// on its own.
#[derive(Debug, Clone, Copy)]
struct Side {
    from: u32,
    to: u32,
    table: Table,
}

const NONE: u32 = u32::MAX;

/// A pixel of a mask's region (relative to the model point's pixel) and its tables.
#[derive(Debug, Clone, Copy)]
struct Cell {
    dx: i32,
    dy: i32,
    /// The crossings into this pixel through either of its (at most two) in-sides, merged
    /// into one table, and those out of it through its (up to four) out-sides: a ray's path
    /// is monotone in x and y, so it enters a pixel at most once and leaves it at most once,
    /// and the merged table's Below(q) is the AND of its sides'. Indices into
    /// `Mask::tables`; NONE for none (the own pixel has no in-table, and its out-sides
    /// are kept apart: `Mask::own_out`). Measured against one
    /// table per side (same bits): half the searches, render + prepare 0.67x-0.91x on six of
    /// the seven accuracy scenes (toy-car, mostly traced fallbacks, 1.03x), at 1.6x-2.05x
    /// the mask memory (ARCHITECTURE.md).
    in_table: u32,
    out_table: u32,
    /// The lowest crossing into this pixel (+inf for the own pixel).
    in_first: f32,
    /// The highest crossing out of this pixel when every ray that enters it (starts in
    /// it, for the own pixel) also leaves it within the march; +inf when some ray's march
    /// ends inside it. A slab whose bottom is at or above it blocks nothing here.
    out_last: f32,
}

/// A square block of a mask's region (`BLOCK` x `BLOCK` pixels, aligned to the model
/// point's pixel) for hierarchical culling (technical note 10.3b): its cells are
/// `cells[start..end]`, in order of `in_first`, inside the pixel box `lo..=hi` relative to
/// the model point's pixel.
#[derive(Debug, Clone, Copy)]
struct Block {
    lo: [i32; 2],
    hi: [i32; 2],
    /// The lowest crossing into any of its pixels.
    first: f32,
    start: u32,
    end: u32,
}

/// Side of a culling block, in pixels. A block is skipped when the highest floor the map
/// has anywhere over it (one min-depth pyramid lookup, at most 25 reads) is below every
/// crossing into it.
const BLOCK: i32 = 8;

/// One edge-table mask.
#[derive(Debug, Clone)]
pub struct Mask {
    /// The model point's offset inside its pixel and its depth.
    pub offset: Vec2,
    pub depth: f32,
    /// Light samples (light frame, z = 0).
    pub samples: Vec<Vec2>,
    words: usize,
    /// Cell 0 is the own pixel; the rest grouped by block (blocks in order of `first`), in
    /// order of `in_first` within a block.
    cells: Vec<Cell>,
    blocks: Vec<Block>,
    /// Whether queries skip blocks by their highest floor (off only to measure it).
    cull_blocks: bool,
    /// The cells' in- and out-tables, in cell order (a cell's two tables are neighbours).
    tables: Vec<Table>,
    /// One table per side, in order of `first`, for the `shells` reading's walls; empty
    /// when built without walls.
    sides: Vec<Side>,
    walls: bool,
    /// Crossing heights, grouped by table (the cells', then the sides'), ascending within
    /// a table.
    heights: Vec<f32>,
    /// Cumulative bitmasks, `span` words per crossing: ray bits still set = not yet
    /// crossed at or below that height.
    masks: Vec<u64>,
    full: Vec<u64>,
    crossings: usize,
    /// The own pixel's crossings out, one table per side it has (shared with `sides` when
    /// built with walls): its rays leave in every direction, so one merged table would
    /// store all `words` per crossing (with 1024 samples in `benches/edge_table.rs`'s small
    /// region, the mask takes 492 KB with it and 428 KB without).
    own_out: [Option<Table>; 4],
    /// The normalised height up to which rays were marched: queries needing more fall back.
    pub h_max: f32,
}

/// Appends a table of `crossings` (height, ray), sorted here, to `heights` / `masks`.
fn push_table(
    crossings: &mut [(f32, u32)],
    full: &[u64],
    heights: &mut Vec<f32>,
    masks: &mut Vec<u64>,
) -> Table {
    crossings.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let word_lo = crossings.iter().map(|c| c.1 as usize / 64).min().unwrap_or(0);
    let word_hi = crossings.iter().map(|c| c.1 as usize / 64).max().unwrap_or(0);
    let table = Table {
        start: heights.len() as u32,
        len: crossings.len() as u32,
        word0: word_lo as u32,
        span: (word_hi - word_lo + 1) as u32,
        mask_start: masks.len() as u32,
        first: crossings.first().map_or(f32::INFINITY, |c| c.0),
    };
    let mut current = [0u64; MAX_WORDS];
    let current = &mut current[..=word_hi - word_lo];
    current.copy_from_slice(&full[word_lo..=word_hi]);
    for &(h, r) in crossings.iter() {
        current[r as usize / 64 - word_lo] &= !(1u64 << (r % 64));
        heights.push(h);
        masks.extend_from_slice(current);
    }
    table
}

impl Mask {
    /// Builds a mask for a model point at `offset` inside its pixel and at depth `depth`,
    /// marching every ray up to the normalised height `h_stop`, for every reading of the
    /// depth map (with the `shells` reading's per-side tables).
    pub fn build(offset: Vec2, depth: f32, samples: Vec<Vec2>, pitch: f32, h_stop: f32) -> Self {
        Self::build_for(Heightfield::Shells, offset, depth, samples, pitch, h_stop)
    }

    /// [`Mask::build`] for queries with `heightfield` only: the per-side tables, as large as
    /// the rest of the mask, are kept for `shells` alone.
    pub fn build_for(
        heightfield: Heightfield,
        offset: Vec2,
        depth: f32,
        mut samples: Vec<Vec2>,
        pitch: f32,
        h_stop: f32,
    ) -> Self {
        // Rays in order of direction, so that the rays crossing into or out of any one pixel
        // are neighbours in the bit order (see `Table::span`).
        samples.sort_by(|a, b| {
            a.y.atan2(a.x).total_cmp(&b.y.atan2(b.x)).then(a.length_squared().total_cmp(&b.length_squared()))
        });
        let n = samples.len();
        let words = bits::words(n);
        // (pixel entered, axis crossed, height, ray)
        let mut crossings: Vec<([i32; 2], u8, f32, u32)> = Vec::new();
        for (r, s) in samples.iter().enumerate() {
            for_each_crossing(offset, *s, depth * pitch, h_stop, |c, axis, h| {
                crossings.push((c, axis, h, r as u32));
                true
            });
        }
        // By side (pixel entered, axis), then height and ray.
        crossings.sort_unstable_by(|a, b| {
            (a.0[1], a.0[0], a.1).cmp(&(b.0[1], b.0[0], b.1)).then(a.2.total_cmp(&b.2)).then(a.3.cmp(&b.3))
        });
        let mut full = vec![0u64; words];
        bits::fill_first(&mut full, n);
        // Rays move monotonically, so every ray crosses a side the same way: from the
        // neighbour nearer the own pixel's row or column.
        let from_of = |to: [i32; 2], axis: u8| {
            let mut from = to;
            let k = to[axis as usize];
            from[axis as usize] = if k > 0 { k - 1 } else { k + 1 };
            from
        };
        // The region's pixels, the own pixel first, and per pixel its crossings in and out.
        let mut cell_index: std::collections::HashMap<[i32; 2], u32> = std::collections::HashMap::new();
        let mut pixels: Vec<[i32; 2]> = vec![[0, 0]];
        cell_index.insert([0, 0], 0);
        let mut cell_of = |c: [i32; 2]| -> u32 {
            *cell_index.entry(c).or_insert_with(|| {
                pixels.push(c);
                pixels.len() as u32 - 1
            })
        };
        // (from, to) cells of each crossing's side (a side's crossings are neighbours).
        let mut side_cells: Vec<(u32, u32)> = Vec::with_capacity(crossings.len());
        for (k, &(to, axis, _, _)) in crossings.iter().enumerate() {
            let same_side = k > 0 && crossings[k - 1].0 == to && crossings[k - 1].1 == axis;
            let cells = if same_side { side_cells[k - 1] } else { (cell_of(from_of(to, axis)), cell_of(to)) };
            side_cells.push(cells);
        }
        // Per pixel: how many crossings enter and leave it, the lowest entering and the
        // highest leaving. A ray enters a pixel at most once and leaves it at most once:
        // when as many crossings leave a pixel as enter it (n start in the own pixel), every
        // ray that enters also leaves, and the last of them to leave sets `out_last`.
        let count = pixels.len();
        let (mut in_count, mut out_count) = (vec![0u32; count], vec![0u32; count]);
        let (mut in_first, mut last_out) = (vec![f32::INFINITY; count], vec![f32::NEG_INFINITY; count]);
        for (&(_, _, h, _), &(f, t)) in crossings.iter().zip(&side_cells) {
            let (f, t) = (f as usize, t as usize);
            in_count[t] += 1;
            out_count[f] += 1;
            in_first[t] = in_first[t].min(h);
            last_out[f] = last_out[f].max(h);
        }
        let out_last: Vec<f32> = (0..count)
            .map(|k| {
                let entering = if k == 0 { n as u32 } else { in_count[k] };
                if out_count[k] == entering { last_out[k] } else { f32::INFINITY }
            })
            .collect();
        // Cells by block (blocks in order of their lowest crossing), then by their own
        // lowest crossing.
        let block_of = |c: [i32; 2]| [c[0].div_euclid(BLOCK), c[1].div_euclid(BLOCK)];
        let mut block_first: std::collections::HashMap<[i32; 2], f32> = std::collections::HashMap::new();
        for k in 1..count {
            let f = block_first.entry(block_of(pixels[k])).or_insert(f32::INFINITY);
            *f = f.min(in_first[k]);
        }
        let key: Vec<(f32, [i32; 2])> = pixels
            .iter()
            .map(|&c| (block_first.get(&block_of(c)).copied().unwrap_or(0.0), block_of(c)))
            .collect();
        let mut cell_order: Vec<usize> = (1..count).collect();
        cell_order.sort_by(|&a, &b| {
            let (ka, kb) = (key[a], key[b]);
            ka.0.total_cmp(&kb.0)
                .then(ka.1.cmp(&kb.1))
                .then(in_first[a].total_cmp(&in_first[b]))
                .then(a.cmp(&b))
        });
        cell_order.insert(0, 0);
        let mut new_cell = vec![0u32; count];
        for (new, &old) in cell_order.iter().enumerate() {
            new_cell[old] = new as u32;
        }
        // Every crossing twice, bucketed by (cell in its new order, in / out): the cells'
        // tables in the order queries visit them.
        let mut bucket_start = vec![0usize; 2 * count + 1];
        // The own pixel's crossings out are kept per side (`own_out`), not bucketed.
        for (new, &old) in cell_order.iter().enumerate() {
            bucket_start[2 * new + 1] = in_count[old] as usize;
            bucket_start[2 * new + 2] = if old == 0 { 0 } else { out_count[old] as usize };
        }
        for k in 1..bucket_start.len() {
            bucket_start[k] += bucket_start[k - 1];
        }
        let mut fill = bucket_start.clone();
        let mut bucketed = vec![(0.0f32, 0u32); bucket_start[2 * count]];
        for (&(_, _, h, r), &(f, t)) in crossings.iter().zip(&side_cells) {
            let out_slot = (f != 0).then(|| 2 * new_cell[f as usize] as usize + 1);
            for slot in std::iter::once(2 * new_cell[t as usize] as usize).chain(out_slot) {
                bucketed[fill[slot]] = (h, r);
                fill[slot] += 1;
            }
        }
        let (mut tables, mut heights, mut masks) =
            (Vec::new(), Vec::with_capacity(bucketed.len()), Vec::new());
        let mut table_of = |bucket: usize| {
            let list = &mut bucketed[bucket_start[bucket]..bucket_start[bucket + 1]];
            if list.is_empty() {
                return NONE;
            }
            tables.push(push_table(list, &full, &mut heights, &mut masks));
            tables.len() as u32 - 1
        };
        let cells: Vec<Cell> = cell_order
            .iter()
            .enumerate()
            .map(|(new, &k)| Cell {
                dx: pixels[k][0],
                dy: pixels[k][1],
                in_table: table_of(2 * new),
                out_table: table_of(2 * new + 1),
                in_first: in_first[k],
                out_last: out_last[k],
            })
            .collect();
        // Per side (a run of `crossings`): a table for the own pixel's out-sides, and with
        // walls for every side.
        let walls = heightfield == Heightfield::Shells;
        let (mut own_out, mut sides) = ([None; 4], Vec::new());
        let mut list = Vec::new();
        let mut i = 0;
        while i < crossings.len() {
            let (to, axis) = (crossings[i].0, crossings[i].1);
            let end = crossings[i..]
                .iter()
                .position(|c| c.0 != to || c.1 != axis)
                .map_or(crossings.len(), |k| i + k);
            let (f, t) = side_cells[i];
            if walls || f == 0 {
                list.clear();
                list.extend(crossings[i..end].iter().map(|c| (c.2, c.3)));
                let table = push_table(&mut list, &full, &mut heights, &mut masks);
                if f == 0 {
                    let free = own_out.iter().position(Option::is_none).expect("a pixel has at most 4 sides");
                    own_out[free] = Some(table);
                }
                if walls {
                    sides.push(Side { from: new_cell[f as usize], to: new_cell[t as usize], table });
                }
            }
            i = end;
        }
        sides.sort_by(|a, b| a.table.first.total_cmp(&b.table.first));
        let mut blocks: Vec<Block> = Vec::new();
        for (k, c) in cells.iter().enumerate().skip(1) {
            let b = block_of([c.dx, c.dy]);
            match blocks.last_mut() {
                Some(last)
                    if block_of([cells[last.start as usize].dx, cells[last.start as usize].dy]) == b =>
                {
                    last.lo = [last.lo[0].min(c.dx), last.lo[1].min(c.dy)];
                    last.hi = [last.hi[0].max(c.dx), last.hi[1].max(c.dy)];
                    last.first = last.first.min(c.in_first);
                    last.end = k as u32 + 1;
                }
                _ => blocks.push(Block {
                    lo: [c.dx, c.dy],
                    hi: [c.dx, c.dy],
                    first: c.in_first,
                    start: k as u32,
                    end: k as u32 + 1,
                }),
            }
        }
        Mask {
            offset,
            depth,
            samples,
            words,
            cells,
            blocks,
            cull_blocks: true,
            tables,
            sides,
            walls,
            heights,
            masks,
            full,
            crossings: crossings.len(),
            own_out,
            h_max: h_stop,
        }
    }

    /// The same mask with hierarchical culling off: the same bits, every pixel visited (for
    /// measuring the culling side by side).
    #[doc(hidden)]
    pub fn without_block_culling(self) -> Self {
        Self { cull_blocks: false, ..self }
    }

    pub fn bytes(&self) -> u64 {
        (self.cells.len() * std::mem::size_of::<Cell>()
            + self.blocks.len() * std::mem::size_of::<Block>()
            + (self.tables.len() + self.own_out.iter().flatten().count()) * std::mem::size_of::<Table>()
            + self.sides.len() * std::mem::size_of::<Side>()
            + self.heights.len() * 4
            + self.masks.len() * 8
            + self.samples.len() * 8) as u64
    }

    /// Ray-side crossings marched (each is stored in its pixels' in- and out-tables, and in
    /// its side's table with walls).
    pub fn crossings(&self) -> usize {
        self.crossings
    }

    /// Below(q) of a table: the cumulative mask of its crossings at or below `q` (ties
    /// count as below), as (first word, words); bits outside are 1. None (all 1) when no
    /// crossing is at or below `q`.
    #[inline]
    fn below(&self, t: &Table, q: f32) -> Option<(usize, &[u64])> {
        if q < t.first {
            return None;
        }
        let range = t.start as usize..(t.start + t.len) as usize;
        let k = self.heights[range].partition_point(|&h| h <= q) - 1;
        let span = t.span as usize;
        Some((t.word0 as usize, &self.masks[t.mask_start as usize + k * span..][..span]))
    }

    /// Below(q) of table `t` of `Mask::tables` (None for NONE).
    #[inline]
    fn below_table(&self, t: u32, q: f32) -> Option<(usize, &[u64])> {
        if t == NONE { None } else { self.below(&self.tables[t as usize], q) }
    }
    /// Unblocked-ray bits for a point at depth `pz` whose mask-relative pixel is `base`,
    /// considering crossings below the normalised height `h_stop` (at most
    /// [`Mask::h_max`]): bit r is 1 iff ray r is not blocked by the heightfield read as
    /// `heightfield`.
    pub fn query(
        &self,
        map: &DepthMap,
        base: [i32; 2],
        pz: f32,
        h_stop: f32,
        heightfield: Heightfield,
        out: &mut [u64],
    ) -> QueryStats {
        self.query_mirrored(map, base, [false; 2], pz, h_stop, heightfield, out)
    }

    /// [`Mask::query`] for the mirror image of this mask: with `mirror[0]`, a point at
    /// offset (1 - fx, fy) in pixel `base` (the mask's pixel columns reflected, cell dx read
    /// at `base.x - dx`), whose bit r is the ray to sample r reflected in x (`mirror[1]`
    /// likewise in y). The crossings are the same numbers: (k - fx) and ((1 - k) - (1 - fx))
    /// round alike, and a side's s = (k - fx) pz pitch / Lx is unchanged when both signs
    /// flip.
    #[allow(clippy::too_many_arguments)]
    pub fn query_mirrored(
        &self,
        map: &DepthMap,
        base: [i32; 2],
        mirror: [bool; 2],
        pz: f32,
        h_stop: f32,
        heightfield: Heightfield,
        out: &mut [u64],
    ) -> QueryStats {
        let sign = mirror.map(|m| if m { -1 } else { 1 });
        let at = |dx: i32, dy: i32| [base[0] + sign[0] * dx, base[1] + sign[1] * dy];
        let mut stats = QueryStats::default();
        let words = self.words;
        let out = &mut out[..words];
        out.copy_from_slice(&self.full);
        let floor = |c: &Cell| {
            let [i, j] = at(c.dx, c.dy);
            floor_height(map.at(i, j), pz)
        };
        let layer_floor = |layer: usize, c: &Cell| {
            let [i, j] = at(c.dx, c.dy);
            floor_height(map.layer_at(layer, i, j), pz)
        };
        // Where a ray must leave a pixel to have passed through its floor: above the floor
        // itself (shells), or above the bottom of its slab (plates).
        let exit_height = |layer: usize, c: &Cell, h: f32| match heightfield {
            Heightfield::Plates => {
                let [i, j] = at(c.dx, c.dy);
                map.layer_heights(layer, i, j, pz).1
            }
            _ => h,
        };
        // `plates` reads the hidden layer too: a ray is blocked by a slab of either layer,
        // so each layer's pass ANDs into the same visible bits.
        let layers = if heightfield == Heightfield::Plates { map.layers() } else { 1 };
        let h_own = floor(&self.cells[0]);
        // Below(q) over the crossings under `h_stop` only, as `depth_march` sees them: a mask
        // that marched further (`h_max > h_stop`) also holds crossings at `h_stop` exactly
        // (floors in the region are at most `h_stop`), e.g. at -0.0 from a point on a pixel
        // side when `h_stop` is 0, and counting them changed the answer at such ties.
        let h_lim = h_stop.next_down();
        let below = |t: u32, q: f32| self.below_table(t, q.min(h_lim));
        // out &= Below (a partial mask); then whether any bit is left.
        let and = |out: &mut [u64], below: Option<(usize, &[u64])>| -> bool {
            if let Some((w0, m)) = below {
                for (o, w) in out[w0..].iter_mut().zip(m) {
                    *o &= *w;
                }
            }
            out.iter().any(|&w| w != 0)
        };
        if h_own < 0.0 && heightfield != Heightfield::Plates {
            // P starts above its floor: both readings block a ray exactly where it first
            // enters a pixel at or below that pixel's floor (note 5.4-5.5), so AND every
            // pixel's Below(its floor) of its in-table: one search per pixel.
            for b in &self.blocks {
                if b.first >= h_stop {
                    break; // this block and every later one is entered only above the stop
                }
                for c in &self.cells[b.start as usize..b.end as usize] {
                    if c.in_first >= h_stop {
                        break;
                    }
                    let h = floor(c);
                    if h < c.in_first {
                        continue;
                    }
                    let t = &self.tables[c.in_table as usize];
                    // Every ray entering this pixel already blocked: nothing to learn here.
                    // (Measured with one table per side: skipped about half the searches in
                    // penumbrae.)
                    if out[t.word0 as usize..][..t.span as usize].iter().all(|&w| w == 0) {
                        continue;
                    }
                    stats.lookups += 1;
                    if !and(out, below(c.in_table, h)) {
                        stats.early_out = true;
                        return stats;
                    }
                }
            }
            return stats;
        }
        match heightfield {
            Heightfield::Solid => {
                // P is inside the solid behind its own floor: every way out is blocked.
                out.iter_mut().for_each(|w| *w = 0);
                stats.early_out = true;
            }
            Heightfield::Shells | Heightfield::Plates => {
                assert!(
                    self.walls || heightfield == Heightfield::Plates,
                    "a mask built without walls read as shells"
                );
                // Floors and front-facing walls (INTERSECTFLOOR / INTERSECTWALL): a ray is
                // blocked where it rises through a floor it is under, or passes from above
                // one floor to under a higher one.
                // One pixel of one layer: false once every ray is blocked.
                let visit = |layer: usize, k: usize, out: &mut [u64], stats: &mut QueryStats| -> bool {
                    let c = &self.cells[k];
                    let h = layer_floor(layer, c);
                    if k > 0 && h < c.in_first {
                        return true; // no ray enters below this floor: the floor blocks nothing
                    }
                    // Every ray through this pixel leaves it at or below the slab's bottom
                    // (the floor, for shells): they all pass under it, and it blocks nothing.
                    // Measured (240x180, 1024 samples, same bytes): 16% fewer lookups on
                    // metal-rough-spheres (render 0.78 s against 0.83 s, best of five at
                    // 320x240), 4.5% on monobloc-chair, under 4% on the other five scenes.
                    let h_exit = exit_height(layer, c, h);
                    if h_exit.min(h_lim) >= c.out_last {
                        return true;
                    }
                    if k == 0 {
                        if h < 0.0 {
                            return true; // P above its own floor: that floor blocks nothing
                        }
                        // Every ray starts under the own floor (P is at 0): blocked unless it
                        // leaves under the slab's bottom, through one of the four sides.
                        let mut not_left = [0u64; MAX_WORDS];
                        let not_left = &mut not_left[..words];
                        not_left.copy_from_slice(&self.full);
                        for t in self.own_out.iter().flatten() {
                            stats.lookups += 1;
                            and(not_left, self.below(t, h_exit.min(h_lim)));
                        }
                        out.iter_mut().zip(not_left.iter()).for_each(|(o, x)| *o &= !*x);
                        return out.iter().any(|&w| w != 0);
                    }
                    // In: the rays that entered at or below the floor (bits cleared), as a
                    // partial mask from word `w0`.
                    stats.lookups += 1;
                    let Some((w0, entered)) = below(c.in_table, h) else {
                        return true; // none entered under the floor below the stop
                    };
                    // Only rays that entered under this floor and are not blocked yet can
                    // change the result: skip the out-table when there are none. Bits outside
                    // `entered`'s words are rays that did not enter under the floor.
                    if entered.iter().zip(&out[w0..]).all(|(i, o)| !*i & *o == 0) {
                        return true;
                    }
                    // Out: left at or below the floor (plates: the slab's bottom); a ray that
                    // entered under it and did not leave under the slab's bottom is blocked.
                    let left = if c.out_table == NONE {
                        None
                    } else {
                        stats.lookups += 1;
                        below(c.out_table, h_exit)
                    };
                    for (w, (o, i)) in out[w0..].iter_mut().zip(entered).enumerate() {
                        let not_left = match left {
                            Some((x0, x)) if w0 + w >= x0 && w0 + w - x0 < x.len() => x[w0 + w - x0],
                            _ => u64::MAX,
                        };
                        *o &= *i | !not_left;
                    }
                    out.iter().any(|&w| w != 0)
                };
                // Each pixel's verdict is ANDed in independently of the others, so the order
                // of pixels and layers is free: the own pixel, then block by block.
                for layer in 0..layers {
                    if !visit(layer, 0, out, &mut stats) {
                        stats.early_out = true;
                        return stats;
                    }
                }
                for b in &self.blocks {
                    if b.first >= h_stop {
                        break; // this block and every later one is entered only above the stop
                    }
                    // The highest floor over the block, of either layer (the hidden layer
                    // lies below the first): below every crossing into it, no pixel of it
                    // blocks anything. Measured: see `benches/edge_table.rs` (flat_unshrunk).
                    let (a, z) = (at(b.lo[0], b.lo[1]), at(b.hi[0], b.hi[1]));
                    let (lo, hi) = ([a[0].min(z[0]), a[1].min(z[1])], [a[0].max(z[0]), a[1].max(z[1])]);
                    if self.cull_blocks && floor_height(map.min_depth(lo, hi), pz) < b.first {
                        stats.blocks_culled += 1;
                        continue;
                    }
                    for layer in 0..layers {
                        for k in b.start as usize..b.end as usize {
                            if self.cells[k].in_first >= h_stop {
                                break;
                            }
                            if !visit(layer, k, out, &mut stats) {
                                stats.early_out = true;
                                return stats;
                            }
                        }
                    }
                }
                for side in &self.sides {
                    let e = &side.table;
                    if e.first >= h_stop || heightfield == Heightfield::Plates {
                        break;
                    }
                    let h_to = floor(&self.cells[side.to as usize]);
                    let h_from = floor(&self.cells[side.from as usize]);
                    if h_from < h_to && h_to >= e.first {
                        // Wall (h_from, h_to]: (NOT Below(h_from)) OR Below(h_to); outside
                        // the side's words both are 1 and the wall is a no-op.
                        let Some((w0, hi)) = self.below(e, h_to.min(h_lim)) else { continue };
                        let lo = self.below(e, h_from.min(h_lim));
                        for (k, (o, u)) in out[w0..].iter_mut().zip(hi).enumerate() {
                            let l = lo.map_or(u64::MAX, |(_, l)| l[k]);
                            *o &= !l | *u;
                        }
                        stats.lookups += 2;
                        if out.iter().all(|&w| w == 0) {
                            stats.early_out = true;
                            return stats;
                        }
                    }
                }
            }
        }
        stats
    }
}

#[derive(Debug, Default, Clone, Copy)]
pub struct QueryStats {
    pub lookups: u64,
    pub early_out: bool,
    /// Blocks of the region skipped whole by hierarchical culling.
    pub blocks_culled: u64,
}

/// The plugin: one depth map and a grid of masks per light and frame.
pub struct EdgeTable {
    params: EdgeTableParams,
    samples: u32,
    state: Option<Prepared>,
    fallback: MapFallback,
    lookups: AtomicU64,
    early_outs: AtomicU64,
    blocks_culled: AtomicU64,
    clipped: AtomicU64,
}

struct Prepared {
    map: DepthMap,
    /// The masks built (all of the grid, or its mirror-image classes' representatives).
    masks: Vec<Mask>,
    /// Per grid cell, indexed [depth level][sub-pixel y][sub-pixel x]: the mask built for it
    /// and whether it is read mirrored in x and y.
    grid_masks: Vec<(u32, [bool; 2])>,
    /// Depth of each level (ascending).
    levels: Vec<f32>,
}

/// Share of receivers whose stop height the masks cover (the rest fall back to traced).
pub const MASK_HEIGHT_QUANTILE: f64 = 0.995;

impl EdgeTable {
    /// # Panics
    /// `samples` outside 1..=4096 or a zero grid dimension (checked at the config boundary).
    pub fn new(params: EdgeTableParams, samples: u32) -> Self {
        assert!((1..=MAX_SAMPLES as u32).contains(&samples));
        assert!(params.grid.iter().all(|&g| g >= 1));
        Self {
            params,
            samples,
            state: None,
            fallback: MapFallback::new(samples),
            lookups: AtomicU64::new(0),
            early_outs: AtomicU64::new(0),
            blocks_culled: AtomicU64::new(0),
            clipped: AtomicU64::new(0),
        }
    }

    /// Weighted masks for a point: up to 8 (mask index, pixel shift, weight).
    fn select(&self, st: &Prepared, offset: Vec2, pz: f32, out: &mut [(usize, [i32; 2], f32); 8]) -> usize {
        let [gx, gy, gz] = self.params.grid;
        let level_pos = level_position(&st.levels, pz);
        let index = |a: i32, b: i32, k: u32| -> (usize, [i32; 2]) {
            let (sx, ax) = (a.div_euclid(gx as i32), a.rem_euclid(gx as i32));
            let (sy, ay) = (b.div_euclid(gy as i32), b.rem_euclid(gy as i32));
            (((k * gy + ay as u32) * gx + ax as u32) as usize, [sx, sy])
        };
        match self.params.blend {
            Blend::Nearest => {
                let a = ((offset.x * gx as f32) as i32).min(gx as i32 - 1);
                let b = ((offset.y * gy as f32) as i32).min(gy as i32 - 1);
                let (m, shift) = index(a, b, level_pos.round() as u32);
                out[0] = (m, shift, 1.0);
                1
            }
            Blend::Trilinear => {
                let tx = offset.x * gx as f32 - 0.5;
                let ty = offset.y * gy as f32 - 0.5;
                let (ax, ay) = (tx.floor(), ty.floor());
                let (wx, wy) = (tx - ax, ty - ay);
                let k0 = (level_pos.floor() as u32).min(gz - 1);
                let wz = level_pos - k0 as f32;
                let mut count = 0;
                for (dk, wk) in [(0u32, 1.0 - wz), (1, wz)] {
                    if wk <= 0.0 || k0 + dk >= gz {
                        continue;
                    }
                    for (db, wb) in [(0, 1.0 - wy), (1, wy)] {
                        for (da, wa) in [(0, 1.0 - wx), (1, wx)] {
                            let w = wk * wb * wa;
                            if w > 0.0 {
                                let (m, shift) = index(ax as i32 + da, ay as i32 + db, k0 + dk);
                                out[count] = (m, shift, w);
                                count += 1;
                            }
                        }
                    }
                }
                count
            }
        }
    }
}

/// Most bytes of masks one light may hold: half the memory available when the edge table
/// is prepared (Linux's `MemAvailable`, or the cgroup's headroom under `memory.max` when
/// that is smaller: a container is killed at its limit, not the machine's), at most 16 GiB;
/// 4 GiB where neither is known. `PENUMBRA_MASK_BUDGET_MIB` overrides it.
fn mask_memory_budget() -> u64 {
    if let Some(mib) = std::env::var("PENUMBRA_MASK_BUDGET_MIB").ok().and_then(|v| v.parse::<u64>().ok()) {
        return mib.saturating_mul(1 << 20);
    }
    let read_u64 = |path: &str| std::fs::read_to_string(path).ok().and_then(|t| t.trim().parse::<u64>().ok());
    let available = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|m| {
            m.lines()
                .find_map(|l| l.strip_prefix("MemAvailable:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        })
        .map(|kib| kib << 10);
    // cgroup v2; "max" (no limit) does not parse and is ignored.
    let cgroup = read_u64("/sys/fs/cgroup/memory.max")
        .zip(read_u64("/sys/fs/cgroup/memory.current"))
        .map(|(max, current)| max.saturating_sub(current));
    let free = match (available, cgroup) {
        (Some(a), Some(c)) => Some(a.min(c)),
        (a, c) => a.or(c),
    };
    free.map_or(4 << 30, |b| b / 2).min(16 << 30)
}

/// Where depth `pz` falls among the (ascending) depth levels: k + f between levels k and
/// k + 1, linear in log depth, clamped to the first and last level.
fn level_position(levels: &[f32], pz: f32) -> f32 {
    let k = levels.partition_point(|&l| l <= pz);
    if k == 0 {
        return 0.0;
    }
    if k == levels.len() {
        return (levels.len() - 1) as f32;
    }
    let (lo, hi) = (levels[k - 1], levels[k]);
    let f = (pz / lo).ln() / (hi / lo).ln();
    // Equal levels (many receivers at one depth) give 0/0: use the lower one.
    (k - 1) as f32 + if f.is_finite() { f.clamp(0.0, 1.0) } else { 0.0 }
}

impl LightShadowing for EdgeTable {
    fn name(&self) -> &'static str {
        "edge_table"
    }

    fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError> {
        self.fallback.prepare(ctx)?;
        let map = DepthMap::build(ctx.scene, ctx.light, ctx.visible, &self.params.depth_map);
        // Depth levels at quantiles of the receivers' log depths: level k at the (k + 1/2) /
        // gz quantile of the points the light reaches. Receivers cluster (a floor facing the
        // light has one depth), and a mask serves a point exactly only at its own depth: the
        // ray footprints of a point at depth z read through a mask built at z0 are off by
        // z0 / z. Measured against levels at the centres of equal log-depth bins and at the
        // range's ends: see ARCHITECTURE.md.
        // Grazed receivers and those outside the map are traced and take no part.
        let mut log_depths: Vec<f32> = ctx
            .visible
            .par_iter()
            .filter(|v| !map.grazing(v.p, v.n_geom) && map.query_point(v.p, v.n_geom).is_some())
            .map(|v| map.frame.light_from_world(v.p).z)
            .filter(|&z| z > map.z_min && z.is_finite())
            .map(f32::ln)
            .collect();
        let fallback_z = map.z_min.max(1e-6) * 2.0;
        let z_hi = log_depths.iter().copied().reduce(f32::max).map_or(fallback_z, f32::exp);
        let [gx, gy, gz] = self.params.grid;
        // Quantiles by selection, not a sort (a few ms at 300k points; the value at a rank is
        // the same whichever way it is found).
        let levels: Vec<f32> = (0..gz)
            .map(|k| {
                if log_depths.is_empty() {
                    return fallback_z;
                }
                let q = ((k as f32 + 0.5) / gz as f32 * log_depths.len() as f32) as usize;
                let q = q.min(log_depths.len() - 1);
                log_depths.select_nth_unstable_by(q, f32::total_cmp).1.exp()
            })
            .collect();
        // Each mask marches far enough for the deepest point it serves.
        let serve_hi: Vec<f32> = (0..gz as usize)
            .map(|k| match self.params.blend {
                Blend::Trilinear if k + 1 < levels.len() => levels[k + 1],
                Blend::Nearest if k + 1 < levels.len() => (levels[k] * levels[k + 1]).sqrt(),
                _ => z_hi.max(levels[k]),
            })
            .collect();
        // The height masks march to: what the receivers need after region shrinking, up to
        // its MASK_HEIGHT_QUANTILE; the few receivers that need more fall back to traced.
        let mut needed: Vec<f32> = ctx
            .visible
            .par_iter()
            .filter(|v| !map.grazing(v.p, v.n_geom))
            .filter_map(|v| {
                // Points off the map are traced and need no height (with `fit_shadowed` they
                // are most of a wide floor).
                map.query_point(v.p, v.n_geom)?;
                let p = map.frame.light_from_world(v.p);
                let mp = map.locate(p)?;
                Some(stop_height(map.stop_depth(mp.pixel, p.z).0, p.z))
            })
            .collect();
        let h_cap = if needed.is_empty() {
            0.0
        } else {
            let q = ((needed.len() - 1) as f64 * MASK_HEIGHT_QUANTILE) as usize;
            *needed.select_nth_unstable_by(q, f32::total_cmp).1
        };
        let n = self.samples as usize;
        let half = map.frame.half_size;
        let pitch = map.pitch;
        let z_min = map.z_min;
        let seed = ctx.seed;
        let light_index = ctx.light_index as u64;
        // Mask memory grows with grid x samples x filter-region size; a grid the machine
        // cannot hold is refused (an error naming the parameters) rather than swapped or
        // killed. Checked as masks are built: once the total passes the budget the rest are
        // skipped, so the overshoot is at most one mask per thread.
        let budget = mask_memory_budget();
        let built = AtomicU64::new(0);
        // With `mirrored`, a sub-pixel column a > (gx - 1) / 2 is read as column gx - 1 - a
        // mirrored (likewise rows); only the others are built.
        let fold = |a: u32, g: u32| {
            if self.params.mirrored && a > (g - 1) / 2 { (g - 1 - a, true) } else { (a, false) }
        };
        let mut built_index = vec![u32::MAX; (gx * gy * gz) as usize];
        let mut to_build = Vec::new();
        for m in 0..gx * gy * gz {
            let (ax, ay) = (m % gx, (m / gx) % gy);
            if !fold(ax, gx).1 && !fold(ay, gy).1 {
                built_index[m as usize] = to_build.len() as u32;
                to_build.push(m);
            }
        }
        let grid_masks: Vec<(u32, [bool; 2])> = (0..gx * gy * gz)
            .map(|m| {
                let ((ax, mx), (ay, my), k) = (fold(m % gx, gx), fold((m / gx) % gy, gy), m / (gx * gy));
                (built_index[((k * gy + ay) * gx + ax) as usize], [mx, my])
            })
            .collect();
        let masks: Vec<Option<Mask>> = to_build
            .par_iter()
            .map(|&m| {
                let m = m as usize;
                if built.load(Ordering::Relaxed) > budget {
                    return None;
                }
                let (ax, ay, k) = (m as u32 % gx, (m as u32 / gx) % gy, m as u32 / (gx * gy));
                let offset = Vec2::new((ax as f32 + 0.5) / gx as f32, (ay as f32 + 0.5) / gy as f32);
                let mut s = vec![Vec2::ZERO; n];
                samples::stratified(
                    &mut s,
                    half,
                    &mut Rng::new(stream_seed(&[seed, light_index, m as u64, 3])),
                );
                let depth = levels[k as usize];
                let h_stop = stop_height(z_min, serve_hi[k as usize]).min(h_cap);
                let mask = Mask::build_for(self.params.heightfield, offset, depth, s, pitch, h_stop);
                built.fetch_add(mask.bytes(), Ordering::Relaxed);
                Some(mask)
            })
            .collect();
        let total = built.load(Ordering::Relaxed);
        let Some(masks) = masks.into_iter().collect::<Option<Vec<Mask>>>().filter(|_| total <= budget) else {
            return Err(ShadowError {
                method: "edge_table",
                message: format!(
                    "the masks need more than {} MiB (grid {:?} x {} samples); use a smaller grid, \
                     fewer samples or a smaller depth map",
                    budget >> 20,
                    self.params.grid,
                    self.samples
                ),
            });
        };
        self.state = Some(Prepared { map, masks, grid_masks, levels });
        Ok(())
    }

    fn visibility(&self, scene: &Scene, q: &ShadowQuery) -> f32 {
        let st = self.state.as_ref().expect("prepare() runs before visibility()");
        let map = &st.map;
        let frame = &map.frame;
        // Grazed points and points outside the map: traced rays answer (counted).
        let OnMap { p, mp, z_stop, clipped } = match self.fallback.locate(map, scene, q) {
            Located::OnMap(on_map) => on_map,
            Located::Traced(v) => return v,
            Located::NearerThanMap => {
                self.early_outs.fetch_add(1, Ordering::Relaxed);
                return 1.0;
            }
        };
        // The masks must reach the region's stop height. A region reaching outside the map
        // sees no occluder there (counted).
        if clipped {
            self.clipped.fetch_add(1, Ordering::Relaxed);
        }
        let h_stop = stop_height(z_stop, p.z);
        let [i, j] = mp.pixel;
        let mut chosen = [(0usize, [0i32; 2], 0.0f32); 8];
        let count = self.select(st, mp.offset, p.z, &mut chosen);
        let mut visible = [0u64; MAX_WORDS];
        let mut above = [0u64; MAX_WORDS];
        let (mut v, mut lookups, mut early_outs, mut culled) = (0.0f32, 0u64, 0u64, 0u64);
        for &(g, shift, w) in &chosen[..count] {
            let (m, mirror) = st.grid_masks[g];
            let mask = &st.masks[m as usize];
            if h_stop > mask.h_max {
                return self.fallback.trace(scene, q);
            }
            let words = bits::words(mask.samples.len());
            let stats = mask.query_mirrored(
                map,
                [i + shift[0], j + shift[1]],
                mirror,
                p.z,
                h_stop,
                self.params.heightfield,
                &mut visible,
            );
            lookups += stats.lookups;
            early_outs += stats.early_out as u64;
            culled += stats.blocks_culled;
            let all_above = samples::above_horizon(
                frame,
                &mask.samples,
                mirror.map(|m| if m { -1.0 } else { 1.0 }).into(),
                q.p,
                q.n_shading,
                &mut above[..words],
            );
            let (n_visible, n_above) = if all_above {
                (bits::count(&visible[..words]), mask.samples.len() as u32)
            } else {
                (bits::count_and(&visible[..words], &above[..words]), bits::count(&above[..words]))
            };
            v += w * if n_above == 0 { 1.0 } else { n_visible as f32 / n_above as f32 };
        }
        self.lookups.fetch_add(lookups, Ordering::Relaxed);
        self.early_outs.fetch_add(early_outs, Ordering::Relaxed);
        if culled > 0 {
            self.blocks_culled.fetch_add(culled, Ordering::Relaxed);
        }
        v.clamp(0.0, 1.0)
    }

    fn counters(&self) -> Vec<(&'static str, u64)> {
        let (masks, bytes, crossings, map_bytes) = match &self.state {
            Some(st) => (
                st.masks.len() as u64,
                st.masks.iter().map(Mask::bytes).sum::<u64>(),
                st.masks.iter().map(|m| m.crossings() as u64).sum::<u64>(),
                st.map.bytes(),
            ),
            None => (0, 0, 0, 0),
        };
        let mut c = vec![
            ("masks_built", masks),
            ("mask_bytes", bytes),
            ("mask_crossings", crossings),
            ("depth_map_bytes", map_bytes),
            ("edge_lookups", self.lookups.load(Ordering::Relaxed)),
            ("early_outs", self.early_outs.load(Ordering::Relaxed)),
            ("blocks_culled", self.blocks_culled.load(Ordering::Relaxed)),
            ("regions_clipped", self.clipped.load(Ordering::Relaxed)),
        ];
        c.extend(self.fallback.counters());
        c
    }
}
