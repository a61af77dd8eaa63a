//! A method is its own code and one registry line: a toy method (constant visibility, its
//! entry written here) added to a registry shows up everywhere the program lists methods,
//! with nothing else told about it: the scene file's `[shadows]` (parsed, checked, named in
//! errors), `--shadows`, the bench (its sweep, rows, plot colour, figures and headline) and
//! the key reference.

use bench_entry::top_samples;
use bench_entry::{BenchEntry, SweepSetting};
use penumbra::bench::plot::{Style, style};
use penumbra::bench::{BenchArgs, run_bench_in, sweep};
use penumbra::key_reference::{page, section_errors, sections};
use penumbra::methods::{METHODS, Registered, find, names, retired, value_parser_of};
use penumbra::request::{Overrides, Request};
use penumbra::shadows_config::ShadowsConfig;
use renderer::{
    KeyError, LightShadowing, MethodEntry, MethodParams, PrepareContext, Scene, SceneError, ShadowError,
    ShadowMethod, ShadowQuery,
};
use serde::{Deserialize, Serialize};
use shadow_plugin::DepthMarchParams;
use std::path::{Path, PathBuf};

use crate::common::tiny_scene;
use tiny_scene::TINY_SCENE;

/// `[shadows.toy]`: every point sees `level` of the light.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ToyParams {
    level: f32,
}

impl Default for ToyParams {
    fn default() -> Self {
        Self { level: 0.5 }
    }
}

impl ShadowMethod for ToyParams {
    fn name(&self) -> &'static str {
        "toy"
    }
    fn max_samples(&self) -> u32 {
        4096
    }
    fn build(&self, _samples: u32) -> Box<dyn LightShadowing> {
        Box::new(*self)
    }
}

impl MethodParams for ToyParams {
    const NAME: &'static str = "toy";
    type Table = Self;
    fn table(&self) -> Self {
        *self
    }
    fn with_table(&self, table: Self) -> Self {
        table
    }
    fn validate(&self) -> Result<(), KeyError> {
        if !(0.0..=1.0).contains(&self.level) {
            return Err(KeyError::new("level", format!("must be in [0, 1], got {}", self.level)));
        }
        Ok(())
    }
}

const TOY_COLOUR: [u8; 3] = [255, 127, 14];

impl MethodEntry for ToyParams {
    const ABOUT: &'static str = "A constant visibility: the registry's test";
    const KEYS_DOC: &'static str = "| key | type | default | meaning |
|---|---|---|---|
| `level` | float | `0.5` | the visibility every point gets, in [0, 1] |
";
}

impl BenchEntry for ToyParams {
    const COLOUR: [u8; 3] = TOY_COLOUR;
    fn sweep(quick: bool) -> Vec<SweepSetting> {
        let n = top_samples(quick);
        vec![
            SweepSetting::new(format!("toy 0.25 N={n}"), ToyParams { level: 0.25 }, n),
            SweepSetting {
                headline: true,
                ..SweepSetting::new(format!("toy 0.5 N={n}"), ToyParams::default(), n)
            },
        ]
    }
}

impl LightShadowing for ToyParams {
    fn name(&self) -> &'static str {
        "toy"
    }
    fn prepare(&mut self, _: &PrepareContext) -> Result<(), ShadowError> {
        Ok(())
    }
    fn visibility(&self, _: &Scene, _: &ShadowQuery) -> f32 {
        self.level
    }
}

const TOY: Registered = Registered::of::<ToyParams>();

/// Every registered method, then the toy.
fn with_toy() -> Vec<Registered> {
    METHODS.iter().copied().chain([TOY]).collect()
}

fn shadows(text: &str, methods: &[Registered]) -> Result<ShadowsConfig, SceneError> {
    ShadowsConfig::from_table_in(&text.parse::<toml::Table>().unwrap(), Path::new("s.toml"), methods, None)
}

