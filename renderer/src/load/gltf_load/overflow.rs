//! Node transforms that take a mesh out of f32's range. Transforms are composed in f64, so a
//! 3e38 scale, or two nested 1e30 scales, place finite f64 positions that no f32 can hold:
//! those triangles are dropped at load with one warning per node that names it, instead of
//! reaching the scene build, which blamed the camera's distance or zero area.

use crate::geometry::instances::{Placing, PrimitiveData};
use crate::geometry::precision::fits_f32;
use glam::{DMat4, DVec3, Vec3};
use std::path::Path;

/// What one node's placements took out of f32's range: triangles, and the largest coordinate
/// (m) they reached.
#[derive(Debug, Default, Clone, Copy)]
pub struct Overflow {
    pub triangles: u64,
    pub reach: f64,
}

impl Overflow {
    /// Counts the world-space triangle `p` if it leaves f32's range; whether it did.
    pub(super) fn count(&mut self, p: [DVec3; 3]) -> bool {
        if fits_f32(&p) {
            return false;
        }
        self.triangles += 1;
        // A NaN coordinate (inf - inf in the product) reads as beyond any range.
        let reach = p
            .iter()
            .flat_map(|v| v.to_array())
            .map(|x| if x.is_nan() { f64::INFINITY } else { x.abs() })
            .fold(0.0, f64::max);
        self.reach = self.reach.max(reach);
        true
    }

    /// Counts the triangles of a placement kept unflattened (`data` under `world`). The
    /// mesh's bounds (`bounds`, file space) placed decide first: an affine map keeps every
    /// vertex inside its bounds' image, so where the eight corners fit, every vertex does and
    /// nothing is walked (10,000 kept boulders would walk 820 M triangles).
    pub(super) fn count_kept(&mut self, data: &[PrimitiveData], bounds: (Vec3, Vec3), world: DMat4) {
        let placing = Placing::new(world);
        let (lo, hi) = bounds;
        let corners: Vec<DVec3> = (0..8)
            .map(|k| {
                let pick = |bit: usize, a: f32, b: f32| if k & bit == 0 { a } else { b };
                placing.position([pick(1, lo.x, hi.x), pick(2, lo.y, hi.y), pick(4, lo.z, hi.z)])
            })
            .collect();
        if fits_f32(&corners) {
            return;
        }
        for d in data {
            for &c in &d.corners {
                self.count(placing.corners(c).map(|i| placing.position(d.positions[i as usize])));
            }
        }
    }

    /// The warning for node `node` of the file `path`, if it dropped any triangle.
    pub(super) fn warning(&self, path: &Path, node: usize) -> Option<String> {
        (self.triangles > 0).then(|| {
            format!(
                "{}: the transform of nodes[{node}] overflows f32: composed with its parents' (and \
                 the scene file's placement of the model) it takes its mesh to coordinates up to \
                 {:.1e} m, beyond f32's {:.1e}; {} triangle(s) dropped",
                path.display(),
                self.reach,
                f32::MAX,
                self.triangles
            )
        })
    }
}

/// The file-space bounds of every position of `data` (empty bounds for no position).
pub(super) fn mesh_bounds(data: &[PrimitiveData]) -> (Vec3, Vec3) {
    data.iter().flat_map(|d| d.positions.iter()).fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
        let p = Vec3::from(*p);
        (lo.min(p), hi.max(p))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_triangle_past_f32s_range_is_counted_with_its_reach() {
        let mut o = Overflow::default();
        let inside = [DVec3::ZERO, DVec3::X * f32::MAX as f64, DVec3::Y];
        assert!(!o.count(inside));
        assert!(o.count([DVec3::ZERO, DVec3::X * 1.5e39, DVec3::Y]));
        assert!(o.count([DVec3::ZERO, DVec3::NAN, DVec3::Y]));
        assert_eq!(o.triangles, 2);
        assert_eq!(o.reach, f64::INFINITY);
    }
}
