//! The light-space depth map shared by the depth-map methods: a perspective map whose centre
//! of projection is the light's centre and whose axis is the light's normal, with square
//! pixels and linear planar depth in f32, rendered by rays through the BVH (alpha test
//! honoured). Its frustum covers what the camera sees that the light reaches, plus the
//! filter margin. Depths are stored already biased (see [`DepthMapParams::slope_bias`]).

use crate::march::{floor_height, region_reach};
use glam::{Vec2, Vec3, Vec3A};
use obvhs::ray::Ray;
use rayon::prelude::*;
use renderer::{KeyError, RectLight, Scene, Shaft, VisiblePoint};
use serde::{Deserialize, Serialize};

/// The light's frame: origin at its centre, x and y along its edges, z along its normal
/// (into the scene). Light samples have z = 0 in this frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightFrame {
    pub origin: Vec3,
    pub x: Vec3,
    pub y: Vec3,
    pub z: Vec3,
    /// Half the light's edge lengths along x and y.
    pub half_size: Vec2,
}

impl LightFrame {
    pub fn new(light: &RectLight) -> Self {
        let x = light.u.normalize();
        let y = light.v.normalize();
        Self {
            origin: light.center,
            x,
            y,
            z: x.cross(y),
            half_size: 0.5 * Vec2::new(light.u.length(), light.v.length()),
        }
    }

    #[inline]
    pub fn light_from_world(&self, p: Vec3) -> Vec3 {
        let d = p - self.origin;
        Vec3::new(d.dot(self.x), d.dot(self.y), d.dot(self.z))
    }

    #[inline]
    pub fn world_from_light(&self, p: Vec3) -> Vec3 {
        self.origin + p.x * self.x + p.y * self.y + p.z * self.z
    }

    /// Cosine between a unit normal `n` at `p` and the direction from `p` to the light's
    /// centre (1 facing the light squarely, 0 edge-on, negative facing away).
    #[inline]
    pub fn facing(&self, p: Vec3, n: Vec3) -> f32 {
        let to_light = self.origin - p;
        n.dot(to_light) / to_light.length()
    }
}

/// Depth-map parameters shared by the depth-map methods, flattened into each one's table:
/// `depth_map`, `slope_bias`, `slab_thickness`, `normal_offset`, `grazing_cos`. The other
/// fields are code-only (ablations the accuracy example and tests switch).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DepthMapParams {
    /// Pixels per side (square). More pixels: finer silhouettes, larger filter regions.
    /// Typical 128 to 1024. Key `depth_map`.
    #[serde(rename = "depth_map")]
    pub resolution: u32,
    /// Slope-scaled bias in depth-map pixels: each texel's floor is pushed back by
    /// `slope_bias x` the depth change of its surface across one pixel footprint (from the
    /// surface normal at the texel), plus the scene's ray epsilon. Too little: lit surfaces
    /// shadow themselves (acne); too much: contact shadows detach. 1.0 by measurement.
    pub slope_bias: f32,
    /// Thickness of each floor's slab, in pixel footprints at its depth, for the `plates`
    /// reading: a ray is blocked where it passes through a slab, so 0 is infinitely thin
    /// plates and a few pixels make closed thin objects (chair legs, stems) opaque to rays
    /// from their own back side while floating occluders keep their inner penumbra.
    pub slab_thickness: f32,
    /// Grazing normal offset, in pixel footprints (see [`DepthMap::lookup_point`]).
    pub normal_offset: f32,
    /// Read closed meshes as solid (`plates`): where the light's ray through a pixel enters
    /// a surface through its front face and next meets a back face, the pixel's slab reaches
    /// down to that back face (a second depth layer), so a chair seat or a fox's leg blocks
    /// the rays that pass under its top surface. Open surfaces keep `slab_thickness`.
    #[serde(skip)]
    pub closed_volumes: bool,
    /// `plates`: a second layer per pixel, the first surface below the first one's slab (a
    /// chair's frame under its seat, a vase's far wall), read like the first and OR-ed with
    /// it: a ray is blocked if it passes through a slab of either layer. The same masks serve
    /// both; queries cost up to twice as much where the layer is near.
    #[serde(skip)]
    pub hidden_layer: bool,
    /// Receivers the light grazes: where the cosine between a shading point's geometric
    /// normal and the direction to the light's centre is below this, traced rays answer
    /// (counted as `fallbacks_grazing`) and the point takes no part in fitting the map. The
    /// map sees such a surface steeply or edge-on: a fold of cloth, the far side of a sphere
    /// near its terminator or a wall beside a stem is a sliver of a pixel, so the occluders
    /// that matter there (the facing fold, the surface's own curvature) are not in it. Only
    /// the samples above the horizon are traced; such points are a small share of most
    /// frames, but up to half of the lit points of a scene of curved surfaces lit from the
    /// side (toy-car), where they are most of the shadow cost. 0 turns it off. Measured:
    /// ARCHITECTURE.md.
    pub grazing_cos: f32,
    /// Fit the map's frustum only to receivers something may shadow: those whose shaft to
    /// the light ([`renderer::Shaft`]) is not provably clear. A receiver outside the map is
    /// answered by the traced fallback, whose first shaft test proves it unblocked at the
    /// cost of one BVH query; the map's pixels go where the shadows are.
    #[serde(skip)]
    pub fit_shadowed: bool,
}

