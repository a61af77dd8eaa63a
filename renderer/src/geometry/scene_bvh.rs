//! The scene's BVH, with each shared mesh's tree built once.
//!
//! A mesh placed by several instances (metal-rough-spheres: one sphere, 98 nodes) gets its
//! tree built once, over one instance's triangles. Every other instance copies that tree,
//! its boxes refit to its own triangles. The rest gets one tree built over all of it:
//! meshes placed once, quads, soups made by hand, and instances missing a triangle (one the
//! load dropped). The trees are then joined under a top tree, split at the median of their
//! roots' centres.
//!
//! Exact whatever the tree's shape: every box is the union of its triangles' f32 boxes, as
//! obvhs builds them, so a ray finds the same triangles. A scene without a shared mesh gets
//! exactly the tree it had before: one build over all triangles in load order.

use crate::geometry::instances::{Instance, MeshTopology, TriangleOrigin};
use crate::geometry::scene::bvh_params;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::triangle::Triangle;
use rayon::prelude::*;
use std::ops::Range;
use std::time::Duration;

/// A tree over some of a larger set's items: its nodes (root first, obvhs's layout) and, in
/// leaf order, the items' indices in the whole set.
pub struct SubTree {
    pub nodes: Vec<Bvh2Node>,
    pub items: Vec<u32>,
}

/// The BVH over `tris` (load order, `origins` naming each one's instance), its
/// `primitive_indices` into `tris`. `None` without triangles.
pub(crate) fn build(
    tris: &[Triangle],
    origins: &[TriangleOrigin],
    instances: &[Instance],
    meshes: &[MeshTopology],
) -> Option<Bvh2> {
    if tris.is_empty() {
        return None;
    }
    let runs = instance_runs(origins);
    let shared = shared_runs(&runs, origins, instances, meshes);
    let mut served = vec![false; runs.len()];
    for (_, copies) in &shared {
        copies.iter().for_each(|&r| served[r] = true);
    }
    let rest: Vec<u32> = runs
        .iter()
        .zip(&served)
        .filter(|(_, s)| !**s)
        .flat_map(|((_, r), _)| r.clone().map(|i| i as u32))
        .collect();
    let mut trees: Vec<SubTree> = Vec::new();
    if !rest.is_empty() {
        // Gathered in load order: with nothing shared, the same input (and tree) as ever.
        let gathered: Vec<Triangle> = rest.iter().map(|&i| tris[i as usize]).collect();
        let bvh =
            obvhs::bvh2::builder::build_bvh2_from_tris(&gathered, bvh_params(), &mut Duration::default());
        let triangles = bvh.primitive_indices.iter().map(|&k| rest[k as usize]).collect();
        if shared.is_empty() {
            return Some(Bvh2 { primitive_indices: triangles, ..bvh });
        }
        trees.push(SubTree { nodes: bvh.nodes, items: triangles });
    }
    for (template, copies) in &shared {
        let first = runs[*template].1.clone();
        let bvh =
            obvhs::bvh2::builder::build_bvh2_from_tris(&tris[first], bvh_params(), &mut Duration::default());
        let refit: Vec<SubTree> =
            copies.par_iter().map(|&r| refit(&bvh, runs[r].1.start as u32, tris)).collect();
        trees.extend(refit);
    }
    Some(join(&trees))
}

/// Runs of consecutive triangles of one instance (or of no mesh), in load order.
fn instance_runs(origins: &[TriangleOrigin]) -> Vec<(u32, Range<usize>)> {
    let mut runs: Vec<(u32, Range<usize>)> = Vec::new();
    for (i, o) in origins.iter().enumerate() {
        match runs.last_mut() {
            Some((inst, r)) if *inst == o.instance && r.end == i => r.end = i + 1,
            _ => runs.push((o.instance, i..i + 1)),
        }
    }
    runs
}

/// Per mesh placed by two or more instances that kept the same triangles, each in one run:
/// (the run its tree is built over, every run that copies it, that one included). The load
/// drops degenerate triangles per instance (metal-rough-spheres' sphere loses its two
/// pole triangles in each), so a run copies the first run of its mesh only where their
/// triangles' indices in the mesh are equal, one for one.
fn shared_runs(
    runs: &[(u32, Range<usize>)],
    origins: &[TriangleOrigin],
    instances: &[Instance],
    meshes: &[MeshTopology],
) -> Vec<(usize, Vec<usize>)> {
    let mut runs_of_instance = vec![0u32; instances.len()];
    for (inst, _) in runs {
        if let Some(n) = runs_of_instance.get_mut(*inst as usize) {
            *n += 1;
        }
    }
    let locals = |r: &Range<usize>| origins[r.clone()].iter().map(|o| o.local);
    let mut copies: Vec<Vec<usize>> = vec![Vec::new(); meshes.len()];
    for (k, (inst, r)) in runs.iter().enumerate() {
        let Some(instance) = instances.get(*inst as usize) else { continue }; // loose
        if runs_of_instance[*inst as usize] != 1 {
            continue;
        }
        let same = &mut copies[instance.mesh as usize];
        if same.first().is_none_or(|&t| runs[t].1.len() == r.len() && locals(&runs[t].1).eq(locals(r))) {
            same.push(k);
        }
    }
    copies.into_iter().filter(|c| c.len() >= 2).map(|c| (c[0], c)).collect()
}

