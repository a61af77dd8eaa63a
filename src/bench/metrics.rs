//! Error metrics against the traced truth, over the pixels each light reaches. The kinds
//! are those of anchors.md section 4.2; the thresholds are the user's guide's (docs/guide.md, the edge-table
//! issue's), looser than anchors.md's 0.01 / 0.99, 0.05 and 0.95.

use glam::Vec3;
use serde::Serialize;

/// Truth strictly between these is penumbra.
pub const PENUMBRA: (f32, f32) = (0.02, 0.98);
/// A leak: truth below `PENUMBRA.0` and ours above this.
pub const LEAK_ABOVE: f32 = 0.1;
/// A false shadow: truth above `PENUMBRA.1` and ours below this.
pub const FALSE_SHADOW_BELOW: f32 = 0.9;

/// How far one frame is from the truth.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Errors {
    /// Visibility RMSE over the (pixel, light) pairs the light reaches.
    pub rmse: f64,
    /// The same over penumbra pixels (truth strictly inside `PENUMBRA`).
    pub penumbra_rmse: f64,
    /// 99th percentile and maximum of |error|.
    pub p99: f64,
    pub max: f64,
    /// Share of truly dark pixels (truth < 0.02) that come out above 0.1.
    pub leak_rate: f64,
    /// Share of truly lit pixels (truth > 0.98) that come out below 0.9.
    pub false_shadow_rate: f64,
    /// Mean signed error in the penumbra (< 0: too dark).
    pub penumbra_bias: f64,
    /// RMSE of the final linear image (every pixel and channel) over its mean.
    pub image_relative_rmse: f64,
    pub lit_pixels: usize,
    pub penumbra_pixels: usize,
    /// The denominators of the leak and false-shadow rates.
    pub dark_pixels: usize,
    pub bright_pixels: usize,
}

/// `reach[k][i] > 0` where light k reaches pixel i at all (from a `none` render);
/// visibilities and radiance as `renderer::Frame` holds them.
pub fn errors(
    reach: &[Vec<f32>],
    truth: &[Vec<f32>],
    ours: &[Vec<f32>],
    truth_radiance: &[Vec3],
    radiance: &[Vec3],
) -> Errors {
    let mut abs = Vec::new();
    let (mut se, mut pse, mut pbias, mut pn) = (0.0f64, 0.0f64, 0.0f64, 0usize);
    let (mut dark, mut leaks, mut bright, mut false_shadows) = (0usize, 0usize, 0usize, 0usize);
    for ((r, t), o) in reach.iter().zip(truth).zip(ours) {
        for ((&r, &t), &o) in r.iter().zip(t).zip(o) {
            if r <= 0.0 || t < 0.0 {
                continue; // the light does not reach it, or no surface
            }
            let d = (o - t) as f64;
            se += d * d;
            abs.push(d.abs());
            if t > PENUMBRA.0 && t < PENUMBRA.1 {
                pse += d * d;
                pbias += d;
                pn += 1;
            }
            if t < PENUMBRA.0 {
                dark += 1;
                leaks += (o > LEAK_ABOVE) as usize;
            }
            if t > PENUMBRA.1 {
                bright += 1;
                false_shadows += (o < FALSE_SHADOW_BELOW) as usize;
            }
        }
    }
    abs.sort_unstable_by(f64::total_cmp);
    let n = abs.len();
    // An empty set has no error, not a zero one: NaN, which the report shows as such.
    let rate = |a: usize, b: usize| if b == 0 { f64::NAN } else { a as f64 / b as f64 };
    let mean = |x: f64, b: usize| if b == 0 { f64::NAN } else { x / b as f64 };
    Errors {
        rmse: mean(se, n).sqrt(),
        penumbra_rmse: mean(pse, pn).sqrt(),
        p99: if n == 0 { f64::NAN } else { abs[(n - 1) * 99 / 100] },
        max: abs.last().copied().unwrap_or(f64::NAN),
        leak_rate: rate(leaks, dark),
        false_shadow_rate: rate(false_shadows, bright),
        penumbra_bias: mean(pbias, pn),
        image_relative_rmse: image_relative_rmse(truth_radiance, radiance),
        lit_pixels: n,
        penumbra_pixels: pn,
        dark_pixels: dark,
        bright_pixels: bright,
    }
}

/// sqrt(mean((ours - truth)^2)) / mean(truth) over every pixel and channel (0 for a black
/// truth).
pub fn image_relative_rmse(truth: &[Vec3], ours: &[Vec3]) -> f64 {
    let (mut se, mut sum, mut n) = (0.0f64, 0.0f64, 0usize);
    for (t, o) in truth.iter().zip(ours) {
        for c in 0..3 {
            let d = (o[c] - t[c]) as f64;
            se += d * d;
            sum += t[c] as f64;
            n += 1;
        }
    }
    if n == 0 || sum <= 0.0 { 0.0 } else { (se / n as f64).sqrt() / (sum / n as f64) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_match_hand_computed_values() {
        // Six pixels the light reaches (one it does not, one miss): a lit pixel read as
        // shadowed, a dark one leaking, two penumbra pixels off by +0.1 and -0.3, two exact.
        let reach = vec![vec![1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0, -1.0]];
        let truth = vec![vec![1.0, 0.0, 0.5, 0.5, 1.0, 0.0, 0.0, -1.0]];
        let ours = vec![vec![0.5, 0.2, 0.6, 0.2, 1.0, 0.0, 0.7, -1.0]];
        let e = errors(&reach, &truth, &ours, &[], &[]);
        let sq = 0.25f64 + 0.04 + 0.01 + 0.09;
        assert!((e.rmse - (sq / 6.0).sqrt()).abs() < 1e-6, "{e:?}");
        assert!((e.penumbra_rmse - (0.1f64 / 2.0).sqrt()).abs() < 1e-6, "{e:?}");
        assert!((e.penumbra_bias - (-0.1)).abs() < 1e-6, "{e:?}");
        assert!((e.max - 0.5).abs() < 1e-6 && (e.p99 - 0.3).abs() < 1e-6, "{e:?}");
        assert_eq!((e.leak_rate, e.false_shadow_rate), (0.5, 0.5));
        assert_eq!((e.lit_pixels, e.penumbra_pixels, e.dark_pixels, e.bright_pixels), (6, 2, 2, 2));
        // Nothing lit: no error at all, not a perfect score.
        let none = errors(&[vec![0.0]], &[vec![1.0]], &[vec![0.0]], &[], &[]);
        assert!(none.rmse.is_nan() && none.leak_rate.is_nan() && none.lit_pixels == 0, "{none:?}");
    }

    #[test]
    fn image_error_is_relative_to_the_mean() {
        let truth = vec![Vec3::splat(2.0), Vec3::splat(2.0)];
        let ours = vec![Vec3::splat(2.2), Vec3::splat(1.8)];
        // RMSE 0.2 over a mean of 2.
        assert!((image_relative_rmse(&truth, &ours) - 0.1).abs() < 1e-6);
        assert_eq!(image_relative_rmse(&truth, &truth), 0.0);
    }
}
