//! One point's visibility from its silhouette edges (see the module doc of `silhouette`):
//! the shaft's candidates, their weights and projections, the counts, one ray.

use super::counting::{Binned, EdgeRows, count_edges, is_reference};
use super::scratch::{MIXED, MIXED_BLOCKED, MIXED_LIT, SCRATCH, Scratch};
use super::{Fallback, Silhouette};
use crate::silhouette_edges::projection::{ActiveEdge, Frame};
use glam::{DVec2, Vec3};
use renderer::geometry::point::ShadingPoint;
use renderer::geometry::ray_origin::offset_origin;
use renderer::geometry::shaft::{self, Shaft};
use renderer::interface::lobe::{GlossyLobe, LobeTally, LobeVisibility};
use renderer::methods::sample_stream::{LightSample, PointSamples};
use renderer::{RectLight, Scene, ShadowQuery};
use std::sync::atomic::Ordering;

/// Where the reference point may go, tried in order: one clear of every edge's band. The
/// centre first (the shortest paths); the outer ones for a point next to a crease, whose
/// edge's band can cover a strip through the middle of the light.
const REFERENCES: [[f64; 2]; 12] = [
    [0.5, 0.5],
    [0.3125, 0.6875],
    [0.6875, 0.3125],
    [0.40625, 0.15625],
    [0.125, 0.125],
    [0.875, 0.875],
    [0.125, 0.875],
    [0.875, 0.125],
    [0.5, 0.0625],
    [0.5, 0.9375],
    [0.0625, 0.5],
    [0.9375, 0.5],
];

/// The reference point: the first of [`REFERENCES`] clear of every edge's band, its
/// column clear of every end ([`is_reference`]).
fn reference(active: &[ActiveEdge]) -> Result<DVec2, Fallback> {
    REFERENCES
        .iter()
        .map(|&[a, b]| DVec2::new(a, b))
        .find(|&r| is_reference(active, r))
        .ok_or(Fallback::NoReference)
}

/// The two origins a point's rays start from: above its geometric tangent plane (every
/// sample over that plane), and below it (the samples under it: the light seen past a
/// smoothed normal). Each side is counted on its own, from its own origin, with its own ray.
/// It carries what the counting reads of the point's samples besides the samples
/// themselves (their strata), so that only drawing and tracing go back to the stream.
#[derive(Clone, Copy)]
struct Side {
    /// The point as seen from this side: `n_geom` toward the side's origin.
    point: ShadingPoint,
    origin: Vec3,
    below: bool,
    /// The samples' strata grid ([`PointSamples::strata`]).
    strata: (u32, u32),
}

impl Side {
    fn both(q: &ShadowQuery, samples: &PointSamples) -> [Side; 2] {
        let mut flipped = q.point;
        flipped.n_geom = -flipped.n_geom;
        flipped.n_shading = -flipped.n_shading;
        let below = offset_origin(&flipped, flipped.n_geom);
        let strata = samples.strata();
        [
            Side { point: q.point, origin: samples.origin, below: false, strata },
            Side { point: flipped, origin: below, below: true, strata },
        ]
    }
}

/// Whether every sample of the point lies over the shading horizon and the geometric
/// tangent plane, inside the shaft and on the light (unwarped), judged from the light's
/// corners: then, with no active edge and no flagged triangle in the shaft, one ray answers
/// the whole point without drawing a sample. (The horizon's margin, 1e-4 of the distance,
/// is far above the rounding of the per-sample test it stands for.)
fn wholly_above(light: &RectLight, above: &Side, warped: bool) -> bool {
    let p = &above.point;
    let corners = light.corners();
    let far = corners.iter().map(|&c| (c - p.p).abs().element_sum()).fold(0.0, f32::max);
    !warped
        && shaft::covers_light(p, above.origin, light)
        && corners.iter().all(|&c| p.n_shading.dot(c - p.p) > 1e-4 * far)
}

/// The whole point's answer where one ray gives it ([`wholly_above`], nothing over the
/// light): the first sample's ray, whose answer every sample shares (D is constant). The
/// above side's edges are left in `s` either way.
fn one_ray(
    plugin: &Silhouette,
    scene: &Scene,
    above: &Side,
    samples: &PointSamples,
    s: &mut Scratch,
) -> Result<Option<f32>, Fallback> {
    side_edges((plugin, scene), above, s)?;
    if !(s.edges.active.is_empty() && s.edges.regions.is_empty()) {
        return Ok(None);
    }
    let Some(first) = samples.at(0) else { return Ok(None) };
    plugin.counters.rays.fetch_add(1, Ordering::Relaxed);
    Ok(Some(if samples.occluded(scene, &first) { 0.0 } else { 1.0 }))
}

