//! Differential test of the edge-table masks against their oracle, the per-ray depth march.
//!
//! For a mask built exactly at a shading point (same sub-pixel offset, same depth, same
//! light samples), `Mask::query` and `depth_march::march_bits` must give the same visibility
//! bits, bit for bit, under every heightfield reading (technical note, sections 3-5). The
//! random cases mix smooth and terraced terrain, floating plates and boxes at shared depths
//! (exact ties), spikes and empty (+inf) pixels; shading points on pixel boundaries, at pixel
//! centres, in front of, exactly on and behind their own pixel's floor; light samples
//! including the ray that stays in the own pixel, rays parallel to the grid lines and rays
//! through pixel corners. A hand-built scene checks the oracle itself against geometry.

use glam::{Vec2, Vec3};
use renderer::util::random::Rng;
use shadow_plugin::depth_map::bits::{MAX_WORDS, count, fill_first, words};
use shadow_plugin::depth_map::march::{floor_height, for_each_crossing, stop_height};
use shadow_plugin::depth_map::{DepthMap, LightFrame, MapPoint};
use shadow_plugin::depth_march::march_bits;
use shadow_plugin::edge_table::{Heightfield, Mask, MaskQuery};

const READINGS: [Heightfield; 3] = [Heightfield::Solid, Heightfield::Shells, Heightfield::Plates];

fn frame(half_size: Vec2) -> LightFrame {
    LightFrame { origin: Vec3::ZERO, x: Vec3::X, y: Vec3::Y, z: Vec3::Z, half_size }
}

/// The oracle: `depth_march`'s bits for the rays from `mp` to `samples`.
fn march(map: &DepthMap, mp: &MapPoint, samples: &[Vec2], heightfield: Heightfield) -> Vec<u64> {
    let (z_stop, _clipped) = map.stop_depth(mp.pixel, mp.z);
    let mut a = vec![0u64; words(samples.len())];
    march_bits(map, mp, samples, z_stop, heightfield, &mut a);
    a
}

/// The edge-table bits of `mask` (built at `mp`'s offset and depth) queried at `mp`.
fn query(map: &DepthMap, mp: &MapPoint, mask: &Mask, heightfield: Heightfield) -> Vec<u64> {
    query_stats(map, mp, mask, heightfield).0
}

/// [`query`] and the query's blocks culled.
fn query_stats(map: &DepthMap, mp: &MapPoint, mask: &Mask, heightfield: Heightfield) -> (Vec<u64>, u64) {
    let (z_stop, _clipped) = map.stop_depth(mp.pixel, mp.z);
    let h_stop = stop_height(z_stop, mp.z);
    assert!(h_stop <= mask.h_max);
    let w = words(mask.samples.len());
    // Poison the buffer: the query must write every word it is asked for.
    let mut b = [0xa5a5_a5a5_a5a5_a5a5u64; MAX_WORDS];
    let stats = mask.query(map, mp.pixel, mp.z, h_stop, heightfield, &mut b);
    (b[..w].to_vec(), stats.blocks_culled)
}

#[inline]
fn bit(bits: &[u64], r: usize) -> bool {
    bits[r / 64] >> (r % 64) & 1 == 1
}

fn differing(a: &[u64], b: &[u64]) -> u64 {
    a.iter().zip(b).map(|(x, y)| (x ^ y).count_ones() as u64).sum()
}

/// Whether `a` and `b` hold the same samples (as a multiset, bit for bit).
fn same_samples(a: &[Vec2], b: &[Vec2]) -> bool {
    let key = |v: &[Vec2]| {
        let mut k: Vec<(u32, u32)> = v.iter().map(|s| (s.x.to_bits(), s.y.to_bits())).collect();
        k.sort_unstable();
        k
    };
    key(a) == key(b)
}

struct Random(Rng);

impl Random {
    fn f(&mut self) -> f32 {
        self.0.next_f32()
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f()
    }
    fn below(&mut self, n: usize) -> usize {
        (self.0.next_u64() % n as u64) as usize
    }
    fn chance(&mut self, p: f32) -> bool {
        self.f() < p
    }
    fn pick<T: Copy>(&mut self, items: &[T]) -> T {
        items[self.below(items.len())]
    }
}

