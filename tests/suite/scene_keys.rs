//! The `[shadows]` tables: every method's keys against the key reference
//! (docs/scene-keys.md), unknown and inapplicable keys rejected with their full path,
//! presets, and the code-only switches kept out of the scene file.

use penumbra::key_reference;
use penumbra::methods::METHODS;
use penumbra::request::{Overrides, Request};
use penumbra::shadows_config::ShadowsConfig;
use renderer::interface::method::default_table;
use renderer::load::scene_file::MaterialsDesc;
use renderer::{MethodEntry, MethodParams, SceneError, TracedParams, parse_method};
use shadow_plugin::{
    Blend, DepthMarchParams, EdgeTableParams, Heightfield, PcssParams, PublishedParams, Reading,
};
use std::collections::BTreeMap;
use std::path::Path;

fn shadows(text: &str) -> Result<ShadowsConfig, SceneError> {
    ShadowsConfig::from_table(&text.parse::<toml::Table>().unwrap(), Path::new("s.toml"))
}

fn error_key(text: &str) -> String {
    shadows(text).expect_err(text).key
}

fn table(text: &str) -> toml::Table {
    text.parse().unwrap()
}

/// The published reading's table (its keys, with their values at the default).
fn published_table() -> toml::Table {
    let published =
        EdgeTableParams { reading: Reading::Published(PublishedParams::DEFAULT), ..Default::default() };
    toml::Table::try_from(published.table()).unwrap()
}

/// The keys only the published reading reads: its table's that the default (exact) one's lacks.
fn published_only() -> Vec<String> {
    let exact = default_table::<EdgeTableParams>();
    let keys: Vec<String> =
        published_table().into_iter().map(|(k, _)| k).filter(|k| !exact.contains_key(k)).collect();
    assert_eq!(keys.len(), 6, "{keys:?}");
    keys
}

/// `c`'s published reading.
fn published(c: &EdgeTableParams) -> PublishedParams {
    match c.reading {
        Reading::Published(p) => p,
        Reading::Exact => panic!("read exactly: {c:?}"),
    }
}

/// docs/scene-keys.md: per `## \`[shadows.NAME]\`` section, each row's key and default.
fn documented() -> BTreeMap<String, BTreeMap<String, String>> {
    key_reference::sections(&std::fs::read_to_string(KEY_REFERENCE).unwrap())
}

const KEY_REFERENCE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/scene-keys.md");

#[test]
fn the_key_reference_lists_every_key_with_its_default() {
    let docs = documented();
    for m in METHODS {
        let section = format!("shadows.{}", m.name);
        let doc = docs.get(&section).unwrap_or_else(|| panic!("docs/scene-keys.md has no section {section}"));
        // Its keys at their defaults, and whatever more it documents (edge_table: the
        // published reading's keys, inapplicable to the default exact one, with their
        // values under `reading = "published"`); choice keys with their documented default.
        let expected = key_reference::expected_keys(m, doc).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(doc, &expected, "{section}: docs/scene-keys.md against the parameter struct");
        assert_eq!(key_reference::section_errors(m), Vec::<String>::new(), "{section}");
    }
    let top = &docs["shadows"];
    let defaults = ShadowsConfig::default();
    assert_eq!(top["method"], format!("\"{}\"", defaults.name()));
    assert_eq!(top["samples"], defaults.samples.to_string());
    // `[materials]`: every key of its struct with its default, and no other.
    let materials: BTreeMap<String, String> = toml::Table::try_from(MaterialsDesc::default())
        .unwrap()
        .into_iter()
        .map(|(k, v)| (k, v.to_string()))
        .collect();
    assert_eq!(docs["materials"], materials, "[materials]: docs/scene-keys.md against MaterialsDesc");
    assert_eq!(docs.len(), METHODS.len() + 2, "a section for [materials], [shadows] and one per method");
}

