//! `render --profile`: the trace's structure (valid trace-event JSON, the phases nested as the
//! contract names them), the cost EXR's layers and the heat map, and that the cost lands where
//! the work is: penumbra pixels cost more than lit ones.

use crate::common::folders;
use folders::temp_dir;
use renderer::util::pixel_cost::PixelCost;
use serde_json::Value;
use std::collections::HashMap;

/// A span of the trace: name, thread, start and end (µs), and its args.
#[derive(Debug, Clone)]
struct Span {
    name: String,
    tid: u64,
    start: f64,
    end: f64,
    parent: Option<String>,
    args: Value,
}

/// Every span of a Chrome trace (B/E pairs per thread), checking the pairs nest.
fn spans(trace: &[u8]) -> Vec<Span> {
    let events: Vec<Value> = serde_json::from_slice(trace).expect("the trace is a JSON array");
    let mut open: HashMap<u64, Vec<(String, f64, Value)>> = HashMap::new();
    let mut out = Vec::new();
    for e in &events {
        let ph = e["ph"].as_str().expect("every event has a phase");
        assert_eq!(e["pid"], 1);
        let tid = e["tid"].as_u64().expect("every event has a thread");
        match ph {
            "M" => assert_eq!(e["name"], "thread_name"),
            "B" => {
                let ts = e["ts"].as_f64().expect("ts");
                open.entry(tid).or_default().push((
                    e["name"].as_str().unwrap().into(),
                    ts,
                    e["args"].clone(),
                ));
            }
            "E" => {
                let (name, start, args) = open.get_mut(&tid).and_then(Vec::pop).expect("an E closes a B");
                assert_eq!(e["name"].as_str().unwrap(), name, "spans nest on thread {tid}");
                let end = e["ts"].as_f64().unwrap();
                assert!(end >= start);
                let parent = open[&tid].last().map(|p| p.0.clone());
                out.push(Span { name, tid, start, end, parent, args });
            }
            other => panic!("unexpected event phase {other}"),
        }
    }
    assert!(open.values().all(Vec::is_empty), "every span is closed");
    out
}