/// Fills `s` with the point's samples, which of them must be traced, the others' counts
/// relative to a reference point, and each side's count of the lit samples (`None`: umbra,
/// or nothing counted there). With `above_gathered`, the above side's edges are already in
/// `s`.
fn relative_counts(
    plugin: &Silhouette,
    scene: &Scene,
    sides: [Side; 2],
    samples: &PointSamples,
    s: &mut Scratch,
    rays: &mut u64,
    above_gathered: bool,
) -> Result<[Option<i32>; 2], Fallback> {
    s.samples.clear();
    samples.collect_into(&mut s.samples);
    // The counting's rows hold samples on the light only (a proven one off it, if f32
    // rounding ever put one there, is traced too).
    s.uncertain.clear();
    s.uncertain.extend(s.samples.iter().map(|x| !((0.0..=1.0).contains(&x.a) && (0.0..=1.0).contains(&x.b))));
    s.rel.clear();
    s.rel.resize(s.samples.len(), 0);
    s.mixed.clear();
    s.mixed.resize(s.samples.len(), 0);
    let mut lit = [None; 2];
    for side in sides {
        if !s.samples.iter().any(|x| (x.height < 0.0) == side.below) {
            continue;
        }
        if side.below {
            plugin.counters.points_below.fetch_add(1, Ordering::Relaxed);
        }
        let edges =
            if side.below || !above_gathered { side_edges((plugin, scene), &side, s) } else { Ok(()) };
        match edges.and_then(|()| side_counts(plugin, &side, s)) {
            Ok(()) => {
                let l = lit_count(plugin, scene, samples, s, side.below, rays)?;
                test_mixed(plugin, scene, samples, s, side.below, l);
                lit[side.below as usize] = l;
            }
            // The side below has no shaft (its origin too near the light's plane, or behind
            // it): its samples are traced.
            Err(Fallback::NoShaft) if side.below => {
                for (u, x) in s.uncertain.iter_mut().zip(&s.samples) {
                    *u |= x.height < 0.0;
                }
            }
            Err(why) => return Err(why),
        }
    }
    Ok(lit)
}

/// A safety net: a point with more active edges than this many per sample (in quarters: 3
/// per sample) is traced whole, so that no point costs much more than `traced` would. The
/// counting's work per active edge is well under a traced sample's: on flight-helmet (N =
/// 1024, 320x240, medians of 3) tracing the 657 points over 2 per sample cost 0.1 s more
/// than counting them (1.47 s against 1.36 s), 1 per sample 1.77 s; at 3 none is traced
/// there, nor on metal-rough-spheres or sauerbraten-zdm2.
const MAX_EDGES_PER_SAMPLE_QUARTERS: usize = 12;

/// The same net before the candidates are filtered and weighed (most of a candidate's cost):
/// a block with more candidates than this many per sample (in quarters: 8) is traced for
/// every point in it, its walk stopped early. Measured (shadow seconds, medians of 3;
/// `scenes/stress/flight-helmet-softbox`, flight-helmet, metal-rough-spheres): none 6.75,
/// 1.35, 1.03; 4 per sample 3.43, 1.44, 1.17; 6: 3.18, 1.34, 1.02; 8: 3.37, 1.36, 0.99 (and
/// 2.64 with the walk stopped, `traced` 2.68); no point of the ten `scenes/gltf` scenes is
/// traced at 8.
const MAX_CANDIDATES_PER_SAMPLE_QUARTERS: usize = 32;