/// The page is generated from the registry: `PENUMBRA_BLESS=1` rewrites it, else a stale one
/// fails.
#[test]
fn the_key_reference_is_the_registrys() {
    let page = key_reference::page(METHODS);
    let mut file = std::fs::read_to_string(KEY_REFERENCE).unwrap();
    if file != page && std::env::var_os("PENUMBRA_BLESS").is_some() {
        // (The other tests here read the file: a blessed run may fail them once.)
        std::fs::write(KEY_REFERENCE, &page).unwrap();
        file = page.clone();
    }
    assert!(
        file == page,
        "docs/scene-keys.md is stale: `PENUMBRA_BLESS=1 cargo test --test suite scene_keys::` rewrites it from the registry"
    );
}

/// What the key reference held edge_table's section to before the method said it: its keys
/// at their defaults, and the published reading's own keys with their published values.
#[test]
fn edge_table_documents_the_published_keys_with_their_published_values() {
    let published = published_table();
    let mut expected = (penumbra::methods::find("edge_table").unwrap().keys)();
    for k in published_only() {
        expected.insert(k.clone(), published[&k].clone());
    }
    assert_eq!(EdgeTableParams::documented_keys(), expected);
}

#[test]
fn an_unknown_key_under_every_method_is_named_with_its_full_path() {
    for m in METHODS {
        let key = error_key(&format!("[{}]\nbogus_key = 1", m.name));
        assert_eq!(key, format!("shadows.{}.bogus_key", m.name));
    }
    assert_eq!(error_key("sample = 3"), "shadows.sample");
    assert_eq!(error_key("method = \"magic\""), "shadows.method");
    assert_eq!(error_key("[magic]\ngrid = 1"), "shadows.magic");
}

#[test]
fn code_only_switches_are_not_scene_keys() {
    for (t, k) in [
        ("traced", "shaft_culling"),
        ("edge_table", "mirrored"),
        ("edge_table", "closed_volumes"),
        ("edge_table", "hidden_layer"),
        ("edge_table", "fit_shadowed"),
    ] {
        assert_eq!(error_key(&format!("[{t}]\n{k} = false")), format!("shadows.{t}.{k}"));
    }
    // The retired depth_march's own table (a library type now, parsed directly).
    assert_eq!(retired_key("fit_shadowed = false"), "shadows.depth_march.fit_shadowed");
}

/// The key `depth_march`'s own parser names for `text`: retired from the registry, its
/// parameters still check their table.
fn retired_key(text: &str) -> String {
    parse_method::<DepthMarchParams>(&table(text), Path::new("s.toml"), "shadows.depth_march")
        .expect_err(text)
        .key
}

#[test]
fn the_retired_depth_march_is_named_with_what_to_use_instead() {
    for (text, key) in [
        ("method = \"depth_march\"", "shadows.method"),
        ("[depth_march]\nslope_bias = 1.0", "shadows.depth_march"),
        ("method = \"traced\"\n[depth_march]", "shadows.depth_march"),
    ] {
        let e = shadows(text).expect_err(text);
        assert_eq!(e.key, key, "{text}");
        assert!(e.message.contains("was retired; use method = \"edge_table\""), "{e}");
    }
}

/// The migration the retired depth_march's error names: its table's keys, as they are, under
/// `[shadows.edge_table]` with `reading = "published"`: the same names, defaults and values.
#[test]
fn depth_marchs_keys_carry_over_to_the_published_reading() {
    let published_keys = published_table();
    for (k, v) in default_table::<DepthMarchParams>() {
        assert_eq!(
            published_keys.get(&k),
            Some(&v),
            "{k}: depth_march's default against the published reading's"
        );
    }
    let p = Path::new("s.toml");
    let old = "depth_map = 512\nheightfield = \"plates\"\nslab_thickness = 3.0\nslope_bias = 2.0\n\
               normal_offset = 0.25\ngrazing_cos = 0.3";
    let d = parse_method::<DepthMarchParams>(&table(old), p, "x").unwrap();
    let e =
        parse_method::<EdgeTableParams>(&table(&format!("reading = \"published\"\n{old}")), p, "x").unwrap();
    let (m, r) = (d.depth_map, published(&e));
    assert_eq!(
        (e.resolution, r.heightfield, r.slab_thickness, r.slope_bias, r.normal_offset, r.grazing_cos),
        (m.resolution, d.heightfield, m.slab_thickness, m.slope_bias, m.normal_offset, m.grazing_cos)
    );
}

