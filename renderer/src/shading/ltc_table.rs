//! The LTC table of `super::ltc` (penumbra's own fit, see `renderer/examples/fit_ltc.rs`):
//! `ltc_table.bin`, written by `cargo run --release -p renderer --example fit_ltc` (do not
//! edit): LTC_SIZE x LTC_SIZE nodes, index `i * LTC_SIZE + j` for roughness row i and view
//! column j, each `[m00, m02, m20, m22, norm, fresnel]` (minv scaled to m11 = 1) as six
//! little-endian f32. Data, not source: 4,096 lines of numbers read no better as Rust.
//!
//! Fitted in 146 s (wall, 2 threads), L1 objective, 1655319 evaluations of it.
//! Total variation distance between the LTC and the normalised lobe, max per band:
//!   roughness          | view <= 60 deg | 60-80 deg | 80-85 deg | > 85 deg
//!   [0.00, 0.05)        | 0.0011 | 0.0047 | 0.0095 | 0.2913
//!   [0.05, 0.10)        | 0.0045 | 0.0191 | 0.0381 | 0.5268
//!   [0.10, 0.20)        | 0.0177 | 0.0713 | 0.1293 | 0.3428
//!   [0.20, 0.40)        | 0.0587 | 0.1609 | 0.2129 | 0.3386
//!   [0.40, 0.70)        | 0.0663 | 0.1623 | 0.2103 | 0.2614
//!   [0.70, 1.00)        | 0.0451 | 0.0852 | 0.0932 | 0.1244

use super::ltc::LTC_SIZE;
use std::sync::OnceLock;

const BYTES: &[u8; LTC_SIZE * LTC_SIZE * 6 * 4] = include_bytes!("ltc_table.bin");

/// The table's nodes, decoded once.
pub(super) fn ltc_table() -> &'static [[f32; 6]] {
    static TABLE: OnceLock<Vec<[f32; 6]>> = OnceLock::new();
    TABLE.get_or_init(|| {
        BYTES
            .chunks_exact(24)
            .map(|node| {
                std::array::from_fn(|k| f32::from_le_bytes(node[4 * k..4 * k + 4].try_into().unwrap()))
            })
            .collect()
    })
}
