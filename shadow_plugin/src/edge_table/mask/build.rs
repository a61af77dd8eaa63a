//! Building a mask, in steps: march every ray through the pixel frusta
//! ([`for_each_crossing`]), find the region's pixels and what crosses into and out of each,
//! order the pixels by culling block, then store one table per pixel and direction (and per
//! side where only a side will do), and group the pixels into blocks.

use super::{BLOCK, Block, Cell, Mask, NONE, Side, Table};
use crate::depth_map::bits::{self, MAX_WORDS};
use crate::depth_map::heightfield::Heightfield;
use crate::depth_map::march::for_each_crossing;
use glam::Vec2;
use std::collections::HashMap;

/// One ray crossing one pixel-frustum side: (pixel entered, axis crossed, height, ray).
type Crossing = ([i32; 2], u8, f32, u32);

impl Mask {
    /// Builds a mask for a model point at `offset` inside its pixel and at depth `depth`,
    /// marching every ray up to the normalised height `h_stop`, for every reading of the
    /// depth map (with the `shells` reading's per-side tables).
    pub fn build(offset: Vec2, depth: f32, samples: Vec<Vec2>, pitch: f32, h_stop: f32) -> Self {
        Self::build_for(Heightfield::Shells, offset, depth, samples, pitch, h_stop)
    }

