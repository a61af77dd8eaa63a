//! `traced`'s light samples, a service of the renderer's: per light a [`SampleStream`], and
//! per shading point its [`PointSamples`] (the strata, the jitter from the point's seed, the
//! horizon warp and the shafts proven clear, drawn in one order), with the rays that test
//! them. `traced` traces them all; methods that must agree with it sample by sample
//! (`silhouette`) draw the same and trace what they cannot settle.

use crate::geometry::horizon_warp::{HorizonPart, HorizonWarp};
use crate::geometry::irradiance_strata::{Columns, IrradianceStrata};
use crate::geometry::light::RectLight;
use crate::geometry::ray_origin::offset_origin;
use crate::geometry::scene::Scene;
use crate::geometry::shaft;
use crate::interface::lobe::{GlossyLobe, LobeTally};
use crate::interface::shadowing::ShadowQuery;
use crate::methods::irradiance_share::{IrradianceShare, ShareTally};
use crate::util::random::{Rng, strata};
use glam::Vec3;
use std::cell::OnceCell;
use std::sync::atomic::{AtomicU64, Ordering};

/// Which shafts prove samples unblocked before any ray.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Culling {
    Off,
    /// The whole light's shaft only: a point it proves clear costs one test (methods with
    /// their own per-sample answer, where parts of the light proven clear save little).
    WholeLight,
    /// The whole light, then its parts down to [`shaft::LEAVES`] per axis (`traced`).
    Leaves,
}

/// Most light samples per shading point `traced` takes ([`SampleStream::prepare`] refuses more).
pub const MAX_TRACED_SAMPLES: u32 = 65536;

/// The most samples in a row of strata: nx is at most the square root of
/// [`MAX_TRACED_SAMPLES`].
const MAX_ROW: usize = 256;
const _: () = assert!(MAX_ROW * MAX_ROW >= MAX_TRACED_SAMPLES as usize);

/// The light samples of one light, `samples` per shading point: prepared with the light,
/// then asked for each point's ([`SampleStream::point`]). Counts the shafts its culling tests.
#[derive(Debug)]
pub struct SampleStream {
    samples: u32,
    light: Option<RectLight>,
    /// Shafts tested, and those found clear.
    shafts: AtomicU64,
    shafts_clear: AtomicU64,
}

impl SampleStream {
    /// A stream of `samples` per point, for a light still to come ([`SampleStream::prepare`]).
    pub fn new(samples: u32) -> Self {
        Self { samples, light: None, shafts: AtomicU64::new(0), shafts_clear: AtomicU64::new(0) }
    }

    /// Takes the light, or says why the sample count cannot be drawn.
    pub fn prepare(&mut self, light: RectLight) -> Result<(), String> {
        if self.samples == 0 {
            return Err("samples must be >= 1".into());
        }
        // A row of strata holds at most sqrt(MAX_TRACED_SAMPLES) samples (the row buffer
        // is that long).
        if self.samples > MAX_TRACED_SAMPLES {
            return Err(format!("samples must be <= {MAX_TRACED_SAMPLES}, not {}", self.samples));
        }
        self.light = Some(light);
        Ok(())
    }

    /// The prepared light, if any.
    pub fn light(&self) -> Option<&RectLight> {
        self.light.as_ref()
    }

    /// The samples of `q` with shafts tested as `culling` says, or `Err` with the answer when
    /// the whole light is proven clear.
    pub fn point<'a>(
        &self,
        scene: &Scene,
        q: &'a ShadowQuery,
        culling: Culling,
    ) -> Result<PointSamples<'a>, f32> {
        let light = self.light.expect("prepare() runs before visibility()");
        let samples = PointSamples::new(scene, light, q, self.samples, culling)?;
        let (tests, clear) = samples.shaft_tests();
        self.shafts.fetch_add(tests as u64, Ordering::Relaxed);
        self.shafts_clear.fetch_add(clear as u64, Ordering::Relaxed);
        Ok(samples)
    }

    /// The shafts tested and those found clear, as the run report names them.
    pub fn shaft_counters(&self) -> [(&'static str, u64); 2] {
        [
            ("shafts", self.shafts.load(Ordering::Relaxed)),
            ("shafts_clear", self.shafts_clear.load(Ordering::Relaxed)),
        ]
    }
}