#[test]
fn the_scene_file_reads_the_toys_table() {
    let reg = with_toy();
    let c = shadows("method = \"toy\"\nsamples = 16\n[toy]\nlevel = 0.25", &reg).unwrap();
    assert_eq!((c.name(), c.samples, c.build().name()), ("toy", 16, "toy"));
    assert_eq!(format!("{:?}", c.method()), format!("{:?}", ToyParams { level: 0.25 }));
    // Its own checks, unknown keys and its limits, named with the full path.
    for (text, key) in [
        ("[toy]\nlevel = 2.0", "shadows.toy.level"),
        ("[toy]\nbogus = 1", "shadows.toy.bogus"),
        ("toy = 1", "shadows.toy"),
        ("method = \"toy\"\nsamples = 4097", "shadows.samples"),
    ] {
        assert_eq!(shadows(text, &reg).expect_err(text).key, key, "{text}");
    }
    let e = shadows("method = \"magic\"", &reg).unwrap_err();
    assert_eq!(e.message, format!("unknown method \"magic\"; expected one of {}, \"toy\"", names()));
    assert!(names().starts_with("\"traced\", \"none\", \"edge_table\", \"pcss\""));
    assert_eq!(shadows("method = \"toy\"", &reg).unwrap().name(), "toy");
    // Without the registry line, the toy is nothing.
    assert_eq!(shadows("[toy]\nlevel = 0.25", METHODS).unwrap_err().key, "shadows.toy");
    assert!(find("toy").is_none());
}

/// Retiring a method is the registry's alone: `depth_march` left `METHODS` for `RETIRED`,
/// its code stayed, and a registry that lists it again reads it as before (the
/// retired names are consulted only for names no method has), its key section still held
/// to its parameters.
#[test]
fn a_retired_method_is_the_registrys_word_alone() {
    assert!(find("depth_march").is_none());
    assert!(retired("depth_march").is_some_and(|a| a.contains("edge_table")));
    for (text, key) in
        [("method = \"depth_march\"", "shadows.method"), ("[depth_march]", "shadows.depth_march")]
    {
        let e = shadows(text, METHODS).unwrap_err();
        assert_eq!(e.key, key, "{text}");
        assert!(e.message.starts_with("\"depth_march\" was retired; use method = \"edge_table\""), "{e}");
        assert!(e.message.contains("docs/notes/2026-11-26-retired-depth-march.md"), "{e}");
    }
    // Given as `--shadows` (merged into the scene file, as the command line does), the
    // error names the flag.
    let flag = Overrides { shadows: Some("depth_march".into()), ..Overrides::default() };
    let e = Request::read(None, &flag).unwrap_err();
    assert_eq!(e.key, "--shadows");
    assert!(e.message.contains("retired"), "{e}");
    let again: Vec<Registered> =
        METHODS.iter().copied().chain([Registered::of::<DepthMarchParams>()]).collect();
    let c = shadows("method = \"depth_march\"\n[depth_march]\nheightfield = \"shells\"", &again).unwrap();
    assert_eq!(c.name(), "depth_march");
    assert_eq!(section_errors(&again[again.len() - 1]), Vec::<String>::new());
}

#[test]
fn shadows_takes_the_toy_with_its_help_line() {
    let cli = |methods: &[Registered]| {
        clap::Command::new("t")
            .arg(clap::Arg::new("shadows").long("shadows").value_parser(value_parser_of(methods)))
    };
    let m = cli(&with_toy()).try_get_matches_from(["t", "--shadows", "toy"]).unwrap();
    assert_eq!(m.get_one::<String>("shadows").unwrap(), "toy");
    assert!(cli(METHODS).try_get_matches_from(["t", "--shadows", "toy"]).is_err());
    let help = cli(&with_toy()).render_long_help().to_string();
    assert!(help.contains("toy") && help.contains(ToyParams::ABOUT), "{help}");
}

#[test]
fn the_key_reference_has_the_toys_section() {
    let reg = with_toy();
    let text = page(&reg);
    assert!(text.ends_with(&format!("\n## `[shadows.toy]`\n\n{}", ToyParams::KEYS_DOC)));
    let listed: Vec<String> = METHODS.iter().map(|m| format!("`\"{}\"`", m.name)).collect();
    assert!(text.contains(&format!("the shadow method: {} or `\"toy\"`; `--shadows`", listed.join(", "))));
    let others = page(METHODS);
    let first_section = others.find("\n## `[shadows.traced]`").unwrap();
    assert!(text.contains(&others[first_section..]), "the other sections unchanged, the toy's after them");
    let docs = sections(&text);
    assert_eq!(docs["shadows.toy"].iter().collect::<Vec<_>>(), [(&"level".to_string(), &"0.5".to_string())]);
    assert_eq!(section_errors(&TOY), Vec::<String>::new());
    // Held to its parameters: a wrong default, a missing key or a key too many is named.
    let wrong =
        Registered { keys_doc: "| `level` | float | `0.7` | x |\n| `gain` | float | `1.0` | x |\n", ..TOY };
    assert_eq!(
        section_errors(&wrong),
        [
            "shadows.toy.level: documented default 0.7, the parameters' 0.5",
            "shadows.toy.gain documented but not a key"
        ]
    );
    let none = Registered { keys_doc: "No keys.\n", ..TOY };
    assert_eq!(section_errors(&none), ["shadows.toy.level undocumented (default 0.5)"]);
}