#[test]
fn bad_values_are_named_even_in_the_shared_depth_map_keys() {
    for (text, key) in [
        ("[edge_table]\ndepth_map = \"big\"", "shadows.edge_table.depth_map"),
        ("[edge_table]\ndepth_map = 2", "shadows.edge_table.depth_map"),
        ("[edge_table]\ngrid = [4, 0, 1]", "shadows.edge_table.grid"),
        ("[edge_table]\ngrid = [4, 4, -1]", "shadows.edge_table.grid[2]"),
        ("[edge_table]\nblend = \"cubic\"", "shadows.edge_table.blend"),
        ("[edge_table]\npreset = \"ultra\"", "shadows.edge_table.preset"),
        ("[pcss]\nnormal_offset = nan", "shadows.pcss.normal_offset"),
        ("[pcss]\nblocker_samples = 0", "shadows.pcss.blocker_samples"),
        ("[pcss]\nblocker_samples = 4097", "shadows.pcss.blocker_samples"),
        ("[edge_table]\ngrazing_cos = 1.0", "shadows.edge_table.grazing_cos"),
        ("samples = 0", "shadows.samples"),
        ("samples = -4", "shadows.samples"),
        ("method = \"edge_table\"\nsamples = 8192", "shadows.samples"),
        ("method = \"pcss\"\nsamples = 8192", "shadows.samples"),
        // Checked whichever method runs.
        ("method = \"traced\"\n[pcss]\ngrazing_cos = -0.5", "shadows.pcss.grazing_cos"),
    ] {
        assert_eq!(error_key(text), key, "{text}");
    }
    assert_eq!(retired_key("slope_bias = -1.0"), "shadows.depth_march.slope_bias");
    assert_eq!(shadows("method = \"traced\"\nsamples = 65536").unwrap().samples, 65536);
}

#[test]
fn a_key_that_does_not_apply_to_the_reading_is_an_error() {
    for h in ["shells", "solid"] {
        let text =
            format!("[edge_table]\nreading = \"published\"\nheightfield = \"{h}\"\nslab_thickness = 3.0");
        assert_eq!(error_key(&text), "shadows.edge_table.slab_thickness");
        let text = format!("heightfield = \"{h}\"\nslab_thickness = 3.0");
        assert_eq!(retired_key(&text), "shadows.depth_march.slab_thickness");
    }
    // The exact reading reads none of the published reading's keys.
    for k in &published_only() {
        let text = format!(
            "[edge_table]\nreading = \"exact\"\n{k} = {}",
            if k == "heightfield" || k == "blend" { "\"nearest\"" } else { "1.0" }
        );
        let text = if k == "heightfield" { text.replace("nearest", "plates") } else { text };
        assert_eq!(error_key(&text), format!("shadows.edge_table.{k}"), "{text}");
    }
    // The paper preset reads shells: its slab key is inapplicable unless the reading changes.
    assert_eq!(
        error_key("[edge_table]\npreset = \"paper\"\nslab_thickness = 1.0"),
        "shadows.edge_table.slab_thickness"
    );
    shadows("[edge_table]\npreset = \"paper\"\nheightfield = \"plates\"\nslab_thickness = 1.0").unwrap();
    assert_eq!(error_key("[pcss]\nslab_thickness = 1.0"), "shadows.pcss.slab_thickness");
}

/// Without `reading`, a table that sets a published-only key reads as published: scene files
/// written before the exact reading (the contract's example among them) keep their meaning.
#[test]
fn published_keys_without_a_reading_keep_the_published_reading() {
    let p = Path::new("s.toml");
    let parse = |text: &str| parse_method::<EdgeTableParams>(&table(text), p, "shadows.edge_table").unwrap();
    let c = parse("depth_map = 256\ngrid = [4, 4, 1]\nblend = \"trilinear\"");
    assert_eq!((published(&c).blend, c.grid), (Blend::Trilinear, [4, 4, 1]));
    assert_eq!(parse("grid = [4, 4, 1]").reading, Reading::Exact);
    assert_eq!(parse("reading = \"published\"").reading, Reading::Published(PublishedParams::DEFAULT));
    assert_eq!(
        error_key("[edge_table]\nreading = \"exact\"\nblend = \"trilinear\""),
        "shadows.edge_table.blend"
    );
}