impl DepthMapParams {
    pub const fn new(resolution: u32) -> Self {
        Self {
            resolution,
            slope_bias: 1.0,
            slab_thickness: DEFAULT_SLAB,
            normal_offset: DEFAULT_NORMAL_OFFSET,
            closed_volumes: true,
            hidden_layer: true,
            grazing_cos: DEFAULT_GRAZING_COS,
            fit_shadowed: true,
        }
    }
}

/// The default slab thickness, in pixel footprints (measured: docs/edge_table_accuracy.md).
pub const DEFAULT_SLAB: f32 = 2.0;

/// The default [`DepthMapParams::grazing_cos`]: 0.5, the light's centre within 30 deg of
/// the tangent plane. Chosen by measurement (ARCHITECTURE.md): against 0.2 it lowered the
/// RMSE on six of seven accuracy scenes, against the same-sample and a 4096-sample truth.
pub const DEFAULT_GRAZING_COS: f32 = 0.5;

/// The default grazing normal offset, in pixel footprints.
pub const DEFAULT_NORMAL_OFFSET: f32 = 0.5;

impl Default for DepthMapParams {
    fn default() -> Self {
        Self::new(256)
    }
}

/// Accepted `depth_map` sizes.
pub const DEPTH_MAP_RANGE: std::ops::RangeInclusive<u32> = 4..=8192;

impl DepthMapParams {
    /// The code-only fields from `base` (the scene file cannot set them).
    pub fn keep_code_only(&mut self, base: &Self) {
        self.closed_volumes = base.closed_volumes;
        self.hidden_layer = base.hidden_layer;
        self.fit_shadowed = base.fit_shadowed;
    }

    /// Checks the ranges; the key is the table's.
    pub fn validate(&self) -> Result<(), KeyError> {
        if !DEPTH_MAP_RANGE.contains(&self.resolution) {
            let (lo, hi) = (DEPTH_MAP_RANGE.start(), DEPTH_MAP_RANGE.end());
            return Err(KeyError::new(
                "depth_map",
                format!("must be in {lo}..={hi}, got {}", self.resolution),
            ));
        }
        for (key, v) in [
            ("slope_bias", self.slope_bias),
            ("normal_offset", self.normal_offset),
            ("slab_thickness", self.slab_thickness),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(KeyError::new(key, "must be finite and >= 0"));
            }
        }
        if !(0.0..1.0).contains(&self.grazing_cos) {
            return Err(KeyError::new("grazing_cos", "must be in [0, 1)"));
        }
        Ok(())
    }
}

/// Largest image-plane coordinate the frustum may reach: a half-angle of atan(4) = 76 deg.
/// Beyond it one map cannot keep useful resolution; points whose filter region would need
/// more fall back to traced rays.
pub const MAX_TAN: f32 = 4.0;

/// How many closed meshes stacked on each other one pixel's slab may span.
const MAX_STACKED_SOLIDS: usize = 4;

/// Steepest surface slope under which `closed_volumes` thickens a pixel's slab.
const MAX_SOLID_SLOPE: f32 = 1.0;

/// Steepest surface slope (tan of the angle to the view ray) the bias accounts for.
const MAX_SLOPE: f32 = 8.0;

#[derive(Debug, Clone)]
pub struct DepthMap {
    pub frame: LightFrame,
    pub resolution: u32,
    /// Image-plane coordinates (x/z, y/z) of the map's lower corner, and the pixel pitch.
    pub origin: Vec2,
    pub pitch: f32,
    /// Biased planar depth per pixel, row-major from `origin`; +inf where no surface. Read
    /// only: the min-depth pyramid (region shrinking, block culling) is built from it when
    /// the map is made, and bounds the hidden layer's depths too.
    pub depth: Vec<f32>,
    /// The smallest biased depth in the map (+inf for an empty map).
    pub z_min: f32,
    /// The nearest depth of any geometry that may cast onto the receivers (the frustum's
    /// margin is sized for it).
    pub caster_z_near: f32,
    /// Biased depth of the bottom of each pixel's slab (`plates` reading): at least the
    /// floor's depth times (1 + `slab_thickness` x pitch), deeper where a closed mesh's back
    /// face lies below its front face (see [`DepthMapParams::closed_volumes`]).
    pub bottom: Vec<f32>,
    /// The hidden layer ([`DepthMapParams::hidden_layer`]): per pixel the floor and slab
    /// bottom of the first surface below `bottom` (+inf where none); empty when off. Read
    /// only, never above `depth`.
    pub depth2: Vec<f32>,
    pub bottom2: Vec<f32>,
    /// See [`DepthMap::lookup_point`].
    pub normal_offset: f32,
    /// See [`DepthMapParams::grazing_cos`].
    pub grazing_cos: f32,
    pyramid: MinPyramid,
}

