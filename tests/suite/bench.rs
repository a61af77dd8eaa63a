//! `penumbra bench --quick`: the outputs are complete and well-formed, the HTML report's
//! every image and plot exists and opens, the truth is cached and recomputed when the scene
//! changes, and bad input is a one-line error with nothing written.

use crate::common::folders;
use folders::temp_dir;
use penumbra::methods::METHODS;
use std::path::{Path, PathBuf};
use std::process::Command;

fn bench(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_penumbra")).arg("bench").args(args).output().unwrap()
}

use crate::common::tiny_scene;
use tiny_scene::TINY_SCENE;

use crate::common::shared;

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Every local `src="..."` and `href="..."` of the report.
fn links(html: &str) -> Vec<String> {
    let mut out = Vec::new();
    for attr in ["src=\"", "href=\""] {
        let mut rest = html;
        while let Some(i) = rest.find(attr) {
            rest = &rest[i + attr.len()..];
            let end = rest.find('"').unwrap();
            out.push(rest[..end].to_string());
            rest = &rest[end..];
        }
    }
    out
}

fn check_outputs(out: &Path, scenes: &[&str]) -> serde_json::Value {
    // CSV: the header, then one row per (scene, setting), every number finite.
    let csv = read(&out.join("results.csv"));
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    for col in
        ["scene", "method", "setting", "shadow_cost_s", "rmse", "penumbra_rmse", "p99", "max", "leak_rate"]
    {
        assert!(header.contains(&col), "CSV lacks {col}: {header:?}");
    }
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert!(!rows.is_empty());
    for r in &rows {
        assert_eq!(r.len(), header.len(), "{r:?}");
        for (name, v) in header.iter().zip(r) {
            if !["scene", "method", "setting", "headline"].contains(name) {
                let x: f64 = v.parse().unwrap_or_else(|_| panic!("{name} = {v:?} is not a number"));
                assert!(x.is_finite(), "{name} = {x}");
            }
        }
    }
    let rmse_col = header.iter().position(|c| *c == "rmse").unwrap();
    for scene in scenes {
        let mine: Vec<&Vec<&str>> = rows.iter().filter(|r| r[0] == *scene).collect();
        // Every registered method with settings in the quick sweep (all but `none`).
        for m in METHODS.iter().filter(|m| !(m.sweep)(true).is_empty()) {
            assert!(mine.iter().any(|r| r[1] == m.name), "{scene}: no {} row", m.name);
        }
        // The errors are real: traced at 64 samples is closer to the truth than at 16.
        let rmse = |s: &str| -> f64 { mine.iter().find(|r| r[2] == s).unwrap()[rmse_col].parse().unwrap() };
        assert!(rmse("traced N=64") < rmse("traced N=16"), "{scene}");
        assert!(rmse("traced N=16") > 0.0, "{scene}");
        // The headline is the fast exact method a user should pick (it was edge_table's
        // default, 0.055x of traced in `bench --quick`).
        let head = header.iter().position(|c| *c == "headline").unwrap();
        let heads: Vec<&str> = mine.iter().filter(|r| r[head] == "true").map(|r| r[2]).collect();
        assert_eq!(heads, vec!["silhouette N=64"], "{scene}");
    }

    // JSON: the same rows, and each scene's equal-error speedup.
    let json: serde_json::Value = serde_json::from_str(&read(&out.join("results.json"))).unwrap();
    assert_eq!(json["rows"].as_array().unwrap().len(), rows.len());
    for s in json["scenes"].as_array().unwrap() {
        match s["equal_error_speedup"]["ratio"].as_f64() {
            Some(r) => assert!(r > 0.0, "{s}"),
            // No ratio only where a cost was lost in the timing noise of these tiny frames
            // (a render no slower than `none`'s): the headline's, or every traced setting's
            // (the plain reference aside). Not a missing computation.
            None => {
                let scene_rows: Vec<&serde_json::Value> =
                    json["rows"].as_array().unwrap().iter().filter(|r| r["scene"] == s["scene"]).collect();
                let row = scene_rows
                    .iter()
                    .find(|r| r["headline"] == true)
                    .unwrap_or_else(|| panic!("no headline row: {s}"));
                let cost = |r: &serde_json::Value| r["shadow_cost_s"].as_f64().unwrap();
                // The references: traced as it ships, its plain reference aside.
                let references: Vec<String> = penumbra::bench::sweep(true, METHODS)
                    .into_iter()
                    .filter(|x| x.reference)
                    .map(|x| x.label)
                    .collect();
                assert!(!references.is_empty());
                let traced_lost = scene_rows
                    .iter()
                    .filter(|r| references.iter().any(|l| r["setting"] == l.as_str()))
                    .all(|r| cost(r) <= 0.0);
                assert!(cost(row) <= 0.0 || traced_lost, "{s} {row}");
            }
        }
    }

    // HTML: every linked file exists; images and plots decode; SVGs are SVG.
    let html = read(&out.join("index.html"));
    let links = links(&html);
    for scene in scenes {
        assert!(links.iter().any(|l| l == &format!("{scene}/plot.png")), "{scene}: no plot");
        assert!(links.iter().any(|l| l == &format!("{scene}/truth.png")), "{scene}: no truth image");
        // The truth is shown as wide as the other figures, and labelled with the resolution
        // it was rendered at: the bench's (64 wide with --quick).
        let truth = image::open(out.join(format!("{scene}/truth.png"))).unwrap();
        let tag = format!("<img class=\"px\" src=\"{scene}/truth.png\" alt=\"truth\" width=\"320\">");
        let at = html.find(&tag).unwrap_or_else(|| panic!("{scene}: {tag} not in the report"));
        let caption = &html[at..html[at..].find("</figcaption>").unwrap() + at];
        let size = format!("{}x{} pixels, the bench's resolution", truth.width(), truth.height());
        assert!(caption.contains(&size), "{scene}: {caption:?} does not say {size:?}");
        for row in json["rows"].as_array().unwrap().iter().filter(|r| r["scene"] == *scene) {
            let size = [row["width"].as_u64().unwrap(), row["height"].as_u64().unwrap()];
            assert_eq!(size, [truth.width() as u64, truth.height() as u64], "{scene}: the truth's size");
        }
        for kind in [".error.png", ".cost.png"] {
            let maps: Vec<&String> =
                links.iter().filter(|l| l.starts_with(&format!("{scene}/")) && l.ends_with(kind)).collect();
            assert!(maps.len() >= 4, "{scene}: {kind} maps {maps:?}");
            // Readable: at least 320 pixels wide whatever the bench's image size.
            for m in maps {
                assert!(image::open(out.join(m)).unwrap().width() >= 320, "{m}");
            }
        }
    }
    // Per scene and family, the cost split: parts non-negative, adding up to the best
    // setting's shadow cost (its row's), prepare equal to the row's where the cost is above
    // it (at tiny sizes a cost can be lost in the noise).
    for s in json["scenes"].as_array().unwrap() {
        for b in s["best"].as_array().unwrap() {
            let split = &b["cost_split_s"];
            let parts: Vec<f64> = ["prepare", "lookups", "rays", "shafts", "rest"]
                .iter()
                .map(|k| split[k].as_f64().unwrap_or_else(|| panic!("{k} in {b}")))
                .collect();
            assert!(parts.iter().all(|&p| p >= 0.0), "{b}");
            let row = json["rows"]
                .as_array()
                .unwrap()
                .iter()
                .find(|r| r["scene"] == s["scene"] && r["setting"] == b["label"])
                .unwrap();
            let cost = row["shadow_cost_s"].as_f64().unwrap();
            if cost > row["shadow_prepare_s"].as_f64().unwrap() {
                let sum: f64 = parts.iter().sum();
                assert!((sum - cost).abs() < 1e-9, "{b}: {sum} against {cost}");
                assert_eq!(parts[0], row["shadow_prepare_s"].as_f64().unwrap(), "{b}");
            }
            if b["family"] == "traced" {
                assert_eq!(parts[1], 0.0, "traced reads no tables: {b}");
            }
        }
    }
    for l in &links {
        let p = out.join(l);
        assert!(p.is_file(), "{l} is linked but missing");
        if l.ends_with(".png") {
            let img = image::open(&p).unwrap_or_else(|e| panic!("{l}: {e}"));
            assert!(img.width() > 0 && img.height() > 0);
        } else if l.ends_with(".svg") {
            assert!(read(&p).contains("<svg"), "{l}");
        } else {
            assert!(l.ends_with(".csv") || l.ends_with(".json"), "unexpected link {l}");
        }
    }
    json
}

