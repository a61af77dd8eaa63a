//! Conservative depth bounds over a light-space map: what the exact edge-table reading
//! classifies rays against (see `edge_table/exact.rs`).
//!
//! Per map pixel, by conservative rasterization of every triangle (alpha-tested ones too:
//! they may block) clipped to the pixel's frustum:
//!
//! - `near`: no geometry anywhere in the pixel's frustum is nearer the light. A ray that stays
//!   nearer than it while inside that frustum meets nothing there.
//! - `far`, where the pixel is *covered*: the deepest point of the nearest opaque sheet in it
//!   (the first connected run of the opaque triangles' depth ranges there). A pixel
//!   is covered when some opaque triangle overlaps it and no *open* edge of opaque geometry
//!   projects into it. An edge is open unless exactly two opaque triangles share it and lie
//!   on opposite sides of the plane through it and the light's centre (no boundary, no
//!   silhouette, no fold). Then every connected piece of opaque surface overlapping the pixel
//!   spans its whole frustum as one continuous sheet, so a ray that is deeper than `far` at
//!   one point of the frustum and nearer than `near` at another crosses the nearest sheet:
//!   blocked. (The nearest sheet's triangles there form one connected surface, so their depth
//!   ranges form one run; other sheets, such as the floor under a card, may lie deeper.)
//!   Alpha-tested triangles (MASK or BLEND) never cover. A pixel wholly inside one opaque triangle is covered
//!   by it alone, whatever other edges cross it (its own deepest point there is its `far`).
//!
//! Both bounds are then taken over 2 x 2 blocks of pixels ([`DepthBounds::near2`],
//! [`DepthBounds::far2`]): a mask's reference ray and a point's own ray differ by a shift of
//! less than one pixel along +x and +y (the mask sits at its sub-pixel cell's lower corner),
//! so where the reference ray is in pixel (i, j), the point's ray is in the block at (i, j).
//!
//! Margins: each pixel's frustum is widened by `PIXEL_MARGIN` pixels plus the world-space
//! slack (`slack`, from the scene's coordinate bound) seen at the casters' nearest depth (one
//! widening for every triangle, so that their depth ranges in a pixel compare), and
//! depths move outwards by `DEPTH_MARGIN` of themselves plus `slack`: the map's rays start at
//! the light's centre in exact arithmetic while traced rays start at an offset origin and
//! stop short of the light, and every projection here rounds.

mod edges;
mod runs;

use super::LightFrame;
use edges::open_edges;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use renderer::Scene;
use renderer::geometry::material::AlphaMode;
use renderer::geometry::ray_origin::gamma;
use runs::{Blocks, blocks, pixel_runs};

/// Widening of every pixel's frustum, in pixels.
pub const PIXEL_MARGIN: f32 = 1e-3;
/// How far inside a triangle's image a pixel's corners must lie for the triangle alone to
/// cover the pixel, in pixels (well above the projection's rounding).
pub const COVER_INSIDE: f32 = 1e-3;
/// Relative widening of every depth bound.
pub const DEPTH_MARGIN: f32 = 1e-5;

/// Conservative bounds of a `res` x `res` map (row-major from `origin`, pitch `pitch`).
#[derive(Debug, Clone)]
pub struct DepthBounds {
    pub resolution: u32,
    /// Per 2 x 2 block at (i, j) (pixels i..=i+1, j..=j+1): the nearest depth of anything
    /// in it; 0 where the block reaches outside the map (anything may be there); +inf empty.
    pub near2: Vec<f32>,
    /// Per 2 x 2 block: where the first run of geometry from `near2` ends, and where the next
    /// begins (+inf: none); between them is free space. 0 where the block leaves the map.
    pub end2: Vec<f32>,
    pub next2: Vec<f32>,
    /// Per 2 x 2 block: the deepest opaque depth where the whole block is covered, else NaN
    /// (never compares true).
    pub far2: Vec<f32>,
    /// The depth under which the map holds no geometry (nearer parts of triangles are not
    /// rasterized: rays there are another test's business).
    pub z_clip: f32,
    /// Open edges found (for the counters).
    pub open_edges: u64,
}

/// Per-pixel accumulators of one rasterization pass.
#[derive(Clone)]
pub(super) struct Raster {
    pub(super) near: Vec<f32>,
    /// (pixel, nearest depth, deepest depth, opaque) of every triangle in every pixel.
    pub(super) ranges: Vec<(u32, f32, f32, bool)>,
    /// Bit 0: an opaque triangle overlaps; bit 1: an open edge (or a cut triangle) does.
    pub(super) flags: Vec<u8>,
    /// Per pixel, the opaque triangle wholly covering it whose deepest point there is
    /// nearest, as (triangle, that depth); (u32::MAX, inf) where none.
    pub(super) cover: Vec<(u32, f32)>,
}

