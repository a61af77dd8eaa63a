//! What a frame's warnings are made of: sums (and one maximum) over the pixels shaded, so
//! that the tiles of a frame, each tallying its own rows, merge to the whole frame's tally
//! and so to its warnings, line for line.

use crate::geometry::precision::{SHAPE_PRECISION, f32_spacing};
use crate::geometry::scene::{Scene, SurfaceHit};
use serde::{Deserialize, Serialize};

/// The counts behind a frame's warnings, over the rows it shaded.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameTally {
    /// Primary samples that hit something.
    pub visible: u64,
    /// Per light: shading points with non-zero irradiance from it.
    pub facing: Vec<u64>,
    /// Per light: shading points with non-zero irradiance and visibility.
    pub lit: Vec<u64>,
    /// Only when the scene holds triangles f32 cannot keep precise: how precise the visible
    /// part is.
    pub precision: Option<VisiblePrecision>,
}

/// How far the visible part lies from the camera, and how much of it f32 cannot keep
/// precise.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct VisiblePrecision {
    /// The farthest visible point's distance from the camera (m).
    pub farthest_m: f64,
    /// Visible points on triangles smaller than SHAPE_PRECISION f32 spacings there.
    pub imprecise: u64,
}

impl FrameTally {
    /// The part of the tally read off the primary hits (`facing` and `lit` come from shading).
    pub fn of_hits(scene: &Scene, hits: &[Option<SurfaceHit>]) -> Self {
        let visible = hits.iter().flatten().count() as u64;
        let precision = (scene.stats.imprecise_triangles > 0).then(|| {
            // The camera is the render-space origin: |p| is the distance from it.
            let mut p = VisiblePrecision::default();
            for hit in hits.iter().flatten() {
                let d = hit.point.p.as_dvec3().length();
                p.farthest_m = p.farthest_m.max(d);
                let t = &scene.hit_triangle(hit);
                let size =
                    [t.v1 - t.v0, t.v2 - t.v1, t.v0 - t.v2].iter().map(|e| e.length()).fold(0.0, f32::max);
                p.imprecise += u64::from(f32_spacing(d) > size as f64 / SHAPE_PRECISION);
            }
            p
        });
        FrameTally { visible, facing: Vec::new(), lit: Vec::new(), precision }
    }

    /// Adds `other` (another tile of the same frame) to this tally.
    pub fn add(&mut self, other: &FrameTally) {
        self.visible += other.visible;
        for (mine, theirs) in [(&mut self.facing, &other.facing), (&mut self.lit, &other.lit)] {
            if mine.len() < theirs.len() {
                mine.resize(theirs.len(), 0);
            }
            mine.iter_mut().zip(theirs).for_each(|(a, b)| *a += b);
        }
        self.precision = match (self.precision, other.precision) {
            (Some(a), Some(b)) => Some(VisiblePrecision {
                farthest_m: a.farthest_m.max(b.farthest_m),
                imprecise: a.imprecise + b.imprecise,
            }),
            (a, b) => a.or(b),
        };
    }

    /// The frame's warnings, one line each: no primary ray hits anything; light k reaches
    /// no visible point; no light reaches any; and how precise the visible part is.
    pub fn warnings(&self) -> Vec<String> {
        let mut warnings = Vec::new();
        let visible = self.visible;
        if visible == 0 {
            warnings.push(
                "the camera sees nothing: no primary ray hits any geometry (the image is black)".into(),
            );
            return warnings;
        }
        for (k, (&f, &l)) in self.facing.iter().zip(&self.lit).enumerate() {
            if f == 0 {
                warnings.push(format!(
                    "light {k} reaches no visible point: every point the camera sees is behind its \
                     emitting side or below the light's horizon"
                ));
            } else if l == 0 {
                warnings.push(format!(
                    "light {k} reaches no visible point: {f} visible point(s) face it, all fully shadowed"
                ));
            }
        }
        if !self.lit.is_empty() && self.lit.iter().all(|&l| l == 0) {
            warnings.push(format!(
                "the camera sees nothing lit: none of {visible} visible point(s) receives light (the image \
                 is black)"
            ));
        }
        if let Some(VisiblePrecision { farthest_m: far, imprecise }) = self.precision {
            warnings.push(format!(
                "the visible part lies within {far:.3e} m of the camera, where f32 positions are spaced \
                 {:.3e} m; {imprecise} of {visible} visible point(s) lie on triangles f32 cannot keep precise",
                f32_spacing(far)
            ));
        }
        warnings
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_add_up_to_the_frames_tally_and_warnings() {
        let a = FrameTally {
            visible: 3,
            facing: vec![2, 0],
            lit: vec![0, 0],
            precision: Some(VisiblePrecision { farthest_m: 5.0, imprecise: 1 }),
        };
        let b = FrameTally {
            visible: 4,
            facing: vec![1, 0],
            lit: vec![1, 0],
            precision: Some(VisiblePrecision { farthest_m: 2.0, imprecise: 2 }),
        };
        let mut sum = FrameTally::default();
        sum.add(&a);
        sum.add(&b);
        let whole = FrameTally {
            visible: 7,
            facing: vec![3, 0],
            lit: vec![1, 0],
            precision: Some(VisiblePrecision { farthest_m: 5.0, imprecise: 3 }),
        };
        assert_eq!(sum, whole);
        // Tile a alone would say light 0 lights nothing; the frame says only light 1 does not.
        assert!(a.warnings().iter().any(|w| w.starts_with("light 0")));
        let w = sum.warnings();
        assert_eq!(w.len(), 2, "{w:?}");
        assert!(w[0].starts_with("light 1 reaches no visible point: every point"));
        assert!(w[1].contains("3 of 7 visible point(s)"), "{}", w[1]);
        // An empty tile (sky) adds nothing and says nothing once merged.
        sum.add(&FrameTally::default());
        assert_eq!(sum, whole);
    }
}