/// One side's active edges and flagged triangles' regions, into `s` (see [`Side`]); `Costly`
/// where the counting would cost more than tracing the point's samples.
fn side_edges((plugin, scene): (&Silhouette, &Scene), side: &Side, s: &mut Scratch) -> Result<(), Fallback> {
    let light = plugin.light();
    let frame = Frame::new(light, side.origin).ok_or(Fallback::NoShaft)?;
    // The whole hull: the path from the reference point to a sample may pass over parts of
    // the light under the tangent plane, and every edge projected there counts.
    let shaft = Shaft::new(light, &side.point).ok_or(Fallback::NoShaft)?.without_cut();
    let (nx, ny) = side.strata;
    let n = (nx * ny) as usize;
    let occluders = &plugin.occluders;
    let max_candidates = MAX_CANDIDATES_PER_SAMPLE_QUARTERS * n / 4;
    s.edges.gather(occluders, light, scene, &shaft, frame.o, max_candidates)?;
    s.edges.activate(occluders, &frame);
    let c = &plugin.counters;
    c.edges_tested.fetch_add(s.edges.candidates.len() as u64, Ordering::Relaxed);
    c.edges_active.fetch_add(s.edges.active.len() as u64, Ordering::Relaxed);
    // The profile's per-pixel unit of this method's own work: its active edges.
    renderer::util::pixel_cost::count_lookups(s.edges.active.len() as u64);
    if 4 * s.edges.active.len() > MAX_EDGES_PER_SAMPLE_QUARTERS * n {
        return Err(Fallback::Costly);
    }
    Ok(())
}

/// The counts of one side's samples from its edges ([`side_edges`]), and which of them must
/// be traced.
fn side_counts(plugin: &Silhouette, side: &Side, s: &mut Scratch) -> Result<(), Fallback> {
    let light = plugin.light();
    // This side's pairs only ([`Scratch::test_regions`] fills them; it may not run).
    s.mixed_pairs.clear();
    let cover = shaft::Cover::new(&side.point, side.origin, light.max_point_error());
    // This side's samples the counting cannot answer for are traced.
    let on_side = |x: &LightSample| (x.height < 0.0) == side.below;
    let sign = if side.below { -1.0 } else { 1.0 };
    // Where the shaft covers the whole light and no flagged triangle is near, no sample of
    // this side is uncertain for these reasons: skip the pass (most counted points).
    let covered = shaft::covers_light(&side.point, side.origin, light);
    if !(covered && s.edges.regions.is_empty()) {
        for (k, x) in s.samples.iter().enumerate() {
            if on_side(x) && !x.proven {
                s.uncertain[k] |= !cover.covers(sign * x.height, x.target - side.point.p);
            }
        }
        if !s.edges.regions.is_empty() {
            s.test_regions(side.strata, side.below);
        }
    }
    if s.edges.active.is_empty() {
        return Ok(());
    }
    let r = reference(&s.edges.active)?;
    s.bin(side.strata, side.below);
    let (nx, ny) = side.strata;
    let (nx, ny) = (nx as usize, ny as usize);
    let cells = nx * ny;
    let Scratch { edges, plans, starts, cell_steps, a, b, grid_rel, near, order, rel, uncertain, .. } = s;
    plans.clear();
    plans.extend(edges.active.iter().map(|e| EdgeRows::new(e, r, ny)));
    cell_steps.clear();
    cell_steps.resize(cells + 1, 0);
    let binned = Binned { grid: (nx, ny), starts, a, b, rel: grid_rel, near };
    count_edges(plans, binned, cell_steps, |_, _, _| true);
    let mut step = 0;
    for c in 0..cells {
        step += cell_steps[c];
        for pos in starts[c] as usize..starts[c + 1] as usize {
            let k = order[pos] as usize;
            rel[k] = grid_rel[pos] + step;
            uncertain[k] |= near[pos] != 0;
        }
    }
    Ok(())
}

/// The count of one side's lit samples (D = 0 over the counted triangles), or `None` in
/// umbra: the lowest count is lit iff its ray, through the counted triangles only, is
/// unblocked (none is traced where a shaft proved a sample lit). Also `None` when every
/// sample of the side is traced. A sample that may also meet an alpha-tested triangle with
/// holes ([`MIXED`]) is then settled by [`test_mixed`].
fn lit_count(
    plugin: &Silhouette,
    scene: &Scene,
    samples: &PointSamples,
    s: &mut Scratch,
    below: bool,
    rays: &mut u64,
) -> Result<Option<i32>, Fallback> {
    // One pass: the first sample with the lowest count, and the first proven one.
    let on_side = |k: usize| !s.uncertain[k] && (s.samples[k].height < 0.0) == below;
    let (mut m, mut proven) = (None::<usize>, None::<usize>);
    for (k, x) in s.samples.iter().enumerate() {
        if !on_side(k) {
            continue;
        }
        if m.is_none_or(|m| s.rel[k] < s.rel[m]) {
            m = Some(k);
        }
        if x.proven && proven.is_none() {
            proven = Some(k);
        }
    }
    let Some(m) = m else { return Ok(None) };
    match proven {
        // A sample proven lit has D = 0: its count is the lowest.
        Some(k) if s.rel[k] == s.rel[m] => Ok(Some(s.rel[k])),
        // Never seen; a count that contradicts a proof is traced rather than trusted.
        Some(_) => Err(Fallback::Inconsistent),
        None => {
            *rays += 1;
            // The triangles left out of the counting are not met by a settled sample's ray,
            // except alpha-tested ones with holes: the ray passes them all, so that it
            // measures the count's constant alone.
            let flags = &plugin.occluders.edges.flags;
            let blocked = samples.occluded_except(scene, &s.samples[m], |slot| flags[slot] != 0);
            Ok((!blocked).then_some(s.rel[m]))
        }
    }
}

