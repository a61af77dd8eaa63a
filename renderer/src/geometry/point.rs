//! The shading point: where a surface is lit from and where its rays leave, as one value
//! (pbrt-v4's `LightSampleContext`). A hit holds one ([`crate::SurfaceHit::point`]), a
//! shadow query holds one ([`crate::ShadowQuery::point`]), and `prepare` sees every primary
//! hit as one ([`crate::PrepareContext::visible`]); ray origins, shafts and light sampling
//! take it whole.

use glam::Vec3;

/// A point on a surface with its own error bound and its two normals (both on the side the
/// ray that found it came from). 48 bytes, `Copy`: passed by reference in hot loops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadingPoint {
    /// The point (render space), on the surface: not offset. A hit's is interpolated from the
    /// triangle's vertices (not `o + t d`).
    pub p: Vec3,
    /// A bound on `p`'s own rounding, per component
    /// ([`crate::geometry::ray_origin::interpolation_error`] for a hit,
    /// [`crate::geometry::ray_origin::point_error`] for a point known only by its f32
    /// position): the one rule for ray origins offsets by it
    /// ([`crate::geometry::ray_origin::offset_origin`]). Zero for a point known exactly.
    pub p_error: Vec3,
    /// Unit geometric normal, on the side of the incoming ray. Ray origins are offset along it.
    pub n_geom: Vec3,
    /// Unit shading (interpolated) normal, flipped to the same side as `n_geom`: defines the
    /// horizon.
    pub n_shading: Vec3,
}
