//! A glossy lobe over the exact visible region ([`renderer::interface::lobe`]): the same
//! boundary pieces, Lambert's terms taken in the lobe's clamped-cosine space (Linearly
//! Transformed Cosines: Lambert's formula on the mapped corners integrates the fit), over
//! the region clipped to the fit's own horizon. That horizon is a straight line on the
//! light's plane, so the clip is exact: pieces cut where they cross it, closed along it
//! between each exit and the next entry.

use super::arrangement::MAX_DOMAIN;
use super::lambert::{LightPlane, clip_polygon};
use glam::{DVec2, DVec3};
use renderer::interface::lobe::GlossyLobe;

/// The light's plane in a lobe's clamped-cosine space.
#[derive(Debug, Clone, Copy)]
pub(super) struct LobePlane {
    pub plane: LightPlane,
}

impl LobePlane {
    pub fn new(plane: &LightPlane, lobe: &GlossyLobe) -> Self {
        Self { plane: plane.transformed(lobe.world_to_cosine()) }
    }

    /// The height of light point `q` over the fit's horizon (z in its space): the lobe is 0
    /// where it is negative.
    #[inline]
    pub fn height(&self, q: DVec2) -> f64 {
        self.plane.height(DVec3::Z, q)
    }

    /// The convex polygon `corners` clipped to the fit's horizon, into `out`; the count.
    pub fn clip(&self, corners: &[DVec2], out: &mut [DVec2; MAX_DOMAIN]) -> usize {
        clip_polygon(corners, |q| self.height(q), out)
    }

    /// Lambert's sum in the lobe's space round the convex polygon `corners` above the fit's
    /// horizon: None where nothing of it is above.
    pub fn convex_sum(&self, corners: &[DVec2]) -> Option<f64> {
        let mut out = [DVec2::ZERO; MAX_DOMAIN];
        let m = self.clip(corners, &mut out);
        (m >= 3).then(|| self.plane.polygon_sum(&out[..m]))
    }

    /// The x range of row `y` (light coordinates) above the fit's horizon.
    pub fn row_range(&self, y: f64) -> (f64, f64) {
        // height = h0 + x hx along the row.
        let h0 = self.height(DVec2::new(0.0, y));
        let hx = self.height(DVec2::new(1.0, y)) - h0;
        if hx > 0.0 {
            (-h0 / hx, f64::INFINITY)
        } else if hx < 0.0 {
            (f64::NEG_INFINITY, -h0 / hx)
        } else if h0 >= 0.0 {
            (f64::NEG_INFINITY, f64::INFINITY)
        } else {
            (0.0, 0.0)
        }
    }
}

/// Where a boundary piece crosses the fit's horizon: its place along the line, the point,
/// and whether the piece leaves the kept side there.
#[derive(Debug, Clone, Copy)]
pub(super) struct Crossing {
    s: f64,
    q: DVec2,
    exit: bool,
}

/// Lambert's sum, in the lobe's space, round a region given piece by piece (each with the
/// region on its left) and clipped to the fit's horizon.
pub(super) struct ClippedSum<'a> {
    lobe: &'a LobePlane,
    crossings: &'a mut Vec<Crossing>,
    /// Along the horizon, with the kept side on its left (closing pieces run this way).
    along: DVec2,
    sum: f64,
}

impl<'a> ClippedSum<'a> {
    pub fn new(lobe: &'a LobePlane, crossings: &'a mut Vec<Crossing>) -> Self {
        crossings.clear();
        let h0 = lobe.height(DVec2::ZERO);
        let grad = DVec2::new(lobe.height(DVec2::X) - h0, lobe.height(DVec2::Y) - h0);
        ClippedSum { lobe, crossings, along: DVec2::new(grad.y, -grad.x), sum: 0.0 }
    }

