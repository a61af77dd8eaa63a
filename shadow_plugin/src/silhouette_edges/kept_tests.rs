//! `kept.rs`'s margins against the exact predicate on placed edges.

use super::*;
use crate::silhouette_edges::projection::exact_orient_sign;
use glam::{DMat4, DQuat};
use renderer::geometry::instances::Placing;
use std::sync::Arc;

/// An edge the mesh-space tests drop has, placed as the walk places it (f32 render
/// space), weight 0 for every origin of the ball, or faces that every light corner sees
/// on opposite sides: random edges, flat and folded; random transforms, mirrored and
/// unevenly scaled, translated up to 1e14 of the mesh's size (world coordinates that
/// dwarf the camera-relative ones, where the f64 placing's rounding counts); origins
/// within a hair of a face's plane; lights anywhere, some in a face's plane. (Written
/// from a review's search, which found drops at 1e12 before the margin held the f64
/// rounding.)
#[test]
fn an_edge_the_mesh_space_tests_drop_is_dead_where_it_is_placed() {
    let stream = std::cell::RefCell::new(crate::silhouette_edges::uniform(0x1234_5678_9abc_def1));
    let next = || (stream.borrow_mut())();
    let r = || next() * 2.0 - 1.0;
    let light = RectLight::new(Vec3::new(0.0, 50.0, 0.0), Vec3::X, Vec3::Z, Vec3::ONE);
    let shaft = Shaft::around_ball(&light, Vec3::ZERO, 1.0).expect("a shaft");
    let (mut dropped, mut wrong) = (0u64, 0u64);
    for round in 0..60_000u64 {
        let size = 10f64.powf(3.0 * r());
        let point = || (DVec3::new(r(), r(), r()) * size).as_vec3().as_dvec3();
        let (a, b) = (point(), point());
        let side_dir = point();
        let bend = if next() < 0.5 { 10f64.powf(-6.0 * next()) } else { 1.0 };
        let side = (b - a).cross(side_dir).normalize_or_zero();
        let up = (b - a).cross(side).normalize_or_zero();
        let mid = 0.5 * (a + b);
        let c0 = (mid + size * side + size * bend * r() * up).as_vec3().as_dvec3();
        let c1 = (mid - size * side + size * bend * r() * up).as_vec3().as_dvec3();
        let points = vec![[a, b, c0], [b, a, c1]];
        let edges = mesh_edges(&points);
        let Some(e) = edges.iter().find(|e| e.faces == 2) else { continue };
        let mirror = if round % 3 == 0 { -1.0 } else { 1.0 };
        let scale = DVec3::new(10f64.powf(2.0 * r()), 10f64.powf(2.0 * r()), 10f64.powf(2.0 * r())) * mirror;
        let turn = DQuat::from_euler(glam::EulerRot::XYZ, 6.0 * r(), 6.0 * r(), 6.0 * r());
        let shift = DVec3::new(r(), r(), r()) * 10f64.powf(14.0 * next()) * size;
        let world = DMat4::from_scale_rotation_translation(scale, turn, shift);
        let placing = Placing::new(world);
        let offset = shift + DVec3::new(r(), r(), r()) * 10f64.powf(4.0 * next() - 1.0) * size;
        let place = |x: DVec3| (placing.point(x) - offset).as_vec3();
        let mut bounds = Aabb::empty();
        for v in [a, b, c0, c1].map(place) {
            bounds.extend(Vec3A::from(v));
        }
        let reach = points.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs().max_element()));
        let p = Placed {
            mesh: 0,
            placing,
            to_mesh: world.inverse() * DMat4::from_translation(offset),
            materials: Arc::from([0u32]),
            instance: 0,
            bounds,
            brute: false,
            corners_at: None,
            world_rounding: placing.rounding(reach, offset),
        };
        let carry = Carry::new(&p);
        let inst =
            InstancedScene { meshes: vec![], placed: vec![], tlas: Bvh2::default(), offset, corners: vec![] };
        // An origin within a hair of a placed face's plane, a ball about it or none.
        let [pa, pb, pc0, pc1] = [a, b, c0, c1].map(|x| place(x).as_dvec3());
        let pc = if round % 2 == 0 { pc0 } else { pc1 };
        let n = (pb - pa).cross(pc - pa).normalize_or_zero();
        let (w0, w1) = (next(), next());
        let along = pa + w0 * (pb - pa) + w1 * (1.0 - w0) * (pc - pa);
        let along = along + (along - pa) * 10f64.powf(2.0 * r()) * next();
        let render_reach = bounds.min.abs().max(bounds.max.abs()).max_element() as f64;
        let hair = 10f64.powf(-10.0 * next()) * render_reach * r().signum();
        let origin = along + n * hair;
        let radius = if next() < 0.5 { 0.0 } else { hair.abs() * next() };
        let lc = if next() < 0.3 {
            pa + (pc - pa) * 3.0 * r() + (pb - pa) * 3.0 * r()
        } else {
            DVec3::new(r(), r(), r()) * 10f64.powf(3.0 * next()) * size
        };
        let lu = DVec3::new(r(), r(), r()) * size * 10f64.powf(r());
        let lv = lu.cross(DVec3::new(r(), r(), r())).normalize_or_zero() * size * 10f64.powf(r());
        let corners = [lc - lu - lv, lc + lu - lv, lc + lu + lv, lc - lu + lv];
        let w = Walk {
            inst: &inst,
            p: &p,
            carry: &carry,
            shaft: &shaft,
            origin,
            radius,
            weights: true,
            light: &corners,
        };
        let all: Vec<DVec3> = points.iter().flatten().copied().collect();
        let (lo, hi) =
            all.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), &x| (l.min(x), h.max(x)));
        let mesh =
            MeshEdges { centre: 0.5 * (lo + hi), radius: 0.5 * (hi - lo).length(), ..Default::default() };
        if InMesh::new(&mesh, &w).needed(e) {
            continue;
        }
        dropped += 1;
        // The edge as the walk would place it, judged by the exact predicate.
        let (ea, eb) = (w.place(e.a).as_dvec3(), w.place(e.b).as_dvec3());
        let t = e.thirds.map(|c| w.place(c).as_dvec3());
        let weight = |o: DVec3| -> i32 { t.iter().map(|&c| exact_orient_sign(o, ea, eb, c)).sum() };
        let mut origins = vec![origin];
        for c in t {
            let nn = (eb - ea).cross(c - ea).normalize_or_zero();
            origins.extend([origin + nn * radius, origin - nn * radius]);
        }
        let dead_for_origins = origins.iter().all(|&o| weight(o) == 0);
        let s0: Vec<i32> = corners.iter().map(|&s| exact_orient_sign(s, ea, eb, t[0])).collect();
        let s1: Vec<i32> = corners.iter().map(|&s| exact_orient_sign(s, ea, eb, t[1])).collect();
        let dead_for_light = s0.iter().all(|&x| x == s0[0] && x != 0) && s1.iter().all(|&x| x == -s0[0]);
        wrong += !(dead_for_origins || dead_for_light) as u64;
    }
    assert_eq!(wrong, 0, "{wrong} of {dropped} dropped edges live where placed");
    assert!(dropped > 10_000, "only {dropped} edges dropped: the test must reach the tests");
}