#[test]
fn quick_bench_writes_a_complete_report_and_caches_the_truth() {
    let dir = temp_dir("quick");
    let scene = dir.join("tiny.toml");
    std::fs::write(&scene, TINY_SCENE).unwrap();
    let default_scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/default.toml");
    let out = dir.join("out");
    let args = [
        scene.to_str().unwrap(),
        default_scene.to_str().unwrap(),
        "--quick",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ];
    let first = bench(&args);
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
    let summary = String::from_utf8_lossy(&first.stdout);
    assert!(summary.contains("equal-error speedup") && summary.contains("index.html"), "{summary}");
    let json = check_outputs(&out, &["tiny", "default"]);
    assert!(json["scenes"].as_array().unwrap().iter().all(|s| s["truth_cached"] == false));

    // Again: the truth comes from the cache, and the errors are the same.
    let second = bench(&args);
    assert!(second.status.success(), "{}", String::from_utf8_lossy(&second.stderr));
    let json2 = check_outputs(&out, &["tiny", "default"]);
    assert!(json2["scenes"].as_array().unwrap().iter().all(|s| s["truth_cached"] == true));
    let rmse = |j: &serde_json::Value| -> Vec<f64> {
        j["rows"].as_array().unwrap().iter().map(|r| r["rmse"].as_f64().unwrap()).collect()
    };
    assert_eq!(rmse(&json), rmse(&json2));

    // A changed scene is a new truth; the stale entry is gone.
    std::fs::write(&scene, TINY_SCENE.replace("[8.0, 8.0, 8.0]", "[9.0, 9.0, 9.0]")).unwrap();
    let third = bench(&args[..1].iter().chain(&args[2..]).copied().collect::<Vec<_>>());
    assert!(third.status.success(), "{}", String::from_utf8_lossy(&third.stderr));
    let json3: serde_json::Value = serde_json::from_str(&read(&out.join("results.json"))).unwrap();
    assert_eq!(json3["scenes"][0]["truth_cached"], false);
    let tiny_entries = std::fs::read_dir(out.join("truth-cache"))
        .unwrap()
        .flatten()
        .filter(|e| {
            e.file_name().to_string_lossy().starts_with("tiny-")
                && e.file_name().to_string_lossy().ends_with(".json")
        })
        .count();
    assert_eq!(tiny_entries, 1, "the stale truth was not removed");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_missing_scene_is_one_line_and_writes_nothing() {
    let dir = temp_dir("missing");
    let out = dir.join("out");
    let missing = dir.join("nope.toml");
    let o = bench(&[missing.to_str().unwrap(), "--quick", "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("nope.toml"), "{err}");
    assert!(!out.exists(), "something was written");
    let _ = std::fs::remove_dir_all(&dir);
}

/// An output folder the reports cannot be written in is refused before any scene is
/// benched: a 0o555 folder, or `/sys` where the tests run as root (root writes anywhere
/// else). One line naming the folder and `--out`, exit 2.
#[test]
fn a_read_only_output_folder_is_refused_before_benching() {
    use std::os::unix::fs::PermissionsExt;
    let dir = temp_dir("read-only");
    let ro = dir.join("ro");
    std::fs::create_dir_all(&ro).unwrap();
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
    let writable = |d: &Path| {
        let probe = d.join("probe");
        let ok = std::fs::write(&probe, b"").is_ok();
        let _ = std::fs::remove_file(&probe);
        ok
    };
    let Some(out) = [ro.clone(), PathBuf::from("/sys")].into_iter().find(|d| d.is_dir() && !writable(d))
    else {
        eprintln!("no read-only folder here: the check is skipped");
        return;
    };
    std::fs::write(dir.join("tiny.toml"), TINY_SCENE).unwrap();
    let o = bench(&[dir.join("tiny.toml").to_str().unwrap(), "--quick", "--out", out.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    let expected = format!("error: {0}: --out: cannot write in the folder {0}: ", out.display());
    assert!(err.starts_with(&expected) && err.trim().lines().count() == 1, "{err:?}");
    assert_eq!(std::fs::read_dir(&ro).unwrap().count(), 0, "something was written");
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o755)).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

/// The truth's key covers a model's buffer, not only the scene file: appending to the .bin
/// (the glTF still loads; the bytes differ) renders the truth anew.
#[test]
fn a_changed_model_buffer_renders_the_truth_anew() {
    if !shared::scenes_present("bench::a_changed_model_buffer_renders_the_truth_anew") {
        return;
    }
    let dir = temp_dir("model");
    let fox = shared::gltf_dir().join("fox");
    let model = dir.join("fox");
    std::fs::create_dir_all(&model).unwrap();
    for e in std::fs::read_dir(&fox).unwrap().flatten() {
        std::fs::copy(e.path(), model.join(e.file_name())).unwrap();
    }
    let scene = dir.join("fox.toml");
    let original = read(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/gltf/fox.toml"));
    std::fs::write(&scene, original.replace("../../../shared/gltf/fox/", "fox/")).unwrap();
    let out = dir.join("out");
    let args = [scene.to_str().unwrap(), "--quick", "--quiet", "--out", out.to_str().unwrap()];
    let cached = || -> bool {
        let o = bench(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let json: serde_json::Value = serde_json::from_str(&read(&out.join("results.json"))).unwrap();
        json["scenes"][0]["truth_cached"].as_bool().unwrap()
    };
    assert!(!cached());
    assert!(cached());
    let bin = std::fs::read_dir(&model)
        .unwrap()
        .flatten()
        .find(|e| e.path().extension().is_some_and(|x| x == "bin"));
    let bin = bin.expect("the fox has a .bin").path();
    let mut bytes = std::fs::read(&bin).unwrap();
    bytes.extend_from_slice(&[0; 4]);
    std::fs::write(&bin, bytes).unwrap();
    assert!(!cached(), "a changed buffer reused the old truth");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A setting the method refuses (masks over the memory budget) is skipped with its reason;
/// the rest of the bench runs and the report is written.
#[test]
fn a_refused_setting_is_skipped_not_fatal() {
    let dir = temp_dir("refused");
    let scene = dir.join("tiny.toml");
    std::fs::write(&scene, TINY_SCENE).unwrap();
    let out = dir.join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(["bench", scene.to_str().unwrap(), "--quick", "--quiet", "--out", out.to_str().unwrap()])
        .env("PENUMBRA_MASK_BUDGET_MIB", "0")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value = serde_json::from_str(&read(&out.join("results.json"))).unwrap();
    let skipped = json["scenes"][0]["skipped"].as_array().unwrap();
    assert!(
        !skipped.is_empty() && skipped.iter().all(|s| s.as_str().unwrap().contains("MiB")),
        "{skipped:?}"
    );
    let rows = json["rows"].as_array().unwrap();
    assert!(rows.iter().all(|r| r["method"] != "edge_table"));
    assert!(rows.iter().any(|r| r["method"] == "pcss") && rows.iter().any(|r| r["method"] == "traced"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The tiny scene with a glowing wall that is not a light (the scene file gives `[[light]]`):
/// under glTF shading at depth 2 each floor point sends one BRDF ray, and what it meets of the
/// wall adds its emission, a noisy term of its own. The truth must follow the runs' very
/// rays: `analytic` (no light samples) then differs from it by the truth's shadow noise alone.
/// With a seed of its own (the truth before `traced-v6`) the wall's noise, not the shadows',
/// was the image error: 0.92 of the image's mean here (both methods), under 1e-4 now.
#[test]
fn the_direct_light_truth_follows_the_runs_brdf_rays() {
    use crate::common::gltf_writer::{GltfBuilder, TRIANGLES, primitive};
    let dir = temp_dir("truth_rays");
    let mut b = GltfBuilder::new();
    let glow = b.material(serde_json::json!({"emissiveFactor": [1.0, 1.0, 1.0], "doubleSided": true,
        "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0]}}));
    // A 2 x 1 m wall at z = -1.2 standing on the floor, facing it.
    let p = b.positions(&[[-1.0, 0.0, -1.2], [1.0, 0.0, -1.2], [1.0, 1.0, -1.2], [-1.0, 1.0, -1.2]]);
    let i = b.indices_u16(&[0, 1, 2, 0, 2, 3]);
    let mesh = b.mesh(vec![primitive(&[("POSITION", p)], Some(i), TRIANGLES, Some(glow))]);
    let node = b.node(serde_json::json!({"mesh": mesh}));
    let s = b.scene(&[node]);
    b.set_default_scene(s);
    b.write(&dir, "wall");
    let scene = dir.join("glow.toml");
    std::fs::write(&scene, format!("[[model]]\npath = \"wall.gltf\"\n{TINY_SCENE}")).unwrap();
    let out = dir.join("out");
    // The full sweep (the quick one has no `analytic`) on the 64 x 48 image, one run each.
    let args = ["--repeats", "1", "--truth-samples", "4096", "--max-run-seconds", "1", "--quiet", "--out"];
    let o = bench(&[&[scene.to_str().unwrap()], &args[..], &[out.to_str().unwrap()]].concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value = serde_json::from_str(&read(&out.join("results.json"))).unwrap();
    let row = |setting: &str| {
        json["rows"].as_array().unwrap().iter().find(|r| r["setting"] == setting).cloned().unwrap()
    };
    let analytic = row("analytic N=1024")["image_relative_rmse"].as_f64().unwrap();
    let traced = row("traced N=1024")["image_relative_rmse"].as_f64().unwrap();
    eprintln!("image error against the truth: analytic {analytic:.4}, traced N=1024 {traced:.4}");
    // The truth (N = 4096) and traced N = 1024 carry shadow noise; analytic none.
    assert!(analytic < 0.01 && analytic <= traced, "analytic {analytic}, traced {traced}");
    let _ = std::fs::remove_dir_all(&dir);
}
