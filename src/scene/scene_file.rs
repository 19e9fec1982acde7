//! `scene.toml` (serde): geometry and sensor paths, up axis, north rotation, ground
//! reflectance and site. PLACEHOLDER.

use super::Scene;
use crate::error::Result;
use std::path::Path;

/// Loads a scene file and everything it references (see INTERFACE.md).
///
/// # Errors
/// [`crate::Error::Input`] naming file, line and value.
pub fn load(path: &Path) -> Result<Scene> {
    let _ = path;
    todo!()
}