/// See [`DepthMapParams::grazing_cos`].
#[inline]
fn grazing(frame: &LightFrame, grazing_cos: f32, p: Vec3, n_geom: Vec3) -> bool {
    grazing_cos > 0.0 && frame.facing(p, n_geom) < grazing_cos
}

/// Share of the receivers' total irradiance, per side and axis, left out of the frustum.
pub const RECEIVER_TRIM: f64 = 0.001;

/// The range of `(coordinate, weight)` pairs that leaves out `RECEIVER_TRIM` of the total
/// weight at each end.
fn trimmed_range(values: &mut [(f32, f32)]) -> (f32, f32) {
    // A total order on both members: the order, and so the sums below, are the same bits
    // whatever the parallel sort's split (thread count).
    values.par_sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let total: f64 = values.iter().map(|v| v.1 as f64).sum();
    let cut = total * RECEIVER_TRIM;
    let position = |iter: &mut dyn Iterator<Item = &(f32, f32)>| {
        let mut acc = 0.0;
        for v in iter {
            acc += v.1 as f64;
            if acc > cut {
                return v.0;
            }
        }
        values[0].0
    };
    let lo = position(&mut values.iter());
    let hi = position(&mut values.iter().rev());
    (lo.min(hi), hi.max(lo))
}

/// Min-depth mip levels: level l holds the minimum over 2^l x 2^l pixel blocks.
#[derive(Debug, Clone)]
struct MinPyramid {
    levels: Vec<(usize, Vec<f32>)>,
}

impl MinPyramid {
    fn new(depth: &[f32], n: usize) -> Self {
        let mut levels = vec![(n, depth.to_vec())];
        while levels.last().unwrap().0 > 1 {
            let (m, prev) = levels.last().unwrap();
            let (m, half) = (*m, m.div_ceil(2));
            let mut next = vec![f32::INFINITY; half * half];
            for j in 0..m {
                for i in 0..m {
                    let d = &mut next[(j / 2) * half + i / 2];
                    *d = d.min(prev[j * m + i]);
                }
            }
            levels.push((half, next));
        }
        Self { levels }
    }

    /// A lower bound of the depths in the pixel rectangle [lo, hi] (clipped to the map):
    /// the minimum over the blocks of the first level where it spans at most 4 blocks.
    fn min(&self, lo: [i32; 2], hi: [i32; 2]) -> f32 {
        let n0 = self.levels[0].0 as i32;
        let lo = [lo[0].clamp(0, n0 - 1), lo[1].clamp(0, n0 - 1)];
        let hi = [hi[0].clamp(0, n0 - 1), hi[1].clamp(0, n0 - 1)];
        let span = (hi[0] - lo[0]).max(hi[1] - lo[1]) as u32;
        let l = (32 - (span / 4).leading_zeros()).min(self.levels.len() as u32 - 1) as usize;
        let (m, data) = &self.levels[l];
        let mut z = f32::INFINITY;
        for j in (lo[1] >> l)..=(hi[1] >> l) {
            for i in (lo[0] >> l)..=(hi[0] >> l) {
                z = z.min(data[j as usize * m + i as usize]);
            }
        }
        z
    }
}

/// A point in depth-map terms: its pixel, its offset inside the pixel, its depth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapPoint {
    pub pixel: [i32; 2],
    pub offset: Vec2,
    pub z: f32,
}

/// What the map's rays see, for [`DepthMap::build`].
struct Surfaces<'a> {
    scene: &'a Scene,
    frame: &'a LightFrame,
    params: &'a DepthMapParams,
    pitch: f32,
    slab: f32,
    eps: f32,
}

