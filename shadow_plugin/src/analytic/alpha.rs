//! Alpha-tested triangles with holes: no closed form follows a texture's cutoff, so the
//! opaque geometry is integrated exactly and only what the leaves take from the visible
//! region is estimated by samples. Jittered strata over the box of the leaves' projections
//! (not the whole light); a sample counts where a leaf's region holds it, its ray meets
//! that leaf (alpha-tested, the leaf alone), and the opaque geometry leaves it visible (one
//! ray through the counted triangles, and no near-light outline over it). The noise is
//! that of the leaves' share alone, at the density of [shadows].samples over their box.

use super::lambert::LightPlane;
use crate::silhouette_edges::projection::Region;
use glam::{DVec2, Vec3};
use renderer::util::random::{Rng, strata, stream_seed};
use renderer::{RectLight, Scene};

/// What one side's alpha estimate needs: the light, the rays' origin, the flags of the
/// triangles left out of the counting, and the near-light outlines (light coordinates).
pub(super) struct Leaves<'a> {
    pub light: &'a RectLight,
    pub origin: Vec3,
    pub flags: &'a [u8],
    pub regions: &'a [Region],
    pub outlines: &'a [(u32, u32)],
    pub corners: &'a [DVec2],
}

/// The estimated sum (in [`LightPlane::edge_term`]'s units, positive) of the part of the
/// visible region the leaves hide, over the convex `part`, with `samples` strata and the
/// point's `seed`; and the samples' rays.
pub(super) fn hidden_by_leaves(
    scene: &Scene,
    plane: &LightPlane,
    leaves: &Leaves,
    part: &[DVec2],
    (samples, seed): (u32, u64),
) -> (f64, u64) {
    let alpha = |r: &&Region| leaves.flags[r.slot as usize] & crate::silhouette_edges::edges::ALPHA != 0;
    let (mut lo, mut hi) = (DVec2::INFINITY, DVec2::NEG_INFINITY);
    for r in leaves.regions.iter().filter(alpha) {
        (lo, hi) = (lo.min(r.lo), hi.max(r.hi));
    }
    let (plo, phi) =
        part.iter().fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(l, h), &q| (l.min(q), h.max(q)));
    let (lo, hi) = (lo.max(plo), hi.min(phi));
    if !(lo.x < hi.x && lo.y < hi.y) {
        return (0.0, 0);
    }
    let (nx, ny) = strata(samples);
    let size = hi - lo;
    let cell = DVec2::new(size.x / nx as f64, size.y / ny as f64);
    let mut rng = Rng::new(stream_seed(&[seed, 0xa1fa]));
    let (mut sum, mut rays) = (0.0, 0u64);
    let mut slots = [0usize; 8];
    for j in 0..ny {
        for i in 0..nx {
            let jitter = DVec2::new(rng.next_f32() as f64, rng.next_f32() as f64);
            let q = lo + cell * (DVec2::new(i as f64, j as f64) + jitter);
            if !inside(part, q) {
                continue;
            }
            let mut held = 0;
            for r in leaves.regions.iter().filter(alpha).filter(|r| r.holds(q)) {
                if held < slots.len() {
                    slots[held] = r.slot as usize;
                }
                held += 1;
            }
            if held == 0 {
                continue;
            }
            let (a, b) = (q.x as f32, q.y as f32);
            let target = leaves.light.point(a, b);
            let ends = (leaves.light.point_error(a, b), leaves.light.normal);
            rays += 1;
            // More leaves over one sample than the list holds: test them all through the
            // scene (every triangle but the alpha-tested ones skipped).
            let met = if held <= slots.len() {
                scene.segment_meets_any(leaves.origin, target, ends, slots[..held].iter().copied())
            } else {
                scene.segment_occluded_from_except(leaves.origin, target, ends, |s| {
                    leaves.flags[s] & crate::silhouette_edges::edges::ALPHA == 0
                })
            };
            if !met {
                continue;
            }
            rays += 1;
            let opaque = scene
                .segment_occluded_from_except(leaves.origin, target, ends, |s| leaves.flags[s] != 0)
                || leaves.outlines.iter().any(|&(l, h)| inside(&leaves.corners[l as usize..h as usize], q));
            if !opaque {
                sum += plane.weight(q);
            }
        }
    }
    (sum * cell.x * cell.y, rays)
}

/// Whether convex polygon `corners` (either orientation) holds `q`.
fn inside(corners: &[DVec2], q: DVec2) -> bool {
    let n = corners.len();
    let side = |k: usize| (corners[(k + 1) % n] - corners[k]).perp_dot(q - corners[k]);
    let first = (0..n).map(side).find(|&x| x != 0.0).unwrap_or(0.0);
    (0..n).all(|k| side(k) * first >= 0.0)
}
