//! `pcss`: Percentage-Closer Soft Shadows (R. Fernando, "Percentage-Closer Soft Shadows",
//! SIGGRAPH 2005 sketch) on the same light-space depth map as `edge_table` and
//! `depth_march` ([`DepthMap::build`]): the real-time baseline a game-engine user knows.
//!
//! Per shading point, three steps, all in the map's perspective image (image-plane units:
//! x/z, y/z in the light's frame; divide by the map's pitch for pixels). A light sample s
//! (its offset in the light's plane) seen from a point P crosses depth z at image offset
//! s (1/z - 1/Pz) from P's image point (see [`crate::depth_map::march`]). So every region PCSS reads
//! is the set of those offsets for s over the light, at one depth:
//!
//! 1. **Blocker search.** `blocker_samples` stratified light samples, each read (nearest
//!    texel) at the depth `z_near` = [`DepthMap::stop_depth`], the nearest depth of the
//!    region rays from P can cross: this is Fernando's search region (the light projected
//!    from the receiver onto the "near plane"), with the nearest possible blocker as the
//!    near plane. The average depth `z_avg` of the texels that are blockers (see below) is
//!    the blocker estimate. No blocker: V = 1.
//! 2. **Penumbra estimate.** Similar triangles, w_penumbra = w_light (d_receiver -
//!    d_blocker) / d_blocker, projected into the image (/ d_receiver): for light sample s
//!    the filter offset is s (Pz - z_avg) / (z_avg Pz) = s (1/z_avg - 1/Pz). That is
//!    exactly where the ray to s crosses depth z_avg.
//! 3. **PCF.** `samples` stratified light samples (the `[shadows].samples`, seeded like
//!    `traced`'s, so tap i and traced ray i aim at the same light point), tap i read at P's
//!    image point + s_i (1/z_avg - 1/Pz) (nearest texel) and lit iff the texel is not a
//!    blocker. V = lit taps / taps whose light sample is above the shading point's horizon
//!    (1 if none): one tap per light sample is what makes the horizon exact and the sample
//!    conventions those of the other methods.
//!
//! Where every occluder lies at one depth parallel to the light (a floating card over a
//! floor, both facing the light) this is exact per ray up to texels: z_avg is the
//! occluder's depth and tap i reads exactly where ray i crosses it. With blockers at
//! several depths the one average is wrong for most of them (contact shadows come out too
//! soft or too hard): PCSS's known error, kept as is.
//!
//! **Which texels are blockers.** Fernando's test is "texel depth < receiver depth" (the
//! map's depths are already biased: slope-scaled, plus each texel's own hit error). On a receiver
//! that does not face the light squarely, its own surface is nearer than P on its uphill
//! side. Region shrinking keeps a lit point's search region too small for that to matter,
//! but inside a penumbra the region is sized by the real occluder's depth, and the bare test
//! counts the receiver's own uphill texels both as blockers (dragging z_avg towards the
//! receiver) and as shadowing taps. Real-time engines pair PCSS with a receiver-plane
//! depth bias for this (Isidoro, "Shadow mapping: GPU-based tips and techniques", GDC
//! 2006); here it is exact: a texel is a blocker iff its depth is below the receiver's
//! (`d < Pz`) **and** its point lies strictly above the receiver's tangent plane at P (on
//! the geometric normal's side), evaluated at the texel's centre. For a receiver facing the
//! light squarely the second test is the first, so the parallel-plane behaviour is
//! Fernando's; and a planar receiver with nothing above its tangent plane in reach gets
//! V = 1 exactly.
//!
//! Measured (tests/pcss.rs, 64x64, 256 samples): a card floating over a floor, parallel to
//! the light, RMSE 0.0059 against `traced` (edge_table 0.0085); a box 1.0 tall lit at 34
//! degrees, RMSE 0.021 (edge_table 0.0086), and 0.060 with the bare depth test. Under a
//! half-plane occluder over a receiver tilted 27 degrees (unit test below) the bare test
//! errs by up to 0.38 in the lit half of the penumbra, this one by 0.005.
//!
//! Points outside the map fall back to `traced` rays (counted as `fallbacks`), as for the
//! other depth-map methods. PCSS reads only the map's depths, so its map is built without
//! the `closed_volumes` slabs and the hidden layer (its depths are the same).
//!
//! | key (`[shadows.pcss]`) | type | default | meaning |
//! |---|---|---|---|
//! | `depth_map` | int | 256 | depth-map pixels per side |
//! | `blocker_samples` | int | 32 | light samples read by the blocker search (1 to 4096) |
//! | `slope_bias` | float | 1.0 | slope-scaled depth bias, in pixels |
//! | `normal_offset` | float | 0.5 | lookups move along the normal by this many pixel footprints times (1 - cos) of the light's axis |
//! | `grazing_cos` | float | 0 | receivers whose geometric normal's cosine to the direction of the light's centre is below this are answered by traced rays (counted as `fallbacks_grazing`); 0 turns it off |
//!
//! `samples` (`[shadows]`) is the number of PCF taps (at most 4096).
//!
//! ```toml
//! [shadows]
//! method = "pcss"
//! samples = 256
//! [shadows.pcss]
//! depth_map = 256
//! blocker_samples = 32
//! ```