/// Settles one side's [`MIXED`] samples: blocked where the opaque count says so, else
/// tested against the alpha-tested triangles whose regions hold them ([`Scratch::test_regions`]
/// paired them), alone (their alpha lookup, `traced`'s ray, built once per sample), instead
/// of tracing them through the scene. (Every region against every mixed sample, a ray per
/// pair: 16% of glass-vase-flowers' time.)
fn test_mixed(
    plugin: &Silhouette,
    scene: &Scene,
    samples: &PointSamples,
    s: &mut Scratch,
    below: bool,
    lit: Option<i32>,
) {
    let mut tests = 0u64;
    s.mixed_pairs.sort_unstable();
    for pairs in s.mixed_pairs.chunk_by(|x, y| x >> 32 == y >> 32) {
        let k = (pairs[0] >> 32) as usize;
        let x = &s.samples[k];
        if s.mixed[k] != MIXED || s.uncertain[k] || (x.height < 0.0) != below {
            continue;
        }
        let regions = &s.edges.regions;
        let slots = pairs.iter().map(|&p| {
            tests += 1;
            regions[p as u32 as usize].slot as usize
        });
        let open = Some(s.rel[k]) == lit && !samples.meets_any(scene, x, slots);
        s.mixed[k] = if open { MIXED_LIT } else { MIXED_BLOCKED };
    }
    plugin.counters.alpha_tests.fetch_add(tests, Ordering::Relaxed);
}

