//! The edge set's connectivity, found once per mesh: vertex ids and edges of an instance
//! are its mesh's, offset ([`renderer::geometry::instances`]). One transform maps a mesh's
//! equal positions to equal positions, so its welded vertices are welded in every copy.
//! Only what can meet another instance is welded by position: the meshes' boundary
//! vertices (seams) and hand-made loose triangles. A vertex left unwelded where another
//! instance's lies, or two ids of one position, is only an edge more: a point's counts are
//! sums over triangles, and two boundary edges on one line sum to the manifold edge.
//!
//! Measured on metal-rough-spheres (98 instances of one sphere, 1.04 M triangles): welding
//! by sorting every corner took 89 ms, linking by sorting every side 68 ms; so, 17 ms and
//! 21 ms (the edge set 157 -> 47 ms).

use glam::Vec3;
use rayon::prelude::*;
use renderer::Scene;
use renderer::geometry::instances::{MeshTopology, position_key};
use std::sync::atomic::{AtomicU32, Ordering};

/// Where each instance's vertex ids start, and the ids its boundary vertices were welded
/// to (identity elsewhere), indexed by `base + local id`.
pub(super) struct Welded {
    pub base: Vec<u32>,
    pub remap: Vec<u32>,
}

impl Welded {
    fn id(&self, instance: u32, local: u32) -> u32 {
        self.remap[(self.base[instance as usize] + local) as usize]
    }
}

/// A triangle side as the link sorts it: (lo, hi, third, whether the winding runs lo -> hi)
/// packed in one u128 (one integer comparison).
pub(super) fn pack_side(a: u32, b: u32, third: u32) -> u128 {
    let (lo, hi) = (a.min(b) as u128, a.max(b) as u128);
    (lo << 96) | (hi << 64) | ((third as u128) << 32) | (a < b) as u128
}

/// A packed side's parts ([`pack_side`]).
pub(super) fn unpack_side(p: u128) -> (u32, u32, u32, bool) {
    ((p >> 96) as u32, (p >> 64) as u32, (p >> 32) as u32, p as u32 != 0)
}

