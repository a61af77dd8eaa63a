//! The `[shadows]` table, typed. This is the composition root's half of the scene file: the
//! renderer keeps `[shadows]` raw because only this crate knows every method.

use renderer::config::deserialize_value;
use renderer::{SceneError, TracedParams};
use serde::Deserialize;
use shadow_plugin::{Blend, DepthMapParams, EdgeTableParams, Heightfield, PcssParams};
use std::path::Path;

/// Shadow methods, as the scene file and `--shadows` spell them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
#[value(rename_all = "snake_case")]
pub enum MethodName {
    /// Shadow rays through the BVH to `samples` stratified points on the light: the truth.
    #[default]
    Traced,
    /// No shadows (V = 1): the cost floor.
    None,
    /// Edge-table masks over a light-space depth map (Egan & Neulander 2004).
    EdgeTable,
    /// Each shadow ray marched through the same depth map (walls and floors).
    DepthMarch,
    /// Percentage-closer soft shadows (Fernando 2005) on the same depth map: the real-time
    /// baseline.
    Pcss,
}

impl MethodName {
    pub fn as_str(self) -> &'static str {
        match self {
            MethodName::Traced => "traced",
            MethodName::None => "none",
            MethodName::EdgeTable => "edge_table",
            MethodName::DepthMarch => "depth_march",
            MethodName::Pcss => "pcss",
        }
    }
}

/// Light samples per shading point when the scene file does not say.
pub const DEFAULT_SAMPLES: u32 = 256;
/// Largest sample count accepted (64 x 1024 bits per mask is the edge-table ceiling too).
pub const MAX_SAMPLES: u32 = 65536;

/// `[shadows]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShadowsConfig {
    #[serde(default)]
    pub method: MethodName,
    /// Light samples per shading point (per mask for `edge_table`).
    #[serde(default = "default_samples")]
    pub samples: u32,
    #[serde(default)]
    pub traced: TracedConfig,
    #[serde(default)]
    pub edge_table: EdgeTableConfig,
    #[serde(default)]
    pub depth_march: DepthMapConfig,
    #[serde(default)]
    pub pcss: PcssConfig,
}

/// Named edge-table presets (`shadow_plugin::EdgeTableParams`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Preset {
    /// The 2004 sketch: 256^2 map, 4 x 4 x 1 masks, nearest mask.
    Paper,
    /// The default: 256^2 map, 2 x 2 x 8 masks, nearest mask, plates.
    Balanced,
    /// 512^2 map, 8 x 8 x 4 masks, trilinear, plates.
    Fine,
}

/// How the depth map's heightfield is read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HeightfieldName {
    /// Variant A: solid behind the first surface (inner penumbrae become umbra).
    Solid,
    /// Variant B: floors and front-facing walls.
    Shells,
    /// Floors only (thin plates): the default.
    Plates,
}

