//! Unit tests of the depth map: its layers and its fit.

use super::*;
use renderer::geometry::ray_origin::point_error;
use renderer::{RectLight, Scene, ShadingPoint, Shaft};

fn map(depth: Vec<f32>) -> DepthMap {
    let frame = LightFrame { origin: Vec3::ZERO, x: Vec3::X, y: Vec3::Y, z: Vec3::Z, half_size: Vec2::ONE };
    DepthMap::from_depths(frame, Vec2::splat(-1.0), 0.5, 4, depth)
}

/// The min-depth pyramid is built from the first layer and bounds the hidden one: a
/// hidden layer given above the first is moved down to it, and is empty where the first
/// is (region shrinking and block culling rely on it).
#[test]
fn the_hidden_layer_never_lies_above_the_first() {
    let mut depth = vec![2.0f32; 16];
    depth[5] = f32::INFINITY;
    let m = map(depth.clone()).with_hidden_layer(vec![1.0; 16], vec![1.5; 16]);
    for k in 0..16 {
        assert!(m.depth2[k] >= m.depth[k] && m.bottom2[k] >= m.depth2[k], "pixel {k}");
    }
    assert_eq!(m.depth2[5], f32::INFINITY);
    assert_eq!(m.min_depth([0, 0], [3, 3]), 2.0);
    let below = map(depth).with_hidden_layer(vec![3.0; 16], vec![3.5; 16]);
    assert_eq!((below.depth2[0], below.bottom2[0]), (3.0, 3.5));
}

#[test]
#[should_panic(expected = "NaN depth")]
fn a_nan_depth_is_refused() {
    let mut depth = vec![2.0f32; 16];
    depth[3] = f32::NAN;
    map(depth);
}

/// A 20 x 20 floor under a 1 x 1 light 2 up, with a 0.2 x 0.2 card 0.5 over it if
/// `card`, and `n` x `n` visible floor points 0.1 apart from `corner` (x, z).
fn floor_scene(card: bool, n: usize, corner: [f32; 2]) -> (Scene, RectLight, Vec<ShadingPoint>) {
    use glam::DVec3;
    use renderer::{Camera, load::gltf_load::Geometry};
    use std::time::Duration;
    let mut g = Geometry::default();
    g.add_quad(DVec3::ZERO, DVec3::new(20.0, 0.0, 0.0), DVec3::new(0.0, 0.0, -20.0), [0.5; 3]);
    if card {
        g.add_quad(
            DVec3::new(0.3, 0.5, 0.0),
            DVec3::new(0.2, 0.0, 0.0),
            DVec3::new(0.0, 0.0, -0.2),
            [0.5; 3],
        );
    }
    let light = RectLight::new(Vec3::new(0.0, 2.0, 0.0), Vec3::X, Vec3::Z, Vec3::ONE);
    let camera = Camera::look_at(Vec3::new(0.0, 5.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0);
    let scene = Scene::build(g, vec![light], camera, DVec3::ZERO, Duration::ZERO);
    let visible = (0..n * n)
        .map(|k| {
            let p = Vec3::new(corner[0] + 0.1 * (k % n) as f32, 0.0, corner[1] + 0.1 * (k / n) as f32);
            ShadingPoint { p, p_error: point_error(p), n_geom: Vec3::Y, n_shading: Vec3::Y }
        })
        .collect();
    (scene, light, visible)
}

/// 64^2 maps of the same receivers fitted to every lit one and to the shadowed ones.
fn both_fits(scene: &Scene, light: &RectLight, visible: &[ShadingPoint]) -> (DepthMap, DepthMap) {
    let params = DepthMapParams::new(64);
    let all_lit = DepthMap::build(
        scene,
        light,
        visible,
        &DepthMapParams { switches: MapSwitches { fit_shadowed: false, ..params.switches }, ..params },
    );
    (all_lit, DepthMap::build(scene, light, visible, &params))
}

/// `fit_shadowed`: on a 20 x 20 floor seen whole, with one small card over it, the map
/// covers the card's shadow (every receiver whose shaft is not clear lies in it) at a
/// pitch far finer than a map fitted to the whole lit floor, and a floor point away from
/// it, clear, lies outside it (but inside the lit floor's map: the light's centre is
/// 43 deg above it, not grazing at the default `grazing_cos`).
#[test]
fn a_map_fitted_to_the_shadowed_receivers_covers_them_finely() {
    let (scene, light, visible) = floor_scene(true, 100, [-5.0, -5.0]);
    let (all_lit, fitted) = both_fits(&scene, &light, &visible);
    assert!(fitted.pitch * 4.0 < all_lit.pitch, "pitch {} against {}", fitted.pitch, all_lit.pitch);
    let mut shadowed = 0;
    for v in &visible {
        let shaft = Shaft::new(&light, v).unwrap();
        if !scene.shaft_clear(&shaft) {
            shadowed += 1;
            assert!(fitted.query_point(v).is_some(), "{} outside", v.p);
        }
    }
    assert!(shadowed > 20, "{shadowed} shadowed receivers");
    let far = Vec3::new(1.5, 0.0, 1.5);
    let far = ShadingPoint { p: far, p_error: point_error(far), n_geom: Vec3::Y, n_shading: Vec3::Y };
    assert!(fitted.query_point(&far).is_none());
    assert!(all_lit.query_point(&far).is_some());
}

/// With nothing that may shadow anything in view, `fit_shadowed` fits the same map as
/// fitting to every lit receiver.
#[test]
fn with_no_shadow_in_view_the_fit_is_the_lit_receivers_fit() {
    let (scene, light, visible) = floor_scene(false, 50, [-3.0, -2.0]);
    let (all_lit, fitted) = both_fits(&scene, &light, &visible);
    assert_eq!((fitted.origin, fitted.pitch), (all_lit.origin, all_lit.pitch));
    assert!(fitted.query_point(&visible[0]).is_some());
}
