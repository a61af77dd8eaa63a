//! The differential tests of the exact methods: a wrapping method ([`Checked`]) that checks
//! each query of the method it wraps (its decided verdicts against traced rays, its answer
//! against tracing every sample it draws), scenes rendered through the CLI's render path with
//! it, and the run report's counters read and summed.

#![allow(dead_code)] // each test binary uses a different subset

use penumbra::{RenderArgs, run_render};
use renderer::{
    KeepInstances, LightShadowing, PrepareContext, Scene, ShadowError, ShadowMethod, ShadowQuery,
};
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// A scene file of the checkout (`scenes/...`).
pub fn scene(relative: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(relative)
}

/// What a differential test checks of one exact method; [`Checked`] wraps it as the light's
/// method and keeps the counters.
pub trait Verdicts: Send + Sync + 'static {
    /// The method's name as the scene file spells it.
    const NAME: &'static str;
    /// The report's names for the two kinds of verdict counted (the first two of
    /// [`Verdicts::check`]'s counts).
    const KINDS: [&'static str; 2];

    /// Prepares the method, and whatever it is held against, for `ctx.light`.
    fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError>;

    /// The query's verdicts checked against traced rays: how many of either kind, and how
    /// many a traced ray disagrees with.
    fn check(&self, scene: &Scene, q: &ShadowQuery) -> [u64; 3];

    /// The method's visibility, then that of tracing every one of its samples.
    fn answers(&self, scene: &Scene, q: &ShadowQuery) -> (f32, f32);

    /// The method's own counters, reported ahead of the checks'.
    fn counters(&self) -> Vec<(&'static str, u64)> {
        Vec::new()
    }

    /// The bytes the prepared method holds, as it tells the memory budget.
    fn memory_bytes(&self) -> u64 {
        0
    }
}

/// `V` as a light's method, counting its checks: the verdicts of [`Verdicts::KINDS`],
/// `checked_wrong` (verdicts a traced ray disagrees with) and `answers_differ` (queries whose
/// answer is not, bit for bit, that of tracing the same samples).
pub struct Checked<V> {
    inner: V,
    kinds: [AtomicU64; 2],
    wrong: AtomicU64,
    answers_differ: AtomicU64,
}

impl<V: Verdicts> LightShadowing for Checked<V> {
    fn name(&self) -> &'static str {
        V::NAME
    }
    fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError> {
        self.inner.prepare(ctx)
    }
    fn visibility(&self, scene: &Scene, q: &ShadowQuery) -> f32 {
        let [first, second, wrong] = self.inner.check(scene, q);
        self.kinds[0].fetch_add(first, Ordering::Relaxed);
        self.kinds[1].fetch_add(second, Ordering::Relaxed);
        self.wrong.fetch_add(wrong, Ordering::Relaxed);
        let (v, traced) = self.inner.answers(scene, q);
        if v.to_bits() != traced.to_bits() {
            self.answers_differ.fetch_add(1, Ordering::Relaxed);
        }
        v
    }
    fn counters(&self) -> Vec<(&'static str, u64)> {
        let mut c = self.inner.counters();
        c.push((V::KINDS[0], self.kinds[0].load(Ordering::Relaxed)));
        c.push((V::KINDS[1], self.kinds[1].load(Ordering::Relaxed)));
        c.push(("checked_wrong", self.wrong.load(Ordering::Relaxed)));
        c.push(("answers_differ", self.answers_differ.load(Ordering::Relaxed)));
        c
    }
    fn memory_bytes(&self) -> u64 {
        self.inner.memory_bytes()
    }
}

/// The method that builds a [`Checked`] `V` per light (`build` takes the sample count), up to
/// 4096 samples.
pub struct CheckedMethod<V>(fn(u32) -> V);

impl<V: Verdicts> CheckedMethod<V> {
    /// The method, ready for [`RenderArgs::method`].
    pub fn shared(build: fn(u32) -> V) -> Arc<dyn ShadowMethod> {
        Arc::new(Self(build))
    }
}

impl<V> fmt::Debug for CheckedMethod<V> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "CheckedMethod<{}>", std::any::type_name::<V>())
    }
}

impl<V: Verdicts> ShadowMethod for CheckedMethod<V> {
    fn name(&self) -> &'static str {
        V::NAME
    }
    fn max_samples(&self) -> u32 {
        4096
    }
    fn build(&self, samples: u32) -> Box<dyn LightShadowing> {
        Box::new(Checked {
            inner: (self.0)(samples),
            kinds: [AtomicU64::new(0), AtomicU64::new(0)],
            wrong: AtomicU64::new(0),
            answers_differ: AtomicU64::new(0),
        })
    }
}