impl Surfaces<'_> {
    /// The first surface the light's ray through image point `img` meets beyond planar depth
    /// `from`, as a (floor, slab bottom) pair of biased depths.
    fn slab_after(&self, img: Vec2, from: f32) -> Option<(f32, f32)> {
        let (frame, params, pitch, eps) = (self.frame, self.params, self.pitch, self.eps);
        // Direction with light-space z = 1: the ray's t is then the planar depth.
        let dir = frame.x * img.x + frame.y * img.y + frame.z;
        let ray = Ray::new(Vec3A::from(frame.origin), Vec3A::from(dir), from, f32::INFINITY);
        let hit = self.scene.intersect(ray)?;
        // Planar depth over the image is z = c / (n . (u, v, 1)) for a plane with light-frame
        // normal n, so one pixel changes it by about pitch * z * |n_xy| / |n . (u, v, 1)|:
        // zero for surfaces facing the light squarely, large for grazing ones (capped at
        // MAX_SLOPE).
        let z = hit.t;
        let n = Vec3::new(hit.n_geom.dot(frame.x), hit.n_geom.dot(frame.y), hit.n_geom.dot(frame.z));
        let facing = (n.x * img.x + n.y * img.y + n.z).abs();
        let slope = (n.truncate().length() / facing.max(1e-12)).min(MAX_SLOPE);
        let d = z + params.slope_bias * pitch * z * slope + eps;
        let mut b = d * (1.0 + self.slab);
        // Closed volumes: the next surface along the same ray. A back face there means the
        // ray was inside a closed mesh from z to it (glTF meshes wind their front faces
        // outwards); anything else is an open surface. Solids stacked within a slab of each
        // other (a ball resting on a seat) are one. Only under surfaces that face the light
        // (slope <= 1, within 45 deg): the depth of a surface the light grazes steps steeply
        // from pixel to pixel, so rays leaving it dip under its neighbours' floors and would
        // stay blocked in a thick slab (measured: false shadows on a grazed wall).
        if params.closed_volumes && hit.front_face && slope <= MAX_SOLID_SLOPE {
            let mut from = z;
            for _ in 0..MAX_STACKED_SOLIDS {
                let inside = Ray::new(ray.origin, ray.direction, from + 2.0 * eps, f32::INFINITY);
                let Some(exit) = self.scene.intersect(inside).filter(|h| !h.front_face) else { break };
                b = b.max(exit.t + eps);
                let beyond = Ray::new(ray.origin, ray.direction, exit.t + 2.0 * eps, f32::INFINITY);
                match self.scene.intersect(beyond) {
                    Some(next) if next.front_face && next.t <= exit.t * (1.0 + self.slab) + eps => {
                        from = next.t
                    }
                    _ => break,
                }
            }
        }
        Some((d, b))
    }
}