    /// [`Mask::build`] for queries with `heightfield` only: the per-side tables, as large as
    /// the rest of the mask, are kept for `shells` alone (a mask built for another reading
    /// must not be read as `shells`).
    pub fn build_for(
        heightfield: Heightfield,
        offset: Vec2,
        depth: f32,
        mut samples: Vec<Vec2>,
        pitch: f32,
        h_stop: f32,
    ) -> Self {
        sort_by_direction(&mut samples);
        let n = samples.len();
        let words = bits::words(n);
        let crossings = march(&samples, offset, depth * pitch, h_stop);
        let mut full = vec![0u64; words];
        bits::fill_first(&mut full, n);
        let region = Region::new(&crossings, n);
        let (cell_order, new_cell) = region.cell_order();
        let mut store =
            Store { full: &full, heights: Vec::with_capacity(2 * crossings.len()), masks: Vec::new() };
        let (cells, tables) = cell_tables(&crossings, &region, &cell_order, &new_cell, &mut store);
        let walls = heightfield == Heightfield::Shells;
        let (own_out, sides) = side_tables(&crossings, &region.side_cells, &new_cell, walls, &mut store);
        let Store { heights, masks, .. } = store;
        let blocks = blocks(&cells);
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
}

impl Mask {
    /// What [`Mask::bytes`] of [`Mask::build_for`] with these arguments would be, found
    /// without building it: the rays are marched and the region found, but of its tables
    /// only their lengths and word spans are counted, not their bitmasks (which are most of
    /// a mask's bytes and of its build time). Lets `prepare` refuse a grid that will not fit
    /// before it builds any mask.
    pub fn estimate_bytes(
        heightfield: Heightfield,
        offset: Vec2,
        depth: f32,
        mut samples: Vec<Vec2>,
        pitch: f32,
        h_stop: f32,
    ) -> u64 {
        sort_by_direction(&mut samples);
        let n = samples.len();
        let crossings = march(&samples, offset, depth * pitch, h_stop);
        let region = Region::new(&crossings, n);
        let count = region.pixels.len();
        // Per cell, its in- and out-table (as `cell_tables` buckets them; the own pixel's
        // crossings out go to `own_out`): (crossings, lowest word, highest word).
        let mut runs = vec![(0u64, u32::MAX, 0u32); 2 * count];
        let add = |run: &mut (u64, u32, u32), ray: u32| {
            *run = (run.0 + 1, run.1.min(ray / 64), run.2.max(ray / 64))
        };
        for (&(_, _, _, r), &(f, t)) in crossings.iter().zip(&region.side_cells) {
            add(&mut runs[2 * t as usize], r);
            if f != 0 {
                add(&mut runs[2 * f as usize + 1], r);
            }
        }
        // A table stores a height and `span` words per crossing (`Store::push`).
        let stored = |(len, lo, hi): (u64, u32, u32)| len * (4 + 8 * (hi - lo + 1) as u64);
        let tables = runs.iter().filter(|r| r.0 > 0).count() as u64;
        let mut data: u64 = runs.iter().filter(|r| r.0 > 0).map(|&r| stored(r)).sum();
        // The per-side tables `side_tables` keeps: the own pixel's, and every side's for walls.
        let walls = heightfield == Heightfield::Shells;
        let (mut own_out, mut sides) = (0u64, 0u64);
        for side in side_runs(&crossings) {
            let from = region.side_cells[side.start].0;
            if walls || from == 0 {
                let mut run = (0, u32::MAX, 0);
                crossings[side].iter().for_each(|c| add(&mut run, c.3));
                data += stored(run);
                own_out += u64::from(from == 0);
                sides += u64::from(walls);
            }
        }
        let blocks: std::collections::HashSet<[i32; 2]> =
            region.pixels[1..].iter().map(|&c| block_of(c)).collect();
        use std::mem::size_of;
        count as u64 * size_of::<Cell>() as u64
            + blocks.len() as u64 * size_of::<Block>() as u64
            + (tables + own_out) * size_of::<Table>() as u64
            + sides * size_of::<Side>() as u64
            + data
            + n as u64 * 8
    }
}

/// Rays in order of direction, so that the rays crossing into or out of any one pixel are
/// neighbours in the bit order (see `Table::span`).
fn sort_by_direction(samples: &mut [Vec2]) {
    samples.sort_by(|a, b| {
        a.y.atan2(a.x).total_cmp(&b.y.atan2(b.x)).then(a.length_squared().total_cmp(&b.length_squared()))
    });
}

/// The runs of `crossings` (sorted by side) that cross one side each.
fn side_runs(crossings: &[Crossing]) -> Vec<std::ops::Range<usize>> {
    let mut runs = Vec::new();
    let mut i = 0;
    while i < crossings.len() {
        let (to, axis) = (crossings[i].0, crossings[i].1);
        let end =
            crossings[i..].iter().position(|c| c.0 != to || c.1 != axis).map_or(crossings.len(), |k| i + k);
        runs.push(i..end);
        i = end;
    }
    runs
}

/// Every ray's crossings up to `h_stop`, by side (pixel entered, axis), then height and ray.
fn march(samples: &[Vec2], offset: Vec2, pz_pitch: f32, h_stop: f32) -> Vec<Crossing> {
    let mut crossings: Vec<Crossing> = Vec::new();
    for (r, s) in samples.iter().enumerate() {
        for_each_crossing(offset, *s, pz_pitch, h_stop, |c, axis, h| {
            crossings.push((c, axis, h, r as u32));
            true
        });
    }
    crossings.sort_unstable_by(|a, b| {
        (a.0[1], a.0[0], a.1).cmp(&(b.0[1], b.0[0], b.1)).then(a.2.total_cmp(&b.2)).then(a.3.cmp(&b.3))
    });
    crossings
}

/// The culling block of a pixel (relative to the model point's pixel).
#[inline]
fn block_of(c: [i32; 2]) -> [i32; 2] {
    [c[0].div_euclid(BLOCK), c[1].div_euclid(BLOCK)]
}

/// The region's pixels, the own pixel first, in the order the crossings found them, and
/// per pixel its crossings in and out.
struct Region {
    pixels: Vec<[i32; 2]>,
    /// (from, to) pixels of each crossing's side (a side's crossings are neighbours).
    side_cells: Vec<(u32, u32)>,
    in_count: Vec<u32>,
    out_count: Vec<u32>,
    /// See [`Cell::in_first`] and [`Cell::out_last`].
    in_first: Vec<f32>,
    out_last: Vec<f32>,
}

impl Region {
    /// The region of `crossings`, sorted by side, of `n` rays.
    fn new(crossings: &[Crossing], n: usize) -> Self {
        // Rays move monotonically, so every ray crosses a side the same way: from the
        // neighbour nearer the own pixel's row or column.
        let from_of = |to: [i32; 2], axis: u8| {
            let mut from = to;
            let k = to[axis as usize];
            from[axis as usize] = if k > 0 { k - 1 } else { k + 1 };
            from
        };
        let mut cell_index: HashMap<[i32; 2], u32> = HashMap::new();
        let mut pixels: Vec<[i32; 2]> = vec![[0, 0]];
        cell_index.insert([0, 0], 0);
        let mut cell_of = |c: [i32; 2]| -> u32 {
            *cell_index.entry(c).or_insert_with(|| {
                pixels.push(c);
                pixels.len() as u32 - 1
            })
        };
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
        Self { pixels, side_cells, in_count, out_count, in_first, out_last }
    }

