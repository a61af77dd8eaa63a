//! The one factory that maps a typed configuration to shadow-method plugins.

use crate::config::{MethodName, ShadowsConfig};
use renderer::{LightShadowing, Traced, TracedParams, Unshadowed};

/// A fresh, unprepared method for one light.
pub fn build_shadowing(config: &ShadowsConfig) -> Box<dyn LightShadowing> {
    match config.method {
        MethodName::Traced => Box::new(Traced::new(TracedParams { samples: config.samples })),
        MethodName::None => Box::new(Unshadowed),
    }
}