pub(super) const OPAQUE: u8 = 1;
pub(super) const NO_COVER: (u32, f32) = (u32::MAX, f32::INFINITY);
const OPEN: u8 = 2;

/// The map's geometry: where its pixels are, and the slack of every test.
#[derive(Clone, Copy)]
struct Grid {
    origin: Vec2,
    pitch: f32,
    res: i32,
    z_clip: f32,
    slack: f32,
    /// The widening of every pixel, in pixels.
    margin: f32,
}

impl Raster {
    fn new(n: usize) -> Self {
        Raster {
            near: vec![f32::INFINITY; n],
            ranges: Vec::new(),
            flags: vec![0; n],
            cover: vec![NO_COVER; n],
        }
    }

    fn merge(mut self, mut other: Raster) -> Raster {
        self.ranges.append(&mut other.ranges);
        for k in 0..self.near.len() {
            self.near[k] = self.near[k].min(other.near[k]);
            self.flags[k] |= other.flags[k];
            if (other.cover[k].1, other.cover[k].0) < (self.cover[k].1, self.cover[k].0) {
                self.cover[k] = other.cover[k];
            }
        }
        self
    }
}

/// Clips a convex polygon (light-frame points) to `plane(v) >= 0`, into `out`.
#[inline]
fn clip(poly: &[Vec3], plane: impl Fn(Vec3) -> f32, out: &mut Vec<Vec3>) {
    out.clear();
    for k in 0..poly.len() {
        let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
        let (da, db) = (plane(a), plane(b));
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            let t = da / (da - db);
            out.push(a + (b - a) * t);
        }
    }
}

impl Grid {
    /// Image point (pixel units from the map's corner) of a light-frame point at z > 0.
    #[inline]
    fn image(&self, v: Vec3) -> Vec2 {
        (Vec2::new(v.x, v.y) / v.z - self.origin) / self.pitch
    }

    /// The pixel box (inclusive, clamped to the map) that points within `m` pixels of the
    /// image box [lo, hi] fall in; None when it misses the map.
    #[inline]
    fn pixel_box(&self, lo: Vec2, hi: Vec2, m: f32) -> Option<([i32; 2], [i32; 2])> {
        let (lo, hi) = ((lo - m).floor(), (hi + m).floor());
        if lo.is_nan() || hi.is_nan() {
            return None;
        }
        let n = (self.res - 1) as f32;
        if hi.x < 0.0 || hi.y < 0.0 || lo.x > n || lo.y > n {
            return None;
        }
        let c = |x: f32| x.clamp(0.0, n) as i32;
        Some(([c(lo.x), c(lo.y)], [c(hi.x), c(hi.y)]))
    }