/// A random depth map and its terrain (the depths before plates, spikes and holes).
fn random_map(rng: &mut Random) -> (DepthMap, Vec<f32>) {
    let res = 32 + rng.below(65); // 32..=96 pixels per side
    let pitch = rng.range(0.01, 0.04);
    let half = Vec2::new(rng.range(0.08, 0.5), rng.range(0.08, 0.5));
    let origin =
        Vec2::splat(-0.5 * res as f32 * pitch) + Vec2::new(rng.range(-0.3, 0.3), rng.range(-0.3, 0.3));

    // Terrain: a sum of waves and a tilt, in some maps terraced to exact steps (ties).
    let base = rng.range(3.0, 6.0);
    let waves: Vec<(f32, f32, f32, f32)> = (0..3)
        .map(|_| (rng.range(0.0, 0.5), rng.range(0.05, 0.6), rng.range(-1.0, 1.0), rng.range(0.0, 6.3)))
        .collect();
    let tilt = Vec2::new(rng.range(-0.02, 0.02), rng.range(-0.02, 0.02));
    let terrace = if rng.chance(0.4) { Some(rng.pick(&[0.0625f32, 0.125, 0.25, 0.5])) } else { None };
    let mut ground = vec![0.0f32; res * res];
    for j in 0..res {
        for i in 0..res {
            let (x, y) = (i as f32, j as f32);
            let mut g = base + tilt.x * x + tilt.y * y;
            for &(a, k, dir, phase) in &waves {
                g += a * (k * (x + dir * y) + phase).sin();
            }
            if let Some(q) = terrace {
                g = (g / q).round() * q;
            }
            ground[j * res + i] = g;
        }
    }
    let mut depth = ground.clone();

    // Floating plates and boxes: mostly at depths from a small palette, so that neighbouring
    // occluders share exact depths; some with sloped tops.
    let palette: Vec<f32> = (0..3).map(|_| base * rng.range(0.3, 0.95)).collect();
    for _ in 0..rng.below(16) {
        let (w, h) = (1 + rng.below(14), 1 + rng.below(14));
        let (x0, y0) = (rng.below(res), rng.below(res));
        let d = if rng.chance(0.6) { rng.pick(&palette) } else { base * rng.range(0.3, 1.0) };
        let slope = if rng.chance(0.3) {
            Vec2::new(rng.range(-0.05, 0.05), rng.range(-0.05, 0.05))
        } else {
            Vec2::ZERO
        };
        for y in y0..(y0 + h).min(res) {
            for x in x0..(x0 + w).min(res) {
                let v = d + slope.x * (x - x0) as f32 + slope.y * (y - y0) as f32;
                let p = &mut depth[y * res + x];
                *p = p.min(v);
            }
        }
    }
    // One-pixel spikes: thin occluders.
    for _ in 0..rng.below(24) {
        let p = rng.below(res * res);
        depth[p] =
            depth[p].min(if rng.chance(0.5) { rng.pick(&palette) } else { base * rng.range(0.3, 0.95) });
    }
    // Empty pixels, and sometimes an empty hole.
    for _ in 0..rng.below(8) {
        depth[rng.below(res * res)] = f32::INFINITY;
    }
    if rng.chance(0.25) {
        let (w, h) = (1 + rng.below(10), 1 + rng.below(10));
        let (x0, y0) = (rng.below(res), rng.below(res));
        for y in y0..(y0 + h).min(res) {
            for x in x0..(x0 + w).min(res) {
                depth[y * res + x] = f32::INFINITY;
            }
        }
    }
    // Half the maps read `plates` as slabs (a floor at depth D reaches down to D * (1 +
    // slab)), a quarter of those with a thickness of its own per pixel (closed volumes), the
    // rest as infinitely thin plates. Drawn from a stream of its own so the maps and points
    // stay those the case counts were measured on.
    let mut slab_rng = Rng::new(rng.0.clone().next_u64() ^ 0x5eed_51ab);
    let bottoms: Option<Vec<f32>> = if slab_rng.next_f32() < 0.5 {
        let slab = 0.3 * slab_rng.next_f32();
        let per_pixel = slab_rng.next_f32() < 0.25;
        Some(
            depth
                .iter()
                .map(|d| d * (1.0 + if per_pixel { 2.0 * slab * slab_rng.next_f32() } else { slab }))
                .collect(),
        )
    } else {
        None
    };
    let map = DepthMap::from_depths(frame(half), origin, pitch, res as u32, depth);
    let map = match bottoms {
        Some(b) => map.with_bottoms(b),
        None => map,
    };
    // Half the maps get a hidden layer (read by `plates` only): under each pixel, with
    // probability 3/4, a floor 5-60% deeper than the first layer's slab bottom, with a slab
    // of its own. From a stream of its own, like the slabs.
    let mut layer_rng = Rng::new(rng.0.clone().next_u64() ^ 0x41dd_e11a);
    let map = if layer_rng.next_f32() < 0.5 {
        let n = map.depth.len();
        let (mut d2, mut b2) = (vec![f32::INFINITY; n], vec![f32::INFINITY; n]);
        for k in 0..n {
            if map.bottom[k].is_finite() && layer_rng.next_f32() < 0.75 {
                d2[k] = map.bottom[k] * (1.05 + 0.55 * layer_rng.next_f32());
                b2[k] = d2[k] * (1.0 + 0.2 * layer_rng.next_f32());
            }
        }
        map.with_hidden_layer(d2, b2)
    } else {
        map
    };
    (map, ground)
}