/// A placeholder for [`PointSamples::for_each`]'s row buffer.
const EMPTY_SAMPLE: LightSample =
    LightSample { a: 0.0, b: 0.0, target: Vec3::ZERO, height: 0.0, proven: false, stratum: 0, scale: 0.0 };

/// One light sample of a shading point, as `traced` draws it.
#[derive(Debug, Clone, Copy)]
pub struct LightSample {
    /// Rectangle coordinates ([`RectLight::point`]); a warped sample may stray a rounding
    /// outside [0, 1].
    pub a: f32,
    pub b: f32,
    /// `light.point(a, b)`.
    pub target: Vec3,
    /// `n_geom . (target - p)`: negative for a target under the geometric tangent plane
    /// (its ray starts from the other side's origin).
    pub height: f32,
    /// Inside a clear shaft: proven unblocked without tracing.
    pub proven: bool,
    /// The stratum, `i + nx j` of the `nx` x `ny` grid ([`PointSamples::strata`]).
    pub stratum: u32,
    /// The stratum's area over the plain grid's (1 / N of the light, or of the warped part):
    /// other than 1 where the strata follow g ([`IrradianceStrata`]). The sample's weight is
    /// g times this.
    pub scale: f32,
}

/// The samples of one shading point, ready to be drawn ([`PointSamples::for_each`]).
#[derive(Debug)]
pub struct PointSamples<'a> {
    light: RectLight,
    q: &'a ShadowQuery,
    strata: (u32, u32),
    warp: Option<HorizonWarp>,
    /// The whole light above the horizon: the strata may follow g.
    whole: bool,
    /// Strata in proportion to g, where it varies over the light ([`PointSamples::by_g`]).
    by_g: OnceCell<Option<IrradianceStrata>>,
    clear: u64,
    shaft_tests: u32,
    /// The origin of every ray above the geometric tangent plane (the shafts' apex).
    pub origin: Vec3,
    cover: shaft::Cover,
    share: IrradianceShare,
}