    /// Rasterizes one triangle (light-frame vertices) into `r`: near, and for opaque ones far
    /// and the opaque flag; a triangle cut by `z_clip` marks its pixels open.
    fn triangle(
        &self,
        id: u32,
        v: [Vec3; 3],
        opaque: bool,
        r: &mut Raster,
        a: &mut Vec<Vec3>,
        b: &mut Vec<Vec3>,
    ) {
        let cut = v.iter().any(|p| p.z < self.z_clip);
        if v.iter().all(|p| p.z < self.z_clip) || !v.iter().all(|p| p.is_finite()) {
            return;
        }
        clip(&v, |p| p.z - self.z_clip, a);
        let (mut lo, mut hi) = (Vec2::INFINITY, Vec2::NEG_INFINITY);
        for p in a.iter() {
            let g = self.image(*p);
            (lo, hi) = (lo.min(g), hi.max(g));
        }
        // One widening for every triangle: the runs of depth ranges in a pixel compare
        // triangles clipped to the same frustum.
        let m = self.margin;
        let Some((p_lo, p_hi)) = self.pixel_box(lo, hi, m) else { return };
        let poly: Vec<Vec3> = std::mem::take(a);
        // Whole-pixel cover by this triangle alone: its image holds the widened pixel's four
        // corners, each by more than COVER_INSIDE pixels (edge functions in pixel units).
        let g = v.map(|p| self.image(p));
        let orient = (g[1] - g[0]).perp_dot(g[2] - g[0]);
        let can_cover = opaque && !cut && orient.is_finite() && orient != 0.0;
        let inside = |c: Vec2| {
            (0..3).all(|e| {
                let (p, q) = (g[e], g[(e + 1) % 3]);
                (q - p).perp_dot(c - p) * orient.signum() > COVER_INSIDE * (q - p).length()
            })
        };
        for j in p_lo[1]..=p_hi[1] {
            for i in p_lo[0]..=p_hi[0] {
                // The pixel's frustum, widened by m pixels: x >= u0 z, x <= u1 z (likewise y).
                let u0 = self.origin.x + (i as f32 - m) * self.pitch;
                let u1 = self.origin.x + (i as f32 + 1.0 + m) * self.pitch;
                let w0 = self.origin.y + (j as f32 - m) * self.pitch;
                let w1 = self.origin.y + (j as f32 + 1.0 + m) * self.pitch;
                clip(&poly, |p| p.x - u0 * p.z, b);
                clip(b, |p| u1 * p.z - p.x, a);
                clip(a, |p| p.y - w0 * p.z, b);
                clip(b, |p| w1 * p.z - p.y, a);
                if a.is_empty() {
                    continue;
                }
                let (zmin, zmax) =
                    a.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), p| (l.min(p.z), h.max(p.z)));
                let k = (j * self.res + i) as usize;
                let zmin = zmin * (1.0 - DEPTH_MARGIN) - self.slack;
                r.near[k] = r.near[k].min(zmin);
                r.ranges.push((k as u32, zmin, zmax * (1.0 + DEPTH_MARGIN) + self.slack, opaque));
                if opaque {
                    r.flags[k] |= OPAQUE;
                }
                if can_cover {
                    let (x0, y0, x1, y1) =
                        (i as f32 - m, j as f32 - m, i as f32 + 1.0 + m, j as f32 + 1.0 + m);
                    let far = zmax * (1.0 + DEPTH_MARGIN) + self.slack;
                    if far < r.cover[k].1
                        && [Vec2::new(x0, y0), Vec2::new(x1, y0), Vec2::new(x1, y1), Vec2::new(x0, y1)]
                            .into_iter()
                            .all(inside)
                    {
                        r.cover[k] = (id, far);
                    }
                }
                if cut {
                    r.flags[k] |= OPEN;
                }
            }
        }
        *a = poly;
    }

    /// Marks open every pixel the segment [p, q] (light frame) passes within the margin of.
    fn open_edge(&self, p: Vec3, q: Vec3, flags: &mut [u8]) {
        // Only the part at z >= z_clip is in the map (the cut triangles mark the rest).
        let (mut p, mut q) = (p, q);
        if p.z < self.z_clip && q.z < self.z_clip {
            return;
        }
        if p.z < self.z_clip {
            p = p + (q - p) * ((self.z_clip - p.z) / (q.z - p.z));
        } else if q.z < self.z_clip {
            q = q + (p - q) * ((self.z_clip - q.z) / (p.z - q.z));
        }
        let (gp, gq) = (self.image(p), self.image(q));
        if !gp.is_finite() || !gq.is_finite() {
            return;
        }
        let m = 2.0 * self.margin;
        let Some((lo, hi)) = self.pixel_box(gp.min(gq), gp.max(gq), m) else { return };
        let d = gq - gp;
        let n = Vec2::new(-d.y, d.x);
        // A pixel box [i - m, i + 1 + m] meets the segment's line iff its centre's distance
        // along the normal is within the box's half-extent on it (its bounding box is given).
        let reach = (0.5 + m) * (n.x.abs() + n.y.abs()) * (1.0 + 1e-4) + 1e-6;
        for j in lo[1]..=hi[1] {
            for i in lo[0]..=hi[0] {
                let c = Vec2::new(i as f32 + 0.5, j as f32 + 0.5);
                if n.dot(c - gp).abs() <= reach {
                    flags[(j * self.res + i) as usize] |= OPEN;
                }
            }
        }
    }
}