impl HeightfieldName {
    fn get(self) -> Heightfield {
        match self {
            HeightfieldName::Solid => Heightfield::Solid,
            HeightfieldName::Shells => Heightfield::Shells,
            HeightfieldName::Plates => Heightfield::Plates,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BlendName {
    Nearest,
    Trilinear,
}

/// `[shadows.edge_table]`: a preset, then any of its fields overridden.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EdgeTableConfig {
    pub preset: Option<Preset>,
    /// Depth-map pixels per side.
    pub depth_map: Option<u32>,
    /// Masks over (sub-pixel x, sub-pixel y, depth).
    pub grid: Option<[u32; 3]>,
    pub blend: Option<BlendName>,
    /// Slope-scaled depth bias in depth-map pixels.
    pub slope_bias: Option<f32>,
    pub heightfield: Option<HeightfieldName>,
    /// Slab thickness of the `plates` reading, in depth-map pixel footprints.
    pub slab_thickness: Option<f32>,
    /// Grazing normal offset of lookups, in depth-map pixel footprints.
    pub normal_offset: Option<f32>,
    /// `plates`: closed meshes are solid from their front face down to their back face.
    pub closed_volumes: Option<bool>,
    /// `plates`: a second, hidden layer (the first surface under each pixel's slab).
    pub hidden_layer: Option<bool>,
    /// Receivers whose normal's cosine to the direction of the light's centre is below this
    /// are traced.
    pub grazing_cos: Option<f32>,
    /// Fit the map to the receivers something may shadow (shaft test), not to all lit ones.
    pub fit_shadowed: Option<bool>,
    /// Build the masks with sub-pixel offsets up to 1/2 only and read the rest mirrored.
    pub mirrored: Option<bool>,
}

/// `[shadows.traced]`.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TracedConfig {
    /// Prove bundles of rays unblocked with one BVH query per part of the light before
    /// tracing them (`renderer::shaft`). Default true: the same bits, 2-4x cheaper on the
    /// scenes measured (README). `false` traces every ray: the plain reference.
    pub shaft_culling: Option<bool>,
}

impl TracedConfig {
    pub fn params(&self, samples: u32) -> TracedParams {
        TracedParams { samples, shaft_culling: self.shaft_culling.unwrap_or(true) }
    }
}

/// `[shadows.depth_march]`.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DepthMapConfig {
    pub depth_map: Option<u32>,
    pub slope_bias: Option<f32>,
    pub heightfield: Option<HeightfieldName>,
    pub slab_thickness: Option<f32>,
    pub normal_offset: Option<f32>,
    pub closed_volumes: Option<bool>,
    pub hidden_layer: Option<bool>,
    pub grazing_cos: Option<f32>,
    pub fit_shadowed: Option<bool>,
}

/// `[shadows.pcss]`: any of `shadow_plugin::PcssParams`' defaults overridden.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PcssConfig {
    /// Depth-map pixels per side.
    pub depth_map: Option<u32>,
    /// Light samples read by the blocker search.
    pub blocker_samples: Option<u32>,
    /// Slope-scaled depth bias in depth-map pixels.
    pub slope_bias: Option<f32>,
    /// Grazing normal offset of lookups, in depth-map pixel footprints.
    pub normal_offset: Option<f32>,
    /// Receivers whose normal's cosine to the direction of the light's centre is below this
    /// are traced (default 0).
    pub grazing_cos: Option<f32>,
}

impl PcssConfig {
    pub fn params(&self) -> PcssParams {
        let mut p = PcssParams::default();
        if let Some(n) = self.depth_map {
            p.depth_map.resolution = n;
        }
        if let Some(n) = self.blocker_samples {
            p.blocker_samples = n;
        }
        if let Some(b) = self.slope_bias {
            p.depth_map.slope_bias = b;
        }
        if let Some(t) = self.normal_offset {
            p.depth_map.normal_offset = t;
        }
        if let Some(c) = self.grazing_cos {
            p.depth_map.grazing_cos = c;
        }
        p
    }
}

/// Bounds checked at the boundary.
pub const DEPTH_MAP_RANGE: std::ops::RangeInclusive<u32> = 4..=8192;
pub const GRID_RANGE: std::ops::RangeInclusive<u32> = 1..=64;
pub const MAX_MASKS: u32 = 4096;

impl EdgeTableConfig {
    pub fn params(&self) -> EdgeTableParams {
        let mut p = match self.preset.unwrap_or(Preset::Balanced) {
            Preset::Paper => EdgeTableParams::paper(),
            Preset::Balanced => EdgeTableParams::balanced(),
            Preset::Fine => EdgeTableParams::fine(),
        };
        if let Some(n) = self.depth_map {
            p.depth_map.resolution = n;
        }
        if let Some(g) = self.grid {
            p.grid = g;
        }
        if let Some(b) = self.blend {
            p.blend = match b {
                BlendName::Nearest => Blend::Nearest,
                BlendName::Trilinear => Blend::Trilinear,
            };
        }
        if let Some(b) = self.slope_bias {
            p.depth_map.slope_bias = b;
        }
        if let Some(h) = self.heightfield {
            p.heightfield = h.get();
        }
        if let Some(t) = self.slab_thickness {
            p.depth_map.slab_thickness = t;
        }
        if let Some(t) = self.normal_offset {
            p.depth_map.normal_offset = t;
        }
        if let Some(c) = self.closed_volumes {
            p.depth_map.closed_volumes = c;
        }
        if let Some(h) = self.hidden_layer {
            p.depth_map.hidden_layer = h;
        }
        if let Some(c) = self.grazing_cos {
            p.depth_map.grazing_cos = c;
        }
        if let Some(f) = self.fit_shadowed {
            p.depth_map.fit_shadowed = f;
        }
        if let Some(m) = self.mirrored {
            p.mirrored = m;
        }
        p
    }
}