/// `template`'s tree over the run of triangles starting at `start` (the same mesh, in the same
/// order): its nodes with boxes refit to those triangles, children before parents.
fn refit(template: &Bvh2, start: u32, tris: &[Triangle]) -> SubTree {
    let mut nodes = template.nodes.clone();
    let triangles: Vec<u32> = template.primitive_indices.iter().map(|&k| start + k).collect();
    // Post-order: a node's box after its children's.
    let mut order = Vec::with_capacity(nodes.len());
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        order.push(i);
        let n = &nodes[i];
        if n.prim_count == 0 {
            stack.extend([n.first_index as usize, n.first_index as usize + 1]);
        }
    }
    for &i in order.iter().rev() {
        let n = nodes[i];
        nodes[i].aabb = if n.prim_count == 0 {
            let c = n.first_index as usize;
            nodes[c].aabb.union(&nodes[c + 1].aabb)
        } else {
            let leaf = &triangles[n.first_index as usize..(n.first_index + n.prim_count) as usize];
            leaf.iter().fold(Aabb::empty(), |b, &t| b.union(&tris[t as usize].aabb()))
        };
    }
    SubTree { nodes, items: triangles }
}

/// One tree over `trees`: a tree over their roots' bounds, split at the median of their
/// centres along the widest axis, each tree whole under it (its nodes moved after the top
/// ones, its items in its leaves' order). `primitive_indices` are the items. Used for the
/// scene's tree (a shared mesh's copies) and `silhouette`'s edge tree (one per instance).
pub fn join(trees: &[SubTree]) -> Bvh2 {
    let mut joined = Bvh2 { nodes: vec![Bvh2Node::default()], ..Bvh2::default() };
    let mut order: Vec<usize> = (0..trees.len()).collect();
    join_at(&mut joined, trees, &mut order, 0);
    joined
}