#[test]
fn presets_start_the_edge_table_and_keys_override_them() {
    let p = Path::new("s.toml");
    let parse = |text: &str| parse_method::<EdgeTableParams>(&table(text), p, "shadows.edge_table").unwrap();
    assert_eq!(parse(""), EdgeTableParams::balanced());
    assert_eq!(parse("preset = \"paper\""), EdgeTableParams::paper());
    assert_eq!(parse("preset = \"fine\""), EdgeTableParams::fine());
    let c = parse("preset = \"fine\"\ngrid = [2, 2, 1]");
    assert_eq!((c.grid, published(&c).blend, c.resolution), ([2, 2, 1], Blend::Trilinear, 512));
    assert!(c.switches.mirrored, "the code-only switch comes from the preset");
    let c = parse("preset = \"paper\"\nheightfield = \"solid\"\ndepth_map = 128");
    assert_eq!(
        (published(&c).heightfield, c.resolution, c.switches.mirrored),
        (Heightfield::Solid, 128, false)
    );
    let map = c.switches.map;
    assert!(map.closed_volumes && map.hidden_layer && map.fit_shadowed);
    let d = parse_method::<DepthMarchParams>(&table("heightfield = \"shells\""), p, "x").unwrap();
    assert_eq!((d.heightfield, d.depth_map), (Heightfield::Shells, EdgeTableParams::default().depth_map()));
    let c = parse_method::<PcssParams>(&table("depth_map = 512\nblocker_samples = 64"), p, "x").unwrap();
    assert_eq!((c.depth_map.resolution, c.blocker_samples), (512, 64));
    assert_eq!(c.depth_map.slope_bias, PcssParams::default().depth_map.slope_bias);
    let t = parse_method::<TracedParams>(&table(""), p, "x").unwrap();
    assert!(t.shaft_culling, "traced ships with shaft culling");
}

#[test]
fn an_empty_table_gives_each_method_its_defaults() {
    let (p, empty) = (Path::new("s.toml"), toml::Table::new());
    assert_eq!(parse_method::<TracedParams>(&empty, p, "x").unwrap(), TracedParams::default());
    assert_eq!(parse_method::<EdgeTableParams>(&empty, p, "x").unwrap(), EdgeTableParams::default());
    assert_eq!(parse_method::<DepthMarchParams>(&empty, p, "x").unwrap(), DepthMarchParams::default());
    let pcss = parse_method::<PcssParams>(&empty, p, "x").unwrap();
    assert_eq!(pcss, PcssParams::default());
    // The real-time baseline: no grazing policy, no fit to the shadowed receivers.
    assert_eq!((pcss.depth_map.grazing_cos, pcss.depth_map.switches.fit_shadowed), (0.0, false));
}

#[test]
fn the_chosen_method_builds_and_the_override_keeps_its_table() {
    let c = shadows("method = \"none\"\nsamples = 64\n[pcss]\nblocker_samples = 8").unwrap();
    assert_eq!((c.name(), c.samples, c.build().name()), ("none", 64, "none"));
    // `--shadows pcss` over that file: the file's `[pcss]` table is the one read.
    let dir = std::env::temp_dir().join(format!("penumbra-scene-keys-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("s.toml");
    let text =
        penumbra::DEFAULT_SCENE.replace("[shadows]", "[shadows.pcss]\nblocker_samples = 8\n\n[shadows]");
    assert_ne!(text, penumbra::DEFAULT_SCENE);
    std::fs::write(&scene, text).unwrap();
    let flag = |m: &str| Overrides { shadows: Some(m.into()), ..Overrides::default() };
    let c = Request::read(Some(&scene), &flag("pcss")).unwrap().shadows;
    assert_eq!((c.name(), c.build().name()), ("pcss", "pcss"));
    assert_eq!(
        format!("{:?}", c.method()),
        format!("{:?}", PcssParams { blocker_samples: 8, ..PcssParams::default() })
    );
    assert_eq!(Request::read(Some(&scene), &flag("magic")).unwrap_err().key, "--shadows");
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(ShadowsConfig::default().name(), "traced");
}