impl<'a> PointSamples<'a> {
    /// The `samples` light samples of `q`, with shafts tested as `culling` says, or `Err`
    /// with the answer (1) when the whole light is proven clear.
    pub fn new(
        scene: &Scene,
        light: RectLight,
        q: &'a ShadowQuery,
        samples: u32,
        culling: Culling,
    ) -> Result<Self, f32> {
        let (nx, ny) = strata(samples);
        // Where the horizon cuts the light, the strata are warped onto the part above it
        // ([`crate::geometry::horizon_warp::HorizonWarp`]): every sample counts. The whole light
        // above, or too thin a part above, keeps the plain grid (and its fallback below).
        let point = &q.point;
        let (warp, whole) = match HorizonPart::new(&light, point) {
            HorizonPart::Clipped(w) => (Some(w), false),
            HorizonPart::Whole => (None, true),
            HorizonPart::Degenerate => (None, false),
        };
        // The origin every ray above the tangent plane starts from (the shafts' apex).
        let origin = offset_origin(point, point.n_geom);
        // Whether the strata follow g is decided when a sample is first drawn, unless the
        // shafts' leaves need their bounds now ([`PointSamples::by_g`]): a point answered
        // without drawing any (one ray, or every sample proven) never pays the test.
        let by_g = OnceCell::new();
        let follows_g = whole && culling == Culling::Leaves && IrradianceStrata::varies(&light, point);
        // Strata following g cost a table (~1 us): a point whose whole light is proven clear
        // answers 1 before it is built (the whole light's shaft is every grid's first test).
        let mut root_tests = 0;
        if follows_g {
            let (clear, tests) =
                shaft::clear_leaves_mapped(scene, &light, point, (nx, ny), false, |a, b| (a, b));
            if clear != 0 && shaft::covers_light(point, origin, &light) {
                return Err(1.0);
            }
            root_tests = tests;
        }
        if culling == Culling::Leaves {
            let _ = by_g.set(if follows_g { IrradianceStrata::new(&light, point) } else { None });
        }
        let (clear, shaft_tests) = if culling != Culling::Off {
            let subdivide = culling == Culling::Leaves;
            // Without subdividing, only the whole light is tested: the same for every grid.
            match (&warp, by_g.get().and_then(Option::as_ref)) {
                (None, None) => {
                    shaft::clear_leaves_mapped(scene, &light, point, (nx, ny), subdivide, |a, b| (a, b))
                }
                (None, Some(g)) => {
                    shaft::clear_leaves_mapped(scene, &light, point, (nx, ny), subdivide, |a, b| {
                        g.block_bounds(a, b)
                    })
                }
                // A leaf's samples lie in the image of its strata block: prove the shaft to
                // that image's bounding rectangle.
                (Some(w), _) => {
                    shaft::clear_leaves_mapped(scene, &light, point, (nx, ny), subdivide, |a, b| {
                        let (a, b) = w.bounds(a.map(f64::from), b.map(f64::from));
                        (a.map(|x| x as f32), b.map(|x| x as f32))
                    })
                }
            }
        } else {
            (0, 0)
        };
        let shaft_tests = shaft_tests + root_tests;
        // The whole light proven clear and wholly covered: every counted sample is unblocked,
        // so the answer is 1 without drawing them. Measured: drawing 1024 samples per such
        // point cost ~10 us, most of a clear point's time.
        if clear != 0 && clear == shaft::all_leaves((nx, ny)) && shaft::covers_light(point, origin, &light) {
            return Err(1.0);
        }
        // Per point, not per sample: the covered test's terms with the light's largest point
        // error (every sample's own bound is at most that: a stricter test, so it still
        // accepts only rays the shaft holds), and the ray origin on the lit side (the one
        // `offset_origin` gives every target with n_geom . (target - p) >= 0).
        let cover = shaft::Cover::new(point, origin, light.max_point_error());
        // The strata cover the warped part, or the whole rectangle (measure-preserving).
        let part = warp.as_ref().map_or(1.0, |w| w.area());
        let share = IrradianceShare::new(&light, q, part, nx * ny);
        Ok(PointSamples {
            light,
            q,
            strata: (nx, ny),
            warp,
            whole,
            by_g,
            clear,
            shaft_tests,
            origin,
            cover,
            share,
        })
    }

    /// The weights of these samples and the visibility they make ([`IrradianceShare`]).
    pub fn share(&self) -> &IrradianceShare {
        &self.share
    }

    /// `s`'s weight: g ([`IrradianceShare::weight`]) times its stratum's [`LightSample::scale`].
    #[inline]
    pub fn weight(&self, s: &LightSample) -> f64 {
        self.share.weight_at(s.a, s.b) * s.scale as f64
    }

    /// Shafts tested, and leaves found clear.
    pub fn shaft_tests(&self) -> (u32, u32) {
        (self.shaft_tests, self.clear.count_ones())
    }

    /// The strata grid (nx, ny): an unwarped sample of stratum (i, j) lies in
    /// [i / nx, (i + 1) / nx] x [j / ny, (j + 1) / ny].
    pub fn strata(&self) -> (u32, u32) {
        self.strata
    }

    /// Whether the strata are the plain grid: stratum (i, j)'s sample in
    /// [i / nx, (i + 1) / nx] x [j / ny, (j + 1) / ny]. Not where they are warped onto the part
    /// of the light above the horizon, or follow g ([`IrradianceStrata`]): then a sample may
    /// lie anywhere, whatever its stratum.
    pub fn plain_grid(&self) -> bool {
        self.warp.is_none() && self.by_g().is_none()
    }