/// [`count`] cell by cell ([`super::cells`]), for a point [`wholly_above`] on the plain strata grid with no flagged
/// triangle in its shaft and its edges in `s`: `None` if a sample it draws falls below the
/// shading horizon after all (then the samples are drawn and counted one by one).
fn count_cells(
    plugin: &Silhouette,
    scene: &Scene,
    (samples, lobe): (&PointSamples, Option<&GlossyLobe>),
    s: &mut Scratch,
) -> Result<Option<LobeVisibility>, Fallback> {
    let r = reference(&s.edges.active)?;
    let (nx, ny) = samples.strata();
    let (nx, ny, cells) = (nx as usize, ny as usize, (nx * ny) as usize);
    let Scratch { edges, plans, starts, cell_steps, a, b, grid_rel: rel, near, drawn, .. } = s;
    plans.clear();
    plans.extend(edges.active.iter().map(|e| EdgeRows::new(e, r, ny)));
    for v in [&mut *a, &mut *b] {
        v.clear();
        v.resize(cells, f32::NAN);
    }
    rel.clear();
    rel.resize(cells, 0);
    near.clear();
    near.resize(cells, 0);
    drawn.clear();
    drawn.resize(cells, false);
    starts.clear();
    starts.extend(0..=cells as u32);
    cell_steps.clear();
    cell_steps.resize(cells + 1, 0);
    // Only the cells some edge tests sample by sample are drawn (the stream jumps to each
    // stratum); runs of cells and whole rows move without their samples.
    let binned = Binned { grid: (nx, ny), starts, a, b, rel: &mut rel[..], near: &mut near[..] };
    let drawn_all = count_edges(plans, binned, cell_steps, |cells, a, b| {
        for c in cells {
            if drawn[c] {
                continue;
            }
            drawn[c] = true;
            let Some(x) = samples.at(c as u32) else { return false };
            (a[c], b[c]) = (x.a, x.b);
        }
        true
    });
    if !drawn_all {
        return Ok(None);
    }
    let mut step = 0;
    for (rel, &d) in rel.iter_mut().zip(cell_steps.iter()) {
        step += d;
        *rel += step;
    }
    // The lowest count's first cell (the sample the one-by-one counting would aim at), and
    // its ray.
    let c = &plugin.counters;
    let mut rays = 0u64;
    let m = (0..cells).filter(|&k| near[k] == 0).min_by_key(|&k| rel[k]);
    let lit = match m.map(|m| (m, samples.at(m as u32))) {
        Some((m, Some(x))) => {
            rays += 1;
            (!samples.occluded(scene, &x)).then_some(rel[m])
        }
        Some((_, None)) => return Ok(None),
        None => None,
    };
    let mut uncertain = 0u64;
    let mut verdicts = Verdicts::new(&mut s.lit);
    for k in 0..cells {
        let open = if near[k] != 0 {
            let Some(x) = samples.at(k as u32) else { return Ok(None) };
            uncertain += 1;
            rays += 1;
            !samples.occluded(scene, &x)
        } else {
            Some(rel[k]) == lit
        };
        verdicts.push(open);
    }
    verdicts.finish();
    if lit.is_none() && uncertain < cells as u64 {
        c.points_umbra.fetch_add(1, Ordering::Relaxed);
    }
    c.rays.fetch_add(rays, Ordering::Relaxed);
    c.samples_uncertain.fetch_add(uncertain, Ordering::Relaxed);
    // Every cell's sample lies above the horizon here (`at` answered each one drawn, and
    // the others by `wholly_above`'s margin) and the strata are not warped: `weight_at`.
    // A cell some edge tested holds its sample's coordinates already: no second draw.
    let (drawn, a, b) = (&s.drawn, &s.a, &s.b);
    let coords = |k: usize| if drawn[k] { (a[k], b[k]) } else { samples.plain_coords(k as u32) };
    let weight = |k: usize| {
        let (a, b) = coords(k);
        samples.share().weight_at(a, b)
    };
    let diffuse = share(samples, &s.lit, cells as u32, weight);
    let glossy = lobe.map(|lobe| {
        lobe_share((&s.lit, cells as u32), diffuse, |k| {
            let (a, b) = coords(k);
            let target = samples.light().point(a, b);
            samples.share().weight_at(a, b) * lobe.factor(target - samples.query().point.p) as f64
        })
    });
    Ok(Some(LobeVisibility { diffuse, glossy: glossy.unwrap_or(diffuse) }))
}

/// A glossy lobe's share from the counted samples' verdicts (bit k of `open`: sample k
/// unblocked), every one weighed by `weighted(k)` (its weight times the lobe's factor): the
/// plain ratio ([`LobeTally`]), weighed only where some are blocked and some are not.
fn lobe_share((open, counted): (&[u64], u32), diffuse: f32, mut weighted: impl FnMut(usize) -> f64) -> f32 {
    let bit = |k: usize| open[k / 64] >> (k % 64) & 1 != 0;
    let visible = (0..counted as usize).filter(|&k| bit(k)).count();
    if visible == 0 || visible == counted as usize {
        return if visible == 0 { 0.0 } else { 1.0 };
    }
    let mut tally = LobeTally::default();
    for k in 0..counted as usize {
        tally.add(weighted(k), bit(k));
    }
    tally.share(diffuse)
}

/// Verdicts packed into bit words (bit k: sample k unblocked), a register word at a time: a
/// read-modify-write of memory per sample serialised the loop on store forwarding (measured:
/// a fifth of `silhouette`'s time on the default scene).
struct Verdicts<'a> {
    words: &'a mut Vec<u64>,
    word: u64,
    bit: u32,
}

impl<'a> Verdicts<'a> {
    fn new(words: &'a mut Vec<u64>) -> Self {
        words.clear();
        Verdicts { words, word: 0, bit: 0 }
    }

    #[inline(always)]
    fn push(&mut self, open: bool) {
        self.word |= (open as u64) << self.bit;
        self.bit += 1;
        if self.bit == 64 {
            self.words.push(self.word);
            (self.word, self.bit) = (0, 0);
        }
    }

    /// Stores the last, partial word.
    fn finish(self) {
        if self.bit > 0 {
            self.words.push(self.word);
        }
    }
}