/// Sub-pixel offsets: pixel corners and sides (exact 0), centres, dyadic and random ones.
fn pick_offset(rng: &mut Random, kind: usize) -> Vec2 {
    let r = |rng: &mut Random| rng.f();
    match kind % 10 {
        0 => Vec2::ZERO,
        1 => Vec2::splat(0.5),
        2 => Vec2::new(0.0, r(rng)),
        3 => Vec2::new(r(rng), 0.0),
        4 => Vec2::new(0.0, 0.5),
        5 => Vec2::new(0.5, 0.25),
        6 => Vec2::splat(rng.pick(&[0.25, 0.75])),
        7 => {
            let a = r(rng);
            Vec2::new(a, 1.0 - a) // on an anti-diagonal through two pixel corners
        }
        _ => Vec2::new(r(rng), r(rng)),
    }
}

/// Light samples: random ones over the light, with special ones spread over the bit words:
/// the ray that stays in the own pixel, rays parallel to the grid lines, the light's corners,
/// and diagonal and 2:1 rays, which pass exactly through pixel corners from dyadic offsets.
fn light_samples(rng: &mut Random, n: usize, half: Vec2) -> (Vec<Vec2>, Vec<usize>) {
    let mut samples: Vec<Vec2> =
        (0..n).map(|_| Vec2::new(rng.range(-half.x, half.x), rng.range(-half.y, half.y))).collect();
    let c = rng.range(0.05, 1.0) * half.min_element();
    let c2 = rng.range(0.05, 1.0) * (0.5 * half.x).min(half.y);
    let c3 = rng.range(0.05, 1.0) * half.x.min(0.5 * half.y);
    let (hx, hy) = (half.x, half.y);
    let specials = [
        Vec2::ZERO,
        Vec2::new(-0.0, 0.0),
        Vec2::new(rng.range(-hx, hx), 0.0),
        Vec2::new(hx, 0.0),
        Vec2::new(-hx, 0.0),
        Vec2::new(0.0, rng.range(-hy, hy)),
        Vec2::new(-0.0, rng.range(-hy, hy)),
        Vec2::new(0.0, hy),
        Vec2::new(0.0, -hy),
        Vec2::new(hx, hy),
        Vec2::new(-hx, -hy),
        Vec2::new(hx, -hy),
        Vec2::new(-hx, hy),
        Vec2::new(c, c),
        Vec2::new(-c, -c),
        Vec2::new(c, -c),
        Vec2::new(-c, c),
        Vec2::new(2.0 * c2, c2),
        Vec2::new(-2.0 * c2, -c2),
        Vec2::new(2.0 * c2, -c2),
        Vec2::new(c3, 2.0 * c3),
        Vec2::new(-c3, -2.0 * c3),
        Vec2::new(-c3, 2.0 * c3),
    ];
    let mut at = Vec::with_capacity(specials.len());
    for (k, s) in specials.iter().enumerate() {
        let r = k * n / specials.len() + rng.below((n / specials.len()).max(1));
        samples[r] = *s;
        at.push(r);
    }
    (samples, at)
}

/// A pixel at least `margin` inside the map; for most points, one near a step in depth
/// (an occluder's edge), where penumbrae are.
fn pick_pixel(rng: &mut Random, map: &DepthMap, margin: i32) -> [i32; 2] {
    let res = map.resolution as i32;
    let mut random = || {
        let span = (res - 2 * margin) as usize;
        [margin + rng.below(span) as i32, margin + rng.below(span) as i32]
    };
    let anywhere = random();
    for _ in 0..40 {
        let [i, j] = random();
        let d = map.at(i, j).min(3.0 * map.z_min);
        let step = (-3..=3).any(|dj| (-3..=3).any(|di| map.at(i + di, j + dj) < 0.9 * d));
        if step {
            return [i, j];
        }
    }
    anywhere
}

/// A shading depth for pixel (i, j), by kind: in front of its own floor, just above the
/// terrain (under any plate over it), exactly on its own floor, behind it, at a neighbour's
/// exact depth, or anywhere.
fn pick_depth(rng: &mut Random, map: &DepthMap, ground: &[f32], i: i32, j: i32, kind: usize) -> f32 {
    let n = map.resolution as i32;
    let d_own = map.at(i, j);
    let g = ground[(j * n + i) as usize];
    let pz = match kind {
        0 | 6 | 7 => d_own * rng.range(0.85, 0.999),
        1 => g * (1.0 - rng.range(0.0, 0.03)),
        2 => d_own,
        3 => d_own * rng.range(1.0005, 1.2),
        4 => map.at(i + rng.below(5) as i32 - 2, j + rng.below(5) as i32 - 2),
        _ => rng.range(map.z_min * 0.9, g * 1.2),
    };
    if pz.is_finite() { pz } else { g * rng.range(0.9, 1.0) }
}

