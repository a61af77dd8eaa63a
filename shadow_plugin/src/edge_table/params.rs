//! The edge-table method's parameters, its readings and named presets, and the scene file's
//! table of them (the keys are listed in the `edge_table` module doc).

use super::EdgeTable;
use crate::depth_map::bits::MAX_SAMPLES;
use crate::depth_map::heightfield::{Heightfield, inapplicable_to_reading};
use crate::depth_map::{DepthMapParams, MapSwitches};
use renderer::interface::method::reads;
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

/// How the masks are read, with what only that reading reads.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Reading {
    /// Each ray classified clear, blocked or undecided against conservative depth bounds; the
    /// undecided ones traced through the BVH. The visibility is exactly that of tracing every
    /// ray of the mask's sample set (`edge_table/exact.rs`). It has no bias, slab, grazing
    /// policy or blending (one mask per point, so its answer is that mask's sample set
    /// traced): of the depth map's keys it reads `depth_map` alone.
    Exact,
    /// The sketch's reading: the centre-ray depth map as a heightfield (`heightfield`), with
    /// its bias, slab and grazing settings, nearest or trilinear (`blend`). Approximate.
    Published(PublishedParams),
}

/// The published reading's parameters: the keys only it reads.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PublishedParams {
    /// How the depth map's heightfield is read (variant A or B).
    pub heightfield: Heightfield,
    pub blend: Blend,
    /// The depth map's bias, slab and grazing policy: [`DepthMapParams`]' fields of these
    /// names.
    pub slope_bias: f32,
    pub slab_thickness: f32,
    pub normal_offset: f32,
    pub grazing_cos: f32,
}

impl PublishedParams {
    /// Thin plates, the nearest mask, and the depth map's default bias, slab and grazing
    /// policy: what `reading = "published"` starts from when the preset reads exactly.
    pub const DEFAULT: Self = {
        let map = DepthMapParams::new(256);
        Self {
            heightfield: Heightfield::Plates,
            blend: Blend::Nearest,
            slope_bias: map.slope_bias,
            slab_thickness: map.slab_thickness,
            normal_offset: map.normal_offset,
            grazing_cos: map.grazing_cos,
        }
    };
}

impl Default for PublishedParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The edge table's code-only switches: the bench and the accuracy example switch them,
/// presets set them; the scene file cannot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EdgeTableSwitches {
    /// Build only the masks with sub-pixel offsets at most 1/2 and read the others as their
    /// mirror images (technical note 10.2): a point at offset (1 - fx, fy) seen through the
    /// mask at (fx, fy) with pixel columns and the samples' x reflected gets the same
    /// crossings, bit for bit. 4x fewer masks on a 4 x 4 grid (less memory, less to build,
    /// more of it in cache); a mirrored pair shares its (reflected) samples. The exact
    /// reading never mirrors.
    pub mirrored: bool,
    /// The depth map's.
    pub map: MapSwitches,
}

/// Parameters of the edge-table method (the scene file's `[shadows.edge_table]` is
/// [`EdgeTableTable`]; see the module doc for the keys).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeTableParams {
    /// Depth-map pixels per side (key `depth_map`, [`DepthMapParams::resolution`]).
    pub resolution: u32,
    /// Masks over (sub-pixel x, sub-pixel y, depth). Sub-pixel samples are cell-centred,
    /// (a + 1/2) / n; depth levels are at the (k + 1/2) / n quantiles of the depths of the
    /// receivers the light reaches.
    pub grid: [u32; 3],
    /// Exact (the default) or the published approximate reading.
    pub reading: Reading,
    pub switches: EdgeTableSwitches,
}

impl EdgeTableParams {
    /// The paper's configuration: 256^2 map, 4 x 4 x 1 masks, nearest mask, walls and floors;
    /// the map itself is this crate's (closed volumes and the hidden layer, which `shells`
    /// does not read, and grazed receivers traced).
    pub const fn paper() -> Self {
        Self {
            resolution: 256,
            grid: [4, 4, 1],
            reading: Reading::Published(PublishedParams {
                heightfield: Heightfield::Shells,
                ..PublishedParams::DEFAULT
            }),
            switches: EdgeTableSwitches { mirrored: false, map: MapSwitches::ALL },
        }
    }
    /// The default, chosen by measurement (docs/edge_table_accuracy.md, docs/notes/2026-11-21-grid-2x2x8.md):
    /// 256^2 map, 2 x 2 x 8 masks, read exactly. Depth levels matter more than
    /// sub-pixel ones (a mask read at another depth sees the light scaled); against 4 x 4 x 4
    /// it has the same RMSE to within 0.0004 on six of seven scenes at under half the mask
    /// memory, and error^2 x cost 0.75x-1.0x of that grid's in the accuracy run and
    /// 0.76x-1.03x in the bench (same note); 8 x 8 x 4 grids and trilinear blending
    /// lower the error less per unit of cost.
    pub const fn balanced() -> Self {
        Self {
            resolution: 256,
            grid: [2, 2, 8],
            reading: Reading::Exact,
            switches: EdgeTableSwitches { mirrored: true, map: MapSwitches::ALL },
        }
    }
    /// Finer and slower: 512^2 map, 8 x 8 x 4 masks, trilinear, published.
    pub const fn fine() -> Self {
        Self {
            resolution: 512,
            grid: [8, 8, 4],
            reading: Reading::Published(PublishedParams {
                blend: Blend::Trilinear,
                ..PublishedParams::DEFAULT
            }),
            switches: EdgeTableSwitches { mirrored: true, map: MapSwitches::ALL },
        }
    }

