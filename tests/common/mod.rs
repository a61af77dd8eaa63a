//! What the integration tests share (`tests/suite/`): each module used by some of them.
#![allow(dead_code)] // each test module uses its own subset

pub mod checked;
pub mod folders;
pub mod gltf_writer;
pub mod material_quad;
pub mod quads;
pub mod shared;
pub mod soups;
pub mod sphere;
#[macro_use]
pub mod tiny_scene;

/// Whether the largest sweeps run whole: under CI (the `CI` variable set, not "false" or
/// "0", as `.ci/run` runs) or with `PENUMBRA_FULL_TESTS=1`. Otherwise (the README's test
/// command on a fresh clone, which must take minutes, not a quarter of an hour) they check
/// every other case of the same sweep with the same assertions: the cases alternate, so
/// each family and each method is still checked. CONTRIBUTING.md, "Build and test".
pub fn full_sweeps() -> bool {
    let set = |name: &str| std::env::var(name).is_ok_and(|v| !v.is_empty() && v != "false" && v != "0");
    set("CI") || set("PENUMBRA_FULL_TESTS")
}

/// The cases a sweep checks: all of them under [`full_sweeps`], else every other one
/// (`k % 2 == parity`), so that two sweeps over the same list can split it.
pub fn sweep_keeps(k: usize, parity: usize) -> bool {
    sweep_keeps_one_in(2, k, parity)
}

/// [`sweep_keeps`] for the costliest sweeps: one case in `stride` outside CI.
pub fn sweep_keeps_one_in(stride: usize, k: usize, parity: usize) -> bool {
    full_sweeps() || k % stride == parity % stride
}

/// `items` as a sweep checks them: all under [`full_sweeps`], else every other one.
pub fn sweep<T>(items: Vec<T>, parity: usize) -> Vec<T> {
    items.into_iter().enumerate().filter(|(k, _)| sweep_keeps(*k, parity)).map(|(_, t)| t).collect()
}

/// A floor on what a sweep counted (settled samples, ...), against a vacuous pass: the full
/// sweep's `floor`, or a quarter of it for every other case (cases differ in size).
pub fn sweep_floor(floor: u64) -> u64 {
    if full_sweeps() { floor } else { floor / 4 }
}
