//! The command line as a user meets it: outputs, determinism across thread counts, and bad
//! input (one line naming file and key, exit status 2, nothing written).

use crate::common::folders;
use folders::{penumbra, temp_dir};
use renderer::{ShadowMethod, TracedParams};
use shadow_plugin::EdgeTableParams;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;

const SCENE: &str = card_scene!("[shadows]\nmethod = \"traced\"\nsamples = 16\n");

#[test]
fn same_bytes_with_one_and_two_threads() {
    let dir = temp_dir("threads");
    // A floor wide enough that every primary ray hits it.
    let scene = SCENE
        .replace("u = [2.0, 0.0, 0.0]\nv = [0.0, 0.0, -2.0]", "u = [40.0, 0.0, 0.0]\nv = [0.0, 0.0, -40.0]");
    assert_ne!(scene, SCENE);
    std::fs::write(dir.join("s.toml"), scene).unwrap();
    for threads in ["1", "2"] {
        let out = format!("t{threads}/img.png");
        let o =
            penumbra(&["render", "s.toml", "--threads", threads, "--aov", "--spp", "2", "--out", &out], &dir);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    for file in [
        "img.png",
        "img.exr",
        "img.visibility.0.exr",
        "img.visibility.0.png",
        "img.base_color.exr",
        "img.metallic.exr",
        "img.roughness.exr",
        "img.normal.exr",
    ] {
        let a = std::fs::read(dir.join("t1").join(file)).unwrap();
        let b = std::fs::read(dir.join("t2").join(file)).unwrap();
        assert!(a == b, "{file} differs between 1 and 2 threads");
    }
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("t2/img.json")).unwrap()).unwrap();
    assert_eq!(report["threads"], 2);
    assert_eq!(report["method"], "traced");
    assert_eq!(report["samples"], 16);
    assert_eq!(report["spp"], 2);
    let phases = ["load", "bvh", "visible_points", "shadow_prepare", "render", "write"];
    let t = |key: &str| report["timings_s"][key].as_f64().unwrap_or_else(|| panic!("{key}"));
    for key in phases {
        assert!(t(key) >= 0.0, "{key}");
    }
    // The phases add up to the whole (to 1%, or 2 ms on a run this short).
    let sum: f64 = phases.iter().map(|k| t(k)).sum();
    assert!((t("total") - sum).abs() <= (0.01 * t("total")).max(0.002), "{sum} of {}", t("total"));
    // 48 x 32 pixels x 2 samples, every primary ray hits the floor.
    assert_eq!(report["counters"]["shading_points"], 48 * 32 * 2);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn visibility_aov_is_minus_one_on_misses_and_in_unit_range_on_hits() {
    let dir = temp_dir("aov");
    // Pull the camera back so the floor does not fill the frame.
    std::fs::write(dir.join("s.toml"), SCENE.replace("[0.0, 2.0, 3.0]", "[0.0, 6.0, 9.0]")).unwrap();
    let o = penumbra(&["render", "s.toml", "--aov", "--out", "a.png"], &dir);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let vis = image::open(dir.join("a.visibility.0.exr")).unwrap().into_rgb32f();
    let (mut misses, mut hits, mut shadowed) = (0, 0, 0);
    for p in vis.pixels() {
        let [r, g, b] = p.0;
        assert!(r == g && g == b);
        if r == -1.0 {
            misses += 1;
        } else {
            assert!((0.0..=1.0).contains(&r), "{r}");
            hits += 1;
            if r < 0.5 {
                shadowed += 1;
            }
        }
    }
    // The top corners see the sky; the centre sees the floor and the card's shadow.
    assert_eq!(vis.get_pixel(0, 0).0[0], -1.0);
    assert!(misses > 0 && hits > 0 && shadowed > 0, "{misses} {hits} {shadowed}");
    // The grey PNG: the visibility as linear grey, sRGB-encoded (to one 8-bit step), misses
    // in the marked blue.
    let grey = image::open(dir.join("a.visibility.0.png")).unwrap().into_rgb8();
    for (p, g) in vis.pixels().zip(grey.pixels()) {
        let v = p.0[0];
        if v == -1.0 {
            assert!(g.0[2] > g.0[0] && g.0[0] == 0, "a miss is blue: {:?}", g.0);
        } else {
            assert!(g.0[0] == g.0[1] && g.0[1] == g.0[2], "grey: {:?}", g.0);
            let expected = penumbra::output::encode_srgb8(v) as i32;
            assert!((g.0[0] as i32 - expected).abs() <= 1, "{v} -> {:?}, expected {expected}", g.0);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Runs a failing render and checks the contract for bad input.
fn assert_bad_input(dir: &Path, args: &[&str], must_name: &[&str]) {
    let o = penumbra(args, dir);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{args:?}: not one line: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    for needle in must_name {
        assert!(stderr.contains(needle), "{args:?}: {stderr:?} does not name {needle:?}");
    }
    let written: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.ends_with(".toml") && !n.ends_with(".gltf") && !n.ends_with(".bin"))
        .collect();
    assert!(written.is_empty(), "{args:?} left files behind: {written:?}");
}

#[test]
fn bad_input_gets_one_line_naming_file_and_key_and_exit_2() {
    let dir = temp_dir("bad");
    let write = |name: &str, text: &str| std::fs::write(dir.join(name), text).unwrap();
    let out = ["--out", "o.png"];
    let run = |scene: &str| -> Vec<String> {
        let mut v = vec!["render".to_string(), scene.to_string()];
        v.extend(out.iter().map(|s| s.to_string()));
        v
    };
    let check = |scene: &str, names: &[&str]| {
        let args = run(scene);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        assert_bad_input(&dir, &args, names);
    };

    // A missing scene file.
    check("nope.toml", &["nope.toml"]);
    // An unknown key.
    write("unknown.toml", &SCENE.replace("[image]", "[image]\nwidht = 3"));
    check("unknown.toml", &["unknown.toml", "image.widht"]);
    // A zero-area light.
    write(
        "zero.toml",
        &SCENE
            .replace("u = [0.5, 0.0, 0.0]\nv = [0.0, 0.0, 0.5]", "u = [0.5, 0.0, 0.0]\nv = [0.0, 0.0, 0.0]"),
    );
    check("zero.toml", &["zero.toml", "light[0].v"]);
    // A broken TOML file: the byte offset.
    write("broken.toml", "[camera\nposition = [");
    check("broken.toml", &["broken.toml", "byte "]);
    // A missing model file.
    write("nomodel.toml", &format!("[[model]]\npath = \"missing.gltf\"\n{SCENE}"));
    check("nomodel.toml", &["nomodel.toml", "model[0].path", "missing.gltf"]);
    // A broken glTF (truncated JSON).
    write("broken.gltf", "{\"asset\": {\"version\": \"2.0\"}, \"nodes\": [");
    write("brokengltf.toml", &format!("[[model]]\npath = \"broken.gltf\"\n{SCENE}"));
    check("brokengltf.toml", &["broken.gltf"]);
    // A NaN vertex.
    let mut bin = Vec::new();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, f32::NAN, 1.0, 0.0] {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(dir.join("nan.bin"), &bin).unwrap();
    write(
        "nan.gltf",
        r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],
"bufferViews":[{"buffer":0,"byteLength":36}],"buffers":[{"uri":"nan.bin","byteLength":36}]}"#,
    );
    write("nan.toml", &format!("[[model]]\npath = \"nan.gltf\"\n{SCENE}"));
    check("nan.toml", &["nan.gltf", "meshes[0].primitives[0].attributes.POSITION"]);
    // Bad flags.
    std::fs::write(dir.join("ok.toml"), SCENE).unwrap();
    assert_bad_input(&dir, &["render", "ok.toml", "--out", "o.jpg"], &["o.jpg", "--out"]);
    assert_bad_input(
        &dir,
        &["render", "ok.toml", "--samples", "0", "--out", "o.png"],
        &["--samples", "1..=65536", "got 0"],
    );
    // A sample count `traced` takes but the chosen method does not: the method's limit.
    assert_bad_input(
        &dir,
        &["render", "ok.toml", "--shadows", "edge_table", "--samples", "60000", "--out", "o.png"],
        &["ok.toml", "--samples", "edge_table"],
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The user's report: `--width -5` suggested "use '-- -5'", which then failed; `--width=-5`
/// said "not in 0..=4294967295" though the limit is 16384; `--height 1e3` said "invalid
/// digit found in string". Every whole-number flag now names its own range (the scene file
/// key's, in the same words), on one line, exit 2, nothing written.
#[test]
fn a_bad_flag_value_names_the_flag_and_its_range() {
    let dir = temp_dir("bad_flags");
    std::fs::write(dir.join("ok.toml"), SCENE).unwrap();
    let cases: [(&[&str], &[&str]); 8] = [
        (&["--width", "-5"], &["--width", "1..=16384", "got -5"]),
        (&["--width=-5"], &["--width", "1..=16384", "got -5"]),
        (&["--width", "abc"], &["--width", "1..=16384", "got abc"]),
        (&["--width", "99999"], &["--width", "1..=16384"]),
        (&["--height", "1e3"], &["--height", "1..=16384", "got 1e3"]),
        (&["--spp", "-1"], &["--spp", "1..=4096"]),
        (&["--max-depth", "1"], &["--max-depth", "2..=64"]),
        (&["--threads", "0"], &["--threads", "1..=1024"]),
    ];
    for (flags, names) in cases {
        let mut args = vec!["render", "ok.toml", "--out", "o.png"];
        args.extend_from_slice(flags);
        assert_bad_input(&dir, &args, names);
        let o = penumbra(&args, &dir);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!stderr.contains("tip:") && !stderr.contains("'-- "), "{args:?}: {stderr}");
    }
    // The same limit from the scene file, in the same words.
    std::fs::write(dir.join("wide.toml"), SCENE.replace("width = 48", "width = 99999")).unwrap();
    assert_bad_input(
        &dir,
        &["render", "wide.toml", "--out", "o.png"],
        &["wide.toml", "image.width", "1..=16384"],
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A scene file naming the retired `depth_march` (its method or its table) gets one line
/// naming the file and the key, saying the method was retired and what to use instead; exit
/// 2, nothing written. So does `--shadows depth_march` (clap's list of methods).
#[test]
fn a_retired_method_is_an_error_naming_its_replacement() {
    let dir = temp_dir("retired");
    let old = SCENE.replace("method = \"traced\"", "method = \"depth_march\"");
    assert_ne!(old, SCENE);
    std::fs::write(dir.join("old.toml"), old).unwrap();
    let needles =
        ["old.toml", "shadows.method", "retired", "edge_table", "2026-11-26-retired-depth-march.md"];
    assert_bad_input(&dir, &["render", "old.toml", "--out", "o.png"], &needles);
    // A `[shadows.depth_march]` table, whichever method renders.
    std::fs::write(dir.join("table.toml"), format!("{SCENE}\n[shadows.depth_march]\ndepth_map = 256\n"))
        .unwrap();
    let needles = ["table.toml", "shadows.depth_march", "retired", "edge_table"];
    assert_bad_input(&dir, &["render", "table.toml", "--out", "o.png"], &needles);
    std::fs::write(dir.join("ok.toml"), SCENE).unwrap();
    let o = penumbra(&["render", "ok.toml", "--shadows", "depth_march", "--out", "o.png"], &dir);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("depth_march") && stderr.contains("edge_table"), "{stderr}");
    assert!(!stderr.contains("panicked") && !dir.join("o.png").exists(), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A light low over a floor, the camera looking at floor points far to the side (beyond the
/// depth map's 76-degree limit) where an occluder's shadow falls: the depth-map methods must
/// answer those points with traced rays, not call them lit.
#[test]
fn points_outside_the_depth_map_fall_back_to_traced_rays() {
    let dir = temp_dir("outside");
    let scene = r#"
[camera]
position = [4.0, 4.0, 3.0]
look_at = [4.0, 0.0, 0.0]
yfov_deg = 40.0
[image]
width = 32
height = 32
[[light]]
center = [0.0, 0.5, 0.0]
u = [0.2, 0.0, 0.0]
v = [0.0, 0.0, 0.2]
radiance = [2000.0, 2000.0, 2000.0]
[[quad]]
center = [0.0, 0.0, 0.0]
u = [20.0, 0.0, 0.0]
v = [0.0, 0.0, -20.0]
[[quad]]
center = [2.5, 0.25, 0.0]
u = [1.0, 0.0, 0.0]
v = [0.0, 0.0, -1.0]
[shadows]
samples = 64
"#;
    std::fs::write(dir.join("s.toml"), scene).unwrap();
    let mut vis = Vec::new();
    for method in ["traced", "edge_table", "pcss"] {
        let out = format!("{method}.png");
        let o = penumbra(&["render", "s.toml", "--shadows", method, "--aov", "--out", &out], &dir);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v = image::open(dir.join(format!("{method}.visibility.0.exr"))).unwrap().into_rgb32f().into_raw();
        let report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.join(format!("{method}.json"))).unwrap()).unwrap();
        // The exact edge_table reading counts such points as `points_off_map` (every ray
        // of its own sample set traced); pcss falls back to traced.
        let off_map = if method == "edge_table" { "points_off_map" } else { "fallbacks" };
        if method != "traced" {
            assert!(report["counters"][off_map].as_u64().unwrap() > 0, "{method}: no {off_map}");
        }
        vis.push(v);
    }
    let shadowed = |v: &[f32]| v.iter().step_by(3).filter(|&&x| (0.0..0.5).contains(&x)).count();
    let truth = shadowed(&vis[0]);
    assert!(truth > 50, "the occluder's shadow is in frame: {truth} pixels");
    for (k, name) in [(1, "edge_table"), (2, "pcss")] {
        // Answered by the same traced rays (per-point seeds), so the shadows agree closely.
        let n = shadowed(&vis[k]);
        assert!(n.abs_diff(truth) <= truth / 20, "{name}: {n} shadowed pixels, traced {truth}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_output_blocked_by_a_folder_leaves_nothing_behind() {
    let dir = temp_dir("blocked");
    std::fs::write(dir.join("s.toml"), SCENE).unwrap();
    std::fs::create_dir_all(dir.join("o/x.exr/keep")).unwrap();
    let o = penumbra(&["render", "s.toml", "--out", "o/x.png"], &dir);
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
    let left: Vec<_> = std::fs::read_dir(dir.join("o")).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(left, vec![std::ffi::OsString::from("x.exr")], "{left:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The primary hits are gathered into a list for `prepare` only when a method reads it:
/// `none`, `traced` and `silhouette` gather none (counter `visible_points`), the depth-map
/// methods every primary hit.
#[test]
fn visible_points_are_gathered_only_for_methods_that_read_them() {
    let dir = temp_dir("gather");
    std::fs::write(dir.join("s.toml"), SCENE).unwrap();
    for (method, gathers) in
        [("none", false), ("traced", false), ("silhouette", false), ("edge_table", true), ("pcss", true)]
    {
        let out = format!("{method}.png");
        let o = penumbra(&["render", "s.toml", "--shadows", method, "--max-depth", "2", "--out", &out], &dir);
        assert!(o.status.success(), "{method}: {}", String::from_utf8_lossy(&o.stderr));
        let report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.join(format!("{method}.json"))).unwrap()).unwrap();
        // One sample per pixel, direct light only: the points gathered are the primary hits.
        let hits = report["counters"]["shading_points"].as_u64().unwrap();
        assert_eq!(hits, 376, "{method}: the scene's primary hits");
        let expected = if gathers { hits } else { 0 };
        assert_eq!(report["counters"]["visible_points"], expected, "{method}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A folder this process cannot write in: a 0o555 folder, or where the test runs as root
/// (which writes there anyway) `/sys`, which refuses root too. None (the test says so) where
/// neither is read-only.
fn read_only_folder(dir: &Path) -> Option<PathBuf> {
    use std::os::unix::fs::PermissionsExt;
    let ro = dir.join("ro");
    std::fs::create_dir_all(&ro).unwrap();
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
    let writable = |d: &Path| {
        let probe = d.join(format!("probe-{}", std::process::id()));
        let ok = std::fs::write(&probe, b"").is_ok();
        let _ = std::fs::remove_file(&probe);
        ok
    };
    [ro, PathBuf::from("/sys")].into_iter().find(|d| d.is_dir() && !writable(d))
}

/// An output folder that cannot be written in is refused before the scene is loaded (so
/// before any render): here the scene's model is a broken glTF, which would be the error
/// had the scene been loaded first. One line naming the output and `--out`, exit 2,
/// nothing written.
#[test]
fn a_read_only_output_folder_is_refused_before_rendering() {
    use std::os::unix::fs::PermissionsExt;
    let dir = temp_dir("read-only");
    let Some(ro) = read_only_folder(&dir) else {
        eprintln!("no read-only folder here: the check is skipped");
        return;
    };
    std::fs::write(dir.join("broken.gltf"), "{").unwrap();
    std::fs::write(dir.join("s.toml"), format!("[[model]]\npath = \"broken.gltf\"\n{SCENE}")).unwrap();
    for out in [ro.join("x.png"), ro.join("sub/x.png")] {
        let o = penumbra(&["render", "s.toml", "--out", out.to_str().unwrap()], &dir);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
        let folder = out.parent().unwrap();
        let expected = if folder == ro {
            format!("error: {}: --out: cannot write in the folder {}: ", out.display(), ro.display())
        } else {
            format!(
                "error: {}: --out: cannot create the folder {} in {}: ",
                out.display(),
                folder.display(),
                ro.display()
            )
        };
        assert!(stderr.starts_with(&expected), "{stderr:?} does not start with {expected:?}");
        assert!(!stderr.contains("broken.gltf"), "the scene was loaded first: {stderr}");
    }
    let ro_local = dir.join("ro");
    assert_eq!(std::fs::read_dir(&ro_local).unwrap().count(), 0, "something was written");
    std::fs::set_permissions(&ro_local, std::fs::Permissions::from_mode(0o755)).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

/// A folder named as the model (the folder a glTF came in, not the file) is called a
/// directory, with the glTF files inside it named, not "no such file"; one line, exit 2.
#[test]
fn a_folder_as_model_path_is_called_a_directory() {
    let dir = temp_dir("model-folder");
    std::fs::create_dir_all(dir.join("chair")).unwrap();
    std::fs::write(dir.join("chair/chair.gltf"), "{}").unwrap();
    std::fs::write(dir.join("s.toml"), format!("[[model]]\npath = \"chair\"\n{SCENE}")).unwrap();
    let o = penumbra(&["render", "s.toml", "--out", "o.png"], &dir);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert_eq!(
        stderr.trim_end(),
        "error: s.toml: model[0].path: chair is a directory, not a .gltf or .glb file (it holds chair.gltf)"
    );
    assert!(!dir.join("o.png").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A `PENUMBRA_MASK_BUDGET_MIB` that is not a whole number of MiB is an error naming the
/// variable (it was ignored, leaving the machine's budget in force); one line, exit 2,
/// before anything is loaded or written.
#[test]
fn a_garbage_budget_variable_is_an_error_naming_it() {
    let dir = temp_dir("budget-garbage");
    std::fs::write(dir.join("s.toml"), SCENE).unwrap();
    for value in ["4G", "-1", "lots", ""] {
        let o = Command::new(env!("CARGO_BIN_EXE_penumbra"))
            .args(["render", "s.toml", "--out", "o.png"])
            .env("PENUMBRA_MASK_BUDGET_MIB", value)
            .current_dir(&dir)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{value:?}: {stderr}");
        let expected = format!(
            "error: PENUMBRA_MASK_BUDGET_MIB: the environment variable must be a whole number of MiB \
             (such as 4096), got {value:?}"
        );
        assert_eq!(stderr.trim_end(), expected);
        assert!(!dir.join("o.png").exists(), "{value:?}: something was written");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every phase shows on a terminal: the render runs under a pseudo-terminal (`script`, from
/// util-linux; the test says so and passes where it is missing), and stderr must name each.
/// Without a terminal, stderr stays empty.
#[test]
fn progress_names_every_phase_on_a_terminal() {
    let dir = temp_dir("pty");
    if Command::new("script").arg("--version").output().is_err() {
        eprintln!("no `script` here: the pseudo-terminal check is skipped");
        return;
    }
    let bin = env!("CARGO_BIN_EXE_penumbra");
    let cmd = format!("{bin} render --shadows edge_table --width 160 --height 120 --out p.png");
    let o = Command::new("script").args(["-qec", &cmd, "/dev/null"]).current_dir(&dir).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let shown = String::from_utf8_lossy(&o.stdout);
    for phase in [
        "loading the scene and building the BVH",
        "primary rays",
        "gathering visible points",
        "preparing the shadow method",
        "shading",
        "writing the outputs",
    ] {
        assert!(shown.contains(phase), "{phase} not shown: {shown}");
    }
    let piped = penumbra(&["render", "--width", "160", "--height", "120", "--out", "q.png"], &dir);
    assert!(piped.status.success());
    assert_eq!(String::from_utf8_lossy(&piped.stderr), "", "nothing on stderr without a terminal");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The command line's values are merged into the scene file before it is checked, and the
/// merged request is checked once: a file too large to render renders at a flag's smaller
/// size, a limit across keys names the flag that broke it, and a sample count is checked
/// against the method a flag chose.
#[test]
fn flags_are_checked_with_the_scene_file_as_one_request() {
    let dir = temp_dir("one_request");
    // 16384 x 16384 x 1 primary samples: over the 2^26 the frame keeps.
    let huge = SCENE.replace("width = 48", "width = 16384").replace("height = 32", "height = 16384");
    assert_ne!(huge, SCENE);
    std::fs::write(dir.join("huge.toml"), huge).unwrap();
    assert_bad_input(
        &dir,
        &["render", "huge.toml", "--out", "o.png"],
        &["huge.toml", "image.spp", "67108864"],
    );
    let o = penumbra(
        &["render", "huge.toml", "--width", "48", "--height", "32", "--out", "o.png", "--quiet"],
        &dir,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["o.png", "o.exr", "o.json"] {
        std::fs::remove_file(dir.join(f)).unwrap();
    }
    std::fs::write(dir.join("ok.toml"), SCENE).unwrap();
    let cases: [(&[&str], &[&str]); 3] = [
        (&["--width", "8192", "--height", "8192", "--spp", "2"], &["ok.toml", "--spp", "67108864"]),
        (&["--shadows", "pcss", "--samples", "65536"], &["ok.toml", "--samples", "1..=4096 for pcss"]),
        (&["--samples", "65536", "--shadows", "edge_table"], &["ok.toml", "--samples", "for edge_table"]),
    ];
    for (flags, names) in cases {
        let mut args = vec!["render", "ok.toml", "--out", "o.png"];
        args.extend_from_slice(flags);
        assert_bad_input(&dir, &args, names);
    }
    // The file is checked as written too: a flag does not hide a bad value under it.
    std::fs::write(dir.join("zero.toml"), SCENE.replace("width = 48", "width = 0")).unwrap();
    assert_bad_input(
        &dir,
        &["render", "zero.toml", "--width", "48", "--out", "o.png"],
        &["zero.toml", "image.width"],
    );
    // Code-only settings (a study's) are checked with the sample count as the method chosen.
    use penumbra::{CliError, RenderArgs, run_render};
    let study = |method: Arc<dyn ShadowMethod>, samples: u32| RenderArgs {
        scene: Some(dir.join("ok.toml")),
        keys: penumbra::request::Overrides {
            samples: Some(samples),
            width: Some(8),
            height: Some(6),
            method: Some(method),
            ..Default::default()
        },
        out: Some(dir.join("study/o.png")),
        quiet: true,
        ..Default::default()
    };
    match run_render(&study(Arc::new(EdgeTableParams::default()), 8192)) {
        Err(CliError::Input(e)) => {
            assert!(e.key == "--samples" && e.message.contains("for edge_table"), "{e}")
        }
        other => panic!("{other:?}"),
    }
    std::fs::write(dir.join("ok.toml"), SCENE.replace("method = \"traced\"", "method = \"edge_table\""))
        .unwrap();
    run_render(&study(Arc::new(TracedParams::PLAIN), 8192)).expect("traced takes 8192 samples");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Each kind of failure is its own error: an output that cannot be written names the path and
/// the flag that chose it (an `OutputError`), bad input the file and the key (a `SceneError`).
#[test]
fn an_unwritable_output_is_an_output_error_and_bad_input_a_scene_error() {
    use penumbra::{CliError, RenderArgs, run_render};
    let dir = temp_dir("error_kinds");
    std::fs::write(dir.join("ok.toml"), SCENE).unwrap();
    std::fs::write(dir.join("bad.toml"), SCENE.replace("width = 48", "width = 0")).unwrap();
    std::fs::write(dir.join("a_file"), "").unwrap();
    let args = |scene: &str, out: &str| RenderArgs {
        scene: Some(dir.join(scene)),
        out: Some(dir.join(out)),
        quiet: true,
        ..Default::default()
    };
    match run_render(&args("ok.toml", "a_file/o.png")) {
        Err(CliError::Output(e)) => {
            assert_eq!((e.path, e.flag), (dir.join("a_file/o.png"), "--out"));
        }
        other => panic!("{other:?}"),
    }
    match run_render(&args("bad.toml", "o.png")) {
        Err(CliError::Input(e)) => {
            assert_eq!((e.file, e.key.as_str()), (dir.join("bad.toml"), "image.width"))
        }
        other => panic!("{other:?}"),
    }
    assert!(!dir.join("o.png").exists());
    let _ = std::fs::remove_dir_all(&dir);
}
