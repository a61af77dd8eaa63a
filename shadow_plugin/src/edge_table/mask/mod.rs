//! One edge-table mask: the crossings of its rays into and out of each pixel of its filter
//! region, sorted by height with cumulative bitmasks. `build.rs` marches the rays and
//! builds the tables, `query.rs` reads them for a point (one function per heightfield
//! reading); this file holds the layout both share.

mod build;
mod classify;
mod query;

pub use classify::ExactQuery;
pub use query::MaskQuery;

use glam::Vec2;

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
    /// the mask memory (docs/notes/2026-11-21-per-pixel-tables.md).
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

/// What one query did, for the counters.
#[derive(Debug, Default, Clone, Copy)]
pub struct QueryStats {
    pub lookups: u64,
    pub early_out: bool,
    /// Blocks of the region skipped whole by hierarchical culling.
    pub blocks_culled: u64,
}

impl Mask {
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
}