/// Fills the edge set's `vertices` and `corners`: an instance's triangle takes its mesh's ids offset
/// by the instance's base; the meshes' boundary vertices and loose triangles' corners
/// are welded by bit-identical position (-0.0 and 0.0 are one), sorted with ties by id
/// so the ids are the same on every run.
pub(super) fn weld(set_vertices: &mut Vec<Vec3>, set_corners: &mut Vec<[u32; 3]>, scene: &Scene) -> Welded {
    // Ids only for the instances flattened into the scene's triangles: a kept one
    // (`Scene::instanced`, `kept.rs`) holds none here.
    let mut flat = vec![false; scene.instances.len()];
    for o in scene.origins.iter().filter(|o| !o.is_loose()) {
        flat[o.instance as usize] = true;
    }
    let mut base = Vec::with_capacity(scene.instances.len());
    let mut total = 0u64;
    for (inst, &flat) in scene.instances.iter().zip(&flat) {
        base.push(total as u32);
        total += if flat { scene.meshes[inst.mesh as usize].vertices as u64 } else { 0 };
    }
    // A loose corner's tag is total + its corner index (3 per triangle slot).
    let corners = 3 * scene.triangles.len() as u64;
    assert!(total + corners < u32::MAX as u64, "more vertices than u32 ids");
    let total = total as u32;
    // Each instance triangle's ids, then each id's position, in parallel: every triangle
    // naming an id writes the same bits there (one transform of one file position), so
    // the order of the writes cannot matter. (boulder-field, 8.2 M triangles: 240 ms on
    // one thread.)
    *set_corners = scene
        .origins
        .par_iter()
        .map(|o| {
            if o.is_loose() {
                return [u32::MAX; 3];
            }
            let inst = scene.instances[o.instance as usize];
            let mut c = scene.meshes[inst.mesh as usize].corners[o.local as usize];
            if inst.mirrored {
                c.swap(1, 2); // as the loader swapped the triangle's corners
            }
            c.map(|i| base[o.instance as usize] + i)
        })
        .collect();
    let bits: Vec<AtomicU32> =
        (0..3 * total as usize).into_par_iter().map(|_| AtomicU32::new(f32::NAN.to_bits())).collect();
    scene.triangles.par_iter().zip(&*set_corners).for_each(|(tri, c)| {
        if c[0] != u32::MAX {
            for (k, v) in [tri.v0, tri.v1, tri.v2].into_iter().enumerate() {
                for (d, x) in Vec3::from(v).to_array().into_iter().enumerate() {
                    bits[3 * c[k] as usize + d].store(x.to_bits(), Ordering::Relaxed);
                }
            }
        }
    });
    *set_vertices = bits
        .par_chunks(3)
        .map(|v| Vec3::from_array([0, 1, 2].map(|d| f32::from_bits(v[d].load(Ordering::Relaxed)))))
        .collect();
    let mut keys = Vec::new();
    for (slot, (tri, o)) in scene.triangles.iter().zip(&scene.origins).enumerate() {
        if o.is_loose() {
            // Tagged after every instance vertex: a run's first tag is an instance's
            // vertex where it has one.
            let p = [tri.v0, tri.v1, tri.v2].map(Vec3::from);
            keys.extend((0..3).map(|k| position_key(p[k], total + (3 * slot + k) as u32)));
        }
    }
    // The meshes' boundary vertices, each instance's that a kept triangle uses.
    let boundaries: Vec<Vec<u32>> = scene.meshes.par_iter().map(boundary_vertices).collect();
    for (i, inst) in scene.instances.iter().enumerate().filter(|&(i, _)| flat[i]) {
        for &v in &boundaries[inst.mesh as usize] {
            let id = base[i] + v;
            if !set_vertices[id as usize].is_nan() {
                keys.push(position_key(set_vertices[id as usize], id));
            }
        }
    }
    keys.par_sort_unstable();
    let mut remap: Vec<u32> = (0..total).collect();
    let mut canonical = 0u32;
    for (n, &k) in keys.iter().enumerate() {
        let tag = k as u32;
        if n == 0 || keys[n - 1] >> 32 != k >> 32 {
            canonical = if tag < total {
                tag
            } else {
                let bits = [(k >> 96) as u32, (k >> 64) as u32, (k >> 32) as u32];
                set_vertices.push(Vec3::from_array(bits.map(f32::from_bits)));
                set_vertices.len() as u32 - 1
            };
        }
        if tag < total {
            remap[tag as usize] = canonical;
        } else {
            let corner = (tag - total) as usize;
            set_corners[corner / 3][corner % 3] = canonical;
        }
    }
    for (c, o) in set_corners.iter_mut().zip(&scene.origins) {
        if !o.is_loose() {
            *c = c.map(|i| remap[i as usize]);
        }
    }
    Welded { base, remap }
}

/// The vertices of a mesh's edges that have one triangle: where the mesh may meet another
/// instance's (or a loose triangle) at a seam.
fn boundary_vertices(mesh: &MeshTopology) -> Vec<u32> {
    let mut on_boundary = vec![false; mesh.vertices as usize];
    let sides = sorted_sides(mesh);
    for run in sides.chunk_by(|x, y| x >> 64 == y >> 64) {
        if run.len() == 1 {
            let (lo, hi, ..) = unpack_side(run[0]);
            on_boundary[lo as usize] = true;
            on_boundary[hi as usize] = true;
        }
    }
    (0..mesh.vertices).filter(|&v| on_boundary[v as usize]).collect()
}

/// A mesh's triangle sides in its own ids ([`pack_side`], the file's winding), sorted.
fn sorted_sides(mesh: &MeshTopology) -> Vec<u128> {
    let mut sides: Vec<u128> = mesh
        .corners
        .iter()
        .flat_map(|c| (0..3).map(move |k| pack_side(c[k], c[(k + 1) % 3], c[(k + 2) % 3])))
        .collect();
    sides.sort_unstable();
    sides
}

/// A mesh's edges of two or more triangles, in its own ids: each with its sides ([`pack_side`]).
pub(super) struct MeshEdges {
    /// (first, count) into `sides` per edge.
    pub runs: Vec<(u32, u32)>,
    pub sides: Vec<u128>,
    /// The sides of one triangle (boundary edges: they may meet another instance's).
    pub single: Vec<u128>,
}

