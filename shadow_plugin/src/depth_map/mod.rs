//! The light-space depth map shared by the depth-map methods: a perspective map whose centre
//! of projection is the light's centre and whose axis is the light's normal, with square
//! pixels and linear planar depth in f32, rendered by rays through the BVH (alpha test
//! honoured). Its frustum covers what the camera sees that the light reaches, plus the
//! filter margin. Depths are stored already biased (see [`DepthMapParams::slope_bias`]).
//!
//! This file holds the map's types and the lookups queries make; `build.rs` renders the map
//! ([`DepthMap::build`]), `fit.rs` fits its frustum to the receivers, `pyramid.rs` is the
//! min-depth pyramid behind region shrinking and block culling.

pub mod bits;
mod bounds;
mod build;
pub mod fallback;
mod fit;
pub mod heightfield;
pub mod march;
pub mod mask_samples;
mod pyramid;
#[cfg(test)]
mod tests;

use crate::depth_map::march::{floor_height, region_reach};
pub use bounds::DepthBounds;
use glam::{Vec2, Vec3};
use pyramid::MinPyramid;
use renderer::{KeyError, RectLight, ShadingPoint};

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

    /// A bound on the error of `light_from_world(p).z` for a point with error bound
    /// `p_error` (zero for a stored vertex): its error along the axis, plus gamma(8) of the
    /// magnitudes the frame change sums.
    #[inline]
    pub fn depth_tolerance(&self, p: Vec3, p_error: Vec3) -> f32 {
        self.z.abs().dot(p_error)
            + renderer::geometry::ray_origin::gamma(8) * (p - self.origin).abs().element_sum()
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

/// Depth-map parameters shared by the depth-map methods: what [`DepthMap::build`] reads.
/// Each method's table spells them as keys (`depth_map`, `slope_bias`, `slab_thickness`,
/// `normal_offset`, `grazing_cos`); [`MapSwitches`] are code-only.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthMapParams {
    /// Pixels per side (square). More pixels: finer silhouettes, larger filter regions.
    /// Typical 128 to 1024. Key `depth_map`.
    pub resolution: u32,
    /// Slope-scaled bias in depth-map pixels: each texel's floor is pushed back by
    /// `slope_bias x` the depth change of its surface across one pixel footprint (from the
    /// surface normal at the texel), plus the texel's own hit error along the map's axis
    /// ([`renderer::ShadingPoint::p_error`]) and the rounding of its depth. Too little: lit surfaces
    /// shadow themselves (acne); too much: contact shadows detach. 1.0 by measurement.
    pub slope_bias: f32,
    /// Thickness of each floor's slab, in pixel footprints at its depth, for the `plates`
    /// reading: a ray is blocked where it passes through a slab, so 0 is infinitely thin
    /// plates and a few pixels make closed thin objects (chair legs, stems) opaque to rays
    /// from their own back side while floating occluders keep their inner penumbra.
    pub slab_thickness: f32,
    /// Grazing normal offset, in pixel footprints (see [`DepthMap::lookup_point`]).
    pub normal_offset: f32,
    /// Receivers the light grazes: where the cosine between a shading point's geometric
    /// normal and the direction to the light's centre is below this, traced rays answer
    /// (counted as `fallbacks_grazing`) and the point takes no part in fitting the map. The
    /// map sees such a surface steeply or edge-on: a fold of cloth, the far side of a sphere
    /// near its terminator or a wall beside a stem is a sliver of a pixel, so the occluders
    /// that matter there (the facing fold, the surface's own curvature) are not in it. Only
    /// the samples above the horizon are traced; such points are a small share of most
    /// frames, but up to half of the lit points of a scene of curved surfaces lit from the
    /// side (toy-car), where they are most of the shadow cost. 0 turns it off. Measured:
    /// docs/notes/2026-11-21-grazing-receivers-traced.md.
    pub grazing_cos: f32,
    /// How the map is built beyond its keys.
    pub switches: MapSwitches,
}

/// The depth map's code-only switches: ablations the accuracy example and tests turn off
/// (methods and presets set them; the scene file cannot).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MapSwitches {
    /// Read closed meshes as solid (`plates`): where the light's ray through a pixel enters
    /// a surface through its front face and next meets a back face, the pixel's slab reaches
    /// down to that back face (a second depth layer), so a chair seat or a fox's leg blocks
    /// the rays that pass under its top surface. Open surfaces keep `slab_thickness`.
    pub closed_volumes: bool,
    /// `plates`: a second layer per pixel, the first surface below the first one's slab (a
    /// chair's frame under its seat, a vase's far wall), read like the first and OR-ed with
    /// it: a ray is blocked if it passes through a slab of either layer. The same masks serve
    /// both; queries cost up to twice as much where the layer is near.
    pub hidden_layer: bool,
    /// Fit the map's frustum only to receivers something may shadow: those whose shaft to
    /// the light ([`renderer::Shaft`]) is not provably clear. A receiver outside the map is
    /// answered by the traced fallback, whose first shaft test proves it unblocked at the
    /// cost of one BVH query; the map's pixels go where the shadows are.
    pub fit_shadowed: bool,
}

impl MapSwitches {
    /// Every switch on: the default.
    pub const ALL: Self = Self { closed_volumes: true, hidden_layer: true, fit_shadowed: true };
}

impl Default for MapSwitches {
    fn default() -> Self {
        Self::ALL
    }
}

impl DepthMapParams {
    pub const fn new(resolution: u32) -> Self {
        Self {
            resolution,
            slope_bias: 1.0,
            slab_thickness: DEFAULT_SLAB,
            normal_offset: DEFAULT_NORMAL_OFFSET,
            grazing_cos: DEFAULT_GRAZING_COS,
            switches: MapSwitches::ALL,
        }
    }
}

/// The default slab thickness, in pixel footprints (measured: docs/edge_table_accuracy.md).
pub const DEFAULT_SLAB: f32 = 2.0;

/// The default [`DepthMapParams::grazing_cos`]: 0.5, the light's centre within 30 deg of
/// the tangent plane. Chosen by measurement (docs/notes/2026-11-21-grazing-cos-0.5.md): against 0.2 it lowered the
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
    /// face lies below its front face (see [`MapSwitches::closed_volumes`]).
    pub bottom: Vec<f32>,
    /// The hidden layer ([`MapSwitches::hidden_layer`]): per pixel the floor and slab
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
fn grazing(frame: &LightFrame, grazing_cos: f32, point: &ShadingPoint) -> bool {
    grazing_cos > 0.0 && frame.facing(point.p, point.n_geom) < grazing_cos
}

/// Share of the receivers' total irradiance, per side and axis, left out of the frustum.
pub const RECEIVER_TRIM: f64 = 0.001;

/// A point in depth-map terms: its pixel, its offset inside the pixel, its depth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapPoint {
    pub pixel: [i32; 2],
    pub offset: Vec2,
    pub z: f32,
}

impl DepthMap {
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
    pub fn lookup_point(&self, point: &ShadingPoint, normal_offset: f32) -> Vec3 {
        let (p, n_geom) = (point.p, point.n_geom);
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
    pub fn grazing(&self, point: &ShadingPoint) -> bool {
        grazing(&self.frame, self.grazing_cos, point)
    }

    /// Where a shading point reads the map: its light-space lookup point
    /// ([`DepthMap::lookup_point`]) and map point, or None where that falls outside the map
    /// (every depth-map method answers those with traced rays).
    #[inline]
    pub fn query_point(&self, point: &ShadingPoint) -> Option<(Vec3, MapPoint)> {
        let pl = self.lookup_point(point, self.normal_offset);
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
