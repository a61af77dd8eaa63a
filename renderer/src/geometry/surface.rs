//! What a hit's material gives there ([`Surface`]): base colour (x COLOR_0 x texture),
//! alpha, metallic, roughness, emission and the shading normal, read from the material's
//! factors and textures at the hit's texture coordinates; and the normal mapping that bends
//! a hit's shading normal as it is made ([`Scene::mapped_normal`]).
//!
//! Normal mapping follows the glTF spec: the texel's RGB (linear) as `2 c - 1`, x and y
//! scaled by `normalTexture.scale`, in the frame of the interpolated tangent T (made
//! orthogonal to the interpolated normal N), B = w (N x T) and N:
//! `normalize(T x + B y + N z)`. It is applied where the hit is made, only in
//! [`Shading::Gltf`], so the horizon of every shadow method, the light's irradiance and the
//! bounces all see the bent normal, and [`Shading::Diffuse`] gives the hits of before.

use crate::geometry::attributes::CornerExtras;
use crate::geometry::material::{Shading, TextureRef};
use crate::geometry::scene::{Scene, SurfaceHit};
use glam::{DVec3, Vec2, Vec3, Vec4};
use obvhs::triangle::Triangle;

/// The material at a hit, as the glTF metallic-roughness model defines it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Surface {
    /// Linear RGB: baseColorFactor x the sRGB base colour texture x COLOR_0.
    pub base_color: Vec3,
    /// The base colour's alpha (factor x texture x COLOR_0).
    pub alpha: f32,
    /// In [0, 1]: the factor x the metallic-roughness texture's B.
    pub metallic: f32,
    /// In [0, 1]: the factor x the metallic-roughness texture's G.
    pub roughness: f32,
    /// The hit's shading normal ([`crate::ShadingPoint::n_shading`]): normal-mapped in
    /// [`Shading::Gltf`], on the incoming ray's side by its own plane.
    pub n_shading: Vec3,
    /// Emitted radiance: emissiveFactor x emissive strength x the sRGB emissive texture.
    pub emission: Vec3,
}

/// Barycentric interpolation of three corner values at (b1, b2), the weights of corners 1
/// and 2 (the intersector's convention).
#[inline]
pub fn interpolate<T>(v: [T; 3], b1: f32, b2: f32) -> T
where
    T: std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T> + Copy,
{
    v[0] * (1.0 - b1 - b2) + v[1] * b1 + v[2] * b2
}

/// `n` (unit, world) bent by a normal texture's `texel` (linear RGB) in the tangent frame of
/// `tangent` (interpolated: xyz, and w's sign the bitangent's), the texel's x and y scaled by
/// `scale`. `n` itself where the frame is degenerate (a zero normal, a tangent along it).
pub fn perturb(n: Vec3, tangent: Vec4, texel: Vec4, scale: f32) -> Vec3 {
    // Gram-Schmidt: interpolation leaves T off N's plane, and a frame that is not
    // orthonormal would scale the texel's components unevenly.
    if n == Vec3::ZERO {
        return n;
    }
    let t = tangent.truncate();
    let Some(t) = (t - n * n.dot(t)).try_normalize() else { return n };
    let b = n.cross(t) * if tangent.w < 0.0 { -1.0 } else { 1.0 };
    let c = texel.truncate() * 2.0 - Vec3::ONE;
    (t * (c.x * scale) + b * (c.y * scale) + n * c.z).try_normalize().unwrap_or(n)
}

/// The barycentrics (b1, b2) of `p` in `tri` (render space), in f64: `p` is the hit's point,
/// interpolated from these corners, so this recovers the intersector's weights to f32's
/// rounding of `p`. (0, 0) for a triangle without area.
pub fn barycentrics(tri: &Triangle, p: Vec3) -> (f32, f32) {
    let v0 = Vec3::from(tri.v0).as_dvec3();
    let (e1, e2) = (Vec3::from(tri.v1).as_dvec3() - v0, Vec3::from(tri.v2).as_dvec3() - v0);
    let d: DVec3 = p.as_dvec3() - v0;
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let den = d11 * d22 - d12 * d12;
    if den.is_nan() || den <= 0.0 {
        return (0.0, 0.0);
    }
    let (d1, d2) = (d.dot(e1), d.dot(e2));
    (((d22 * d1 - d12 * d2) / den) as f32, ((d11 * d2 - d12 * d1) / den) as f32)
}

