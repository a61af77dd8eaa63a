//! The edge-table method's parameters and named presets (the scene-file keys are listed in
//! the `edge_table` module doc).

use crate::depth_map::DepthMapParams;
use crate::heightfield::Heightfield;

/// How visibilities of neighbouring masks combine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Blend {
    /// The mask nearest in sub-pixel offset and (log) depth.
    Nearest,
    /// Trilinear weights over the 8 surrounding masks (4 with a single depth level); the
    /// visibility fractions are blended, never the bits (each mask has its own samples).
    Trilinear,
}

/// Parameters of the edge-table method. See the module doc for the scene-file keys.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeTableParams {
    pub depth_map: DepthMapParams,
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
    pub mirrored: bool,
}

impl EdgeTableParams {
    /// The paper's configuration: 256^2 map, 4 x 4 x 1 masks, nearest mask, walls and floors;
    /// the map itself is this crate's (closed volumes and the hidden layer, which `shells`
    /// does not read, and grazed receivers traced).
    pub const fn paper() -> Self {
        Self {
            depth_map: DepthMapParams::new(256),
            grid: [4, 4, 1],
            blend: Blend::Nearest,
            heightfield: Heightfield::Shells,
            mirrored: false,
        }
    }
    /// The default, chosen by measurement (docs/edge_table_accuracy.md, ARCHITECTURE.md):
    /// 256^2 map, 2 x 2 x 8 masks, nearest mask, thin plates. Depth levels matter more than
    /// sub-pixel ones (a mask read at another depth sees the light scaled); against 4 x 4 x 4
    /// it has the same RMSE to within 0.0004 on six of seven scenes at under half the mask
    /// memory, and error^2 x cost 0.75x-1.0x of that grid's in the accuracy run and
    /// 0.76x-1.03x in the bench (ARCHITECTURE.md); 8 x 8 x 4 grids and trilinear blending
    /// lower the error less per unit of cost.
    pub const fn balanced() -> Self {
        Self {
            depth_map: DepthMapParams::new(256),
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