impl DepthBounds {
    /// Rasterizes every triangle of `scene` into a `res` x `res` map over the light frame
    /// `frame` (lower image-plane corner `origin`, pixel pitch `pitch`), down to depth
    /// `z_clip`; beside the bounds, per 2 x 2 block the nearest depth of its pixels on the map
    /// (what the near map's pyramid holds: a border block's 0 would make every region
    /// reaching it reach to the light).
    pub fn build(
        scene: &Scene,
        frame: &LightFrame,
        origin: Vec2,
        pitch: f32,
        res: u32,
        z_clip: f32,
        z_casters: f32,
    ) -> (Self, Vec<f32>) {
        let _span = tracing::info_span!("bounds", resolution = res).entered();
        let n = (res * res) as usize;
        let slack = gamma(64) * (scene.coordinate_bound() + frame.origin.abs().max_element());
        // The world-space slack seen at the casters' nearest depth, in pixels.
        let margin = PIXEL_MARGIN + (slack / (z_casters.max(z_clip) * pitch)).min(0.25);
        let grid = Grid { origin, pitch, res: res as i32, z_clip, slack, margin };
        let light_tris: Vec<(u32, [Vec3; 3], bool)> = scene
            .triangles
            .par_iter()
            .zip(&scene.shading)
            .enumerate()
            .map(|(id, (t, s))| {
                let v = [t.v0, t.v1, t.v2].map(|p| frame.light_from_world(Vec3::from(p)));
                let opaque = matches!(scene.materials[s.material as usize].alpha, AlphaMode::Opaque);
                (id as u32, v, opaque)
            })
            .collect();
        let raster_span = tracing::info_span!("rasterize").entered();
        let raster = light_tris
            .par_chunks(4096)
            .fold(
                || (Raster::new(n), Vec::new(), Vec::new()),
                |(mut r, mut a, mut b), chunk| {
                    for (id, v, opaque) in chunk {
                        grid.triangle(*id, *v, *opaque, &mut r, &mut a, &mut b);
                    }
                    (r, a, b)
                },
            )
            .map(|(r, _, _)| r)
            .reduce(|| Raster::new(n), Raster::merge);
        drop(raster_span);
        let edges_span = tracing::info_span!("open_edges").entered();
        let opaque: Vec<[Vec3; 3]> = light_tris.iter().filter(|(_, _, o)| *o).map(|(_, v, _)| *v).collect();
        let open = open_edges(&opaque);
        // Open edges only set flags: rasterized into flag maps of their own, then ORed in.
        let open_flags = open
            .par_chunks(1024)
            .fold(
                || vec![0u8; n],
                |mut flags, chunk| {
                    for (p, q) in chunk {
                        grid.open_edge(*p, *q, &mut flags);
                    }
                    flags
                },
            )
            .reduce(
                || vec![0u8; n],
                |mut a, b| {
                    a.iter_mut().zip(&b).for_each(|(x, y)| *x |= *y);
                    a
                },
            );
        let mut raster = raster;
        raster.flags.iter_mut().zip(&open_flags).for_each(|(x, y)| *x |= *y);
        drop(edges_span);
        let _runs_span = tracing::info_span!("runs").entered();
        let runs = pixel_runs(std::mem::take(&mut raster.ranges), n);
        let Blocks { near2, end2, next2, far2, near_on_map } = blocks(&raster, &runs, res as usize);
        let bounds =
            DepthBounds { resolution: res, near2, end2, next2, far2, z_clip, open_edges: open.len() as u64 };
        (bounds, near_on_map)
    }

    /// The index of the block at (i, j), None outside the map.
    #[inline]
    fn block(&self, i: i32, j: i32) -> Option<usize> {
        let n = self.resolution as i32;
        (i >= 0 && j >= 0 && i < n && j < n).then(|| (j * n + i) as usize)
    }

    /// The nearest depth in the block at (i, j); 0 outside the map.
    #[inline]
    pub fn near2_at(&self, i: i32, j: i32) -> f32 {
        self.block(i, j).map_or(0.0, |k| self.near2[k])
    }

    /// The first run's end and the next run's start in the block at (i, j); (0, 0) outside
    /// the map.
    #[inline]
    pub fn gap2_at(&self, i: i32, j: i32) -> (f32, f32) {
        self.block(i, j).map_or((0.0, 0.0), |k| (self.end2[k], self.next2[k]))
    }

    /// The deepest opaque depth of the covered block at (i, j); NaN where not covered.
    #[inline]
    pub fn far2_at(&self, i: i32, j: i32) -> f32 {
        self.block(i, j).map_or(f32::NAN, |k| self.far2[k])
    }

    pub fn bytes(&self) -> u64 {
        ((self.near2.len() + self.end2.len() + self.next2.len() + self.far2.len()) * 4) as u64
    }
}

impl DepthBounds {
    /// The exact reading's map for `light`: the frustum fitted to the receivers as for every
    /// depth map ([`super::DepthMapParams`]' fit), the bounds rasterized into it, and the near
    /// bounds as a [`DepthMap`] (its pyramid shrinks regions and culls blocks).
    pub fn build_for_light(
        scene: &Scene,
        light: &renderer::RectLight,
        visible: &[renderer::ShadingPoint],
        params: &super::DepthMapParams,
    ) -> (DepthBounds, super::DepthMap) {
        let _span = tracing::info_span!("depth_map", resolution = params.resolution).entered();
        let frame = LightFrame::new(light);
        let res = params.resolution.max(4);
        let super::fit::Frustum { origin, pitch, caster_z_near } =
            super::fit::fit(scene, light, &frame, visible, params, res);
        // Geometry nearer the light than this is left to the far-field shaft: its projection
        // runs off to infinity at the light's plane.
        let z_clip = if caster_z_near.is_finite() && caster_z_near > 0.0 {
            1e-3 * caster_z_near
        } else {
            1e-6 * scene.coordinate_bound().max(1e-30)
        };
        let (bounds, near_on_map) =
            DepthBounds::build(scene, &frame, origin, pitch, res, z_clip, caster_z_near);
        let near = super::DepthMap::from_depths(frame, origin, pitch, res, near_on_map);
        (bounds, near)
    }
}