use crate::depth_map::bits::{self, MAX_SAMPLES, MAX_WORDS};
use crate::depth_map::fallback::{Located, MapFallback, OnMap};
use crate::depth_map::mask_samples;
use crate::depth_map::{DepthMap, DepthMapParams, LightFrame, MapPoint, MapSwitches};
use glam::{Vec2, Vec3};
use renderer::methods::irradiance_share::IrradianceShare;
use renderer::util::random::Rng;
use renderer::{
    KeyError, LightShadowing, MethodParams, PrepareContext, RectLight, Scene, ShadowError, ShadowMethod,
    ShadowQuery,
};
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicU64, Ordering};

/// Parameters of the PCSS method (the scene file's `[shadows.pcss]` is [`PcssTable`]; see
/// the module doc for the keys).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PcssParams {
    pub depth_map: DepthMapParams,
    /// Light samples read by the blocker search (1 to [`MAX_SAMPLES`]).
    pub blocker_samples: u32,
}

impl Default for PcssParams {
    fn default() -> Self {
        // No grazing fallback and no fit to the shadowed receivers: the real-time baseline
        // traces only what falls off its map.
        let switches = MapSwitches { fit_shadowed: false, ..MapSwitches::ALL };
        Self {
            depth_map: DepthMapParams { grazing_cos: 0.0, switches, ..DepthMapParams::new(256) },
            blocker_samples: 32,
        }
    }
}

/// `[shadows.pcss]`: the depth map's keys but `slab_thickness` ([`DepthMapParams`]), and
/// `blocker_samples`. `slab_thickness` is read only to be refused by name (the other
/// depth-map methods take it).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PcssTable {
    depth_map: u32,
    slope_bias: f32,
    normal_offset: f32,
    grazing_cos: f32,
    blocker_samples: u32,
    #[serde(skip_serializing_if = "Option::is_none")]
    slab_thickness: Option<f32>,
}

impl ShadowMethod for PcssParams {
    fn name(&self) -> &'static str {
        Pcss::NAME
    }
    fn max_samples(&self) -> u32 {
        MAX_SAMPLES as u32
    }
    fn build(&self, samples: u32) -> Box<dyn LightShadowing> {
        Box::new(Pcss::new(*self, samples))
    }
}

impl MethodParams for PcssParams {
    const NAME: &'static str = Pcss::NAME;
    type Table = PcssTable;
    fn table(&self) -> PcssTable {
        let m = &self.depth_map;
        PcssTable {
            depth_map: m.resolution,
            slope_bias: m.slope_bias,
            normal_offset: m.normal_offset,
            grazing_cos: m.grazing_cos,
            blocker_samples: self.blocker_samples,
            slab_thickness: None,
        }
    }
    fn with_table(&self, t: PcssTable) -> Self {
        let depth_map = DepthMapParams {
            resolution: t.depth_map,
            slope_bias: t.slope_bias,
            // Not read: a table that sets it is refused (`inapplicable`).
            slab_thickness: self.depth_map.slab_thickness,
            normal_offset: t.normal_offset,
            grazing_cos: t.grazing_cos,
            switches: self.depth_map.switches,
        };
        Self { depth_map, blocker_samples: t.blocker_samples }
    }
    fn inapplicable(&self, key: &str) -> Option<String> {
        (key == "slab_thickness").then(|| "pcss reads no slabs (edge_table and depth_march do)".to_string())
    }
    fn validate(&self) -> Result<(), KeyError> {
        self.depth_map.validate()?;
        if !(1..=MAX_SAMPLES as u32).contains(&self.blocker_samples) {
            return Err(KeyError::new(
                "blocker_samples",
                format!("must be in 1..={MAX_SAMPLES}, got {}", self.blocker_samples),
            ));
        }
        Ok(())
    }
}

