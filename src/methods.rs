//! The one factory that maps a typed configuration to shadow-method plugins.

use crate::config::{MethodName, ShadowsConfig};
use renderer::{LightShadowing, Traced, Unshadowed};
use shadow_plugin::{DepthMarch, EdgeTable, Pcss};

/// A fresh, unprepared method for one light.
pub fn build_shadowing(config: &ShadowsConfig) -> Box<dyn LightShadowing> {
    match config.method {
        MethodName::Traced => Box::new(Traced::new(config.traced.params(config.samples))),
        MethodName::None => Box::new(Unshadowed),
        MethodName::EdgeTable => Box::new(EdgeTable::new(config.edge_table.params(), config.samples)),
        MethodName::DepthMarch => Box::new(DepthMarch::new(
            config.depth_march.params(),
            config.depth_march.heightfield(),
            config.samples,
        )),
        MethodName::Pcss => Box::new(Pcss::new(config.pcss.params(), config.samples)),
    }
}