impl MeshEdges {
    pub(super) fn new(mesh: &MeshTopology) -> MeshEdges {
        let proper =
            MeshTopology { corners: mesh.corners.iter().filter(|c| distinct(c)).copied().collect(), ..*mesh };
        let sorted = sorted_sides(&proper);
        let mut edges = MeshEdges { runs: Vec::new(), sides: Vec::new(), single: Vec::new() };
        for run in sorted.chunk_by(|x, y| x >> 64 == y >> 64) {
            if run.len() == 1 {
                edges.single.push(run[0]);
            } else {
                edges.runs.push((edges.sides.len() as u32, run.len() as u32));
                edges.sides.extend_from_slice(run);
            }
        }
        edges
    }
}

/// One side of `instance`'s copy of a mesh side `p` (mesh ids), in the set's ids and the
/// instance's winding (a mirrored instance's triangles run the other way).
pub(super) fn instance_side(welded: &Welded, instance: u32, mirrored: bool, p: u128) -> u128 {
    let (lo, hi, third, forward) = unpack_side(p);
    let (a, b) = if forward != mirrored { (lo, hi) } else { (hi, lo) };
    pack_side(welded.id(instance, a), welded.id(instance, b), welded.id(instance, third))
}

/// Which instances are whole (every triangle of their mesh counted: none flagged, clear or
/// dropped, but those of repeated ids, which never are), and the edges of the meshes they
/// place.
pub(super) struct Templates {
    whole: Vec<bool>,
    meshes: Vec<Option<MeshEdges>>,
}

impl Templates {
    pub(super) fn new(scene: &Scene, counted: impl Fn(usize) -> bool) -> Templates {
        let proper: Vec<usize> =
            scene.meshes.par_iter().map(|m| m.corners.iter().filter(|c| distinct(c)).count()).collect();
        let mut kept = vec![0usize; scene.instances.len()];
        for (slot, o) in scene.origins.iter().enumerate() {
            if !o.is_loose() && counted(slot) {
                kept[o.instance as usize] += 1;
            }
        }
        let whole: Vec<bool> =
            scene.instances.iter().zip(&kept).map(|(inst, &k)| k == proper[inst.mesh as usize]).collect();
        let mut used = vec![false; scene.meshes.len()];
        for (inst, _) in scene.instances.iter().zip(&whole).filter(|(_, w)| **w) {
            used[inst.mesh as usize] = true;
        }
        let meshes = scene.meshes.par_iter().zip(used).map(|(m, u)| u.then(|| MeshEdges::new(m))).collect();
        Templates { whole, meshes }
    }

    /// The edges of instance `i`'s mesh if the instance is whole (`None` for a loose
    /// triangle's `u32::MAX`).
    pub(super) fn of(&self, scene: &Scene, i: u32) -> Option<&MeshEdges> {
        let inst = scene.instances.get(i as usize)?;
        self.meshes[inst.mesh as usize].as_ref().filter(|_| self.whole[i as usize])
    }
}

fn distinct(c: &[u32; 3]) -> bool {
    c[0] != c[1] && c[1] != c[2] && c[0] != c[2]
}

/// One whole instance's kept edges: their sides back to back and each one's count, and how
/// many edges (and of those, of more than two faces) were dropped, for the stats.
#[derive(Default)]
pub(super) struct InstanceEdges {
    pub sides: Vec<u128>,
    pub lens: Vec<u32>,
    pub dropped: [u64; 2],
}

impl InstanceEdges {
    /// Instance `i`'s (`mirrored` or not) copy of mesh edges `t`, in the set's ids, the ones
    /// `keep` accepts.
    pub(super) fn new(
        t: &MeshEdges,
        welded: &Welded,
        (i, mirrored): (u32, bool),
        keep: impl Fn(&[u128]) -> bool,
    ) -> Self {
        let mut copy = InstanceEdges::default();
        let mut run = Vec::new();
        for &(first, count) in &t.runs {
            run.clear();
            let sides = &t.sides[first as usize..(first + count) as usize];
            run.extend(sides.iter().map(|&p| instance_side(welded, i, mirrored, p)));
            if keep(&run) {
                copy.sides.extend_from_slice(&run);
                copy.lens.push(count);
            } else {
                copy.dropped[0] += 1;
                copy.dropped[1] += (count > 2) as u64;
            }
        }
        copy
    }
}