impl DepthMap {
    /// Fits the frustum to the receivers in `visible` and renders the map.
    ///
    /// # Panics
    /// A negative or non-finite `slope_bias` or `slab_thickness` (checked at the config
    /// boundary): every layer must lie at or below the one before it.
    pub fn build(
        scene: &Scene,
        light: &RectLight,
        visible: &[VisiblePoint],
        params: &DepthMapParams,
    ) -> Self {
        assert!(params.slope_bias >= 0.0 && params.slope_bias.is_finite(), "slope_bias");
        assert!(params.slab_thickness >= 0.0 && params.slab_thickness.is_finite(), "slab_thickness");
        let frame = LightFrame::new(light);
        let res = params.resolution.max(1);
        let eps = scene.epsilon.eps;

        // Receivers: visible points the light reaches, weighted by their irradiance. The
        // frustum leaves out RECEIVER_TRIM of the total irradiance on each side of each axis:
        // surfaces reaching up to the light's plane (a wall beside a ceiling light) would
        // otherwise stretch the map over a huge field of view for points that the light
        // only grazes; those fall back to traced rays.
        // In parallel, with the sorts in `trimmed_range`: on the default scene at 640x480 (307k
        // points) the serial fit took 67 of prepare's 160 ms.
        // With `fit_shadowed`, the box is fitted to the receivers whose shaft is not clear
        // (the third member), while the depth range (and so the margin below) still spans
        // every receiver: the margin fitted to the shadowed ones alone grew with their depth
        // and coarsened the map (tests/hard_cases.rs, light larger than the scene: RMSE 0.025
        // -> 0.038).
        let receivers: Vec<(Vec3, f32, bool)> = visible
            .par_iter()
            .filter_map(|v| {
                let p = frame.light_from_world(v.p);
                if p.z <= eps || grazing(&frame, params.grazing_cos, v.p, v.n_geom) {
                    return None;
                }
                let e = light.irradiance_factor(v.p, v.n_shading);
                if e <= 0.0 {
                    return None;
                }
                let fitted = !params.fit_shadowed
                    || Shaft::new(light, v.p, v.n_geom, eps).is_none_or(|shaft| !scene.shaft_clear(&shaft));
                Some((p, e, fitted))
            })
            .collect();
        // Nothing in view that anything may shadow: fit to every receiver, as without the
        // option (not to a default box the points would read masks through for nothing).
        let any_fitted = receivers.iter().any(|r| r.2);
        let fitted = receivers.iter().filter(|r| r.2 || !any_fitted);
        let mut xs: Vec<(f32, f32)> = fitted.clone().map(|(p, e, _)| (p.x / p.z, *e)).collect();
        let mut ys: Vec<(f32, f32)> = fitted.map(|(p, e, _)| (p.y / p.z, *e)).collect();
        let mut z_recv_min = receivers.iter().map(|(p, _, _)| p.z).fold(f32::INFINITY, f32::min);
        let (mut lo, mut hi) = if xs.is_empty() {
            // No receiver at all (some are always fitted when there are any).
            z_recv_min = 1.0;
            (Vec2::splat(-1.0), Vec2::splat(1.0))
        } else {
            let (x0, x1) = trimmed_range(&mut xs);
            let (y0, y1) = trimmed_range(&mut ys);
            (Vec2::new(x0, y0), Vec2::new(x1, y1))
        };
        lo = lo.clamp(Vec2::splat(-MAX_TAN), Vec2::splat(MAX_TAN));
        hi = hi.clamp(lo, Vec2::splat(MAX_TAN));

        // Casters: the nearest vertex in front of the light whose image could reach a
        // receiver's filter region (conservatively, within the receivers' box grown by the
        // light's half size / z).
        let mut caster_z_near = z_recv_min;
        for t in &scene.triangles {
            for v in [t.v0, t.v1, t.v2] {
                let p = frame.light_from_world(Vec3::from(v));
                if p.z > eps && p.z < caster_z_near {
                    let img = Vec2::new(p.x, p.y) / p.z;
                    let reach = frame.half_size / p.z;
                    if img.cmpge(lo - reach).all() && img.cmple(hi + reach).all() {
                        caster_z_near = p.z;
                    }
                }
            }
        }
        // The margin: how far a shadow ray travels in the image before it is above the
        // nearest caster.
        let margin = frame.half_size * (1.0 / caster_z_near - 1.0 / (z_recv_min.max(caster_z_near)));
        let lo = (lo - margin).max(Vec2::splat(-MAX_TAN));
        let hi = (hi + margin).min(Vec2::splat(MAX_TAN));
        let side = (hi - lo).max_element().max(1e-6);
        let centre = 0.5 * (lo + hi);
        // One pixel of padding on each side so the border pixels are inside the fit.
        let pitch = side / (res as f32 - 2.0).max(1.0);
        let origin = centre - Vec2::splat(0.5 * pitch * res as f32);

        let slab = params.slab_thickness * pitch;
        let n_pixels = (res * res) as usize;
        let mut depth = vec![f32::INFINITY; n_pixels];
        let mut bottom = vec![f32::INFINITY; n_pixels];
        let mut depth2 = vec![f32::INFINITY; n_pixels];
        let mut bottom2 = vec![f32::INFINITY; n_pixels];
        let surface = Surfaces { scene, frame: &frame, params, pitch, slab, eps };
        let row = res as usize;
        depth
            .par_chunks_mut(row)
            .zip(bottom.par_chunks_mut(row))
            .zip(depth2.par_chunks_mut(row))
            .zip(bottom2.par_chunks_mut(row))
            .enumerate()
            .for_each(|(j, (((d_row, b_row), d2_row), b2_row))| {
                for i in 0..row {
                    let img = origin + pitch * Vec2::new(i as f32 + 0.5, j as f32 + 0.5);
                    let Some((d, b)) = surface.slab_after(img, 2.0 * eps) else { continue };
                    (d_row[i], b_row[i]) = (d, b);
                    // The hidden layer: the first surface below this pixel's slab.
                    if params.hidden_layer
                        && let Some((d2, b2)) = surface.slab_after(img, b)
                    {
                        (d2_row[i], b2_row[i]) = (d2, b2);
                    }
                }
            });
        if !params.hidden_layer {
            (depth2, bottom2) = (Vec::new(), Vec::new());
        }
        let z_min = depth.iter().copied().fold(f32::INFINITY, f32::min);
        let pyramid = MinPyramid::new(&depth, res as usize);
        DepthMap {
            frame,
            resolution: res,
            origin,
            pitch,
            depth,
            z_min,
            caster_z_near,
            bottom,
            depth2,
            bottom2,
            normal_offset: params.normal_offset,
            grazing_cos: params.grazing_cos,
            pyramid,
        }
    }

    /// A map over a given heightfield (biased depths, row-major), for tests and tools.
    ///
    /// # Panics
    /// A depth count other than `resolution`^2, or a NaN depth.
    pub fn from_depths(
        frame: LightFrame,
        origin: Vec2,
        pitch: f32,
        resolution: u32,
        depth: Vec<f32>,
    ) -> Self {
        assert_eq!(depth.len(), (resolution * resolution) as usize);
        assert!(!depth.iter().any(|d| d.is_nan()), "NaN depth");
        let z_min = depth.iter().copied().fold(f32::INFINITY, f32::min);
        let pyramid = MinPyramid::new(&depth, resolution as usize);
        DepthMap {
            frame,
            resolution,
            origin,
            pitch,
            bottom: depth.clone(),
            depth2: Vec::new(),
            bottom2: Vec::new(),
            depth,
            z_min,
            caster_z_near: z_min,
            normal_offset: 0.0,
            grazing_cos: 0.0,
            pyramid,
        }
    }

