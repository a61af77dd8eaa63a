//! A tiny scene file for the bench and registry tests: a floor, a floating card and a box
//! under a square light. Included with `#[path]` by the test files that use it.

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