/// Mixed into the query's seed for the blocker search's samples, so they are not the PCF
/// taps' samples (those use the seed itself, like `traced`).
const BLOCKER_SEED: u64 = 0x5bd1_e995_9e37_79b9;

/// The plugin.
pub struct Pcss {
    params: PcssParams,
    samples: u32,
    map: Option<DepthMap>,
    fallback: MapFallback,
    early_outs: AtomicU64,
    blocker_searches: AtomicU64,
    pcf_taps: AtomicU64,
}

impl Pcss {
    pub const NAME: &'static str = "pcss";

    /// # Panics
    /// `samples` or `params.blocker_samples` outside 1..=[`MAX_SAMPLES`] (checked at the
    /// config boundary).
    pub fn new(params: PcssParams, samples: u32) -> Self {
        assert!((1..=MAX_SAMPLES as u32).contains(&samples));
        assert!((1..=MAX_SAMPLES as u32).contains(&params.blocker_samples));
        Self {
            params,
            samples,
            map: None,
            fallback: MapFallback::new(samples),
            early_outs: AtomicU64::new(0),
            blocker_searches: AtomicU64::new(0),
            pcf_taps: AtomicU64::new(0),
        }
    }

    fn early_out(&self) -> f32 {
        self.early_outs.fetch_add(1, Ordering::Relaxed);
        1.0
    }
}

/// The blocker test of one shading point (see the module doc): a texel blocks iff its depth
/// is below the receiver's and its point is strictly above the receiver's tangent plane.
struct Receiver {
    pz: f32,
    /// The geometric normal in the light's frame, and its dot with P: a texel's point
    /// d (g, 1) is above the plane iff d (n . (g, 1)) > n . P.
    n: Vec3,
    n_dot_p: f32,
    /// Image point of texel (0, 0)'s centre, and the pitch.
    centre0: Vec2,
    pitch: f32,
}

impl Receiver {
    fn new(map: &DepthMap, p: Vec3, n_geom: Vec3) -> Self {
        let f = &map.frame;
        let n = Vec3::new(n_geom.dot(f.x), n_geom.dot(f.y), n_geom.dot(f.z));
        Self {
            pz: p.z,
            n,
            n_dot_p: n.dot(p),
            centre0: map.origin + Vec2::splat(0.5 * map.pitch),
            pitch: map.pitch,
        }
    }

    /// Whether texel (i, j), of biased depth `d` (+inf: no surface), blocks. The plane is
    /// evaluated at the texel's centre, where its depth was taken, so a planar receiver's
    /// own texels (pushed back by the bias) never block.
    #[inline]
    fn blocks(&self, i: i32, j: i32, d: f32) -> bool {
        if d >= self.pz {
            return false; // also +inf
        }
        let g = self.centre0 + self.pitch * Vec2::new(i as f32, j as f32);
        d * (self.n.x * g.x + self.n.y * g.y + self.n.z) > self.n_dot_p
    }
}

/// The texel at image offset `offset_px` (in pixels) from the map point `mp`: nearest
/// texel, i.e. the pixel the offset point falls in. Saturating: a huge offset lands off the
/// map, where [`DepthMap::at`] reads no surface.
#[inline]
fn texel(mp: &MapPoint, offset_px: Vec2) -> (i32, i32) {
    let g = mp.offset + offset_px;
    (mp.pixel[0].saturating_add(g.x.floor() as i32), mp.pixel[1].saturating_add(g.y.floor() as i32))
}

/// V as the share of irradiance ([`IrradianceShare`]) from the taps' verdicts: the smaller
/// set's light samples weighed (only penumbra points weigh any). The taps are uniform over
/// the whole light, in the frame's plane coordinates.
fn share_of_irradiance(
    frame: &LightFrame,
    q: &ShadowQuery,
    taps: &[Vec2],
    above: &[u64],
    open: &[u64],
    lit: u32,
) -> f32 {
    debug_assert_eq!(bits::count_and(above, open), lit);
    let size = 2.0 * frame.half_size;
    let light = RectLight::new(frame.origin, frame.x * size.x, frame.y * size.y, Vec3::ONE);
    let share = IrradianceShare::new(&light, q, 1.0, taps.len() as u32);
    let words = above.iter().copied().zip(open.iter().copied());
    share.visibility_from_bits(words, |k| share.weight(frame.world_from_light(taps[k].extend(0.0))))
}

