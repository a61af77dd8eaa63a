//! The edge-table method's parameters and named presets (the scene-file keys are listed in
//! the `edge_table` module doc).

use super::EdgeTable;
use crate::bits::MAX_SAMPLES;
use crate::depth_map::DepthMapParams;
use crate::heightfield::{Heightfield, inapplicable_to_reading};
use renderer::{KeyError, LightShadowing, MethodParams, ShadowMethod};
use serde::{Deserialize, Serialize};

/// How visibilities of neighbouring masks combine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Blend {
    /// The mask nearest in sub-pixel offset and (log) depth.
    Nearest,
    /// Trilinear weights over the 8 surrounding masks (4 with a single depth level); the
    /// visibility fractions are blended, never the bits (each mask has its own samples).
    Trilinear,
}

/// How the masks are read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reading {
    /// Each ray classified clear, blocked or undecided against conservative depth bounds; the
    /// undecided ones traced through the BVH. The visibility is exactly that of tracing every
    /// ray of the mask's sample set (`edge_table/exact.rs`).
    Exact,
    /// The sketch's reading: the centre-ray depth map as a heightfield (`heightfield`), with
    /// its bias, slab and grazing settings, nearest or trilinear (`blend`). Approximate.
    Published,
}

/// Parameters of the edge-table method: `[shadows.edge_table]` (see the module doc for the
/// keys); `mirrored` is code-only, set by the preset.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EdgeTableParams {
    #[serde(flatten)]
    pub depth_map: DepthMapParams,
    /// Exact (the default) or the published approximate reading.
    pub reading: Reading,
    /// Masks over (sub-pixel x, sub-pixel y, depth). Sub-pixel samples are cell-centred,
    /// (a + 1/2) / n; depth levels are at the (k + 1/2) / n quantiles of the depths of the
    /// receivers the light reaches.
    pub grid: [u32; 3],
    pub blend: Blend,
    /// How the depth map's heightfield is read (variant A or B).
    pub heightfield: Heightfield,
    /// Build only the masks with sub-pixel offsets at most 1/2 and read the others as their
    /// mirror images (technical note 10.2): a point at offset (1 - fx, fy) seen through the
    /// mask at (fx, fy) with pixel columns and the samples' x reflected gets the same
    /// crossings, bit for bit. 4x fewer masks on a 4 x 4 grid (less memory, less to build,
    /// more of it in cache); a mirrored pair shares its (reflected) samples.
    #[serde(skip)]
    pub mirrored: bool,
}

impl EdgeTableParams {
    /// The paper's configuration: 256^2 map, 4 x 4 x 1 masks, nearest mask, walls and floors;
    /// the map itself is this crate's (closed volumes and the hidden layer, which `shells`
    /// does not read, and grazed receivers traced).
    pub const fn paper() -> Self {
        Self {
            depth_map: DepthMapParams::new(256),
            reading: Reading::Published,
            grid: [4, 4, 1],
            blend: Blend::Nearest,
            heightfield: Heightfield::Shells,
            mirrored: false,
        }
    }
    /// The default, chosen by measurement (docs/edge_table_accuracy.md, docs/notes/2026-11-21-grid-2x2x8.md):
    /// 256^2 map, 2 x 2 x 8 masks, nearest mask, thin plates. Depth levels matter more than
    /// sub-pixel ones (a mask read at another depth sees the light scaled); against 4 x 4 x 4
    /// it has the same RMSE to within 0.0004 on six of seven scenes at under half the mask
    /// memory, and error^2 x cost 0.75x-1.0x of that grid's in the accuracy run and
    /// 0.76x-1.03x in the bench (same note); 8 x 8 x 4 grids and trilinear blending
    /// lower the error less per unit of cost.
    pub const fn balanced() -> Self {
        Self {
            depth_map: DepthMapParams::new(256),
            reading: Reading::Exact,
            grid: [2, 2, 8],
            blend: Blend::Nearest,
            heightfield: Heightfield::Plates,
            mirrored: true,
        }
    }
    /// Finer and slower: 512^2 map, 8 x 8 x 4 masks, trilinear.
    pub const fn fine() -> Self {
        Self {
            depth_map: DepthMapParams::new(512),
            reading: Reading::Published,
            grid: [8, 8, 4],
            blend: Blend::Trilinear,
            heightfield: Heightfield::Plates,
            mirrored: true,
        }
    }
}

impl Default for EdgeTableParams {
    fn default() -> Self {
        Self::balanced()
    }
}

/// The named starting points of `[shadows.edge_table]` (`preset`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Preset {
    /// [`EdgeTableParams::paper`].
    Paper,
    /// [`EdgeTableParams::balanced`], the default.
    Balanced,
    /// [`EdgeTableParams::fine`].
    Fine,
}

/// Keys only the published reading reads: the exact one has no bias, slab, grazing policy or
/// blending (one mask per point, so its answer is that mask's sample set traced).
pub const PUBLISHED_ONLY: &[&str] =
    &["heightfield", "blend", "slab_thickness", "slope_bias", "normal_offset", "grazing_cos"];

/// Most masks a grid may hold, and the range of each grid dimension.
pub const MAX_MASKS: u32 = 4096;
pub const GRID_RANGE: std::ops::RangeInclusive<u32> = 1..=64;

impl ShadowMethod for EdgeTableParams {
    fn name(&self) -> &'static str {
        EdgeTable::NAME
    }
    fn max_samples(&self) -> u32 {
        MAX_SAMPLES as u32
    }
    fn build(&self, samples: u32) -> Box<dyn LightShadowing> {
        Box::new(EdgeTable::new(*self, samples))
    }
}

impl MethodParams for EdgeTableParams {
    const NAME: &'static str = EdgeTable::NAME;
    const CHOICE_KEYS: &'static [&'static str] = &["preset"];

    fn base(table: &toml::Table) -> Result<Self, KeyError> {
        let preset = match table.get("preset") {
            None => Preset::Balanced,
            Some(v) => {
                v.clone().try_into().map_err(|e: toml::de::Error| KeyError::new("preset", e.message()))?
            }
        };
        let mut base = match preset {
            Preset::Paper => Self::paper(),
            Preset::Balanced => Self::balanced(),
            Preset::Fine => Self::fine(),
        };
        // A table that sets the published reading's keys and no `reading` means that reading:
        // scene files written before the exact reading (the contract's example sets `blend`)
        // keep their meaning. With `reading = "exact"` those keys are errors.
        if !table.contains_key("reading") && PUBLISHED_ONLY.iter().any(|k| table.contains_key(*k)) {
            base.reading = Reading::Published;
        }
        Ok(base)
    }

    fn keep_code_only(&mut self, base: &Self) {
        self.depth_map.keep_code_only(&base.depth_map);
        self.mirrored = base.mirrored;
    }

    fn inapplicable(&self, key: &str) -> Option<String> {
        if self.reading == Reading::Exact && PUBLISHED_ONLY.contains(&key) {
            return Some("applies only to reading = \"published\"".into());
        }
        inapplicable_to_reading(key, self.heightfield)
    }

    fn validate(&self) -> Result<(), KeyError> {
        self.depth_map.validate()?;
        if !self.grid.iter().all(|g| GRID_RANGE.contains(g)) || self.grid.iter().product::<u32>() > MAX_MASKS
        {
            return Err(KeyError::new(
                "grid",
                format!("each entry in 1..=64 and at most {MAX_MASKS} masks, got {:?}", self.grid),
            ));
        }
        Ok(())
    }
}