/// The map with up to `k` pixel depths moved so that a shadow ray from `mp` enters (or
/// leaves) that pixel exactly at its floor height: ties between crossing and floor heights,
/// which count as below (blocked). Some ties are at the lowest crossing into the pixel
/// through that side. Returns the new map and the number of ties made.
fn tie_floors(
    rng: &mut Random,
    map: &DepthMap,
    mp: &MapPoint,
    samples: &[Vec2],
    k: usize,
) -> (DepthMap, usize) {
    let (z_stop, _) = map.stop_depth(mp.pixel, mp.z);
    let h_stop = stop_height(z_stop, mp.z);
    // (pixel entered, side axis, height, pixel left)
    let mut crossings: Vec<([i32; 2], u8, f32, [i32; 2])> = Vec::new();
    for s in samples {
        let mut prev = [0, 0];
        for_each_crossing(mp.offset, *s, mp.z * map.pitch, h_stop, |c, axis, h| {
            crossings.push((c, axis, h, prev));
            prev = c;
            true
        });
    }
    let mut depth = map.depth.clone();
    let res = map.resolution as i32;
    let mut ties = 0;
    for _ in 0..k {
        if crossings.is_empty() {
            break;
        }
        let (c, axis, mut h, prev) = crossings[rng.below(crossings.len())];
        let mut cell = c;
        match rng.below(3) {
            0 => {
                h = crossings.iter().filter(|x| x.0 == c && x.1 == axis).map(|x| x.2).fold(h, f32::min);
            }
            1 => cell = prev, // the ray leaves `prev` exactly at its floor height
            _ => {}
        }
        let [i, j] = [mp.pixel[0] + cell[0], mp.pixel[1] + cell[1]];
        if cell == [0, 0] || i < 0 || j < 0 || i >= res || j >= res {
            continue;
        }
        // A depth whose floor height seen from mp.z is exactly h, if one is near.
        let mut d = mp.z * (1.0 - h);
        for _ in 0..4 {
            d = d.next_down();
        }
        for _ in 0..9 {
            if d > 0.0 && floor_height(d, mp.z) == h {
                depth[(j * res + i) as usize] = d;
                ties += 1;
                break;
            }
            d = d.next_up();
        }
    }
    let map = DepthMap::from_depths(map.frame, map.origin, map.pitch, map.resolution, depth);
    (map, ties)
}

#[derive(Default)]
struct Tally {
    cases: u64,
    bits: u64,
    compared: u64,
    differing: u64,
    blocks_culled: u64,
    blocked: [u64; 3],
    partial: [u64; 3],
    readings_differ: [u64; 3], // Solid/Shells, Shells/Plates, Solid/Plates
    behind_own_floor: u64,
    on_own_floor: u64,
    on_boundary: u64,
    clipped: u64,
    trivial: u64,
    shrunk: u64,
    own_ray: [[u64; 2]; 3],      // [blocked, visible] of the ray that stays in its pixel
    parallel_ray: [[u64; 2]; 3], // [blocked, visible] of grid-parallel rays that cross sides
    corner_crossings: u64,
    floor_ties_made: u64,
    floor_ties: u64,
}