    /// The same map with its slabs reaching down to `bottom` (biased depths, row-major; each
    /// at least its floor's depth), for tests and tools.
    pub fn with_bottoms(mut self, bottom: Vec<f32>) -> Self {
        assert_eq!(bottom.len(), self.depth.len());
        self.bottom = bottom.iter().zip(&self.depth).map(|(b, d)| b.max(*d)).collect();
        self
    }

    /// The depth above which shadow rays from a point at pixel `pixel` and depth `pz` can no
    /// longer be blocked by the map (region shrinking with a min-depth pyramid, technical
    /// note 10.3a): starting from the map's nearest depth, the filter region is shrunk to the
    /// nearest depth inside it, a few times. Each depth is a lower bound of the depths in
    /// the region the previous one implied, so a ray is blocked iff it is blocked below it.
    /// Outside the map there is no occluder (the frustum's margin is sized for the casters,
    /// seen from the nearest receiver: a deeper receiver's region can reach past it);
    /// the flag says whether the final region reaches outside it.
    pub fn stop_depth(&self, pixel: [i32; 2], pz: f32) -> (f32, bool) {
        let mut z = self.z_min;
        for _ in 0..3 {
            if pz <= z {
                break;
            }
            let reach = region_reach(self.frame.half_size, self.pitch, z, pz);
            let lo = [pixel[0] - reach[0], pixel[1] - reach[1]];
            let hi = [pixel[0] + reach[0], pixel[1] + reach[1]];
            let z_region = self.pyramid.min(lo, hi);
            if z_region <= z {
                break;
            }
            z = z_region;
        }
        let reach = region_reach(self.frame.half_size, self.pitch, z.min(pz), pz);
        let (lo, hi) =
            ([pixel[0] - reach[0], pixel[1] - reach[1]], [pixel[0] + reach[0], pixel[1] + reach[1]]);
        (z, !self.contains(lo, hi))
    }

    /// The light-space point at which to look a shading point up: moved along its
    /// geometric normal by `normal_offset` pixel footprints, scaled by how grazing the light
    /// is (1 - |n . axis|): a surface the light meets edge-on otherwise falls under the
    /// floor of the surface beside it (a box wall under the box's top), while surfaces
    /// facing the light (floors at contact shadows) barely move.
    #[inline]
    pub fn lookup_point(&self, p: Vec3, n_geom: Vec3, normal_offset: f32) -> Vec3 {
        let pl = self.light_from_world(p);
        if normal_offset == 0.0 || pl.z <= 0.0 {
            return pl;
        }
        let grazing = 1.0 - n_geom.dot(self.frame.z).abs();
        let shift = normal_offset * grazing * self.pitch * pl.z;
        self.light_from_world(p + n_geom * shift)
    }

    /// Whether the light grazes a shading point's surface ([`DepthMapParams::grazing_cos`]):
    /// traced rays answer it.
    #[inline]
    pub fn grazing(&self, p: Vec3, n_geom: Vec3) -> bool {
        grazing(&self.frame, self.grazing_cos, p, n_geom)
    }

    /// Where a shading point (`p`, geometric normal `n_geom`) reads the map: its light-space
    /// lookup point ([`DepthMap::lookup_point`]) and map point, or None where that falls
    /// outside the map (every depth-map method answers those with traced rays).
    #[inline]
    pub fn query_point(&self, p: Vec3, n_geom: Vec3) -> Option<(Vec3, MapPoint)> {
        let pl = self.lookup_point(p, n_geom, self.normal_offset);
        let mp = self.locate(pl).filter(|mp| self.contains(mp.pixel, mp.pixel))?;
        Some((pl, mp))
    }

    #[inline]
    fn light_from_world(&self, p: Vec3) -> Vec3 {
        self.frame.light_from_world(p)
    }

    /// Where a light-space point falls in the map (None behind or on the light plane).
    #[inline]
    pub fn locate(&self, p_light: Vec3) -> Option<MapPoint> {
        if p_light.z <= 0.0 {
            return None;
        }
        let g = (Vec2::new(p_light.x, p_light.y) / p_light.z - self.origin) / self.pitch;
        // Far outside the map (or not finite): no pixel; also keeps pixel arithmetic in i32.
        if !g.is_finite() || g.abs().max_element() > 1e7 {
            return None;
        }
        let cell = g.floor();
        Some(MapPoint { pixel: [cell.x as i32, cell.y as i32], offset: g - cell, z: p_light.z })
    }