    /// The strata in proportion to g, where the whole light is above the horizon and g
    /// varies over it ([`IrradianceStrata::new`]); decided once, on first use.
    pub fn by_g(&self) -> Option<&IrradianceStrata> {
        self.by_g
            .get_or_init(|| if self.whole { IrradianceStrata::new(&self.light, &self.q.point) } else { None })
            .as_ref()
    }

    /// Whether the strata are warped onto the part of the light above the horizon (the
    /// whole light is sampled otherwise).
    pub fn warped(&self) -> bool {
        self.warp.is_some()
    }

    /// Calls `f` with every sample above the shading horizon, in `traced`'s order.
    #[inline(always)]
    pub fn for_each(&self, mut f: impl FnMut(LightSample)) {
        self.rows(|row| {
            for &x in row {
                f(x);
            }
        });
    }

    /// Every sample above the shading horizon appended to `out`, in `traced`'s order
    /// ([`PointSamples::for_each`] without a call per sample).
    pub fn collect_into(&self, out: &mut Vec<LightSample>) {
        out.reserve((self.strata.0 * self.strata.1) as usize);
        self.rows(|row| out.extend_from_slice(row));
    }

    /// Calls `each` with every row's samples above the shading horizon, in order. A row is
    /// drawn into a buffer by a loop for the plain grid or one for strata following g (a
    /// branch per sample cost `traced` 13% and `silhouette` 10% on some scenes), and `each`
    /// is called from this one place: a closure called from two loops was left out of line
    /// (`traced` 25% slower on the default scene).
    #[inline(always)]
    fn rows(&self, mut each: impl FnMut(&[LightSample])) {
        let by_g = self.by_g();
        let (nx, ny) = self.strata;
        let mut rng = Rng::new(self.q.seed);
        let mut row = [EMPTY_SAMPLE; MAX_ROW];
        for j in 0..ny {
            let n = match by_g {
                None => self.draw_row(j, &mut rng, None, &mut row),
                Some(g) => {
                    let band = g.row(j, ny);
                    self.draw_row(j, &mut rng, Some(&(band, g.columns(band))), &mut row)
                }
            };
            debug_assert!(n <= nx as usize);
            each(&row[..n]);
        }
    }

    /// Row j's samples above the horizon into `out`, in order; returns how many.
    #[inline(always)]
    fn draw_row(
        &self,
        j: u32,
        rng: &mut Rng,
        by_g: Option<&([f32; 2], Columns)>,
        out: &mut [LightSample; MAX_ROW],
    ) -> usize {
        let mut leaves = self.row_leaves(j);
        let mut n = 0;
        for i in 0..self.strata.0 {
            if let Some(x) = self.draw(i, j, rng, leaves.clear_at(i), by_g) {
                out[n] = x;
                n += 1;
            }
        }
        n
    }

    /// Row j's clear leaves, to be stepped along the row.
    #[inline(always)]
    fn row_leaves(&self, j: u32) -> RowLeaves {
        let (nx, ny) = self.strata;
        let (lx, ly) = shaft::leaves_per_axis((nx, ny));
        // This row's clear leaves, as bits 0..lx; leaf column `x` holds samples
        // first(x) <= i < first(x + 1) ([`shaft::leaf_bit`], stepped instead of divided).
        let clear =
            (self.clear >> (shaft::LEAVES as u32 * (j * ly as u32 / ny))) & ((1 << shaft::LEAVES) - 1);
        RowLeaves { clear, col: 0, next_col: shaft::first_stratum(1, nx, lx), nx, lx }
    }

    /// The weight of the sample [`PointSamples::at`] draws for `stratum`, for a point on the
    /// plain grid whose samples all lie above its horizon (then `at` would draw it): the same
    /// target, without the horizon and shaft tests.
    #[inline]
    pub fn weight_at(&self, stratum: u32) -> f64 {
        let (a, b) = self.plain_coords(stratum);
        self.share.weight_at(a, b)
    }

