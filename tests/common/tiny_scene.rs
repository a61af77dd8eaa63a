//! Tiny scene files for the tests: a floor, a floating card and a box under a square light
//! (the bench and registry tests); a floor and a card under a light, with the test's own
//! `[shadows]` table ([`card_scene!`]: the command line's tests). Included with `#[path]` by
//! the test files that use them.

#![allow(dead_code)] // each test file uses its own subset

/// The scene file's text.
pub const TINY_SCENE: &str = r#"
[camera]
position = [0.0, 2.5, 2.5]
look_at = [0.0, 0.0, 0.0]
yfov_deg = 45.0
[image]
width = 64
height = 48
[[light]]
center = [0.6, 2.0, 0.4]
u = [0.5, 0.0, 0.0]
v = [0.0, 0.0, 0.5]
radiance = [8.0, 8.0, 8.0]
[[quad]]
center = [0.0, 0.0, 0.0]
u = [4.0, 0.0, 0.0]
v = [0.0, 0.0, -4.0]
color = [0.7, 0.7, 0.7]
[[quad]]
center = [-0.3, 0.6, 0.0]
u = [0.5, 0.0, 0.0]
v = [0.0, 0.0, -0.5]
color = [0.5, 0.5, 0.8]
[[quad]]
center = [0.5, 0.3, -0.4]
u = [0.3, 0.0, 0.0]
v = [0.0, 0.0, -0.3]
color = [0.8, 0.4, 0.3]
"#;

/// The card scene (camera, a 48 x 32 image, a 2 m floor, a 0.5 m card half a metre above it, a
/// 0.5 m light) with the scene file text `$shadows` appended, as a `&'static str`.
#[allow(unused_macros)] // each test file uses its own subset
macro_rules! card_scene {
    ($shadows:literal) => {
        concat!(
            r#"
[camera]
position = [0.0, 2.0, 3.0]
look_at = [0.0, 0.0, 0.0]

[image]
width = 48
height = 32

[[quad]]
center = [0.0, 0.0, 0.0]
u = [2.0, 0.0, 0.0]
v = [0.0, 0.0, -2.0]

[[quad]]
center = [0.0, 0.5, 0.0]
u = [0.5, 0.0, 0.0]
v = [0.0, 0.0, -0.5]

[[light]]
center = [0.2, 1.5, 0.1]
u = [0.5, 0.0, 0.0]
v = [0.0, 0.0, 0.5]
radiance = [4.0, 4.0, 4.0]

"#,
            $shadows
        )
    };
}