impl LightShadowing for Pcss {
    fn name(&self) -> &'static str {
        Self::NAME
    }

    fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError> {
        // The same map as depth_march's; the closed-volume layer only changes the slab
        // bottoms, which PCSS never reads, so it is not traced.
        let map = self.params.depth_map;
        let switches = MapSwitches { closed_volumes: false, hidden_layer: false, ..map.switches };
        let params = DepthMapParams { switches, ..map };
        self.map = Some(DepthMap::build(ctx.scene, ctx.light, ctx.visible, &params));
        self.fallback.prepare(ctx)
    }

    fn visibility(&self, scene: &Scene, q: &ShadowQuery) -> f32 {
        let map = self.map.as_ref().expect("prepare() runs before visibility()");
        let frame = &map.frame;
        // Grazed points (when `grazing_cos` is set) and points outside the map: traced rays
        // answer (counted). The stop depth is the nearest depth any ray from P can meet:
        // nothing nearer the light lies in reach.
        let OnMap { p, mp, z_stop: z_near, .. } = match self.fallback.locate(map, scene, q) {
            Located::OnMap(on_map) => on_map,
            Located::Traced(v) => return v,
            Located::NearerThanMap => return self.early_out(),
        };
        if z_near >= p.z {
            return self.early_out();
        }
        let receiver = Receiver::new(map, p, q.point.n_geom);
        let mut sample_buf = [Vec2::ZERO; MAX_SAMPLES];

        // 1. Blocker search: where the rays to the blocker samples cross depth z_near.
        self.blocker_searches.fetch_add(1, Ordering::Relaxed);
        let blocker_samples = &mut sample_buf[..self.params.blocker_samples as usize];
        mask_samples::stratified(blocker_samples, frame.half_size, &mut Rng::new(q.seed ^ BLOCKER_SEED));
        let search = (1.0 / z_near - 1.0 / p.z) / map.pitch;
        let (mut depth_sum, mut blockers) = (0.0f32, 0u32);
        for s in blocker_samples.iter() {
            let (i, j) = texel(&mp, *s * search);
            let d = map.at(i, j);
            if receiver.blocks(i, j, d) {
                depth_sum += d;
                blockers += 1;
            }
        }
        if blockers == 0 {
            return self.early_out();
        }
        // 2. Penumbra estimate: the filter is where the rays cross the average blocker depth
        // (below p.z, as every blocker is).
        let z_avg = depth_sum / blockers as f32;
        let filter = (1.0 / z_avg - 1.0 / p.z) / map.pitch;

        // 3. PCF: one tap per light sample, counted over the samples above the horizon.
        let n = self.samples as usize;
        let taps = &mut sample_buf[..n];
        mask_samples::stratified(taps, frame.half_size, &mut Rng::new(q.seed));
        let w = bits::words(n);
        let mut above = [0u64; MAX_WORDS];
        mask_samples::above_horizon(frame, taps, Vec2::ONE, &q.point, &mut above[..w]);
        let (mut lit, mut n_above) = (0u32, 0u32);
        let mut open = [0u64; MAX_WORDS];
        for (r, s) in taps.iter().enumerate() {
            if above[r / 64] >> (r % 64) & 1 == 0 {
                continue; // below the horizon: not part of the light this point sees
            }
            n_above += 1;
            let (i, j) = texel(&mp, *s * filter);
            let unblocked = !receiver.blocks(i, j, map.at(i, j));
            lit += unblocked as u32;
            open[r / 64] |= (unblocked as u64) << (r % 64);
        }
        self.pcf_taps.fetch_add(n_above as u64, Ordering::Relaxed);
        renderer::util::pixel_cost::count_lookups(n_above as u64);
        share_of_irradiance(frame, q, taps, &above[..w], &open[..w], lit)
    }

    fn memory_bytes(&self) -> u64 {
        self.map.as_ref().map_or(0, DepthMap::bytes)
    }

    fn counters(&self) -> Vec<(&'static str, u64)> {
        let mut c = vec![
            ("early_outs", self.early_outs.load(Ordering::Relaxed)),
            ("blocker_searches", self.blocker_searches.load(Ordering::Relaxed)),
            ("pcf_taps", self.pcf_taps.load(Ordering::Relaxed)),
            ("depth_map_bytes", self.map.as_ref().map_or(0, |m| m.bytes())),
        ];
        c.extend(self.fallback.counters());
        c
    }
}

mod entry;
#[cfg(test)]
mod tests;
