//! Proving from a few numbers per mesh that an instance keeps every triangle the flattened
//! build would keep, without testing them one by one.
//!
//! The flattened build tests each placed triangle: zero area in world space, out of f32's
//! range, collapsed by the f32 rounding of render space, too imprecise for its size, or so
//! large against its plane's distance from the camera that the intersector cannot place
//! hits on it ([`super::precision_tally`]). A kept instance must count the same, and testing
//! every copy made the load of 10,000 82k-triangle boulders O(flattened): 31-50 s. Here each
//! test is bounded over the whole instance from its mesh's extremes and the transform's
//! singular values (bounded by Frobenius norms of it and its inverse):
//! - a face's sine shrinks by at most cond^2, its |e1 x e2| / (|e1| + |e2|) by at most
//!   sigma_min^2 / sigma_max, an edge by at most sigma_min;
//! - f32 moves a corner by under its spacing at the instance's largest coordinate;
//! - a plane's distance from the camera is at least its distance in the mesh's space over
//!   the inverse's norm, less the tilt the corners' rounding can give it (the bound in
//!   `shadow_plugin`'s `silhouette_edges/kept.rs`): one dot product per triangle, and the few
//!   triangles whose planes pass near the camera placed and tested as the flattened build
//!   tests them.
//!
//! 10,000 boulders: load 51 -> 6 s.
//!
//! Where every bound holds with a margin the instance keeps all its triangles, adds nothing
//! to the tally, and its bounds come from its used vertices (the same f32 and f64 values
//! as over its triangles' corners). Otherwise the caller tests it triangle by triangle.

use super::precision_tally::{INTERSECTOR_ROUNDING, PrecisionTally};
use crate::geometry::instances::{Placement, Placing, PrimitiveData};
use crate::geometry::precision::{SHAPE_PRECISION, f32_spacing, fits_f32};
use glam::{DMat3, DVec3, Vec3, Vec3A};
use obvhs::aabb::Aabb;

/// What the proofs read of one mesh (its primitives), found once.
pub(super) struct MeshExtremes {
    /// The vertices its triangles of nonzero area use, per primitive.
    used: Vec<Vec<u32>>,
    triangles: u64,
    /// Its triangles of zero area (sine at most [`FLAT_SINE`]: repeated or collinear
    /// corners), by index in the mesh; of those with three distinct corners, the largest
    /// sine and the shortest edge; the largest coordinate of its positions.
    flat: Vec<u32>,
    flat_sine: f64,
    flat_edge: f64,
    reach: f64,
    /// Over its triangles: the smallest sine at the first corner (the zero-area test's
    /// measure), the smallest |e1 x e2| / (|e1| + |e2|), the shortest longest edge, the
    /// longest edge and the largest 1 / altitude.
    min_sine: f64,
    min_cross_ratio: f64,
    min_longest: f64,
    max_edge: f64,
    max_thin: f64,
    /// Per triangle, its plane n . x = d (unit n), as four columns.
    planes: [Vec<f64>; 4],
}

impl MeshExtremes {
    pub(super) fn new(primitives: &[PrimitiveData]) -> MeshExtremes {
        let mut m = MeshExtremes {
            used: Vec::new(),
            triangles: 0,
            flat: Vec::new(),
            flat_sine: 0.0,
            flat_edge: f64::INFINITY,
            reach: 0.0,
            min_sine: f64::INFINITY,
            min_cross_ratio: f64::INFINITY,
            min_longest: f64::INFINITY,
            max_edge: 0.0,
            max_thin: 0.0,
            planes: Default::default(),
        };
        for data in primitives {
            let mut used = vec![false; data.positions.len()];
            for c in &data.corners {
                let p = c.map(|i| DVec3::from(data.positions[i as usize].map(f64::from)));
                let (e1, e2, e3) = (p[1] - p[0], p[2] - p[0], p[2] - p[1]);
                let cross = e1.cross(e2);
                let (l1, l2, l3) = (e1.length(), e2.length(), e3.length());
                let area2 = cross.length();
                let sine = area2 / (l1 * l2);
                m.reach = p.iter().fold(m.reach, |r, x| r.max(x.abs().max_element()));
                // Zero area: dropped by every placing the proof accepts (its plane never
                // near the camera). Two equal corners stay equal placed: exactly zero.
                let has_area = sine > FLAT_SINE;
                if !has_area {
                    m.flat.push(m.triangles as u32);
                    if p[0] != p[1] && p[1] != p[2] && p[0] != p[2] {
                        m.flat_sine = m.flat_sine.max(sine);
                        m.flat_edge = m.flat_edge.min(l1.min(l2).min(l3));
                    }
                    for (column, x) in m.planes.iter_mut().zip([0.0, 0.0, 0.0, f64::INFINITY]) {
                        column.push(x);
                    }
                    m.triangles += 1;
                    continue;
                }
                c.iter().for_each(|&i| used[i as usize] = true);
                let longest = l1.max(l2).max(l3);
                m.min_sine = m.min_sine.min(sine);
                m.min_cross_ratio = m.min_cross_ratio.min(area2 / (l1 + l2));
                m.min_longest = m.min_longest.min(longest);
                m.max_edge = m.max_edge.max(longest);
                m.max_thin = m.max_thin.max(longest / area2);
                let n = cross / area2;
                for (column, x) in m.planes.iter_mut().zip([n.x, n.y, n.z, n.dot(p[0])]) {
                    column.push(x);
                }
                m.triangles += 1;
            }
            m.used.push((0..used.len() as u32).filter(|&i| used[i as usize]).collect());
        }
        m
    }
}

