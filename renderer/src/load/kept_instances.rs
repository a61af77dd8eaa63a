//! Building the kept instances ([`InstancedScene`]) from the loader's placements: which
//! triangles each instance keeps (the flattened scene's rules, counted in the same tally),
//! one tree per mesh and set of kept triangles, and the top tree over the instances.

use super::instance_proof::{self, MeshExtremes};
use super::precision_tally::PrecisionTally;
use crate::geometry::instanced::{InstancedScene, Placed, StoredMesh, place_corners};
use crate::geometry::instances::{Placement, Placing, PrimitiveData};
use crate::geometry::precision::{fits_f32, is_degenerate};
use crate::geometry::scene::{bvh_params, cover_depth};
use glam::{DMat4, DVec3, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::triangle::Triangle;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;

/// What one instance keeps: the mesh indices of the triangles the flattened scene would drop
/// (zero area, or lost to f32), its render-space bounds and largest coordinate, its tally.
pub(super) struct Pass {
    pub(super) dropped: Vec<u32>,
    pub(super) kept: u64,
    pub(super) bounds: Aabb,
    pub(super) tally: PrecisionTally,
    /// World-space (f64) bounds of its triangles of nonzero area, as the flattened scene's
    /// bounds count them (before f32 drops any).
    pub(super) world: (DVec3, DVec3),
}

/// Every placement's pass, in parallel, in order: proven from its mesh's extremes where it
/// keeps every triangle ([`super::instance_proof`]), else triangle by triangle.
pub(super) fn passes(placements: &[Placement], offset: DVec3) -> Vec<Pass> {
    let mut meshes: HashMap<usize, usize> = HashMap::new();
    let mut unique: Vec<&Placement> = Vec::new();
    for p in placements {
        meshes.entry(Arc::as_ptr(&p.primitives) as usize).or_insert_with(|| {
            unique.push(p);
            unique.len() - 1
        });
    }
    let extremes: Vec<MeshExtremes> = unique.par_iter().map(|p| MeshExtremes::new(&p.primitives)).collect();
    placements
        .par_iter()
        .map(|p| {
            let m = &extremes[meshes[&(Arc::as_ptr(&p.primitives) as usize)]];
            match instance_proof::prove(p, m, offset) {
                Some(proven) => {
                    let mut tally = PrecisionTally::default();
                    tally.zero_area = proven.dropped.len() as u64;
                    Pass {
                        dropped: proven.dropped,
                        kept: proven.kept,
                        bounds: proven.bounds,
                        tally,
                        world: proven.world,
                    }
                }
                None => pass(p, offset),
            }
        })
        .collect()
}

/// The kept instances and how many triangles they hold (flattened), with `tally` counting
/// their drops as the flattened scene's build would, instance by instance in order.
/// `passes` are the placements' own ([`passes`]).
pub(super) fn build(
    placements: Vec<Placement>,
    passes: Vec<Pass>,
    (offset, corner_budget): (DVec3, u64),
    tally: &mut PrecisionTally,
) -> (Option<InstancedScene>, u64) {
    let mut kept_triangles = 0;
    for p in &passes {
        tally.merge(&p.tally);
        kept_triangles += p.kept;
    }
    // One stored mesh per (mesh, dropped triangles): almost always one per mesh.
    let mut groups: HashMap<(usize, Vec<u32>), u32> = HashMap::new();
    let mut meshes: Vec<(Arc<Vec<PrimitiveData>>, Vec<u32>, f64)> = Vec::new();
    let mut placed = Vec::new();
    // Per mesh: its largest file coordinate (the f64 rounding of its placed corners).
    let mut reaches: HashMap<usize, f64> = HashMap::new();
    for (pl, pass) in placements.iter().zip(passes) {
        if pass.kept == 0 {
            continue;
        }
        let reach = *reaches.entry(Arc::as_ptr(&pl.primitives) as usize).or_insert_with(|| {
            let coordinates = pl.primitives.iter().flat_map(|d| d.positions.iter().flatten());
            coordinates.fold(0.0f64, |r, &x| r.max((x as f64).abs()))
        });
        let placing = Placing::new(pl.world);
        let world_rounding = placing.rounding(reach, offset);
        let key = (Arc::as_ptr(&pl.primitives) as usize, pass.dropped);
        let next = meshes.len() as u32;
        let mesh = *groups.entry(key.clone()).or_insert_with(|| {
            meshes.push((pl.primitives.clone(), key.1.clone(), 0.0));
            next
        });
        let to_mesh = pl.world.inverse() * DMat4::from_translation(offset);
        // The mesh's boxes must hold, for this instance: the f32 rounding of its placed
        // corners moved back into the mesh's space, and the rounding of the ray's move there
        // (from where it enters the bounds: the mesh's size times f32's epsilon, with room).
        let render_reach =
            Vec3::from(pass.bounds.min).abs().max(Vec3::from(pass.bounds.max).abs()).max_element();
        let inverse_norm = {
            let m = glam::DMat3::from_mat4(to_mesh).transpose();
            [m.x_axis, m.y_axis, m.z_axis].iter().map(|r| r.abs().element_sum()).fold(0.0, f64::max)
        };
        let pad = (4.0 * f32::EPSILON as f64 * render_reach as f64 + world_rounding) * inverse_norm;
        // A nearly singular transform (its inverse past 1e15, or not finite) walks no tree: its
        // triangles are all tested.
        let brute = !(to_mesh.is_finite() && pad.is_finite() && inverse_norm < 1e15);
        if !brute {
            let g = &mut meshes[mesh as usize];
            g.2 = g.2.max(pad);
        }
        placed.push(Placed {
            mesh,
            placing,
            world_rounding,
            to_mesh,
            materials: pl.materials.clone(),
            instance: pl.instance,
            bounds: pass.bounds,
            brute,
            corners_at: None,
        });
    }
    if placed.is_empty() {
        return (None, kept_triangles);
    }
    let meshes: Vec<StoredMesh> =
        meshes.into_par_iter().map(|(prims, dropped, pad)| stored(prims, &dropped, pad)).collect();
    let boxes: Vec<Aabb> = placed.iter().map(|p| p.bounds).collect();
    // One instance per leaf: the walk's f32 box test then culls instances before their f64
    // entry test and the ray's move into their space.
    let params = obvhs::BvhBuildParams { max_prims_per_leaf: 1, ..bvh_params() };
    let mut tlas = obvhs::bvh2::builder::build_bvh2(&boxes, params, &mut Duration::default());
    cover_depth(&mut tlas);
    let corners = hold_corners(&meshes, &mut placed, offset, corner_budget);
    (Some(InstancedScene { meshes, placed, tlas, offset, corners }), kept_triangles)
}

/// The placed corners of the first instances whose corners fit in `budget` bytes, in order
/// (each instance's `corners_at` set), placed in parallel.
fn hold_corners(meshes: &[StoredMesh], placed: &mut [Placed], offset: DVec3, budget: u64) -> Vec<[Vec3; 3]> {
    const BYTES: u64 = std::mem::size_of::<[Vec3; 3]>() as u64;
    let mut total = 0usize;
    for p in placed.iter_mut() {
        let n = meshes[p.mesh as usize].slots.len();
        if (total + n) as u64 * BYTES > budget {
            break;
        }
        p.corners_at = Some(total);
        total += n;
    }
    let mut corners = vec![[Vec3::ZERO; 3]; total];
    let mut rest: &mut [[Vec3; 3]] = &mut corners;
    let mut jobs = Vec::new();
    for p in placed.iter().filter(|p| p.corners_at.is_some()) {
        let (mine, tail) = rest.split_at_mut(meshes[p.mesh as usize].slots.len());
        jobs.push((p, mine));
        rest = tail;
    }
    jobs.into_par_iter().for_each(|(p, out)| {
        let mesh = &meshes[p.mesh as usize];
        for (slot, c) in out.iter_mut().enumerate() {
            *c = place_corners(mesh, p, offset, slot);
        }
    });
    corners
}

/// [`pass`], for the proof's tests.
#[cfg(test)]
pub(super) fn pass_of(p: &Placement, offset: DVec3) -> Pass {
    pass(p, offset)
}

/// One instance's pass over its triangles: the flattened build's rules, in its order.
fn pass(p: &Placement, offset: DVec3) -> Pass {
    let placing = Placing::new(p.world);
    let mut tally = PrecisionTally::default();
    let (mut dropped, mut kept, mut bounds) = (Vec::new(), 0u64, Aabb::empty());
    let mut world = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    let mut local = 0u32;
    for data in p.primitives.iter() {
        for &c in &data.corners {
            let c = placing.corners(c);
            let w = c.map(|i| placing.position(data.positions[i as usize]));
            // The loader counts zero-area triangles before the build sees the rest, and drops
            // (and warns of, by node) those out of f32's range before either.
            let keep = if !fits_f32(&w) {
                false
            } else if is_degenerate(w) {
                tally.zero_area += 1;
                false
            } else {
                for v in w {
                    world = (world.0.min(v), world.1.max(v));
                }
                tally.keep(w, offset).is_some()
            };
            if keep {
                kept += 1;
                for v in w {
                    bounds.extend(Vec3A::from((v - offset).as_vec3()));
                }
            } else {
                dropped.push(local);
            }
            local += 1;
        }
    }
    Pass { dropped, kept, bounds, tally, world }
}

/// A mesh's tree over the triangles not `dropped`, in its own space, every box grown by
/// `pad` plus the rounding of the ray's move (f32's epsilon times the mesh's size, 32-fold).
fn stored(primitives: Arc<Vec<PrimitiveData>>, dropped: &[u32], pad: f64) -> StoredMesh {
    let mut slots = Vec::new();
    let mut tris = Vec::new();
    let mut magnitude = 0.0f32;
    let mut local = 0u32;
    let mut skip = dropped.iter().peekable();
    for (pi, data) in primitives.iter().enumerate() {
        for (k, c) in data.corners.iter().enumerate() {
            if skip.peek() == Some(&&local) {
                skip.next();
            } else {
                let v = c.map(|i| Vec3A::from(data.positions[i as usize]));
                magnitude = v.iter().fold(magnitude, |m, p| m.max(p.abs().max_element()));
                tris.push(Triangle { v0: v[0], v1: v[1], v2: v[2] });
                slots.push([pi as u32, k as u32]);
            }
            local += 1;
        }
    }
    let mut bvh = obvhs::bvh2::builder::build_bvh2_from_tris(&tris, bvh_params(), &mut Duration::default());
    cover_depth(&mut bvh);
    let slots: Vec<[u32; 2]> = bvh.primitive_indices.iter().map(|&i| slots[i as usize]).collect();
    let points = slots
        .iter()
        .map(|&[pi, k]| {
            let data = &primitives[pi as usize];
            data.corners[k as usize].map(|i| DVec3::from(data.positions[i as usize].map(f64::from)))
        })
        .collect();
    let grow = (pad + 32.0 * f32::EPSILON as f64 * magnitude as f64) as f32;
    for n in &mut bvh.nodes {
        n.aabb.min -= Vec3A::splat(grow);
        n.aabb.max += Vec3A::splat(grow);
    }
    let first_local = primitives
        .iter()
        .scan(0u32, |n, d| {
            let first = *n;
            *n += d.corners.len() as u32;
            Some(first)
        })
        .collect();
    StoredMesh { primitives, slots, points, bvh, first_local }
}