/// The counters `keys` of `scenes` rendered at `dims` (width, height, samples) through
/// `method`, printed per scene and summed, with instances kept as `keep` says (`None`: the
/// method's rule). Asserts that no verdict disagreed with the BVH and that every answer
/// equalled tracing the same samples: `keys` must name `checked_wrong` and `answers_differ`.
pub fn check_all<const K: usize>(
    scenes: &[PathBuf],
    dims: (u32, u32, u32),
    method: &Arc<dyn ShadowMethod>,
    tag: &str,
    keys: [&str; K],
    keep: Option<KeepInstances>,
) -> [u64; K] {
    let at = |key| keys.iter().position(|k| *k == key).unwrap_or_else(|| panic!("{key} not among {keys:?}"));
    let (wrong, differ) = (at("checked_wrong"), at("answers_differ"));
    let total = summed(scenes, |s| {
        let got = counters_kept(s, dims, method.clone(), tag, keys, keep);
        eprintln!("{}: {}", s.display(), listed(&keys, &got));
        got
    });
    eprintln!("{}, total: {}", method.name(), listed(&keys, &total));
    assert_eq!(total[wrong], 0, "{}: verdicts the BVH disagrees with", method.name());
    assert_eq!(total[differ], 0, "{}: answers differing from tracing the same samples", method.name());
    total
}

/// `key value, ...`.
fn listed(keys: &[&str], values: &[u64]) -> String {
    keys.iter().zip(values).map(|(k, v)| format!("{k} {v}")).collect::<Vec<_>>().join(", ")
}

/// The run report's counters `keys` after rendering `scene` at `width` x `height` with
/// `samples` through `method`; the image files are removed (`tag` names their folder).
pub fn counters<const K: usize>(
    scene: &Path,
    dims: (u32, u32, u32),
    method: Arc<dyn ShadowMethod>,
    tag: &str,
    keys: [&str; K],
) -> [u64; K] {
    counters_kept(scene, dims, method, tag, keys, None)
}

/// [`counters`] with instances kept unflattened or not as `keep` says (`None`: the method's
/// rule).
pub fn counters_kept<const K: usize>(
    scene: &Path,
    (width, height, samples): (u32, u32, u32),
    method: Arc<dyn ShadowMethod>,
    tag: &str,
    keys: [&str; K],
    keep: Option<renderer::KeepInstances>,
) -> [u64; K] {
    let dir = std::env::temp_dir().join(format!("penumbra-{tag}-{}", std::process::id()));
    let stem = scene.file_stem().unwrap().to_string_lossy().to_string();
    let out = dir.join(format!("{stem}.png"));
    let args = RenderArgs {
        scene: Some(scene.to_path_buf()),
        keys: penumbra::request::Overrides {
            samples: Some(samples),
            width: Some(width),
            height: Some(height),
            method: Some(method),
            max_depth: paths_depth(scene),
            ..Default::default()
        },
        out: Some(out.clone()),
        quiet: true,
        keep_instances: keep,
        ..Default::default()
    };
    let outcome = run_render(&args).unwrap_or_else(|e| panic!("{}: {e}", scene.display()));
    for suffix in ["png", "exr", "json"] {
        let _ = std::fs::remove_file(out.with_extension(suffix));
    }
    let c = &outcome.report.counters;
    keys.map(|k| *c.get(k).unwrap_or_else(|| panic!("{k} missing from {c:?}")))
}

/// The scene files of `scenes/gltf` and `scenes/bench` render direct light only
/// (`max_depth = 2`, for a clean picture at 1 spp); the checks follow their paths as they
/// did before (`--max-depth 5`: three bounces), so they still meet the secondary vertices.
/// Other scenes keep their own setting.
fn paths_depth(scene: &Path) -> Option<u32> {
    let dir = scene.parent().and_then(|d| d.file_name()).and_then(|d| d.to_str());
    let in_scenes = scene.parent().and_then(|d| d.parent()).is_some_and(|d| d.ends_with("scenes"));
    (in_scenes && matches!(dir, Some("gltf" | "bench"))).then_some(5)
}

/// `check`'s counters summed over `scenes`.
pub fn summed<const K: usize>(scenes: &[std::path::PathBuf], check: impl Fn(&Path) -> [u64; K]) -> [u64; K] {
    scenes.iter().map(|s| check(s)).fold([0; K], |mut total, got| {
        for (t, g) in total.iter_mut().zip(got) {
            *t += g;
        }
        total
    })
}
