//! Rendering a depth map: the light's rays through the pixel centres, the first surface
//! each meets (its biased depth and slab bottom) and, with the hidden layer, the first
//! surface below that slab.

use super::fit::{Frustum, fit};
use super::pyramid::MinPyramid;
use super::{DepthMap, DepthMapParams, LightFrame};
use glam::{Vec2, Vec3, Vec3A};
use obvhs::ray::Ray;
use rayon::prelude::*;
use renderer::geometry::ray_origin::gamma;
use renderer::{RectLight, Scene, ShadingPoint};

/// How many closed meshes stacked on each other one pixel's slab may span.
const MAX_STACKED_SOLIDS: usize = 4;

/// Steepest surface slope under which `closed_volumes` thickens a pixel's slab.
const MAX_SOLID_SLOPE: f32 = 1.0;

/// Steepest surface slope (tan of the angle to the view ray) the bias accounts for.
const MAX_SLOPE: f32 = 8.0;

/// What the map's rays see, for [`DepthMap::build`].
struct Surfaces<'a> {
    scene: &'a Scene,
    frame: &'a LightFrame,
    params: &'a DepthMapParams,
    pitch: f32,
    slab: f32,
    /// Where the map's rays start (planar depth): past the rounding of t for geometry in the
    /// light's own plane (an emitter's triangles), gamma(32) of the light's size and place.
    start: f32,
}

/// A bound on a hit's error along the map ray that found it (planar depth): its point's
/// error along the axis, plus the rounding of `t` itself (gamma(8) of it).
#[inline]
fn depth_error(frame: &LightFrame, hit: &renderer::SurfaceHit) -> f32 {
    frame.z.abs().dot(hit.point.p_error) + gamma(8) * hit.t
}

impl Surfaces<'_> {
    /// The first surface the light's ray through image point `img` meets beyond planar depth
    /// `from`, as a (floor, slab bottom) pair of biased depths.
    fn slab_after(&self, img: Vec2, from: f32) -> Option<(f32, f32)> {
        let (frame, params, pitch) = (self.frame, self.params, self.pitch);
        // Direction with light-space z = 1: the ray's t is then the planar depth.
        let dir = frame.x * img.x + frame.y * img.y + frame.z;
        let ray = Ray::new(Vec3A::from(frame.origin), Vec3A::from(dir), from, f32::INFINITY);
        let hit = self.scene.intersect(ray)?;
        // Planar depth over the image is z = c / (n . (u, v, 1)) for a plane with light-frame
        // normal n, so one pixel changes it by about pitch * z * |n_xy| / |n . (u, v, 1)|:
        // zero for surfaces facing the light squarely, large for grazing ones (capped at
        // MAX_SLOPE).
        let z = hit.t;
        let n = Vec3::new(
            hit.point.n_geom.dot(frame.x),
            hit.point.n_geom.dot(frame.y),
            hit.point.n_geom.dot(frame.z),
        );
        let facing = (n.x * img.x + n.y * img.y + n.z).abs();
        let slope = (n.truncate().length() / facing.max(1e-12)).min(MAX_SLOPE);
        let e = depth_error(frame, &hit);
        let d = z + params.slope_bias * pitch * z * slope + e;
        let mut b = d * (1.0 + self.slab);
        // Closed volumes: the next surface along the same ray. A back face there means the
        // ray was inside a closed mesh from z to it (glTF meshes wind their front faces
        // outwards); anything else is an open surface. Solids stacked within a slab of each
        // other (a ball resting on a seat) are one. Only under surfaces that face the light
        // (slope <= 1, within 45 deg): the depth of a surface the light grazes steps steeply
        // from pixel to pixel, so rays leaving it dip under its neighbours' floors and would
        // stay blocked in a thick slab (measured: false shadows on a grazed wall).
        if params.switches.closed_volumes && hit.front_face && slope <= MAX_SOLID_SLOPE {
            let (mut from, mut from_error) = (z, e);
            for _ in 0..MAX_STACKED_SOLIDS {
                let inside = Ray::new(ray.origin, ray.direction, from + 2.0 * from_error, f32::INFINITY);
                let Some(exit) = self.scene.intersect(inside).filter(|h| !h.front_face) else { break };
                let exit_error = depth_error(frame, &exit);
                b = b.max(exit.t + exit_error);
                let beyond = Ray::new(ray.origin, ray.direction, exit.t + 2.0 * exit_error, f32::INFINITY);
                match self.scene.intersect(beyond) {
                    Some(next) if next.front_face && next.t <= exit.t * (1.0 + self.slab) + exit_error => {
                        (from, from_error) = (next.t, depth_error(frame, &next));
                    }
                    _ => break,
                }
            }
        }
        Some((d, b))
    }

    /// The map's four layers, row-major from `origin`: the floor and slab bottom of the
    /// first surface, and of the hidden layer (both empty when it is off); +inf where no
    /// surface.
    fn render(&self, origin: Vec2, res: u32) -> [Vec<f32>; 4] {
        let (params, pitch) = (self.params, self.pitch);
        let n_pixels = (res * res) as usize;
        let mut depth = vec![f32::INFINITY; n_pixels];
        let mut bottom = vec![f32::INFINITY; n_pixels];
        let mut depth2 = vec![f32::INFINITY; n_pixels];
        let mut bottom2 = vec![f32::INFINITY; n_pixels];
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
                    let Some((d, b)) = self.slab_after(img, self.start) else { continue };
                    (d_row[i], b_row[i]) = (d, b);
                    // The hidden layer: the first surface below this pixel's slab.
                    if params.switches.hidden_layer
                        && let Some((d2, b2)) = self.slab_after(img, b)
                    {
                        (d2_row[i], b2_row[i]) = (d2, b2);
                    }
                }
            });
        if !params.switches.hidden_layer {
            (depth2, bottom2) = (Vec::new(), Vec::new());
        }
        [depth, bottom, depth2, bottom2]
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
        visible: &[ShadingPoint],
        params: &DepthMapParams,
    ) -> Self {
        let _span = tracing::info_span!("depth_map", resolution = params.resolution).entered();
        assert!(params.slope_bias >= 0.0 && params.slope_bias.is_finite(), "slope_bias");
        assert!(params.slab_thickness >= 0.0 && params.slab_thickness.is_finite(), "slab_thickness");
        let frame = LightFrame::new(light);
        let res = params.resolution.max(1);
        let start = gamma(32) * (light.u.length() + light.v.length() + light.center.abs().max_element());
        let Frustum { origin, pitch, caster_z_near } = fit(scene, light, &frame, visible, params, res);
        let slab = params.slab_thickness * pitch;
        let surface = Surfaces { scene, frame: &frame, params, pitch, slab, start };
        let [depth, bottom, depth2, bottom2] = surface.render(origin, res);
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
}
