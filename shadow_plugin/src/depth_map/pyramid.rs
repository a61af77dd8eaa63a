//! The min-depth pyramid of a depth map: a lower bound of the depths over any pixel
//! rectangle in a few reads (region shrinking, `DepthMap::stop_depth`, and block culling,
//! `DepthMap::min_depth`).

/// Min-depth mip levels: level l holds the minimum over 2^l x 2^l pixel blocks.
#[derive(Debug, Clone)]
pub(super) struct MinPyramid {
    levels: Vec<(usize, Vec<f32>)>,
}

impl MinPyramid {
    pub(super) fn new(depth: &[f32], n: usize) -> Self {
        let mut levels = vec![(n, depth.to_vec())];
        while levels.last().unwrap().0 > 1 {
            let (m, prev) = levels.last().unwrap();
            let (m, half) = (*m, m.div_ceil(2));
            let mut next = vec![f32::INFINITY; half * half];
            for j in 0..m {
                for i in 0..m {
                    let d = &mut next[(j / 2) * half + i / 2];
                    *d = d.min(prev[j * m + i]);
                }
            }
            levels.push((half, next));
        }
        Self { levels }
    }

    /// A lower bound of the depths in the pixel rectangle [lo, hi] (clipped to the map):
    /// the minimum over the blocks of the first level where it spans at most 4 blocks.
    pub(super) fn min(&self, lo: [i32; 2], hi: [i32; 2]) -> f32 {
        let n0 = self.levels[0].0 as i32;
        let lo = [lo[0].clamp(0, n0 - 1), lo[1].clamp(0, n0 - 1)];
        let hi = [hi[0].clamp(0, n0 - 1), hi[1].clamp(0, n0 - 1)];
        let span = (hi[0] - lo[0]).max(hi[1] - lo[1]) as u32;
        let l = (32 - (span / 4).leading_zeros()).min(self.levels.len() as u32 - 1) as usize;
        let (m, data) = &self.levels[l];
        let mut z = f32::INFINITY;
        for j in (lo[1] >> l)..=(hi[1] >> l) {
            for i in (lo[0] >> l)..=(hi[0] >> l) {
                z = z.min(data[j as usize * m + i as usize]);
            }
        }
        z
    }
}