    /// The rectangle coordinates of that sample (the plain grid's draw for `stratum`).
    #[inline]
    pub fn plain_coords(&self, stratum: u32) -> (f32, f32) {
        debug_assert!(self.plain_grid());
        let (nx, ny) = self.strata;
        let (i, j) = (stratum % nx, stratum / nx);
        let mut rng = Rng::new(self.q.seed);
        rng.skip(2 * stratum as u64);
        let a = (i as f32 + rng.next_f32()) / nx as f32;
        let b = (j as f32 + rng.next_f32()) / ny as f32;
        (a, b)
    }

    /// The query these samples answer.
    pub fn query(&self) -> &ShadowQuery {
        self.q
    }

    /// The light this point's samples lie on.
    pub fn light(&self) -> &RectLight {
        &self.light
    }

    /// The sample [`PointSamples::for_each`] draws for stratum `i + nx j`, alone (the
    /// stream jumps to its draws), unless it falls below the shading horizon.
    pub fn at(&self, stratum: u32) -> Option<LightSample> {
        let (i, j) = (stratum % self.strata.0, stratum / self.strata.0);
        let leaf_clear = self.clear & shaft::leaf_bit(i, j, self.strata) != 0;
        let mut rng = Rng::new(self.q.seed);
        rng.skip(2 * stratum as u64);
        match self.by_g() {
            // Two calls, so that the plain grid's draw carries no stratum bounds.
            None => self.draw(i, j, &mut rng, leaf_clear, None),
            Some(g) => {
                let band = g.row(j, self.strata.1);
                self.draw(i, j, &mut rng, leaf_clear, Some(&(band, g.columns(band))))
            }
        }
    }

    /// The sample of stratum (i, j), the next one `rng` draws; `None` below the horizon.
    /// `by_g`: row j's band and column CDF where the strata follow g.
    #[inline(always)]
    fn draw(
        &self,
        i: u32,
        j: u32,
        rng: &mut Rng,
        leaf_clear: bool,
        by_g: Option<&([f32; 2], Columns)>,
    ) -> Option<LightSample> {
        let (light, point, warp) = (&self.light, &self.q.point, &self.warp);
        let (nx, ny) = self.strata;
        let (mut a, mut b, scale) = if let Some((band, columns)) = by_g {
            let (a0, a1) = (columns.at(i as f32 / nx as f32), columns.at((i + 1) as f32 / nx as f32));
            let (u, v) = (rng.next_f32(), rng.next_f32());
            let scale = (a1 - a0) * (band[1] - band[0]) * (nx * ny) as f32;
            (a0 + u * (a1 - a0), band[0] + v * (band[1] - band[0]), scale)
        } else {
            let a = (i as f32 + rng.next_f32()) / nx as f32;
            (a, (j as f32 + rng.next_f32()) / ny as f32, 1.0)
        };
        if let Some(w) = warp {
            let (wa, wb) = w.map(a as f64, b as f64);
            (a, b) = (wa as f32, wb as f32);
        }
        let target = light.point(a, b);
        let w = target - point.p;
        if point.n_shading.dot(w) <= 0.0 {
            // Below the horizon: not part of the light this point sees. (A warped sample is
            // above it in f64; f32 rounding may still drop one at the cut.)
            return None;
        }
        let height = point.n_geom.dot(w);
        // `max_point_error` bounds points with a, b in [0, 1] (a warped sample off the unit
        // square by a rounding is traced instead).
        let proven = leaf_clear
            && (self.plain_grid() || ((0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b)))
            && self.cover.covers(height, w);
        Some(LightSample { a, b, target, height, proven, stratum: i + nx * j, scale })
    }

    /// Every sample traced (but those a shaft proved unblocked), counted and weighed in
    /// stratum order: the tally, and the rays traced. `traced`'s answer, and the whole-point
    /// fallback of the methods that must agree with it bit for bit.
    pub fn trace(&self, scene: &Scene) -> (ShareTally, u32) {
        let (mut tally, mut traced) = (ShareTally::default(), 0u32);
        self.for_each(|s| {
            // Inside a clear shaft: proven unblocked, no ray.
            let blocked = !s.proven && {
                traced += 1;
                self.occluded(scene, &s)
            };
            tally.add(self.weight(&s), blocked);
        });
        (tally, traced)
    }

