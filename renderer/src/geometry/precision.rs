//! f32 precision in render space: when a triangle is degenerate (relative to its own size)
//! and how finely f32 stores a position at a given distance from the camera.

use glam::DVec3;

/// A triangle is zero-area when the sine of the angle between two of its edges is at most
/// this: relative to its own size, so a 1e-20 m and a 1e20 m triangle are both real.
pub const DEGENERATE_SINE: f64 = 1e-12;

/// A kept triangle is flagged imprecise when f32's spacing at its distance from the camera
/// is more than 1/`SHAPE_PRECISION` of its longest edge: its corners then move by more than
/// 0.2% of its size, a visible step once it spans a few hundred pixels.
pub const SHAPE_PRECISION: f64 = 256.0;

/// Whether the triangle `p` has zero area relative to its own size:
/// `|e1 x e2| <= DEGENERATE_SINE |e1| |e2|`, on edges scaled to unit size first so that
/// neither tiny nor huge triangles under- or overflow. Non-finite corners count as degenerate.
/// The unit face normal of a render-space triangle `q` (its f32 corners in f64), as the
/// scene stores it where a file gives no normals: scaled by its first edge first, so that tiny
/// and huge triangles alike normalise.
pub fn render_face(q: [DVec3; 3]) -> DVec3 {
    let m = (q[1] - q[0]).abs().max_element();
    ((q[1] - q[0]) / m).cross((q[2] - q[0]) / m).normalize()
}

pub fn is_degenerate(p: [DVec3; 3]) -> bool {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let m = e1.abs().max_element().max(e2.abs().max_element());
    if !(m > 0.0 && m.is_finite()) {
        return true;
    }
    let (e1, e2) = (e1 / m, e2 / m);
    // Edges are finite here, so neither side is NaN.
    e1.cross(e2).length() <= DEGENERATE_SINE * e1.length() * e2.length()
}

/// Whether every coordinate of `p` is one f32 can hold (NaN is not): a glTF node's
/// transform, composed in f64, can place finite positions that no render space holds.
pub fn fits_f32(p: &[DVec3]) -> bool {
    p.iter().all(|v| v.abs().cmple(DVec3::splat(f32::MAX as f64)).all())
}

/// The distance between neighbouring f32 values at distance `d` from the render-space origin
/// (the camera): how precisely a position there is stored. Infinite beyond f32's range.
pub fn f32_spacing(d: f64) -> f64 {
    let x = (d.abs() as f32).max(f32::MIN_POSITIVE);
    if !x.is_finite() || x == f32::MAX {
        return f64::INFINITY;
    }
    (f32::from_bits(x.to_bits() + 1) - x) as f64
}
