//! Emissive surfaces that are not lights. A scene file that gives `[[light]]` lights the
//! scene with those rectangles alone: the models' emissive primitives are not made lights
//! (`load::emitter_lights` does that only without `[[light]]`), so their emission reaches the
//! camera and whatever bounce rays find of it (under glTF shading, one BRDF ray a point even
//! at `max_depth = 2`), and no shadow method samples it: grain at low `--spp`, and light a
//! user may not expect twice. Where a `[[light]]` lies over the surface (a scene file's light
//! placed on a model's lamp) the paths count its hits as the light's (`on_a_light` in
//! `integrator::gltf_path`); any other emissive material is named in one warning.

use crate::geometry::instances::{Placing, PrimitiveData};
use crate::load::scene_file::LightDesc;
use glam::{DMat4, DVec3};
use std::path::Path;

/// The scene file's lights (world space) and the emissive materials met off them.
#[derive(Debug, Default)]
pub struct UnlitEmitters {
    /// Centre, u and v of each `[[light]]`; empty when the models' emitters are the lights,
    /// or under diffuse shading (which shows no emission).
    lights: Vec<[DVec3; 3]>,
    /// `FILE: materials[i] ("name")`, each once, in the order met.
    off: Vec<String>,
}

impl UnlitEmitters {
    pub fn new(lights: &[LightDesc]) -> Self {
        let lights = lights.iter().map(|l| [l.center, l.u, l.v].map(DVec3::from)).collect();
        Self { lights, off: Vec::new() }
    }

    /// The key of `material` (of file `path`) while it is still to be checked: it emits,
    /// lights are given, and it has not been found off them yet.
    pub(super) fn pending(&self, material: &gltf::Material, path: &Path) -> Option<String> {
        let emits = material.emissive_factor().iter().any(|&e| e > 0.0)
            && material.emissive_strength().unwrap_or(1.0) > 0.0;
        if !emits || self.lights.is_empty() {
            return None;
        }
        let index = material.index().unwrap_or(0);
        let key = match material.name() {
            Some(name) => format!("{}: materials[{index}] (\"{name}\")", path.display()),
            None => format!("{}: materials[{index}]", path.display()),
        };
        (!self.off.contains(&key)).then_some(key)
    }

    /// Notes `key` when the world-space triangle `p` lies on no given light; whether it did.
    pub(super) fn check(&mut self, key: &str, p: &[DVec3; 3]) -> bool {
        let off = !self.lights.iter().any(|l| p.iter().all(|&v| on_rectangle(l, v)));
        if off {
            self.off.push(key.to_string());
        }
        off
    }

    /// Checks a placement kept unflattened: its triangles placed by `world`, until one is off.
    pub(super) fn check_kept(
        &mut self,
        data: &PrimitiveData,
        material: &gltf::Material,
        world: DMat4,
        path: &Path,
    ) {
        let Some(key) = self.pending(material, path) else { return };
        let placing = Placing::new(world);
        for &c in &data.corners {
            let p = placing.corners(c).map(|i| placing.position(data.positions[i as usize]));
            if self.check(&key, &p) {
                return;
            }
        }
    }

    /// One warning line per emissive material off every light.
    pub fn warnings(&self) -> impl Iterator<Item = String> + '_ {
        self.off.iter().map(|key| {
            format!(
                "{key} emits but is not a light, since the scene file gives [[light]]: no shadow \
                 method samples it, the camera and bounce rays see its emission (grain at low \
                 --spp); to light the scene with it, drop [[light]] (its rectangles become lights) \
                 or lay a [[light]] over it"
            )
        })
    }
}

/// Whether `p` lies on the rectangle (centre, u, v): within the tolerance the paths use to
/// tell a hit on a light (`RectLight::holds`), 1e-4 of its size off its plane or its edges.
fn on_rectangle([c, u, v]: &[DVec3; 3], p: DVec3) -> bool {
    let q = p - *c;
    let n = u.cross(*v).normalize_or_zero();
    let slack = 1e-4;
    q.dot(n).abs() <= slack * (u.length() + v.length())
        && (q.dot(*u) / u.length_squared()).abs() <= 0.5 + slack
        && (q.dot(*v) / v.length_squared()).abs() <= 0.5 + slack
}
