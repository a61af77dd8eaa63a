//! How a depth map's heightfield is read: the one choice `march` (per ray), `depth_march`
//! and `edge_table` (per mask) share. On its own so that every one of them can name it
//! without naming the others.

use serde::{Deserialize, Serialize};

/// How a single depth map's heightfield is read (technical note, section 5.5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Heightfield {
    /// Variant A: everything behind the first surface seen from the light's centre is solid.
    /// Points in that hard shadow are fully blocked, so the inner penumbra becomes umbra.
    Solid,
    /// Variant B: floors and front-facing walls only; occluders are shells at their
    /// light-facing surfaces, so rays may leave from under a thin occluder sideways.
    /// Identical to `Solid` for points in front of their own floor.
    Shells,
    /// Floors only: every depth-map pixel is a thin plate at its depth, with nothing under
    /// it. Floating thin occluders get their outer penumbra right (no walls hang from their
    /// edges); thick occluders leak where a ray passes under their top and out of a side.
    Plates,
}

impl Heightfield {
    /// The name the scene file spells.
    pub fn as_str(self) -> &'static str {
        match self {
            Heightfield::Solid => "solid",
            Heightfield::Shells => "shells",
            Heightfield::Plates => "plates",
        }
    }
}

/// Why `key` has no effect with this reading: `slab_thickness` means something only to
/// `plates`.
pub fn inapplicable_to_reading(key: &str, heightfield: Heightfield) -> Option<String> {
    (key == "slab_thickness" && heightfield != Heightfield::Plates)
        .then(|| format!("applies only to heightfield = \"plates\", not \"{}\"", heightfield.as_str()))
}
