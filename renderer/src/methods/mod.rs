//! The built-in shadow methods: `traced` (the ground truth) and `none` (the cost floor).
//! Every other method lives in `shadow_plugin`, one folder each.

pub mod irradiance_share;
pub mod sample_stream;
pub mod traced;