#[test]
fn edge_table_matches_depth_march_bit_for_bit() {
    let mut rng = Random(Rng::new(0x5eed_d1ff_e7e2_0004));
    let sample_counts = [64usize, 100, 128, 192, 256, 512, 1024];
    let mut t = Tally::default();
    let mut reports = Vec::new();
    let n_maps = 100;
    let points_per_map = 6;
    for m in 0..n_maps {
        let (map, ground) = random_map(&mut rng);
        let res = map.resolution as i32;
        let margin = (res / 6).max(2);
        for p in 0..points_per_map {
            let case = m * points_per_map + p;
            let [i, j] = pick_pixel(&mut rng, &map, margin);
            let offset_kind = rng.below(10);
            let offset = pick_offset(&mut rng, offset_kind);
            let depth_kind = rng.below(8);
            let pz = pick_depth(&mut rng, &map, &ground, i, j, depth_kind);
            let n = sample_counts[case % sample_counts.len()];
            let (samples, specials) = light_samples(&mut rng, n, map.frame.half_size);
            let mp = MapPoint { pixel: [i, j], offset, z: pz };
            // In half the cases, rays enter or leave pixels exactly at their floor heights.
            let map = if rng.chance(0.5) {
                let k = 1 + rng.below(12);
                let (tied, made) = tie_floors(&mut rng, &map, &mp, &samples, k);
                t.floor_ties_made += made as u64;
                tied
            } else {
                map.clone()
            };

            let (z_stop, clipped) = map.stop_depth(mp.pixel, pz);
            let h_stop = stop_height(z_stop, pz);
            let h_own = 1.0 - map.at(i, j) / pz;
            t.cases += 1;
            t.bits += 3 * n as u64;
            t.clipped += clipped as u64;
            t.trivial += (h_stop <= 0.0) as u64;
            t.shrunk += (z_stop > map.z_min && pz > map.z_min) as u64;
            t.on_boundary += (offset.x == 0.0 || offset.y == 0.0) as u64;
            if h_stop > 0.0 {
                t.behind_own_floor += (h_own > 0.0) as u64;
                t.on_own_floor += (h_own == 0.0) as u64;
            }
            for s in &samples {
                let mut prev = f32::NAN;
                for_each_crossing(offset, *s, pz * map.pitch, h_stop, |c, _, h| {
                    t.corner_crossings += (h == prev) as u64;
                    t.floor_ties += (h == floor_height(map.at(i + c[0], j + c[1]), pz)) as u64;
                    prev = h;
                    true
                });
            }

            let oracle: Vec<Vec<u64>> = READINGS.iter().map(|&hf| march(&map, &mp, &samples, hf)).collect();
            for (k, (a, b)) in [(0, 1), (1, 2), (0, 2)].into_iter().enumerate() {
                t.readings_differ[k] += differing(&oracle[a], &oracle[b]);
            }
            for (h, bits) in oracle.iter().enumerate() {
                let visible = count(bits) as u64;
                t.blocked[h] += n as u64 - visible;
                t.partial[h] += (visible > 0 && visible < n as u64) as u64;
                for &r in &specials {
                    let s = samples[r];
                    let stays = s.x == 0.0 && s.y == 0.0;
                    let parallel = (s.x == 0.0) != (s.y == 0.0);
                    // Parallel rays count only if they cross a side below the stop height.
                    let mut crosses = false;
                    for_each_crossing(offset, s, pz * map.pitch, h_stop, |_, _, _| {
                        crosses = true;
                        false
                    });
                    let v = bit(bits, r) as usize;
                    if stays {
                        t.own_ray[h][v] += 1;
                    } else if parallel && crosses {
                        t.parallel_ray[h][v] += 1;
                    }
                }
            }

            // Masks marching exactly to the point's stop height, to the map's (the height
            // a mask serving this depth needs without region shrinking), and about twice as
            // far (a mask serving deeper points too).
            let h_map = stop_height(map.z_min, pz);
            let h_far = stop_height(0.5 * map.z_min, pz);
            for h_build in [h_stop, h_map, h_far] {
                assert!(h_build >= h_stop);
                let mask = Mask::build(offset, pz, samples.clone(), map.pitch, h_build);
                // A mask may keep its rays in its own order (bit r of a query is ray
                // `mask.samples[r]`): the same set of samples, compared in the mask's order.
                assert!(same_samples(&mask.samples, &samples), "the mask's samples are not the given ones");
                let oracle: Vec<Vec<u64>> = if mask.samples == samples {
                    oracle.clone()
                } else {
                    READINGS.iter().map(|&hf| march(&map, &mp, &mask.samples, hf)).collect()
                };
                for (h, &hf) in READINGS.iter().enumerate() {
                    let (b, culled) = query_stats(&map, &mp, &mask, hf);
                    t.blocks_culled += culled;
                    let a = &oracle[h];
                    t.compared += n as u64;
                    let d = differing(a, &b);
                    t.differing += d;
                    if d > 0 && reports.len() < 12 {
                        let r = (0..n).find(|&r| bit(a, r) != bit(&b, r)).unwrap();
                        reports.push(format!(
                            "case {case} {hf:?}: {d} bits differ, first ray {r} sample {:?} (march {}, mask \
                             {}); pixel {:?} of {res}^2, offset {offset:?}, pz {pz}, own depth {}, \
                             h_own {h_own}, h_stop {h_stop}, h_build {h_build}, n {n}",
                            mask.samples[r],
                            bit(a, r),
                            bit(&b, r),
                            mp.pixel,
                            map.at(i, j),
                        ));
                    }
                }
            }
        }
    }

    let names = ["solid", "shells", "plates"];
    println!(
        "{} cases (points), {} rays each under 3 readings; {} mask bits compared with march bits \
         (3 mask heights), {} differing",
        t.cases,
        t.bits / 3,
        t.compared,
        t.differing
    );
    for (h, name) in names.iter().enumerate() {
        println!(
            "{:>6}: {} blocked, {} visible; {} cases partly visible; own-pixel ray blocked/visible {:?}, \
             grid-parallel rays {:?}",
            name,
            t.blocked[h],
            t.bits / 3 - t.blocked[h],
            t.partial[h],
            t.own_ray[h],
            t.parallel_ray[h]
        );
    }
    println!("blocks of filter regions culled whole: {}", t.blocks_culled);
    println!(
        "readings differ: solid/shells {}, shells/plates {}, solid/plates {} bits",
        t.readings_differ[0], t.readings_differ[1], t.readings_differ[2]
    );
    println!(
        "floor heights set to crossing heights {}; crossings exactly at the entered pixel's floor {}",
        t.floor_ties_made, t.floor_ties
    );
    println!(
        "points behind their floor {}, exactly on it {}, on a pixel boundary {}; trivially lit (stop \
         height <= 0) {}; stop height lowered by region shrinking {}; regions clipped {}; corner \
         crossings {}",
        t.behind_own_floor, t.on_own_floor, t.on_boundary, t.trivial, t.shrunk, t.clipped, t.corner_crossings
    );
    for r in &reports {
        println!("{r}");
    }

    assert_eq!(t.differing, 0, "edge_table and depth_march disagree:\n{}", reports.join("\n"));

    // The comparison is not trivial: many blocked and many visible bits under every reading,
    // many penumbra cases, the readings differ (so mixing them up would be caught), and the
    // special configurations occurred.
    assert!(t.cases >= 300 && t.trivial < t.cases / 5 && t.shrunk > t.cases / 5);
    let per_reading = t.bits / 3;
    for (h, name) in names.iter().enumerate() {
        assert!(t.blocked[h] > per_reading / 5, "{}: too few blocked bits", name);
        assert!(per_reading - t.blocked[h] > per_reading / 5, "{}: too few visible bits", name);
        assert!(t.partial[h] > t.cases / 5, "{}: too few penumbra cases", name);
        assert!(t.own_ray[h].iter().all(|&c| c > 10), "{}: own-pixel ray {:?}", name, t.own_ray[h]);
        assert!(t.parallel_ray[h].iter().all(|&c| c > 50), "{}: parallel rays {:?}", name, t.parallel_ray[h]);
    }
    assert!(
        t.readings_differ.iter().all(|&d| d > 1000),
        "readings differ too little: {:?}",
        t.readings_differ
    );
    assert!(t.behind_own_floor > 50 && t.on_own_floor > 20 && t.on_boundary > 50);
    assert!(t.corner_crossings > 1000 && t.floor_ties > 500);
    // Hierarchical culling took part (its skips are covered by the 0 differing bits).
    assert!(t.blocks_culled > 1000, "only {} blocks culled", t.blocks_culled);
}