#[test]
fn the_bench_sweeps_and_colours_the_toy() {
    for quick in [true, false] {
        let n = top_samples(quick);
        let with: Vec<String> = sweep(quick, &with_toy()).into_iter().map(|s| s.label).collect();
        let without: Vec<String> = sweep(quick, METHODS).into_iter().map(|s| s.label).collect();
        // After every other method's settings (no bench rank: last), which keep their order.
        assert_eq!(with[..without.len()], without[..]);
        assert_eq!(with[without.len()..], [format!("toy 0.25 N={n}"), format!("toy 0.5 N={n}")]);
    }
    assert_eq!(style(&with_toy(), "toy"), Style { colour: TOY_COLOUR, line: false });
    assert_eq!(style(METHODS, "toy"), Style { colour: [148, 103, 189], line: false }, "unregistered");
}

/// The whole bench on a registry of `traced` and the toy: the toy's rows with its errors,
/// its figures, its colour in the plot, and the speedup of its headline setting.
#[test]
fn a_bench_of_the_toy_reports_it() {
    let dir = std::env::temp_dir().join(format!("penumbra-registry-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("tiny.toml");
    std::fs::write(&scene, TINY_SCENE).unwrap();
    let out = dir.join("out");
    let args = BenchArgs {
        scenes: vec![scene],
        out: Some(out.clone()),
        repeats: 1,
        truth_samples: 256,
        cache: None,
        width: None,
        height: None,
        threads: Some(2),
        seed: 0,
        max_run_seconds: 10.0,
        quick: true,
        max_depth: 2,
        quiet: true,
    };
    let reg = [*find("traced").unwrap(), TOY];
    let summary = run_bench_in(&args, &reg).unwrap();
    assert!(summary.contains("  best toy "), "{summary}");
    assert!(summary.contains("equal-error speedup of toy: "), "{summary}");

    let read = |p: PathBuf| std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let json: serde_json::Value = serde_json::from_str(&read(out.join("results.json"))).unwrap();
    let rows = json["rows"].as_array().unwrap();
    let methods: Vec<&str> = rows.iter().map(|r| r["method"].as_str().unwrap()).collect();
    assert_eq!(methods, ["traced", "traced", "traced", "traced", "toy", "toy"]);
    for r in rows.iter().filter(|r| r["method"] == "toy") {
        let level = if r["setting"] == "toy 0.5 N=64" { 0.5 } else { 0.25 };
        assert_eq!(r["headline"], level == 0.5, "the headline column: {r}");
        // |level - truth| over the lit pixels: the fully lit ones (truth 1) are the largest.
        let max = r["max"].as_f64().unwrap();
        assert!((max - (1.0 - level)).abs() < 1e-6, "{r}");
        assert!(r["rmse"].as_f64().unwrap() > 0.1, "{r}");
    }
    let csv = read(out.join("results.csv"));
    assert!(csv.lines().any(|l| l.starts_with("tiny,toy,toy 0.5 N=64,64,true,")), "{csv}");
    assert!(json["scenes"][0]["best"].as_array().unwrap().iter().any(|b| b["family"] == "toy"));
    assert!(read(out.join("index.html")).contains("tiny/toy.png"));
    let [r, g, b] = TOY_COLOUR;
    let svg = read(out.join("tiny/plot.svg")).to_uppercase();
    assert!(svg.contains(&format!("#{r:02X}{g:02X}{b:02X}")), "the toy's colour in the plot");
    let _ = std::fs::remove_dir_all(&dir);
}
