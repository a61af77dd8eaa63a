//! The surface AOVs (`--aov`): per pixel, the primary hit's base colour, metallic, roughness
//! and shading normal ([`crate::Surface`]), each the mean over the pixel's samples that hit
//! (as the visibility AOVs are), 0 where none does.
//!
//! A pass of its own over the same primary rays the frame casts ([`render::primary_hits`]:
//! the same jitter, so the same hits), asked only for the AOVs: a render without them pays
//! nothing.

use crate::geometry::scene::Scene;
use crate::integrator::render::{self, RenderSettings};
use glam::Vec3;
use rayon::prelude::*;
use std::ops::Range;

/// Per pixel of a band of rows (row-major, top row first), the primary hits' surface.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SurfaceAovs {
    /// Linear RGB.
    pub base_color: Vec<Vec3>,
    pub metallic: Vec<f32>,
    pub roughness: Vec<f32>,
    /// The shading normal (render space, on the camera ray's side): the mean of the samples'
    /// unit normals, not renormalised.
    pub normal: Vec<Vec3>,
}

/// The surface AOVs of the rows `rows` of the frame `settings` describes.
pub fn surface_aovs(scene: &Scene, settings: &RenderSettings, rows: Range<u32>) -> SurfaceAovs {
    let hits = render::primary_hits(scene, settings, &rows, &|_| {});
    let spp = settings.spp as usize;
    let pixels: Vec<(Vec3, f32, f32, Vec3)> = hits
        .par_chunks(spp)
        .map(|samples| {
            let (mut sum, mut count) = ((Vec3::ZERO, 0.0f32, 0.0f32, Vec3::ZERO), 0u32);
            for hit in samples.iter().flatten() {
                let s = scene.surface(hit);
                sum = (sum.0 + s.base_color, sum.1 + s.metallic, sum.2 + s.roughness, sum.3 + s.n_shading);
                count += 1;
            }
            let k = if count == 0 { 0.0 } else { 1.0 / count as f32 };
            (sum.0 * k, sum.1 * k, sum.2 * k, sum.3 * k)
        })
        .collect();
    SurfaceAovs {
        base_color: pixels.iter().map(|p| p.0).collect(),
        metallic: pixels.iter().map(|p| p.1).collect(),
        roughness: pixels.iter().map(|p| p.2).collect(),
        normal: pixels.iter().map(|p| p.3).collect(),
    }
}