#[test]
fn profile_writes_a_trace_of_every_phase_the_cost_exr_and_the_heat_map() {
    // Through the binary: one render per process, as users run it (tracing's per-callsite
    // interest is process-wide, and another test's render without a trace would race it).
    let dir = temp_dir("outputs");
    let args =
        ["render", "--shadows", "edge_table", "--width", "96", "--height", "72", "--profile", "--quiet"];
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(args)
        .args(["--out", "p.png"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = spans(&std::fs::read(dir.join("p.trace.json")).unwrap());
    let one = |name: &str| {
        let v: Vec<&Span> = s.iter().filter(|x| x.name == name).collect();
        assert_eq!(v.len(), 1, "one {name} span");
        v[0].clone()
    };
    // The top-level phases, in order, none inside another.
    let top = ["load", "bvh", "primary_pass", "visible_points", "prepare", "shading", "write"];
    for pair in top.windows(2) {
        let (a, b) = (one(pair[0]), one(pair[1]));
        assert!(a.end <= b.start, "{} ends before {} begins", pair[0], pair[1]);
        assert_eq!(a.parent, None, "{}", pair[0]);
    }
    assert_eq!(one("prepare").args["light"], "0");
    // The prepare's stages inside it: the depth map (with the fit and the bounds), the depth
    // levels, the masks.
    for (stage, parent) in
        [("depth_map", "prepare"), ("fit", "depth_map"), ("bounds", "depth_map"), ("masks", "prepare")]
    {
        assert_eq!(one(stage).parent.as_deref(), Some(parent), "{stage}");
    }
    // Shading in row bands, on every thread, inside the shading span's time, covering every row.
    let shading = one("shading");
    let bands: Vec<&Span> = s.iter().filter(|x| x.name == "rows").collect();
    let rows: u64 = bands
        .iter()
        .map(|b| {
            b.args["y1"].as_str().unwrap().parse::<u64>().unwrap()
                - b.args["y0"].as_str().unwrap().parse::<u64>().unwrap()
        })
        .sum();
    assert_eq!(rows, 72);
    for b in &bands {
        assert!(b.start >= shading.start && b.end <= shading.end, "a band inside shading");
        assert!(b.tid != shading.tid || b.parent.as_deref() == Some("shading"));
    }
    // The cost EXR's layers and the heat map (scaled up to at least 320 pixels wide).
    let exr = exr::prelude::read_all_flat_layers_from_file(dir.join("p.cost.exr")).unwrap();
    let names: Vec<String> = exr.layer_data[0].channel_data.list.iter().map(|c| c.name.to_string()).collect();
    assert_eq!(names, ["lookups.Y", "rays.Y", "shafts.Y", "time.Y"]);
    let heat = image::open(dir.join("p.cost.png")).unwrap();
    assert!(heat.width() >= 320);
    let report: Value = serde_json::from_slice(&std::fs::read(dir.join("p.json")).unwrap()).unwrap();
    let outputs: Vec<&str> =
        report["outputs"].as_array().unwrap().iter().map(|o| o.as_str().unwrap()).collect();
    assert_eq!(outputs, ["p.png", "p.exr", "p.cost.exr", "p.cost.png", "p.trace.json", "p.json"]);
    assert!(report["profile"]["shading_s"].as_f64().unwrap() > 0.0);
    assert!(report["profile"]["lookups"].as_u64().unwrap() > 0);
    // Profiling changes no other output's bytes.
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(&args[..args.len() - 2])
        .args(["--quiet", "--out", "q.png"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(o.status.success());
    for ext in ["png", "exr"] {
        let (p, q) =
            (std::fs::read(dir.join(format!("p.{ext}"))), std::fs::read(dir.join(format!("q.{ext}"))));
        assert!(p.unwrap() == q.unwrap(), "{ext} differs with --profile");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Mean shading time of penumbra pixels (visibility in (0.05, 0.95)) over that of lit ones
/// (visibility 1), on the default scene at 160 x 120.
fn penumbra_over_lit(method: &str) -> (f64, usize, usize) {
    let scene =
        renderer::SceneFile::parse(penumbra::DEFAULT_SCENE, std::path::Path::new("default.toml")).unwrap();
    let scene = renderer::Scene::load(&scene, std::path::Path::new("default.toml")).unwrap();
    let config = penumbra::shadows_config::ShadowsConfig::from_table(
        &toml::from_str(&format!("method = \"{method}\"\nsamples = 256")).unwrap(),
        std::path::Path::new("default.toml"),
    )
    .unwrap();
    let mut methods: Vec<_> = scene.lights.iter().map(|_| config.build()).collect();
    let settings = renderer::RenderSettings {
        width: 160,
        height: 120,
        spp: 1,
        seed: 0,
        memory_budget_bytes: 1 << 30,
        profile: true,
        max_depth: 2,
    };
    let frame = renderer::render(&scene, &mut methods, &settings, &|_| {}).unwrap();
    let costs: &[PixelCost] = frame.costs.as_deref().unwrap();
    let (mut pen, mut lit) = (Vec::new(), Vec::new());
    for (c, &v) in costs.iter().zip(&frame.visibility[0]) {
        if v == 1.0 {
            lit.push(c.time_s as f64);
        } else if v > 0.05 && v < 0.95 {
            pen.push(c.time_s as f64);
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    (mean(&pen) / mean(&lit), pen.len(), lit.len())
}

#[test]
fn penumbra_pixels_cost_more_than_twice_what_lit_pixels_cost() {
    for method in ["traced", "edge_table"] {
        let (ratio, pen, lit) = penumbra_over_lit(method);
        println!("{method}: penumbra / lit shading time {ratio:.1} ({pen} penumbra, {lit} lit pixels)");
        assert!(pen > 100 && lit > 1000, "{method}: {pen} penumbra, {lit} lit pixels");
        assert!(ratio > 2.0, "{method}: penumbra pixels cost {ratio:.2}x lit ones");
    }
}
