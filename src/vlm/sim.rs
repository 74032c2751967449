//! The offline `sim` model (being built by the search work).
use std::path::Path;
use std::sync::Arc;

use crate::ir::Domain;
use crate::vlm::Model;

/// Load a sim profile (TOML) checked against the domain's concept names.
pub fn load(path: &Path, _domain: &Domain) -> Result<Arc<dyn Model>, String> {
    Err(format!("cannot load sim profile `{}`: the sim model is not built yet", path.display()))
}