    /// [`PointSamples::trace`] with `lobe`'s sums beside the tally: each sample's weight
    /// times the lobe's factor at it ([`GlossyLobe::factor`]), for the glossy share.
    ///
    /// The lobe is weighed only where some samples are blocked and some are not (a lit point's
    /// share is 1, an umbra's 0, whatever the lobe): the verdicts are kept as bits and the
    /// samples drawn again for it. Weighing every sample cost the Cornell box 30% at N = 256.
    pub fn trace_glossy(&self, scene: &Scene, lobe: &GlossyLobe) -> (ShareTally, LobeTally, u32) {
        let (mut tally, mut traced) = (ShareTally::default(), 0u32);
        let mut open = [0u64; (MAX_TRACED_SAMPLES as usize).div_ceil(64)];
        let mut k = 0usize;
        self.for_each(|s| {
            let blocked = !s.proven && {
                traced += 1;
                self.occluded(scene, &s)
            };
            tally.add(self.weight(&s), blocked);
            open[k / 64] |= u64::from(!blocked) << (k % 64);
            k += 1;
        });
        let mut glossy = LobeTally::default();
        if tally.blocked != 0 && tally.blocked != tally.counted {
            let p = self.q.point.p;
            let mut k = 0usize;
            self.for_each(|s| {
                glossy.add(
                    self.weight(&s) * lobe.factor(s.target - p) as f64,
                    open[k / 64] >> (k % 64) & 1 != 0,
                );
                k += 1;
            });
        } else {
            glossy.add(1.0, tally.blocked == 0);
        }
        (tally, glossy, traced)
    }

    /// Whether `s`'s shadow ray (`traced`'s own) meets any of the triangles `slots`, alone
    /// (tried in order until one is met).
    pub fn meets_any(&self, scene: &Scene, s: &LightSample, slots: impl IntoIterator<Item = usize>) -> bool {
        let point = &self.q.point;
        let from = if s.height < 0.0 { offset_origin(point, s.target - point.p) } else { self.origin };
        let ends = (self.light.point_error(s.a, s.b), self.light.normal);
        scene.segment_meets_any(from, s.target, ends, slots)
    }

    /// Whether `s`'s shadow ray ([`PointSamples::occluded`]'s) meets a triangle other than
    /// those `skip` holds.
    pub fn occluded_except(&self, scene: &Scene, s: &LightSample, skip: impl Fn(usize) -> bool) -> bool {
        let point = &self.q.point;
        let from = if s.height < 0.0 { offset_origin(point, s.target - point.p) } else { self.origin };
        let ends = (self.light.point_error(s.a, s.b), self.light.normal);
        scene.segment_occluded_from_except(from, s.target, ends, skip)
    }

    /// Whether `s`'s shadow ray is blocked: `traced`'s own ray.
    #[inline(always)]
    pub fn occluded(&self, scene: &Scene, s: &LightSample) -> bool {
        let point = &self.q.point;
        // `offset_origin(point, target - p)`: the lit side's origin unless the target is
        // under the geometric tangent plane.
        let from = if s.height < 0.0 { offset_origin(point, s.target - point.p) } else { self.origin };
        scene.segment_occluded_from(from, s.target, self.light.point_error(s.a, s.b), self.light.normal)
    }
}

/// One row's clear leaves, stepped column by column ([`PointSamples::row_leaves`]).
struct RowLeaves {
    clear: u64,
    col: u32,
    next_col: u32,
    nx: u32,
    lx: usize,
}

impl RowLeaves {
    /// Whether sample column `i` (called for 0, 1, 2, ... in turn) lies in a clear leaf.
    #[inline(always)]
    fn clear_at(&mut self, i: u32) -> bool {
        if i == self.next_col {
            self.col += 1;
            self.next_col = shaft::first_stratum(self.col + 1, self.nx, self.lx);
        }
        self.clear & (1 << self.col) != 0
    }
}