    /// The depth map the reading builds: the published reading's bias, slab and grazing
    /// policy, or for the exact reading the defaults (its frustum's fit leaves grazed
    /// receivers out by the default policy, as every map's does).
    pub fn depth_map(&self) -> DepthMapParams {
        match self.reading {
            Reading::Exact => {
                DepthMapParams { switches: self.switches.map, ..DepthMapParams::new(self.resolution) }
            }
            Reading::Published(p) => DepthMapParams {
                resolution: self.resolution,
                slope_bias: p.slope_bias,
                slab_thickness: p.slab_thickness,
                normal_offset: p.normal_offset,
                grazing_cos: p.grazing_cos,
                switches: self.switches.map,
            },
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

/// `[shadows.edge_table]` as the scene file spells it (`preset` aside): flat, every key of
/// either reading. An exact reading's table leaves the published reading's keys out
/// (`None`): it does not read them, and a table that sets one with it is an error.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EdgeTableTable {
    depth_map: u32,
    grid: [u32; 3],
    reading: ReadingKind,
    #[serde(skip_serializing_if = "Option::is_none")]
    heightfield: Option<Heightfield>,
    #[serde(skip_serializing_if = "Option::is_none")]
    blend: Option<Blend>,
    #[serde(skip_serializing_if = "Option::is_none")]
    slope_bias: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    slab_thickness: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    normal_offset: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    grazing_cos: Option<f32>,
}

/// The values of `reading`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
enum ReadingKind {
    Exact,
    Published,
}

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
    type Table = EdgeTableTable;

    fn base(table: &toml::Table) -> Result<Self, KeyError> {
        let preset = match table.get("preset") {
            None => Preset::Balanced,
            Some(v) => {
                v.clone().try_into().map_err(|e: toml::de::Error| KeyError::new("preset", e.message()))?
            }
        };
        let base = match preset {
            Preset::Paper => Self::paper(),
            Preset::Balanced => Self::balanced(),
            Preset::Fine => Self::fine(),
        };
        // A table that sets keys only the published reading reads, and no `reading`, means
        // that reading: scene files written before the exact reading (the contract's example
        // sets `blend`) keep their meaning. With `reading = "exact"` those keys are errors.
        let published = Self { reading: Reading::Published(PublishedParams::DEFAULT), ..base };
        let only_published = |k: &String| !reads(&base, k) && reads(&published, k);
        if !table.contains_key("reading") && table.keys().any(only_published) {
            return Ok(published);
        }
        Ok(base)
    }

    fn table(&self) -> EdgeTableTable {
        let (reading, p) = match self.reading {
            Reading::Exact => (ReadingKind::Exact, None),
            Reading::Published(p) => (ReadingKind::Published, Some(p)),
        };
        EdgeTableTable {
            depth_map: self.resolution,
            grid: self.grid,
            reading,
            heightfield: p.map(|p| p.heightfield),
            blend: p.map(|p| p.blend),
            slope_bias: p.map(|p| p.slope_bias),
            slab_thickness: p.map(|p| p.slab_thickness),
            normal_offset: p.map(|p| p.normal_offset),
            grazing_cos: p.map(|p| p.grazing_cos),
        }
    }

    fn with_table(&self, t: EdgeTableTable) -> Self {
        let reading = match t.reading {
            // The published keys a preset under it gave are not read (and those the table
            // gives are errors: `inapplicable`).
            ReadingKind::Exact => Reading::Exact,
            ReadingKind::Published => {
                let d = PublishedParams::DEFAULT;
                Reading::Published(PublishedParams {
                    heightfield: t.heightfield.unwrap_or(d.heightfield),
                    blend: t.blend.unwrap_or(d.blend),
                    slope_bias: t.slope_bias.unwrap_or(d.slope_bias),
                    slab_thickness: t.slab_thickness.unwrap_or(d.slab_thickness),
                    normal_offset: t.normal_offset.unwrap_or(d.normal_offset),
                    grazing_cos: t.grazing_cos.unwrap_or(d.grazing_cos),
                })
            }
        };
        Self { resolution: t.depth_map, grid: t.grid, reading, switches: self.switches }
    }

    fn inapplicable(&self, key: &str) -> Option<String> {
        match self.reading {
            // Its table holds every key it reads; the others are the published reading's.
            Reading::Exact => (!reads(self, key)).then(|| "applies only to reading = \"published\"".into()),
            Reading::Published(p) => inapplicable_to_reading(key, p.heightfield),
        }
    }

    fn validate(&self) -> Result<(), KeyError> {
        self.depth_map().validate()?;
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