/// Triangles of a mesh whose sine (at the first corner) is at most this are zero-area in
/// every placing the proof accepts (a transform multiplies a sine by at most cond^2, and
/// [`prove`] takes none that could lift one past `DEGENERATE_SINE`).
const FLAT_SINE: f64 = 1e-15;

/// What a proven instance gives its pass: the triangles it drops (the mesh's zero-area
/// ones), how many it keeps, its render-space bounds and its world-space (f64) bounds.
pub(super) struct Proven {
    pub(super) dropped: Vec<u32>,
    pub(super) kept: u64,
    pub(super) bounds: Aabb,
    pub(super) world: (DVec3, DVec3),
}

/// The instance `p` of the mesh `m` (render space centred on `offset`), if it provably keeps
/// every triangle with nothing to count (see the module doc).
pub(super) fn prove(p: &Placement, m: &MeshExtremes, offset: DVec3) -> Option<Proven> {
    // A mesh with no triangle of nonzero area is tested triangle by triangle.
    let any = m.triangles > m.flat.len() as u64 && m.min_sine > 0.0 && m.max_thin.is_finite();
    if !any {
        return None;
    }
    let placing = Placing::new(p.world);
    let linear = placing.linear();
    let frobenius =
        |a: DMat3| (a.x_axis.length_squared() + a.y_axis.length_squared() + a.z_axis.length_squared()).sqrt();
    // sigma_max <= stretch, 1 / sigma_min <= shrink.
    let (stretch, shrink) = (frobenius(linear), frobenius(linear.inverse()));
    let cond = stretch * shrink;
    // Zero area in world space where the mesh has it, and nowhere else (`DEGENERATE_SINE`
    // is 1e-12). A collinear triangle's placed sine also carries f64's rounding of its
    // corners (relative 2^-52 of the world coordinates) over its edges.
    let world_reach = stretch * m.reach + p.world.w_axis.truncate().abs().max_element() * 2.0;
    let noise =
        if m.flat_edge.is_finite() { 8.0 * f64::EPSILON * world_reach * shrink / m.flat_edge } else { 0.0 };
    let area_holds = m.min_sine / (cond * cond) > 4e-12 && m.flat_sine * cond * cond + noise <= 5e-13;
    if !area_holds {
        return None;
    }
    let (bounds, world, distance) = used_bounds(p, &placing, m, offset)?;
    // Positions out of f32's range are dropped by the pass (and were warned of by node).
    if !fits_f32(&[world.0, world.1]) {
        return None;
    }
    let (lo, hi) = (Vec3::from(bounds.min).as_dvec3(), Vec3::from(bounds.max).as_dvec3());
    let corner = lo.abs().max(hi.abs());
    // A render-space corner is off by at most `error`: f32's spacing at the largest
    // coordinate (per component half of it), and the f64 rounding of its world placing
    // (which render space alone does not bound where world coordinates dwarf it). An edge
    // is off by at most `moved`.
    let error = f32_spacing(corner.max_element()) + 2.0 * placing.rounding(m.reach, offset);
    let moved = 2.0 * error;
    // Collapsed by f32: |e1 x e2| / (|e1| + |e2|) against what the rounding can take from it.
    let longest = m.min_longest / shrink - moved;
    let ratio = m.min_cross_ratio / (shrink * shrink * stretch);
    let largest = stretch * m.max_edge + moved;
    if !(longest > 0.0
        && ratio > 2.0 * (moved + moved * moved / longest) + 2e-12 * largest * largest / longest)
    {
        return None;
    }
    // Imprecise: f32's spacing at the farthest corner (its f64 distance from the camera, as
    // the flattened pass measures it) against the smallest size.
    let precise = f32_spacing(distance) * SHAPE_PRECISION < longest * (1.0 - 1e-9);
    if !precise {
        return None;
    }
    planes_clear_of_camera(p, (&placing, m), (distance + moved, error, shrink), offset)?;
    let kept = m.triangles - m.flat.len() as u64;
    Some(Proven { dropped: m.flat.clone(), kept, bounds, world })
}