    /// The piece a -> b: its part on the kept side summed, a crossing remembered. The kept
    /// side holds its line (h >= 0), as [`clip_polygon`] keeps it, so that pieces sharing an
    /// end agree on it.
    #[inline]
    pub fn piece(&mut self, a: DVec2, b: DVec2) {
        let (ha, hb) = (self.lobe.height(a), self.lobe.height(b));
        let (ka, kb) = (ha >= 0.0, hb >= 0.0);
        if ka && kb {
            self.sum += self.lobe.plane.edge_term(a, b);
            return;
        }
        if !ka && !kb {
            return;
        }
        let t = ha / (ha - hb);
        let q = if t <= 0.0 {
            a
        } else if t >= 1.0 {
            b
        } else {
            a + t * (b - a)
        };
        if ka {
            self.sum += self.lobe.plane.edge_term(a, q);
        } else {
            self.sum += self.lobe.plane.edge_term(q, b);
        }
        self.crossings.push(Crossing { s: self.along.dot(q), q, exit: ka });
    }

    /// The sum with the region's closing pieces along the horizon: sorted along it, the
    /// crossings pair up (an exit, then an entry) and each pair's span is inside the region.
    /// None where they do not pair (a region that is not closed).
    pub fn finish(self) -> Option<f64> {
        let ClippedSum { lobe, crossings, mut sum, .. } = self;
        // Exits first where two meet at one place (a corner touching the line from under it).
        crossings.sort_unstable_by(|x, y| x.s.total_cmp(&y.s).then(y.exit.cmp(&x.exit)));
        if crossings.len() % 2 != 0 {
            return None;
        }
        for pair in crossings.chunks_exact(2) {
            let (first, second) = (pair[0], pair[1]);
            if first.exit == second.exit {
                return None;
            }
            let (exit, entry) = if first.exit { (first, second) } else { (second, first) };
            sum += lobe.plane.edge_term(exit.q, entry.q);
        }
        Some(sum)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use renderer::RectLight;

    /// A lobe plane whose horizon is the line b = 1/2 of light coordinates: the identity map
    /// with the light 2 over the point, its v axis along z, so that z' = 0 cuts it halfway.
    /// A region's clipped sum is then the sum of its part with b >= 1/2, done by hand.
    #[test]
    fn a_clipped_region_sums_as_its_clipped_polygon() {
        let light = RectLight::new(Vec3::new(0.0, 2.0, 0.0), Vec3::X, Vec3::Z, Vec3::ONE);
        let base = LightPlane::new(&light, DVec3::ZERO, DVec3::Y);
        let lobe = LobePlane { plane: base.transformed(glam::DMat3::IDENTITY) };
        let square = [DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0), DVec2::new(1.0, 1.0), DVec2::new(0.0, 1.0)];
        let expected = lobe.convex_sum(&square).expect("half the light is above");
        // And an L-shaped region (the square less its upper-right quarter), counter-clockwise,
        // crossing the horizon twice, against its clip done by hand (two convex pieces).
        let l_shape = [
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, 0.5),
            DVec2::new(0.5, 0.5),
            DVec2::new(0.5, 1.0),
            DVec2::new(0.0, 1.0),
        ];
        let mut crossings = Vec::new();
        for region in [&square[..], &l_shape[..]] {
            let mut sum = ClippedSum::new(&lobe, &mut crossings);
            for k in 0..region.len() {
                sum.piece(region[k], region[(k + 1) % region.len()]);
            }
            let got = sum.finish().expect("closed");
            // The square keeps its upper half; the L keeps its upper-left quarter.
            let want = if region.len() == 4 {
                expected
            } else {
                lobe.plane.polygon_sum(&[
                    DVec2::new(0.0, 0.5),
                    DVec2::new(0.5, 0.5),
                    DVec2::new(0.5, 1.0),
                    DVec2::new(0.0, 1.0),
                ])
            };
            let half = lobe.plane.polygon_sum(&[
                DVec2::new(0.0, 0.5),
                DVec2::new(1.0, 0.5),
                DVec2::new(1.0, 1.0),
                DVec2::new(0.0, 1.0),
            ]);
            assert!((expected - half).abs() <= 1e-12 * half.abs(), "{expected} vs {half}");
            assert!((got - want).abs() <= 1e-12 * want.abs().max(1e-300), "{got} vs {want}");
            assert!(got.abs() > 0.0);
        }
    }
}