/// A mask read mirrored (`Mask::query_mirrored`, how `mirrored` grids serve the sub-pixel
/// offsets above 1/2) gives, bit for bit, the oracle's answer at the mirror point: offset
/// (1 - fx, fy), (fx, 1 - fy) or both, in the same pixel, with the mask's samples reflected
/// the same way. Offsets are those whose mirror 1 - f is exact in f32 (the grids' cell
/// centres (a + 1/2) / g for g a power of two, and any f >= 1/2); pixels near depth steps,
/// every reading, with ties between crossings and floors in half the cases.
#[test]
fn mirrored_masks_match_depth_march_at_the_mirror_point() {
    let mut rng = Random(Rng::new(0x0005_eed0_fa11_0e55));
    let (mut compared, mut differing_bits, mut blocked, mut partial) = (0u64, 0u64, 0u64, 0u64);
    let mut reports = Vec::new();
    for m in 0..60 {
        let (map, ground) = random_map(&mut rng);
        let res = map.resolution as i32;
        for p in 0..4 {
            let [i, j] = pick_pixel(&mut rng, &map, (res / 6).max(2));
            let mut f = || {
                if rng.chance(0.7) {
                    let g = rng.pick(&[1u32, 2, 4, 8, 16]);
                    (rng.below(g as usize) as f32 + 0.5) / g as f32
                } else {
                    rng.range(0.5, 1.0)
                }
            };
            let offset = Vec2::new(f(), f());
            let depth_kind = rng.below(8);
            let pz = pick_depth(&mut rng, &map, &ground, i, j, depth_kind);
            let n = [64usize, 256, 1024][(m * 4 + p) % 3];
            let (samples, _) = light_samples(&mut rng, n, map.frame.half_size);
            let mp = MapPoint { pixel: [i, j], offset, z: pz };
            let map = if rng.chance(0.5) {
                let k = 1 + rng.below(12);
                tie_floors(&mut rng, &map, &mp, &samples, k).0
            } else {
                map.clone()
            };
            let (z_stop, _) = map.stop_depth(mp.pixel, pz);
            let h_stop = stop_height(z_stop, pz);
            let mask = Mask::build(offset, pz, samples, map.pitch, stop_height(map.z_min, pz));
            for mirror in [[true, false], [false, true], [true, true]] {
                let sign = Vec2::new(if mirror[0] { -1.0 } else { 1.0 }, if mirror[1] { -1.0 } else { 1.0 });
                let at = MapPoint {
                    offset: Vec2::new(
                        if mirror[0] { 1.0 - offset.x } else { offset.x },
                        if mirror[1] { 1.0 - offset.y } else { offset.y },
                    ),
                    ..mp
                };
                let reflected: Vec<Vec2> = mask.samples.iter().map(|s| *s * sign).collect();
                for hf in READINGS {
                    let a = march(&map, &at, &reflected, hf);
                    let mut b = [0xa5a5_a5a5_a5a5_a5a5u64; MAX_WORDS];
                    let at = MaskQuery { map: &map, base: mp.pixel, mirror, pz, h_stop };
                    mask.query_mirrored(&at, hf, &mut b);
                    let b = &b[..words(n)];
                    let d = differing(&a, b);
                    let visible = count(&a) as u64;
                    compared += n as u64;
                    differing_bits += d;
                    blocked += n as u64 - visible;
                    partial += (visible > 0 && visible < n as u64) as u64;
                    if d > 0 && reports.len() < 8 {
                        reports.push(format!(
                            "map {m} point {p} {hf:?} mirror {mirror:?}: {d} of {n} bits differ; offset \
                             {offset:?}, pixel {:?}, pz {pz}",
                            mp.pixel
                        ));
                    }
                }
            }
        }
    }
    println!("{compared} mirrored bits compared, {blocked} blocked, {partial} partly visible cases");
    assert_eq!(differing_bits, 0, "mirrored masks disagree with the march:\n{}", reports.join("\n"));
    // Not trivial: many blocked and visible bits, many penumbra cases.
    assert!(blocked > compared / 5 && compared - blocked > compared / 5, "{blocked} of {compared} blocked");
    assert!(partial > 100, "only {partial} penumbra cases");
}