/// V from the counted samples' verdicts (bit k of `open`: sample k unblocked), in stratum
/// order ([`renderer::methods::irradiance_share::IrradianceShare::visibility_from_bits`]): only the smaller set's weights, from
/// `weight`, and none at a point with nothing blocked or nothing visible.
fn share(samples: &PointSamples, open: &[u64], counted: u32, weight: impl FnMut(usize) -> f64) -> f32 {
    let counted_bits = move |w: usize| match (counted as usize).saturating_sub(64 * w) {
        n if n >= 64 => !0u64,
        n => (1u64 << n) - 1,
    };
    let words = open.iter().enumerate().map(move |(w, &bits)| (counted_bits(w), bits));
    samples.share().visibility_from_bits(words, weight)
}

/// The visibility of `q` from its silhouette edges, or why the point must be traced whole.
pub(super) fn count(
    plugin: &Silhouette,
    scene: &Scene,
    (q, lobe): (&ShadowQuery, Option<&GlossyLobe>),
    samples: &PointSamples,
) -> Result<LobeVisibility, Fallback> {
    SCRATCH.with(|cell| {
        let s = &mut *cell.borrow_mut();
        let light = plugin.light();
        let sides = Side::both(q, samples);
        let gathered = wholly_above(light, &sides[0], samples.warped());
        if gathered && let Some(v) = one_ray(plugin, scene, &sides[0], samples, s)? {
            return Ok(LobeVisibility::both(v));
        }
        if gathered
            && samples.plain_grid()
            && s.edges.regions.is_empty()
            && let Some(v) = count_cells(plugin, scene, (samples, lobe), s)?
        {
            plugin.counters.points_by_cell.fetch_add(1, Ordering::Relaxed);
            return Ok(v);
        }
        plugin.counters.points_by_sample.fetch_add(1, Ordering::Relaxed);
        let mut rays = 0u64;
        let lit = relative_counts(plugin, scene, sides, samples, s, &mut rays, gathered)?;
        if s.samples.is_empty() {
            return Ok(LobeVisibility::both(1.0));
        }
        let c = &plugin.counters;
        let mut uncertain = 0u64;
        let mut verdicts = Verdicts::new(&mut s.lit);
        for (k, x) in s.samples.iter().enumerate() {
            let open = if s.uncertain[k] {
                uncertain += 1;
                rays += 1;
                !samples.occluded(scene, x)
            } else if s.mixed[k] != 0 {
                s.mixed[k] == MIXED_LIT
            } else {
                Some(s.rel[k]) == lit[(x.height < 0.0) as usize]
            };
            verdicts.push(open);
        }
        verdicts.finish();
        if lit == [None; 2] && uncertain < s.samples.len() as u64 {
            c.points_umbra.fetch_add(1, Ordering::Relaxed);
        }
        c.rays.fetch_add(rays, Ordering::Relaxed);
        c.samples_uncertain.fetch_add(uncertain, Ordering::Relaxed);
        let counted = s.samples.len() as u32;
        let diffuse = share(samples, &s.lit, counted, |k| samples.weight(&s.samples[k]));
        let p = q.point.p;
        let glossy = lobe.map(|lobe| {
            lobe_share((&s.lit, counted), diffuse, |k| {
                let x = &s.samples[k];
                samples.weight(x) * lobe.factor(x.target - p) as f64
            })
        });
        Ok(LobeVisibility { diffuse, glossy: glossy.unwrap_or(diffuse) })
    })
}

/// Every sample of `q` with the method's verdict: `Some(lit)` where the counting settles it,
/// `None` where it traces it; `Err` where the whole point is traced. For the differential
/// tests (allocates).
pub(super) fn verdicts(
    plugin: &Silhouette,
    scene: &Scene,
    q: &ShadowQuery,
    samples: &PointSamples,
) -> Result<Vec<(LightSample, Option<bool>)>, Fallback> {
    SCRATCH.with(|cell| {
        let s = &mut *cell.borrow_mut();
        let lit = relative_counts(plugin, scene, Side::both(q, samples), samples, s, &mut 0, false)?;
        Ok((0..s.samples.len())
            .map(|k| {
                let x = s.samples[k];
                let settled = match s.mixed[k] {
                    0 => Some(s.rel[k]) == lit[(x.height < 0.0) as usize],
                    mark => mark == MIXED_LIT,
                };
                (x, (!s.uncertain[k]).then_some(settled))
            })
            .collect())
    })
}