impl DepthMapConfig {
    pub fn heightfield(&self) -> Heightfield {
        self.heightfield.map_or(EdgeTableParams::default().heightfield, HeightfieldName::get)
    }

    pub fn params(&self) -> DepthMapParams {
        let d = DepthMapParams::default();
        DepthMapParams {
            resolution: self.depth_map.unwrap_or(d.resolution),
            slope_bias: self.slope_bias.unwrap_or(d.slope_bias),
            slab_thickness: self.slab_thickness.unwrap_or(d.slab_thickness),
            normal_offset: self.normal_offset.unwrap_or(d.normal_offset),
            closed_volumes: self.closed_volumes.unwrap_or(d.closed_volumes),
            hidden_layer: self.hidden_layer.unwrap_or(d.hidden_layer),
            grazing_cos: self.grazing_cos.unwrap_or(d.grazing_cos),
            fit_shadowed: self.fit_shadowed.unwrap_or(d.fit_shadowed),
        }
    }
}

fn check_depth_map(p: &DepthMapParams, file: &Path, table: &str) -> Result<(), SceneError> {
    if !DEPTH_MAP_RANGE.contains(&p.resolution) {
        return Err(SceneError::new(
            file,
            format!("{table}.depth_map"),
            format!(
                "must be in {}..={}, got {}",
                DEPTH_MAP_RANGE.start(),
                DEPTH_MAP_RANGE.end(),
                p.resolution
            ),
        ));
    }
    if !(p.slope_bias.is_finite() && p.slope_bias >= 0.0) {
        return Err(SceneError::new(file, format!("{table}.slope_bias"), "must be finite and >= 0"));
    }
    if !(p.normal_offset.is_finite() && p.normal_offset >= 0.0) {
        return Err(SceneError::new(file, format!("{table}.normal_offset"), "must be finite and >= 0"));
    }
    if !(p.slab_thickness.is_finite() && p.slab_thickness >= 0.0) {
        return Err(SceneError::new(file, format!("{table}.slab_thickness"), "must be finite and >= 0"));
    }
    if !(0.0..1.0).contains(&p.grazing_cos) {
        return Err(SceneError::new(file, format!("{table}.grazing_cos"), "must be in [0, 1)"));
    }
    Ok(())
}

fn default_samples() -> u32 {
    DEFAULT_SAMPLES
}

impl Default for ShadowsConfig {
    fn default() -> Self {
        Self {
            method: MethodName::default(),
            samples: DEFAULT_SAMPLES,
            traced: TracedConfig::default(),
            edge_table: EdgeTableConfig::default(),
            depth_march: DepthMapConfig::default(),
            pcss: PcssConfig::default(),
        }
    }
}

impl ShadowsConfig {
    /// Types the raw `[shadows]` table of `scene_path`.
    pub fn from_table(table: &toml::Table, scene_path: &Path) -> Result<Self, SceneError> {
        let config: ShadowsConfig =
            deserialize_value(toml::Value::Table(table.clone()), scene_path, "shadows")?;
        config.validate(scene_path, "shadows.samples")?;
        Ok(config)
    }