    /// A lower bound of the (first layer's, so every layer's) biased depths over the pixel
    /// rectangle [lo, hi], clipped to the map: a few min-pyramid reads.
    #[inline]
    pub fn min_depth(&self, lo: [i32; 2], hi: [i32; 2]) -> f32 {
        self.pyramid.min(lo, hi)
    }

    /// Biased depth at pixel (i, j); +inf outside the map.
    #[inline]
    pub fn at(&self, i: i32, j: i32) -> f32 {
        let n = self.resolution as i32;
        if i < 0 || j < 0 || i >= n || j >= n {
            return f32::INFINITY;
        }
        self.depth[(j * n + i) as usize]
    }

    /// Whether the pixel rectangle [lo, hi] (inclusive) lies inside the map.
    #[inline]
    pub fn contains(&self, lo: [i32; 2], hi: [i32; 2]) -> bool {
        let n = self.resolution as i32;
        lo[0] >= 0 && lo[1] >= 0 && hi[0] < n && hi[1] < n
    }

    /// The normalised heights (floor, slab bottom) of pixel (i, j) seen from depth `pz`.
    #[inline]
    pub fn heights(&self, i: i32, j: i32, pz: f32) -> (f32, f32) {
        self.layer_heights(0, i, j, pz)
    }

    /// How many layers the map holds (1, or 2 with the hidden layer).
    #[inline]
    pub fn layers(&self) -> usize {
        if self.depth2.is_empty() { 1 } else { 2 }
    }

    /// Biased depth of layer `layer` at pixel (i, j); +inf outside the map or where empty.
    #[inline]
    pub fn layer_at(&self, layer: usize, i: i32, j: i32) -> f32 {
        let n = self.resolution as i32;
        if i < 0 || j < 0 || i >= n || j >= n {
            return f32::INFINITY;
        }
        let k = (j * n + i) as usize;
        if layer == 0 { self.depth[k] } else { self.depth2.get(k).copied().unwrap_or(f32::INFINITY) }
    }

    /// [`DepthMap::heights`] of layer `layer`.
    #[inline]
    pub fn layer_heights(&self, layer: usize, i: i32, j: i32, pz: f32) -> (f32, f32) {
        let n = self.resolution as i32;
        if i < 0 || j < 0 || i >= n || j >= n {
            return (f32::NEG_INFINITY, f32::NEG_INFINITY);
        }
        let k = (j * n + i) as usize;
        let (d, b) = if layer == 0 {
            (self.depth[k], self.bottom[k])
        } else {
            (
                self.depth2.get(k).copied().unwrap_or(f32::INFINITY),
                self.bottom2.get(k).copied().unwrap_or(f32::INFINITY),
            )
        };
        (floor_height(d, pz), floor_height(b, pz))
    }

    /// The same map with a hidden layer (floors and slab bottoms, biased depths, row-major;
    /// +inf where empty), for tests and tools.
    ///
    /// # Panics
    /// Lengths other than the map's, or a NaN depth.
    pub fn with_hidden_layer(mut self, depth2: Vec<f32>, bottom2: Vec<f32>) -> Self {
        assert_eq!(depth2.len(), self.depth.len());
        assert_eq!(bottom2.len(), self.depth.len());
        assert!(!depth2.iter().chain(&bottom2).any(|d| d.is_nan()), "NaN depth");
        // The hidden layer lies below the first (the min-depth pyramid, built from the first,
        // bounds both: region shrinking and block culling rely on it), and is empty where
        // the first is.
        let depth2: Vec<f32> = depth2.iter().zip(&self.depth).map(|(d2, d)| d2.max(*d)).collect();
        self.bottom2 = bottom2.iter().zip(&depth2).map(|(b, d)| b.max(*d)).collect();
        self.depth2 = depth2;
        self
    }

