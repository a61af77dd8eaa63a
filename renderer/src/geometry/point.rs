//! The shading point: where a surface is lit from and where its rays leave, as one value
//! (pbrt-v4's `LightSampleContext`). A hit holds one ([`crate::SurfaceHit::point`]), a
//! shadow query holds one ([`crate::ShadowQuery::point`]), and `prepare` sees every primary
//! hit as one ([`crate::PrepareContext::visible`]); ray origins, shafts and light sampling
//! take it whole.

use glam::Vec3;

/// A point on a surface with its own error bound and its two normals, each facing the ray
/// that found it (`wo`, toward where it came from): `n_geom . wo > 0` and
/// `n_shading . wo > 0`. The rule is pbrt-v4's and Mitsuba 3's: light reflects only between
/// directions on one side of the shading plane, so the horizon (irradiance, light samples,
/// bounces) is the shading normal's, on `wo`'s side. Where a smoothed normal tilts the
/// shading plane past `wo`, `n_shading . n_geom < 0`: the lit side then lies mostly under
/// the geometric plane, and rays toward it leave from that side (every ray origin is offset
/// along `n_geom` to the side its direction leaves to,
/// [`crate::geometry::ray_origin::offset_origin`]). 48 bytes, `Copy`: passed by reference in
/// hot loops.
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
    /// Unit geometric normal, on the side of the incoming ray. Ray origins are offset along it,
    /// to the side of its plane the ray leaves to.
    pub n_geom: Vec3,
    /// Unit shading (interpolated) normal, flipped to the side of the incoming ray by its own
    /// plane (not `n_geom`'s side): defines the horizon.
    pub n_shading: Vec3,
}