/// A hit's texture coordinates for either set its material's textures read.
struct HitUvs {
    base_set: u32,
    base: Vec2,
    /// The second set ([`Material::second_uv_set`]); zero where the primitive lacks it.
    second: Vec2,
}

impl HitUvs {
    fn of(&self, t: &TextureRef) -> Vec2 {
        if t.tex_coord == self.base_set { self.base } else { self.second }
    }
}

impl Scene {
    /// The material at `hit` ([`Surface`]). In [`Shading::Diffuse`] the surface the renderer
    /// shades (a two-sided Lambertian of today's albedo, factor x texture: metallic 0,
    /// roughness 1, no COLOR_0, the unmapped normal; emission without its texture, which
    /// that shading does not load), so that a BRDF reading it keeps that mode's bytes.
    pub fn surface(&self, hit: &SurfaceHit) -> Surface {
        let m = &self.materials[hit.material as usize];
        let base = m.base_color_at(hit.uv, &self.textures);
        let extras = self.hit_extras(hit);
        let (b1, b2) =
            if extras.is_empty() { (0.0, 0.0) } else { barycentrics(&self.hit_triangle(hit), hit.point.p) };
        let uvs = HitUvs {
            base_set: m.base_uv_set(),
            base: hit.uv,
            second: extras.uv2.map_or(Vec2::ZERO, |uv| interpolate(uv, b1, b2)),
        };
        let emission = m.emission
            * m.emissive_texture.map_or(Vec3::ONE, |t| t.color(uvs.of(&t), &self.textures).truncate());
        if self.shading_mode == Shading::Diffuse {
            let n_shading = hit.point.n_shading;
            return Surface {
                base_color: base.truncate(),
                alpha: base.w,
                metallic: 0.0,
                roughness: 1.0,
                n_shading,
                emission,
            };
        }
        let base = base * extras.color.map_or(Vec4::ONE, |c| interpolate(c, b1, b2));
        let (metallic, roughness) = match m.metallic_roughness_texture {
            Some(t) => {
                let c = t.data(uvs.of(&t), &self.textures);
                (m.metallic * c.z, m.roughness * c.y)
            }
            None => (m.metallic, m.roughness),
        };
        Surface {
            base_color: base.truncate(),
            alpha: base.w,
            metallic,
            roughness,
            n_shading: hit.point.n_shading,
            emission,
        }
    }

    /// The extra attributes of the triangle `hit` lies on.
    pub fn hit_extras(&self, hit: &SurfaceHit) -> CornerExtras {
        match (hit.kept, &self.instanced) {
            (Some(p), Some(inst)) => {
                let placed = &inst.placed[p as usize];
                inst.extras(placed, &inst.triangle(placed, hit.triangle as usize))
            }
            _ => self.extras.get(hit.triangle as usize),
        }
    }