    /// Checks the whole configuration for the chosen method; `samples_key` names where the
    /// sample count came from (the scene key or the CLI flag).
    pub fn validate(&self, file: &Path, samples_key: &str) -> Result<(), SceneError> {
        let max = match self.method {
            MethodName::EdgeTable | MethodName::DepthMarch | MethodName::Pcss => {
                shadow_plugin::bits::MAX_SAMPLES as u32
            }
            _ => MAX_SAMPLES,
        };
        if self.samples == 0 || self.samples > max {
            return Err(SceneError::new(
                file,
                samples_key,
                format!("must be in 1..={max} for {}, got {}", self.method.as_str(), self.samples),
            ));
        }
        let et = self.edge_table.params();
        check_depth_map(&et.depth_map, file, "shadows.edge_table")?;
        if !et.grid.iter().all(|g| GRID_RANGE.contains(g)) || et.grid.iter().product::<u32>() > MAX_MASKS {
            return Err(SceneError::new(
                file,
                "shadows.edge_table.grid",
                format!("each entry in 1..=64 and at most {MAX_MASKS} masks, got {:?}", et.grid),
            ));
        }
        check_depth_map(&self.depth_march.params(), file, "shadows.depth_march")?;
        let pcss = self.pcss.params();
        check_depth_map(&pcss.depth_map, file, "shadows.pcss")?;
        let max_blockers = shadow_plugin::bits::MAX_SAMPLES as u32;
        if !(1..=max_blockers).contains(&pcss.blocker_samples) {
            return Err(SceneError::new(
                file,
                "shadows.pcss.blocker_samples",
                format!("must be in 1..={max_blockers}, got {}", pcss.blocker_samples),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> toml::Table {
        text.parse().unwrap()
    }

    #[test]
    fn methods_and_samples_parse() {
        let p = Path::new("s.toml");
        let c = ShadowsConfig::from_table(&table("method = \"none\"\nsamples = 64"), p).unwrap();
        assert_eq!((c.method, c.samples), (MethodName::None, 64));
        assert_eq!(ShadowsConfig::from_table(&table(""), p).unwrap(), ShadowsConfig::default());
    }

    #[test]
    fn bad_shadow_keys_are_named() {
        let p = Path::new("s.toml");
        let e = ShadowsConfig::from_table(&table("method = \"magic\""), p).unwrap_err();
        assert_eq!(e.key, "shadows.method", "{e}");
        let e = ShadowsConfig::from_table(&table("sample = 3"), p).unwrap_err();
        assert_eq!(e.key, "shadows.sample", "{e}");
        let e = ShadowsConfig::from_table(&table("samples = 0"), p).unwrap_err();
        assert_eq!(e.key, "shadows.samples", "{e}");
        let e = ShadowsConfig::from_table(&table("method = \"edge_table\"\nsamples = 8192"), p).unwrap_err();
        assert_eq!(e.key, "shadows.samples", "{e}");
        let e = ShadowsConfig::from_table(&table("[edge_table]\ngrid = [4, 0, 1]"), p).unwrap_err();
        assert_eq!(e.key, "shadows.edge_table.grid", "{e}");
        let e = ShadowsConfig::from_table(&table("[edge_table]\ngird = [4, 4, 1]"), p).unwrap_err();
        assert_eq!(e.key, "shadows.edge_table.gird", "{e}");
        let e = ShadowsConfig::from_table(&table("[edge_table]\nblend = \"cubic\""), p).unwrap_err();
        assert_eq!(e.key, "shadows.edge_table.blend", "{e}");
        let e = ShadowsConfig::from_table(&table("[depth_march]\ndepth_map = 2"), p).unwrap_err();
        assert_eq!(e.key, "shadows.depth_march.depth_map", "{e}");
    }

    #[test]
    fn traced_shaft_culling_is_on_by_default_and_can_be_turned_off() {
        let p = Path::new("s.toml");
        assert!(ShadowsConfig::default().traced.params(64).shaft_culling);
        let c = ShadowsConfig::from_table(&table("[traced]\nshaft_culling = false"), p).unwrap();
        assert_eq!(c.traced.params(64), TracedParams::plain(64));
        let e = ShadowsConfig::from_table(&table("[traced]\nshaft_cull = false"), p).unwrap_err();
        assert_eq!(e.key, "shadows.traced.shaft_cull", "{e}");
        let e = ShadowsConfig::from_table(&table("[traced]\nshaft_culling = 1"), p).unwrap_err();
        assert_eq!(e.key, "shadows.traced.shaft_culling", "{e}");
    }

    #[test]
    fn presets_and_overrides() {
        let p = Path::new("s.toml");
        let c = ShadowsConfig::from_table(
            &table("method = \"edge_table\"\n[edge_table]\npreset = \"fine\"\ngrid = [2, 2, 1]"),
            p,
        )
        .unwrap();
        let params = c.edge_table.params();
        assert_eq!(params.grid, [2, 2, 1]);
        assert_eq!(params.blend, Blend::Trilinear);
        assert_eq!(params.depth_map.resolution, 512);
        assert!(params.mirrored);
        assert_eq!(ShadowsConfig::default().edge_table.params(), EdgeTableParams::balanced());
        let c = ShadowsConfig::from_table(&table("[edge_table]\nmirrored = false"), p).unwrap();
        assert!(!c.edge_table.params().mirrored && !EdgeTableParams::paper().mirrored);
    }

    #[test]
    fn pcss_parses_and_bad_pcss_keys_are_named() {
        let p = Path::new("s.toml");
        let c = ShadowsConfig::from_table(
            &table("method = \"pcss\"\nsamples = 1024\n[pcss]\ndepth_map = 512\nblocker_samples = 64"),
            p,
        )
        .unwrap();
        assert_eq!((c.method, c.samples, c.method.as_str()), (MethodName::Pcss, 1024, "pcss"));
        let params = c.pcss.params();
        assert_eq!((params.depth_map.resolution, params.blocker_samples), (512, 64));
        assert_eq!(params.depth_map.slope_bias, DepthMapParams::default().slope_bias);
        assert_eq!(ShadowsConfig::default().pcss.params(), PcssParams::default());

        let e = ShadowsConfig::from_table(&table("[pcss]\nblocker_sample = 8"), p).unwrap_err();
        assert_eq!(e.key, "shadows.pcss.blocker_sample", "{e}");
        let e = ShadowsConfig::from_table(&table("[pcss]\nblocker_samples = 0"), p).unwrap_err();
        assert_eq!(e.key, "shadows.pcss.blocker_samples", "{e}");
        let e = ShadowsConfig::from_table(&table("[pcss]\nblocker_samples = 4097"), p).unwrap_err();
        assert_eq!(e.key, "shadows.pcss.blocker_samples", "{e}");
        let e = ShadowsConfig::from_table(&table("[pcss]\ndepth_map = 2"), p).unwrap_err();
        assert_eq!(e.key, "shadows.pcss.depth_map", "{e}");
        let e = ShadowsConfig::from_table(&table("[pcss]\nslope_bias = -1.0"), p).unwrap_err();
        assert_eq!(e.key, "shadows.pcss.slope_bias", "{e}");
        let e = ShadowsConfig::from_table(&table("method = \"pcss\"\nsamples = 8192"), p).unwrap_err();
        assert_eq!(e.key, "shadows.samples", "{e}");
        // The PCSS keys are checked whichever method runs, like the other tables'.
        let e = ShadowsConfig::from_table(&table("method = \"traced\"\n[pcss]\nnormal_offset = nan"), p)
            .unwrap_err();
        assert_eq!(e.key, "shadows.pcss.normal_offset", "{e}");
    }

    #[test]
    fn grazing_cos_is_read_per_table_and_bounded() {
        let p = Path::new("s.toml");
        let c = ShadowsConfig::from_table(
            &table("[edge_table]\ngrazing_cos = 0.05\n[depth_march]\ngrazing_cos = 0.0\n[pcss]\ngrazing_cos = 0.3"),
            p,
        )
        .unwrap();
        assert_eq!(c.edge_table.params().depth_map.grazing_cos, 0.05);
        assert_eq!(c.depth_march.params().grazing_cos, 0.0);
        assert_eq!(c.pcss.params().depth_map.grazing_cos, 0.3);
        // Defaults: the policy for the two marching methods, none for the PCSS baseline.
        let d = ShadowsConfig::default();
        assert_eq!(
            d.edge_table.params().depth_map.grazing_cos,
            shadow_plugin::depth_map::DEFAULT_GRAZING_COS
        );
        assert_eq!(d.depth_march.params().grazing_cos, shadow_plugin::depth_map::DEFAULT_GRAZING_COS);
        assert_eq!(d.pcss.params().depth_map.grazing_cos, 0.0);
        for (t, bad) in [("edge_table", "-0.1"), ("depth_march", "1.0"), ("pcss", "nan")] {
            let e = ShadowsConfig::from_table(&table(&format!("[{t}]\ngrazing_cos = {bad}")), p).unwrap_err();
            assert_eq!(e.key, format!("shadows.{t}.grazing_cos"), "{e}");
        }
    }
}