/// Fills node `slot` of `joined` with a tree over `trees[groups]`: the tree itself where one
/// is left, else two children over the halves of `groups` sorted along the widest axis of
/// their roots' centres.
fn join_at(joined: &mut Bvh2, trees: &[SubTree], groups: &mut [usize], slot: usize) {
    if let [g] = groups {
        let tree = &trees[*g];
        let (node_base, prim_base) = (joined.nodes.len() as u32 - 1, joined.primitive_indices.len() as u32);
        // Node k > 0 of the tree goes to node_base + k; its root to `slot`.
        fn moved(n: &Bvh2Node, node_base: u32, prim_base: u32) -> Bvh2Node {
            let base = if n.prim_count == 0 { node_base } else { prim_base };
            Bvh2Node { first_index: n.first_index + base, ..*n }
        }
        joined.nodes[slot] = moved(&tree.nodes[0], node_base, prim_base);
        joined.nodes.extend(tree.nodes[1..].iter().map(|n| moved(n, node_base, prim_base)));
        joined.primitive_indices.extend_from_slice(&tree.items);
        return;
    }
    let root = |g: usize| trees[g].nodes[0].aabb;
    let bounds = groups.iter().fold(Aabb::empty(), |b, &g| b.union(&root(g)));
    let axis = bounds.largest_axis();
    groups.sort_by(|&x, &y| root(x).center()[axis].total_cmp(&root(y).center()[axis]).then(x.cmp(&y)));
    let first = joined.nodes.len();
    joined.nodes.extend([Bvh2Node::default(); 2]);
    joined.nodes[slot] = Bvh2Node::new(bounds, 0, first as u32);
    let (lo, hi) = groups.split_at_mut(groups.len() / 2);
    join_at(joined, trees, lo, first);
    join_at(joined, trees, hi, first + 1);
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;
    use obvhs::ray::{Ray, RayHit};

    /// A 2 x 2 grid of squares (8 triangles) in the mesh's own space.
    fn grid() -> Vec<[Vec3A; 3]> {
        let mut t = Vec::new();
        for i in 0..2 {
            for j in 0..2 {
                let p = |a: f32, b: f32| Vec3A::new(i as f32 + a, 0.1 * (i + j) as f32, j as f32 + b);
                t.push([p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)]);
                t.push([p(0.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)]);
            }
        }
        t
    }

    /// Five placements of the grid (the fourth missing a triangle, as a load drops a
    /// degenerate one; the fifth turned), a second mesh placed once, and loose triangles.
    fn scene() -> (Vec<Triangle>, Vec<TriangleOrigin>, Vec<Instance>, Vec<MeshTopology>) {
        let mesh = |n: usize| MeshTopology { vertices: 3 * n as u32, corners: vec![[0, 1, 2]; n] };
        let meshes = vec![mesh(8), mesh(8)];
        let (mut tris, mut origins, mut instances) = (Vec::new(), Vec::new(), Vec::new());
        let offsets =
            [[0.0, 0.0, 0.0], [3.0, 0.5, 0.0], [0.0, 1.0, 3.0], [-3.0, 0.2, -1.0], [1.0, 2.0, -4.0]];
        for (k, o) in offsets.iter().enumerate() {
            let instance = instances.len() as u32;
            instances.push(Instance { mesh: 0, mirrored: false });
            for (local, t) in grid().into_iter().enumerate() {
                if k == 3 && local == 5 {
                    continue;
                }
                let v = t.map(|p| if k == 4 { Vec3A::new(p.z, p.y, -p.x) } else { p } + Vec3A::from(*o));
                tris.push(Triangle { v0: v[0], v1: v[1], v2: v[2] });
                origins.push(TriangleOrigin { instance, local: local as u32 });
            }
        }
        instances.push(Instance { mesh: 1, mirrored: false });
        for (local, t) in grid().into_iter().enumerate() {
            let v = t.map(|p| p * 2.0 + Vec3A::new(0.0, -1.0, 0.0));
            tris.push(Triangle { v0: v[0], v1: v[1], v2: v[2] });
            origins.push(TriangleOrigin { instance: 5, local: local as u32 });
        }
        for k in 0..3 {
            let o = Vec3A::new(k as f32, 3.0, 0.5);
            tris.push(Triangle { v0: o, v1: o + Vec3A::X, v2: o + Vec3A::Z });
            origins.push(TriangleOrigin::LOOSE);
        }
        (tris, origins, instances, meshes)
    }

    /// The shared mesh's three whole placements copy one tree (the other two, and the rest,
    /// are built); every triangle sits in exactly one leaf, every box holds its subtree; and
    /// rays find the closest hit a brute-force search over all triangles finds.
    #[test]
    fn a_joined_scene_tree_holds_every_triangle_once_and_finds_the_closest_hits() {
        let (tris, origins, instances, meshes) = scene();
        let runs = instance_runs(&origins);
        let shared = shared_runs(&runs, &origins, &instances, &meshes);
        assert_eq!(shared.len(), 1);
        assert_eq!(shared[0].1, [0, 1, 2, 4], "the placement missing a triangle is built, not copied");
        let bvh = build(&tris, &origins, &instances, &meshes).expect("a tree");
        let mut seen = bvh.primitive_indices.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..tris.len() as u32).collect::<Vec<_>>());
        // Boxes: each node's holds its children's, each leaf's its triangles'.
        let mut stack = vec![0usize];
        let mut leaves = 0;
        while let Some(i) = stack.pop() {
            let n = &bvh.nodes[i];
            let inside = |b: &Aabb| b.min.cmpge(n.aabb.min).all() && b.max.cmple(n.aabb.max).all();
            if n.prim_count == 0 {
                for c in [n.first_index as usize, n.first_index as usize + 1] {
                    assert!(inside(&bvh.nodes[c].aabb), "node {c} outside its parent {i}");
                    stack.push(c);
                }
            } else {
                for k in n.first_index..n.first_index + n.prim_count {
                    leaves += 1;
                    assert!(inside(&tris[bvh.primitive_indices[k as usize] as usize].aabb()), "leaf {i}");
                }
            }
        }
        assert_eq!(leaves, tris.len());
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut hits = 0;
        for _ in 0..2000 {
            let o = Vec3A::new(8.0 * uniform() - 4.0, 6.0, 8.0 * uniform() - 4.0);
            let target = Vec3A::new(10.0 * uniform() - 5.0, -1.0, 10.0 * uniform() - 5.0);
            let ray = Ray::new_inf(o, (target - o).normalize());
            let brute = tris.iter().map(|t| t.intersect(&ray)).fold(f32::INFINITY, f32::min);
            let mut hit = RayHit::none();
            bvh.ray_traverse(ray, &mut hit, |r, slot| {
                tris[bvh.primitive_indices[slot] as usize].intersect(r)
            });
            assert_eq!(hit.t, brute, "ray from {o} to {target}");
            hits += brute.is_finite() as u32;
        }
        assert!(hits > 500, "{hits} of 2000 rays hit: the test must meet triangles");
    }
}