/// The oracle against geometry, on hand-built maps: a flat floor, and a plate at depth 2 over
/// a floor at depth 4 covering either the point's whole filter region or a half-plane; for
/// points inside and on the sides and corners of their pixel. The masks must agree on each.
#[test]
fn oracle_matches_hand_built_cases() {
    let res = 64usize;
    let pitch = 0.02f32;
    let half = Vec2::splat(0.25);
    let origin = Vec2::splat(-0.5 * res as f32 * pitch);
    let pixel = [32i32, 32];
    let mut rng = Random(Rng::new(17));
    let (samples, _) = light_samples(&mut rng, 256, half);
    let n = samples.len();
    let w = words(n);
    let mut full = vec![0u64; w];
    fill_first(&mut full, n);
    let empty = vec![0u64; w];
    let floor = vec![4.0f32; res * res];
    let plate = |cols: std::ops::Range<usize>, rows: std::ops::Range<usize>| {
        let mut d = floor.clone();
        for y in rows {
            for x in cols.clone() {
                d[y * res + x] = 2.0;
            }
        }
        d
    };

    for offset in [Vec2::new(0.5, 0.25), Vec2::ZERO, Vec2::new(0.25, 0.0), Vec2::new(0.0, 0.75)] {
        // Both methods' bits at depth pz, for each reading (in the order of `samples`).
        let eval = |depth: &[f32], pz: f32| -> Vec<Vec<u64>> {
            let map = DepthMap::from_depths(frame(half), origin, pitch, res as u32, depth.to_vec());
            let mp = MapPoint { pixel, offset, z: pz };
            // Marching further than any ray can be blocked (to depth 1, half the plate's).
            let mask = Mask::build(offset, pz, samples.clone(), pitch, stop_height(1.0, pz));
            READINGS
                .iter()
                .map(|&hf| {
                    let a = march(&map, &mp, &samples, hf);
                    let in_mask_order = march(&map, &mp, &mask.samples, hf);
                    assert_eq!(
                        in_mask_order,
                        query(&map, &mp, &mask, hf),
                        "{hf:?} at pz {pz}, offset {offset}"
                    );
                    a
                })
                .collect()
        };

        // A flat floor: everything visible in front of it; everything blocked on it (ties
        // block; on a pixel side, rays leave at height -0.0 into a pixel whose floor is 0,
        // the stop height) and behind it.
        for bits in eval(&floor, 3.0) {
            assert_eq!(bits, full, "flat floor, offset {offset}");
        }
        for pz in [4.0, 5.0] {
            for bits in eval(&floor, pz) {
                assert_eq!(bits, empty, "flat floor, pz {pz}, offset {offset}");
            }
        }

        // A plate at depth 2 over the point (at depth 3) covering its whole filter region:
        // every ray rises through the plate.
        let reach = half.x * (1.0 / 2.0 - 1.0 / 3.0) / pitch; // pixels to the plate's height
        let r = reach.ceil() as usize + 2;
        let covered = plate(32 - r..32 + r + 1, 32 - r..32 + r + 1);
        for bits in eval(&covered, 3.0) {
            assert_eq!(bits, empty, "covered, offset {offset}");
        }

        // A plate over the half-plane of columns from `col` on. A ray from image point u_P to
        // sample L reaches the plate's depth 2 at s = pz / 2 - 1, at image position
        // u_P + s Lx / pz: it meets the plate's underside iff that is at or beyond the
        // plate's edge u_c, i.e. iff Lx >= (u_c - u_P) pz / s. Samples within 1e-3 of the
        // threshold are skipped (the depth map's arithmetic is f32).
        let pz = 3.5f32;
        let s_plate = (pz / 2.0 - 1.0) as f64;
        let u_p = origin.x as f64 + (pixel[0] as f64 + offset.x as f64) * pitch as f64;
        for (col, point_under_plate) in [(34usize, false), (31, true)] {
            let bits = eval(&plate(col..res, 0..res), pz);
            let u_c = origin.x as f64 + col as f64 * pitch as f64;
            let threshold = (u_c - u_p) * pz as f64 / s_plate;
            let (mut hits, mut checked) = (0, 0);
            for (r, s) in samples.iter().enumerate() {
                if (s.x as f64 - threshold).abs() < 1e-3 {
                    continue;
                }
                let meets_plate = s.x as f64 >= threshold;
                hits += meets_plate as usize;
                checked += 1;
                for (h, &hf) in READINGS.iter().enumerate() {
                    // In front of the floor all readings block exactly the rays that meet the
                    // plate. Under the plate the solid reading blocks everything; shells and
                    // plates let through the rays that leave the plate's columns below it
                    // (the inner penumbra, note 5.5).
                    let expect_visible = if point_under_plate {
                        hf != Heightfield::Solid && !meets_plate
                    } else {
                        !meets_plate
                    };
                    assert_eq!(
                        bit(&bits[h], r),
                        expect_visible,
                        "{hf:?}, plate from column {col}, sample {s:?}, offset {offset}"
                    );
                }
            }
            // Both outcomes occur in numbers.
            assert!(hits > n / 16 && hits < n - n / 16, "plate from column {col}: {hits} of {n} meet it");
            assert!(checked > n - 20, "{checked} of {n}");
        }
    }

    // Under the half-plane plate, a step two pixels beyond its edge whose floor is exactly the
    // height at which the lowest ray enters it through that side (the sample (-half.x, 0),
    // which has left the plate's columns below the plate): ties block, as a wall under
    // shells and as a floor the ray then rises through under plates.
    let offset = Vec2::new(0.5, 0.25);
    let pz = 3.5f32;
    let mut lowest = (f32::INFINITY, 0);
    for (r, s) in samples.iter().enumerate() {
        for_each_crossing(offset, *s, pz * pitch, stop_height(2.0, pz), |c, axis, h| {
            if c == [-3, 0] && axis == 0 && h < lowest.0 {
                lowest = (h, r);
            }
            true
        });
    }
    let (h_tie, r_tie) = lowest;
    assert_eq!(samples[r_tie], Vec2::new(-half.x, 0.0));
    let mut d = (pz * (1.0 - h_tie)).next_down().next_down();
    while floor_height(d, pz) != h_tie {
        d = d.next_up();
        assert!(d < pz * (1.0 - h_tie) * 1.0001, "no depth with floor height {h_tie}");
    }
    let mut stepped = plate(31..res, 0..res);
    for y in 0..res {
        stepped[y * res + 29] = d;
    }
    let map = DepthMap::from_depths(frame(half), origin, pitch, res as u32, stepped.clone());
    let mp = MapPoint { pixel, offset, z: pz };
    let mask = Mask::build(offset, pz, samples.clone(), pitch, stop_height(1.0, pz));
    let without_step = DepthMap::from_depths(frame(half), origin, pitch, res as u32, plate(31..res, 0..res));
    for hf in READINGS {
        let a = march(&map, &mp, &samples, hf);
        assert!(!bit(&a, r_tie), "{hf:?}: the ray entering the step at its floor height is not blocked");
        if hf != Heightfield::Solid {
            assert!(bit(&march(&without_step, &mp, &samples, hf), r_tie), "{hf:?}: the ray was not lit");
        }
        assert_eq!(march(&map, &mp, &mask.samples, hf), query(&map, &mp, &mask, hf), "{hf:?} at the step");
    }
}
