//! `render --tile K/N` and `penumbra merge`: the tiles of a frame merge to the single
//! render's bytes (PNG, EXR, every AOV) and report (counters, warnings), for every method,
//! with and without paths; a bad set of tiles is refused on one line, exit 2, nothing
//! written.

use crate::common::tiny_scene;
use crate::common::{self, folders};
use folders::temp_dir;

use penumbra::merge::{MergeArgs, run_merge};
use penumbra::request::Overrides;
use penumbra::run_report::RunReport;
use penumbra::tile::TileSpec;
use penumbra::{RenderArgs, run_render};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The tiny scene with two lights that shade it and a third that faces up, away from
/// everything (so the frame warns of it); its top rows see only sky (so the first of 16
/// tiles sees nothing, which the frame must not warn of).
fn scene(dir: &Path) -> PathBuf {
    let text = format!(
        "{}{}",
        tiny_scene::TINY_SCENE,
        r#"
[[light]]
center = [-0.8, 1.6, -0.2]
u = [0.3, 0.0, 0.0]
v = [0.0, 0.0, 0.3]
radiance = [3.0, 4.0, 5.0]
[[light]]
center = [0.0, 3.0, 0.0]
u = [0.0, 0.0, 0.3]
v = [0.3, 0.0, 0.0]
radiance = [1.0, 1.0, 1.0]
"#
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn args(scene: &Path, method: &str, max_depth: u32, out: PathBuf) -> RenderArgs {
    RenderArgs {
        scene: Some(scene.to_path_buf()),
        keys: Overrides {
            shadows: Some(method.to_string()),
            samples: Some(16),
            width: Some(40),
            height: Some(32),
            spp: Some(4),
            max_depth: Some(max_depth),
            ..Overrides::default()
        },
        out: Some(out),
        aov: true,
        quiet: true,
        threads: Some(2),
        ..RenderArgs::default()
    }
}

/// Renders tiles K = 0..n of `base`'s settings beside `stem`; returns their reports' paths.
fn render_tiles(base: &RenderArgs, n: u32, stem: &Path) -> Vec<PathBuf> {
    (0..n)
        .map(|k| {
            let out = PathBuf::from(format!("{}.tile-{k}.png", stem.display()));
            let a = RenderArgs {
                tile: Some(TileSpec { index: k, count: n }),
                out: Some(out.clone()),
                ..base.clone()
            };
            run_render(&a).unwrap_or_else(|e| panic!("tile {k}/{n}: {e}"));
            out.with_extension("json")
        })
        .collect()
}

fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn tiles_merge_to_the_single_renders_bytes_for_every_method_and_depth() {
    let dir = temp_dir("bytes");
    let scene = scene(&dir);
    let files = [
        "png",
        "exr",
        "visibility.0.exr",
        "visibility.0.png",
        "visibility.1.exr",
        "visibility.1.png",
        "visibility.2.exr",
        "base_color.exr",
        "metallic.exr",
        "roughness.exr",
        "normal.exr",
    ];
    // Outside CI (common::full_sweeps) each method at one of the two depths, alternating.
    for (j, method) in penumbra::methods::METHODS.iter().map(|m| m.name).enumerate() {
        for (d, max_depth) in [2, 5].into_iter().enumerate() {
            if !common::sweep_keeps(j + d, 0) {
                continue;
            }
            let single = dir.join(format!("{method}-{max_depth}.png"));
            let base = args(&scene, method, max_depth, single.clone());
            let report = run_render(&base).unwrap().report;
            for n in [1, 2, 7, 16] {
                let stem = dir.join(format!("{method}-{max_depth}-{n}"));
                let tiles = render_tiles(&base, n, &stem);
                let merged = stem.with_extension("png");
                let m = run_merge(&MergeArgs {
                    out: merged.clone(),
                    tiles: tiles.into_iter().rev().collect(),
                    quiet: true,
                })
                .unwrap_or_else(|e| panic!("{method} depth {max_depth}, {n} tiles: {e}"));
                for f in files {
                    let (a, b) = (single.with_extension(f), merged.with_extension(f));
                    assert!(read(&a) == read(&b), "{method} depth {max_depth}, {n} tiles: {f} differs");
                }
                let what = format!("{method} depth {max_depth}, {n} tiles");
                // The whole report but what differs by nature: timings, files, threads, tiles.
                let fields = |r: &RunReport| {
                    let mut v = serde_json::to_value(r).unwrap();
                    for key in ["timings_s", "outputs", "threads", "tiles"] {
                        v.as_object_mut().unwrap().remove(key);
                    }
                    v
                };
                assert_eq!(fields(&m), fields(&report), "{what}: the report");
                assert_eq!(m.tiles.as_ref().map(Vec::len), Some(n as usize), "{what}: each tile's run kept");
            }
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_tile_of_sky_does_not_warn_but_the_merged_frame_does_of_the_light_facing_away() {
    let dir = temp_dir("warnings");
    let scene = scene(&dir);
    let base = args(&scene, "traced", 2, dir.join("single.png"));
    let single = run_render(&base).unwrap().report;
    assert_eq!(
        single.warnings,
        [
            "light 2 reaches no visible point: every point the camera sees is behind its emitting side or below \
          the light's horizon"
        ]
    );
    let tiles = render_tiles(&base, 16, &dir.join("t"));
    let first: RunReport = serde_json::from_slice(&read(&tiles[0])).unwrap();
    let info = first.tile.as_ref().unwrap();
    assert_eq!((info.index, info.count, info.rows), (0, 16, [0, 2]));
    assert_eq!(info.tally.visible, 0, "the top rows see only sky");
    assert!(
        first.warnings.is_empty(),
        "a tile leaves the frame's warnings to the merge: {:?}",
        first.warnings
    );
    let merged = run_merge(&MergeArgs { out: dir.join("m.png"), tiles, quiet: true }).unwrap();
    assert_eq!(merged.warnings, single.warnings);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn profiled_tiles_merge_to_the_same_work_layers() {
    use exr::prelude::{FlatSamples, read_all_flat_layers_from_file};
    let dir = temp_dir("profile");
    let scene = scene(&dir);
    let base = RenderArgs { profile: true, ..args(&scene, "traced", 5, dir.join("single.png")) };
    let single = run_render(&base).unwrap().report;
    let tiles = render_tiles(&base, 7, &dir.join("t"));
    let merged = run_merge(&MergeArgs { out: dir.join("m.png"), tiles, quiet: true }).unwrap();
    let layers = |p: PathBuf| {
        let image = read_all_flat_layers_from_file(p).unwrap();
        image.layer_data[0]
            .channel_data
            .list
            .iter()
            .filter_map(|c| match &c.sample_data {
                FlatSamples::U32(v) => Some((c.name.to_string(), v.clone())),
                _ => None,
            })
            .collect::<Vec<_>>()
    };
    // Times differ from run to run; the work counted per pixel does not.
    let (a, b) = (layers(dir.join("single.cost.exr")), layers(dir.join("m.cost.exr")));
    assert_eq!(a.iter().map(|l| &l.0).collect::<Vec<_>>(), ["lookups.Y", "rays.Y", "shafts.Y"]);
    assert!(a == b, "the merged cost layers differ from the single render's");
    assert!(dir.join("m.cost.png").exists());
    let (p, q) = (single.profile.unwrap(), merged.profile.unwrap());
    assert_eq!((p.rays, p.shafts, p.lookups), (q.rays, q.shafts, q.lookups));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Runs `penumbra merge --out OUT tiles...`: its exit status and stderr.
fn merge_cli(out: &Path, tiles: &[PathBuf]) -> (Option<i32>, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .arg("merge")
        .arg("--out")
        .arg(out)
        .args(tiles)
        .output()
        .unwrap();
    (o.status.code(), String::from_utf8_lossy(&o.stderr).into_owned())
}

/// Asserts that merging `tiles` is refused: exit 2, one line naming `named` and saying
/// `says`, nothing written and no temporary file left in `dir`.
fn assert_refused(dir: &Path, what: &str, tiles: &[PathBuf], named: &Path, says: &str) {
    let (code, stderr) = merge_cli(&dir.join("merged").join("frame.png"), tiles);
    assert_eq!(code, Some(2), "{what}: {stderr}");
    assert_eq!(stderr.lines().count(), 1, "{what}: one line: {stderr}");
    assert!(stderr.starts_with(&format!("error: {}: ", named.display())), "{what}: names the file: {stderr}");
    assert!(stderr.contains(says), "{what}: says {says:?}: {stderr}");
    assert!(!dir.join("merged").exists(), "{what}: nothing written");
    let leftovers: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{what}: temporary files left: {leftovers:?}");
}

#[test]
fn bad_sets_of_tiles_name_the_file_on_one_line_exit_2_and_write_nothing() {
    let dir = temp_dir("bad");
    let scene = scene(&dir);
    let base = args(&scene, "traced", 2, dir.join("unused.png"));
    let t = render_tiles(&base, 3, &dir.join("t"));
    let o = render_tiles(
        &RenderArgs { keys: Overrides { samples: Some(32), ..base.keys.clone() }, ..base.clone() },
        3,
        &dir.join("o"),
    );
    // The same settings, another scene at the same path: the same fields, another
    // fingerprint.
    let original = read(&scene);
    let brighter = String::from_utf8(original.clone()).unwrap().replace("radiance = [8.0", "radiance = [9.0");
    std::fs::write(&scene, brighter).unwrap();
    let s = render_tiles(&base, 3, &dir.join("s"));
    std::fs::write(&scene, original).unwrap();
    let whole =
        run_render(&args(&scene, "traced", 2, dir.join("whole.png"))).unwrap().png.with_extension("json");
    let (t0, t1, t2) = (t[0].clone(), t[1].clone(), t[2].clone());
    assert_refused(
        &dir,
        "a tile missing",
        &[t0.clone(), t2.clone()],
        &t0,
        "tile.index: tile(s) 1 of 3 missing",
    );
    let twice = [t0.clone(), t1.clone(), t1.clone(), t2.clone()];
    assert_refused(&dir, "a tile twice", &twice, &t1, "tile 1 of 3 is given twice");
    let other = [t0.clone(), o[1].clone(), t2.clone()];
    assert_refused(&dir, "other samples", &other, &o[1], "samples: a tile of another render: 32, but 16");
    let another = [t0.clone(), t1.clone(), s[2].clone()];
    assert_refused(&dir, "another scene", &another, &s[2], "tile.fingerprint");
    assert_refused(&dir, "a whole render's report", std::slice::from_ref(&whole), &whole, "not a tile's");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn damaged_tiles_name_the_file_on_one_line_exit_2_and_write_nothing() {
    let dir = temp_dir("damaged");
    let scene = scene(&dir);
    let t = render_tiles(&args(&scene, "traced", 2, dir.join("unused.png")), 3, &dir.join("t"));
    // A copy of tile `k`'s report named `name`, its EXR and AOVs taken from tile `exr_of`, the
    // report's text edited by `edit`, the EXR cut to half with `cut`.
    let copy = |name: &str, k: usize, exr_of: usize, edit: (&str, &str), cut: bool| {
        let json = dir.join(name);
        let text = String::from_utf8(read(&t[k])).unwrap();
        assert!(text.contains(edit.0), "{} in {text}", edit.0);
        std::fs::write(&json, text.replace(edit.0, edit.1)).unwrap();
        let exr = read(&t[exr_of].with_extension("exr"));
        std::fs::write(json.with_extension("exr"), &exr[..if cut { exr.len() / 2 } else { exr.len() }])
            .unwrap();
        let visibility = (0..3).map(|k| format!("visibility.{k}.exr"));
        let surface = ["base_color", "metallic", "roughness", "normal"].map(|n| format!("{n}.exr"));
        for aov in visibility.chain(surface) {
            std::fs::copy(t[exr_of].with_extension(&aov), json.with_extension(&aov)).unwrap();
        }
        json
    };
    let cut_json = dir.join("cut.tile-1.json");
    std::fs::write(&cut_json, &read(&t[1])[..read(&t[1]).len() / 2]).unwrap();
    let cut_exr = copy("cutexr.tile-1.json", 1, 1, ("", ""), true);
    // Tiles 1 and 2 are both 11 rows: the size fits, the pixels are another tile's.
    let swapped = copy("swapped.tile-1.json", 1, 2, ("", ""), false);
    // Hand-edited numbers: errors, not a division by zero or an index out of bounds.
    let zero = copy("zero.tile-0.json", 0, 0, ("\"count\": 3", "\"count\": 0"), false);
    let beyond = copy("beyond.tile-0.json", 0, 0, ("\"index\": 0", "\"index\": 7"), false);
    let (t0, t2) = (t[0].clone(), t[2].clone());
    let with = |p: &PathBuf| [t0.clone(), p.clone(), t2.clone()];
    assert_refused(&dir, "a truncated report", &with(&cut_json), &cut_json, "not a tile report");
    let cut_exr_file = cut_exr.with_extension("exr");
    assert_refused(&dir, "truncated pixels", &with(&cut_exr), &cut_exr_file, "cannot read the tile's pixels");
    assert_refused(&dir, "another tile's pixels", &with(&swapped), &swapped, "tile.pixels: the pixel files");
    assert_refused(
        &dir,
        "zero tiles",
        std::slice::from_ref(&zero),
        &zero,
        "tile.count: must be in 1..=32, got 0",
    );
    let past = [t[1].clone(), beyond.clone(), t2.clone()];
    assert_refused(&dir, "an index past the count", &past, &beyond, "tile.index: 7 is not below");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn tile_flags_are_checked_before_anything_renders() {
    for (flag, says) in
        [("3/3", "K is 0-based"), ("1/0", "N must be in"), ("2", "expected K/N"), ("a/4", "expected K/N")]
    {
        let o = Command::new(env!("CARGO_BIN_EXE_penumbra"))
            .args(["render", "--tile", flag, "--quiet"])
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{flag}");
        assert!(
            String::from_utf8_lossy(&o.stderr).contains(says),
            "{flag}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let dir = temp_dir("flags");
    let scene = scene(&dir);
    let a = RenderArgs {
        tile: Some(TileSpec { index: 0, count: 33 }),
        ..args(&scene, "traced", 2, dir.join("x.png"))
    };
    let e = run_render(&a).unwrap_err().to_string();
    assert_eq!(
        e,
        format!("{}: --tile: 33 tiles of a 32-row image: at most one tile per row", scene.display())
    );
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "nothing written beside the scene");
    // The bands: every row once, in order, none empty.
    for (h, n) in [(32, 7), (480, 16), (5, 5), (1000, 3)] {
        let rows: Vec<_> = (0..n).map(|k| TileSpec { index: k, count: n }.rows(h)).collect();
        assert_eq!(rows[0].start, 0);
        assert_eq!(rows[n as usize - 1].end, h);
        assert!(rows.windows(2).all(|w| w[0].end == w[1].start && !w[0].is_empty()));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_precision_warning_merges_to_the_single_renders_line() {
    let dir = temp_dir("precision");
    let scene = scene(&dir);
    // A 1 m card 10^6 m away, where f32 positions are spaced 0.06 m: the scene holds a
    // triangle f32 cannot keep precise, and the warning gives the visible part's reach.
    let mut text = String::from_utf8(read(&scene)).unwrap();
    text.push_str("[[quad]]\ncenter = [0.0, 0.0, -1.0e6]\nu = [1.0, 0.0, 0.0]\nv = [0.0, 1.0, 0.0]\n");
    std::fs::write(&scene, text).unwrap();
    let base = args(&scene, "traced", 2, dir.join("single.png"));
    let single = run_render(&base).unwrap().report;
    assert!(
        single.warnings.iter().any(|w| w.starts_with("the visible part lies within")),
        "{:?}",
        single.warnings
    );
    let tiles = render_tiles(&base, 7, &dir.join("t"));
    let merged = run_merge(&MergeArgs { out: dir.join("m.png"), tiles, quiet: true }).unwrap();
    assert_eq!(merged.warnings, single.warnings);
    std::fs::remove_dir_all(&dir).unwrap();
}