    /// The order the mask stores its cells in: the own pixel, then by block (blocks in order
    /// of their lowest crossing), then by their own lowest crossing. As (pixel of each cell,
    /// cell of each pixel).
    fn cell_order(&self) -> (Vec<usize>, Vec<u32>) {
        let (pixels, in_first) = (&self.pixels, &self.in_first);
        let count = pixels.len();
        let mut block_first: HashMap<[i32; 2], f32> = HashMap::new();
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
        (cell_order, new_cell)
    }
}

/// The cells, in `cell_order`, with their merged in- and out-tables (the tables stored in
/// `store`).
fn cell_tables(
    crossings: &[Crossing],
    region: &Region,
    cell_order: &[usize],
    new_cell: &[u32],
    store: &mut Store,
) -> (Vec<Cell>, Vec<Table>) {
    let Region { pixels, side_cells, in_count, out_count, in_first, out_last } = region;
    let count = pixels.len();
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
    for (&(_, _, h, r), &(f, t)) in crossings.iter().zip(side_cells) {
        let out_slot = (f != 0).then(|| 2 * new_cell[f as usize] as usize + 1);
        for slot in std::iter::once(2 * new_cell[t as usize] as usize).chain(out_slot) {
            bucketed[fill[slot]] = (h, r);
            fill[slot] += 1;
        }
    }
    let mut tables = Vec::new();
    let mut table_of = |bucket: usize| {
        let list = &mut bucketed[bucket_start[bucket]..bucket_start[bucket + 1]];
        if list.is_empty() {
            return NONE;
        }
        tables.push(store.push(list));
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
    (cells, tables)
}

/// Per side (a run of `crossings`): a table for the own pixel's out-sides, and with `walls`
/// for every side (in order of their lowest crossing), stored in `store`.
fn side_tables(
    crossings: &[Crossing],
    side_cells: &[(u32, u32)],
    new_cell: &[u32],
    walls: bool,
    store: &mut Store,
) -> ([Option<Table>; 4], Vec<Side>) {
    let (mut own_out, mut sides) = ([None; 4], Vec::new());
    let mut list = Vec::new();
    for side in side_runs(crossings) {
        let (f, t) = side_cells[side.start];
        if walls || f == 0 {
            list.clear();
            list.extend(crossings[side].iter().map(|c| (c.2, c.3)));
            let table = store.push(&mut list);
            if f == 0 {
                let free = own_out.iter().position(Option::is_none).expect("a pixel has at most 4 sides");
                own_out[free] = Some(table);
            }
            if walls {
                sides.push(Side { from: new_cell[f as usize], to: new_cell[t as usize], table });
            }
        }
    }
    sides.sort_by(|a, b| a.table.first.total_cmp(&b.table.first));
    (own_out, sides)
}

/// The culling blocks of `cells` (stored block by block after the own pixel).
fn blocks(cells: &[Cell]) -> Vec<Block> {
    let mut blocks: Vec<Block> = Vec::new();
    for (k, c) in cells.iter().enumerate().skip(1) {
        let b = block_of([c.dx, c.dy]);
        match blocks.last_mut() {
            Some(last) if block_of([cells[last.start as usize].dx, cells[last.start as usize].dy]) == b => {
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
    blocks
}

/// A mask's tables' crossing heights and cumulative bitmasks (see [`Mask`]), as they are
/// appended.
struct Store<'a> {
    /// Every ray's bit set.
    full: &'a [u64],
    heights: Vec<f32>,
    masks: Vec<u64>,
}

impl Store<'_> {
    /// Appends a table of `crossings` (height, ray), sorted here.
    fn push(&mut self, crossings: &mut [(f32, u32)]) -> Table {
        let (full, heights, masks) = (self.full, &mut self.heights, &mut self.masks);
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
}
