//! The projected segments the arrangement is built from, and what it says of them: a
//! segment with its jump, one clipped to the domain, a crossing of two, why a point's
//! arrangement is refused, and the exact orientation every decision rests on. Shared by the
//! arrangement and the contacts between segments.

use glam::DVec2;

/// One projected edge: depth jumps by `jump` = D(left) - D(right) across it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    pub p0: DVec2,
    pub p1: DVec2,
    pub jump: i32,
}

/// Why a point's arrangement is not trusted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Failure {
    /// Collinear overlap, a T-junction, a lone end inside the domain, an end on a side.
    Degenerate,
    /// Two paths gave one piece different depths, or a loop of jumps did not close.
    Inconsistent,
}

/// Sign of orient2d(a, b, c): positive where a, b, c turn counter-clockwise. Exact.
#[inline]
pub fn orient(a: DVec2, b: DVec2, c: DVec2) -> i8 {
    let p = |v: DVec2| robust::Coord { x: v.x, y: v.y };
    let d = robust::orient2d(p(a), p(b), p(c));
    (d > 0.0) as i8 - (d < 0.0) as i8
}

/// A clipped segment with where its ends lie on the domain's boundary (`s` = side index +
/// position along it, or NaN for an end inside).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Clipped {
    pub(crate) seg: Segment,
    pub(crate) s: [f64; 2],
}

/// One crossing of segments `i` and `j`, at `point`; `ti`, `tj` its parameters along them.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Crossing {
    pub(crate) i: u32,
    pub(crate) j: u32,
    pub(crate) ti: f64,
    pub(crate) tj: f64,
    pub(crate) point: DVec2,
    /// i's start lies on j's right, j's start on i's right.
    pub(crate) i0_right_of_j: bool,
    pub(crate) j0_right_of_i: bool,
}

/// Whether the convex polygon `corners` (either orientation) holds `q` (its sides too).
pub(crate) fn inside_convex(corners: &[DVec2], q: DVec2) -> bool {
    let n = corners.len();
    let side = |k: usize| (corners[(k + 1) % n] - corners[k]).perp_dot(q - corners[k]);
    let first = (0..n).map(side).find(|&x| x != 0.0).unwrap_or(0.0);
    (0..n).all(|k| side(k) * first >= 0.0)
}

/// `x`'s bits as an integer that sorts as `f64::total_cmp` does.
pub(crate) fn order_key(x: f64) -> u64 {
    let b = x.to_bits();
    if b >> 63 == 1 { !b } else { b | 1 << 63 }
}

/// The inverse of [`order_key`].
pub(crate) fn from_order_key(k: u64) -> f64 {
    f64::from_bits(if k >> 63 == 1 { k & !(1 << 63) } else { !k })
}