    pub fn bytes(&self) -> u64 {
        ((self.depth.len() + self.bottom.len() + self.depth2.len() + self.bottom2.len())
            * std::mem::size_of::<f32>()) as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(depth: Vec<f32>) -> DepthMap {
        let frame =
            LightFrame { origin: Vec3::ZERO, x: Vec3::X, y: Vec3::Y, z: Vec3::Z, half_size: Vec2::ONE };
        DepthMap::from_depths(frame, Vec2::splat(-1.0), 0.5, 4, depth)
    }

    /// The min-depth pyramid is built from the first layer and bounds the hidden one: a
    /// hidden layer given above the first is moved down to it, and is empty where the first
    /// is (region shrinking and block culling rely on it).
    #[test]
    fn the_hidden_layer_never_lies_above_the_first() {
        let mut depth = vec![2.0f32; 16];
        depth[5] = f32::INFINITY;
        let m = map(depth.clone()).with_hidden_layer(vec![1.0; 16], vec![1.5; 16]);
        for k in 0..16 {
            assert!(m.depth2[k] >= m.depth[k] && m.bottom2[k] >= m.depth2[k], "pixel {k}");
        }
        assert_eq!(m.depth2[5], f32::INFINITY);
        assert_eq!(m.min_depth([0, 0], [3, 3]), 2.0);
        let below = map(depth).with_hidden_layer(vec![3.0; 16], vec![3.5; 16]);
        assert_eq!((below.depth2[0], below.bottom2[0]), (3.0, 3.5));
    }

    #[test]
    #[should_panic(expected = "NaN depth")]
    fn a_nan_depth_is_refused() {
        let mut depth = vec![2.0f32; 16];
        depth[3] = f32::NAN;
        map(depth);
    }

    /// A 20 x 20 floor under a 1 x 1 light 2 up, with a 0.2 x 0.2 card 0.5 over it if
    /// `card`, and `n` x `n` visible floor points 0.1 apart from `corner` (x, z).
    fn floor_scene(card: bool, n: usize, corner: [f32; 2]) -> (Scene, RectLight, Vec<VisiblePoint>) {
        use glam::DVec3;
        use renderer::{Camera, gltf_load::Geometry};
        use std::time::Duration;
        let mut g = Geometry::default();
        g.add_quad(DVec3::ZERO, DVec3::new(20.0, 0.0, 0.0), DVec3::new(0.0, 0.0, -20.0), [0.5; 3]);
        if card {
            g.add_quad(
                DVec3::new(0.3, 0.5, 0.0),
                DVec3::new(0.2, 0.0, 0.0),
                DVec3::new(0.0, 0.0, -0.2),
                [0.5; 3],
            );
        }
        let light = RectLight::new(Vec3::new(0.0, 2.0, 0.0), Vec3::X, Vec3::Z, Vec3::ONE);
        let camera = Camera::look_at(Vec3::new(0.0, 5.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0);
        let scene = Scene::build(g, vec![light], camera, DVec3::ZERO, Duration::ZERO);
        let visible = (0..n * n)
            .map(|k| {
                let p = Vec3::new(corner[0] + 0.1 * (k % n) as f32, 0.0, corner[1] + 0.1 * (k / n) as f32);
                VisiblePoint { p, n_geom: Vec3::Y, n_shading: Vec3::Y }
            })
            .collect();
        (scene, light, visible)
    }

    /// 64^2 maps of the same receivers fitted to every lit one and to the shadowed ones.
    fn both_fits(scene: &Scene, light: &RectLight, visible: &[VisiblePoint]) -> (DepthMap, DepthMap) {
        let params = DepthMapParams::new(64);
        let all_lit =
            DepthMap::build(scene, light, visible, &DepthMapParams { fit_shadowed: false, ..params });
        (all_lit, DepthMap::build(scene, light, visible, &params))
    }

    /// `fit_shadowed`: on a 20 x 20 floor seen whole, with one small card over it, the map
    /// covers the card's shadow (every receiver whose shaft is not clear lies in it) at a
    /// pitch far finer than a map fitted to the whole lit floor, and a floor point away from
    /// it, clear, lies outside it (but inside the lit floor's map: the light's centre is
    /// 43 deg above it, not grazing at the default `grazing_cos`).
    #[test]
    fn a_map_fitted_to_the_shadowed_receivers_covers_them_finely() {
        let (scene, light, visible) = floor_scene(true, 100, [-5.0, -5.0]);
        let (all_lit, fitted) = both_fits(&scene, &light, &visible);
        assert!(fitted.pitch * 4.0 < all_lit.pitch, "pitch {} against {}", fitted.pitch, all_lit.pitch);
        let eps = scene.epsilon.eps;
        let mut shadowed = 0;
        for v in &visible {
            let shaft = Shaft::new(&light, v.p, v.n_geom, eps).unwrap();
            if !scene.shaft_clear(&shaft) {
                shadowed += 1;
                assert!(fitted.query_point(v.p, v.n_geom).is_some(), "{} outside", v.p);
            }
        }
        assert!(shadowed > 20, "{shadowed} shadowed receivers");
        let far = Vec3::new(1.5, 0.0, 1.5);
        assert!(fitted.query_point(far, Vec3::Y).is_none());
        assert!(all_lit.query_point(far, Vec3::Y).is_some());
    }

    /// With nothing that may shadow anything in view, `fit_shadowed` fits the same map as
    /// fitting to every lit receiver.
    #[test]
    fn with_no_shadow_in_view_the_fit_is_the_lit_receivers_fit() {
        let (scene, light, visible) = floor_scene(false, 50, [-3.0, -2.0]);
        let (all_lit, fitted) = both_fits(&scene, &light, &visible);
        assert_eq!((fitted.origin, fitted.pitch), (all_lit.origin, all_lit.pitch));
        assert!(fitted.query_point(visible[0].p, Vec3::Y).is_some());
    }
}
