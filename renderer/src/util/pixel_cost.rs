//! Where shading time goes, per pixel (`render --profile`): the wall time of each pixel's
//! shading (all its samples and lights) and the work the shadow methods did for it.
//!
//! The work is counted in per-thread counters that the BVH queries bump themselves
//! ([`Scene::occluded`](crate::Scene::occluded): a ray; [`Scene::shaft_clear`](crate::Scene::shaft_clear):
//! a shaft) and that a plugin bumps for its own unit of work ([`count_lookups`]: a table
//! lookup). A thread-local add costs about a nanosecond against the 50-200 ns of a traced
//! ray, so the counters are always on; only the per-pixel clock is read when profiling.
//! Rayon runs each row band on one thread, so a pixel's work is the difference of its
//! thread's counters before and after it.

use std::cell::Cell;

thread_local! {
    static RAYS: Cell<u64> = const { Cell::new(0) };
    static SHAFTS: Cell<u64> = const { Cell::new(0) };
    static LOOKUPS: Cell<u64> = const { Cell::new(0) };
    static FALLBACKS: Cell<u64> = const { Cell::new(0) };
}

/// One traced ray (any-hit or closest-hit query through the BVH).
#[inline]
pub fn count_ray() {
    RAYS.with(|c| c.set(c.get() + 1));
}

/// One shaft proven or refuted through the BVH.
#[inline]
pub fn count_shaft() {
    SHAFTS.with(|c| c.set(c.get() + 1));
}

/// `n` table lookups (a plugin's own unit of work: an edge table's cell, a depth-map texel).
#[inline]
pub fn count_lookups(n: u64) {
    LOOKUPS.with(|c| c.set(c.get() + n));
}

/// One query a depth-map method did not answer from its map (off it, grazed, or below its
/// horizon rule) and handed to traced rays.
#[inline]
pub fn count_fallback() {
    FALLBACKS.with(|c| c.set(c.get() + 1));
}

/// The calling thread's work counters so far.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Work {
    pub rays: u64,
    pub shafts: u64,
    pub lookups: u64,
    pub fallbacks: u64,
}

impl Work {
    /// This thread's counts since it started.
    pub fn now() -> Self {
        Work {
            rays: RAYS.with(Cell::get),
            shafts: SHAFTS.with(Cell::get),
            lookups: LOOKUPS.with(Cell::get),
            fallbacks: FALLBACKS.with(Cell::get),
        }
    }

    /// The work done between `earlier` and `self` (both of this thread).
    pub fn since(self, earlier: Work) -> Work {
        Work {
            rays: self.rays - earlier.rays,
            shafts: self.shafts - earlier.shafts,
            lookups: self.lookups - earlier.lookups,
            fallbacks: self.fallbacks - earlier.fallbacks,
        }
    }
}

/// One pixel's shading cost: the wall time of its shading (every sample and light: the
/// irradiance, the albedo and every shadow query; not its primary rays, not `prepare`) and
/// the shadow work done for it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PixelCost {
    pub time_s: f32,
    pub work: Work,
}

/// Sums over an image's pixels: (seconds, work).
pub fn totals(costs: &[PixelCost]) -> (f64, Work) {
    costs.iter().fold((0.0, Work::default()), |(t, w), c| {
        (
            t + c.time_s as f64,
            Work {
                rays: w.rays + c.work.rays,
                shafts: w.shafts + c.work.shafts,
                lookups: w.lookups + c.work.lookups,
                fallbacks: w.fallbacks + c.work.fallbacks,
            },
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counters_are_per_thread_and_differences_count_the_work_between() {
        let before = Work::now();
        count_ray();
        count_ray();
        count_shaft();
        count_lookups(5);
        count_fallback();
        let done = Work::now().since(before);
        assert_eq!(done, Work { rays: 2, shafts: 1, lookups: 5, fallbacks: 1 });
        // Another thread's work does not show on this one.
        let here = Work::now();
        std::thread::spawn(|| count_lookups(1000)).join().unwrap();
        assert_eq!(Work::now().since(here), Work::default());
    }
}