    /// The shading normal at a hit of material `material` at barycentrics (b1, b2): `n` (the
    /// interpolated vertex normal, unit, the file's side) bent by the material's normal
    /// texture at `uv` (the base set's coordinates) in the frame of the corners' tangents
    /// (`extras`, asked only when the material has a normal texture). `n` itself in
    /// [`Shading::Diffuse`], without a normal texture, or without tangents.
    #[inline]
    pub(crate) fn mapped_normal(
        &self,
        material: u32,
        n: Vec3,
        (uv, b1, b2): (Vec2, f32, f32),
        extras: impl FnOnce() -> CornerExtras,
    ) -> Vec3 {
        let m = &self.materials[material as usize];
        let Some(nt) = m.normal_texture.filter(|_| self.normal_maps) else { return n };
        let extras = extras();
        let Some(tangents) = extras.tangent else { return n };
        let uv = if nt.texture.tex_coord == m.base_uv_set() {
            uv
        } else {
            extras.uv2.map_or(Vec2::ZERO, |uv| interpolate(uv, b1, b2))
        };
        let texel = nt.texture.data(uv, &self.textures);
        perturb(n, interpolate(tangents, b1, b2), texel, nt.scale)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A texel encoding (sin a, 0, cos a) tilts the normal by a toward the tangent; one
    /// encoding (0, sin a, cos a) toward the bitangent N x T (w = 1) or its opposite (w = -1).
    /// The truth: the angle of the decoded texel's own vector, from its bytes in f64.
    #[test]
    fn a_texel_tilts_the_normal_by_its_own_angle() {
        let (n, t) = (Vec3::Z, Vec4::new(1.0, 0.0, 0.0, 1.0));
        for deg in [0.0f64, 5.0, 20.0, 45.0, 70.0] {
            let a = deg.to_radians();
            let code = |c: f64| ((c + 1.0) * 0.5 * 255.0).round() as u8;
            let bytes = [code(a.sin()), code(0.0), code(a.cos())];
            let decoded = bytes.map(|b| 2.0 * b as f64 / 255.0 - 1.0);
            let want = decoded[0].atan2(decoded[2]);
            let texel =
                Vec4::new(bytes[0] as f32 / 255.0, bytes[1] as f32 / 255.0, bytes[2] as f32 / 255.0, 1.0);
            let m = perturb(n, t, texel, 1.0).as_dvec3();
            assert!(((m.x.atan2(m.z)) - want).abs() < 1e-6 && m.y.abs() < 0.01, "{deg}: {m}");
            // The same texel with y and x swapped tilts toward +-B.
            let swapped = Vec4::new(texel.y, texel.x, texel.z, 1.0);
            for w in [1.0, -1.0] {
                let m = perturb(n, Vec4::new(1.0, 0.0, 0.0, w), swapped, 1.0).as_dvec3();
                assert!((m.y.atan2(m.z) - w as f64 * want).abs() < 1e-6, "{deg}, w {w}: {m}");
            }
        }
    }

    #[test]
    fn scale_scales_the_tilt_and_a_degenerate_frame_keeps_the_normal() {
        // Codes (255, 128, 255): (1, 1/255, 1) decoded; x and y scaled by 0.5, z not.
        let texel = Vec4::new(1.0, 128.0 / 255.0, 1.0, 1.0);
        let m = perturb(Vec3::Z, Vec4::X.with_w(1.0), texel, 0.5);
        let c = 2.0 * 128.0 / 255.0 - 1.0;
        let want = Vec3::new(0.5, c * 0.5, 1.0).normalize();
        assert!((m - want).length() < 1e-6, "{m} against {want}");
        assert_eq!(perturb(Vec3::Z, Vec4::new(0.0, 0.0, 3.0, 1.0), texel, 1.0), Vec3::Z);
        assert_eq!(perturb(Vec3::ZERO, Vec4::X, texel, 1.0), Vec3::ZERO);
    }

    #[test]
    fn barycentrics_recover_the_interpolation_weights() {
        let tri = Triangle {
            v0: glam::Vec3A::new(1.0, 2.0, 3.0),
            v1: glam::Vec3A::new(4.0, 2.5, 3.0),
            v2: glam::Vec3A::new(1.5, 6.0, 2.0),
        };
        for (b1, b2) in [(0.0, 0.0), (0.25, 0.5), (1.0, 0.0), (0.1, 0.85)] {
            let p = interpolate([tri.v0, tri.v1, tri.v2].map(Vec3::from), b1, b2);
            let (c1, c2) = barycentrics(&tri, p);
            assert!((c1 - b1).abs() < 1e-6 && (c2 - b2).abs() < 1e-6, "({b1}, {b2}) -> ({c1}, {c2})");
        }
    }
}