/// Bounds of `p`'s used vertices: render space (f32, as the flattened triangles' corners are
/// rounded) and world space (f64), and the largest distance from the camera (f64, as the
/// flattened pass measures a corner's); `None` where one leaves f32's range.
fn used_bounds(
    p: &Placement,
    placing: &Placing,
    m: &MeshExtremes,
    offset: DVec3,
) -> Option<(Aabb, (DVec3, DVec3), f64)> {
    let mut bounds = Aabb::empty();
    let mut world = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    let mut distance = 0.0f64;
    for (data, used) in p.primitives.iter().zip(&m.used) {
        for &i in used {
            let w = placing.position(data.positions[i as usize]);
            world = (world.0.min(w), world.1.max(w));
            distance = distance.max((w - offset).length());
            let r = (w - offset).as_vec3();
            if !r.is_finite() {
                return None;
            }
            bounds.extend(Vec3A::from(r));
        }
    }
    Some((bounds, world, distance))
}

/// Whether no triangle is so large against its plane's distance from the camera that the
/// intersector cannot place hits on it (`check_size`: its rounding at the triangle's reach
/// over 1% of that distance). Each plane is tested in the mesh's space, one dot product a
/// triangle: far enough, with the tilt the corners' rounding can give the plane, it passes;
/// the few nearer (the camera within millimetres of a plane of a boulder 10 m away) are
/// placed and tested as the flattened build tests them.
fn planes_clear_of_camera(
    p: &Placement,
    (placing, m): (&Placing, &MeshExtremes),
    (far, error, shrink): (f64, f64, f64),
    offset: DVec3,
) -> Option<()> {
    let thin = m.max_thin * shrink;
    let small_tilt = thin * error <= 0.05;
    if !small_tilt {
        return None;
    }
    let tilt = 8.0 * error * (1.0 + far * thin);
    let threshold = 100.0 * INTERSECTOR_ROUNDING * far + tilt;
    let camera = p.world.inverse().transform_point3(offset);
    // The camera's move into the mesh's space, rounded by far less than this.
    let translation = p.world.w_axis.truncate().abs().max_element();
    let moved = 1e-9 * (camera.abs().max_element() + shrink * (offset.abs().max_element() + translation));
    let margin = threshold * shrink + moved;
    let [nx, ny, nz, d] = &m.planes;
    let near = |k: usize| (nx[k] * camera.x + ny[k] * camera.y + nz[k] * camera.z - d[k]).abs() <= margin;
    let mut k = 0;
    for data in p.primitives.iter() {
        for &c in &data.corners {
            if near(k) {
                let w = placing.corners(c).map(|i| placing.position(data.positions[i as usize]));
                let mut tally = PrecisionTally::default();
                if tally.keep(w, offset).is_none() || !tally.is_clean() {
                    return None;
                }
            }
            k += 1;
        }
    }
    Some(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::load::kept_instances::pass_of;
    use glam::{DMat4, DQuat};
    use std::sync::Arc;

    /// A bumpy grid of `n` x `n` quads (f32 positions), two triangles each.
    fn grid(n: u32, bump: &mut impl FnMut() -> f64) -> PrimitiveData {
        let mut positions = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                positions.push([i as f32, (0.3 * bump()) as f32, j as f32]);
            }
        }
        let mut corners = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let a = j * (n + 1) + i;
                corners.push([a, a + n + 1, a + 1]);
                corners.push([a + 1, a + n + 1, a + n + 2]);
            }
        }
        PrimitiveData { positions, corners, ..Default::default() }
    }

    /// Wherever the proof holds, testing every triangle drops none, counts nothing, and
    /// gives the same bounds bit for bit (random meshes under random rotations, uneven and
    /// mirroring scales from 1e-6 to 1e6, translations to 1e7, cameras anywhere, some in a
    /// triangle's plane); and it holds for most ordinary placements.
    #[test]
    fn a_proven_instance_keeps_every_triangle_as_testing_each_one_finds() {
        let mut state = 0x853c_49e6_748f_ea9bu64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut proven, mut total, mut hard) = (0, 0, 0);
        for round in 0..400 {
            let mut data = grid(6, &mut next);
            // Zero-area triangles, as files have them (a repeated corner, three in a row).
            if round % 2 == 0 {
                data.corners.push([3, 3, 9]);
                data.corners.push([0, 1, 2]);
                data.positions[1] = [1.0, 0.0, 0.0];
                data.positions[0] = [0.0, 0.0, 0.0];
                data.positions[2] = [2.0, 0.0, 0.0];
            }
            let mesh = Arc::new(vec![data]);
            let extremes = MeshExtremes::new(&mesh);
            let scale_exp = if round % 4 == 0 { 12.0 * next() - 6.0 } else { 2.0 * next() - 1.0 };
            let mut scale =
                DVec3::splat(10f64.powf(scale_exp)) * DVec3::new(0.5 + next(), 0.5 + next(), 0.5 + next());
            if round % 3 == 0 {
                scale.x = -scale.x;
            }
            let turn = DQuat::from_euler(glam::EulerRot::XYZ, 6.0 * next(), 6.0 * next(), 6.0 * next());
            let reach = 10f64.powf(7.0 * next());
            let shift = reach * DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
            let world = DMat4::from_scale_rotation_translation(scale, turn, shift);
            let placement =
                Placement { primitives: mesh.clone(), world, materials: Arc::from([0u32]), instance: 0 };
            // The camera: near the instance, far from it, or on one of its vertices (in the
            // planes of the triangles there).
            let offset = match round % 5 {
                0 => Placing::new(world).position(mesh[0].positions[7]),
                1 => shift + 1e4 * DVec3::new(next(), next(), next()),
                _ => {
                    shift + scale.abs().max_element() * 20.0 * DVec3::new(next() - 0.5, next(), next() - 0.5)
                }
            };
            total += 1;
            let full = pass_of(&placement, offset);
            let flat = mesh[0].corners.len() - 72;
            hard += (full.dropped.len() > flat || full.tally.warnings().len() > (flat > 0) as usize) as u32;
            let Some(p) = prove(&placement, &extremes, offset) else { continue };
            proven += 1;
            assert_eq!(full.dropped, p.dropped, "round {round}");
            assert_eq!(full.kept, p.kept, "round {round}");
            let mut tally = PrecisionTally::default();
            tally.zero_area = p.dropped.len() as u64;
            assert_eq!(full.tally.warnings(), tally.warnings(), "round {round}");
            assert_eq!((full.bounds.min, full.bounds.max), (p.bounds.min, p.bounds.max), "round {round}");
            assert_eq!(full.world, p.world, "round {round}");
        }
        assert!(proven > total / 2, "{proven} of {total} proven");
        assert!(hard > 10, "only {hard} placements with a dropped or counted triangle");
    }

    /// A corner whose f64 distance from the camera lies just past a power of two while its
    /// f32 render coordinates round under it: the flattened pass takes f32's spacing at the
    /// f64 distance and counts the triangle imprecise, so the proof must not hold (found by
    /// review: it took the spacing at the rounded bounds).
    #[test]
    fn the_shape_test_takes_the_spacing_at_the_f64_distance() {
        let positions = vec![[0.0f32, 0.0, 0.0], [-2e-5, -2e-5, 0.0], [-2e-5, 0.0, 1e-5]];
        let mesh =
            Arc::new(vec![PrimitiveData { positions, corners: vec![[0, 1, 2]], ..Default::default() }]);
        let world = DMat4::from_translation(DVec3::new(1.0 - 5.0 * 2f64.powi(-27), 2f64.powf(-12.5), 0.0));
        let placement =
            Placement { primitives: mesh.clone(), world, materials: Arc::from([0u32]), instance: 0 };
        let full = pass_of(&placement, DVec3::ZERO);
        assert_eq!(full.tally.imprecise, 1, "the case must be one the flattened pass counts");
        assert!(prove(&placement, &MeshExtremes::new(&mesh), DVec3::ZERO).is_none());
    }
}
