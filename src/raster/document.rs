//! Documents that name a raster where a risk goes (docs/rasters.md): a
//! mission or scenario JSON whose `risk` (or a scenario's `truth`) is
//! `{"raster": "FILE.tif", "spacing": M}` instead of a base and objects.
//! The file is read relative to the document's directory and fitted in
//! the document's own region and origin; what comes out is the same
//! document with the fitted risk in place, for the mission layer to
//! validate as any other.
//!
//! Invariant: a document that names no raster is returned as it is, byte
//! for byte, whatever it holds (its errors are the mission layer's to
//! report).

use std::path::{Path, PathBuf};

use serde_json::{Value, json};

use super::{Raster, RasterError, fit};
use crate::mission::Mission;

/// The fields a raster may stand in for.
const FIELDS: [&str; 2] = ["risk", "truth"];

/// `text` (a mission or scenario JSON document read from directory `dir`)
/// with every raster it names fitted in its place.
pub fn resolve(text: &str, dir: &Path) -> Result<String, RasterError> {
    let Ok(mut doc) = serde_json::from_str::<Value>(text) else {
        return Ok(text.to_string());
    };
    let named: Vec<(&str, PathBuf, Option<f64>)> = FIELDS
        .iter()
        .filter_map(|&field| {
            let r = doc.get(field)?;
            let file = r.get("raster")?.as_str()?;
            Some((
                field,
                dir.join(file),
                r.get("spacing").and_then(Value::as_f64),
            ))
        })
        .collect();
    if named.is_empty() {
        return Ok(text.to_string());
    }
    // The region and origin the rasters are placed in, with a flat
    // stand-in for what they will give.
    for (field, ..) in &named {
        doc[*field] = json!({"base": 0.0, "objects": []});
    }
    let mission =
        Mission::from_text(&doc.to_string()).map_err(|source| RasterError::Mission { source })?;
    for (field, path, spacing) in named {
        let raster = Raster::read(&path)?;
        let fitted = fit(&raster, &mission, spacing)?;
        doc[field] = serde_json::to_value(crate::mission::belief::risk_document(&fitted.risk))
            .expect("a risk document serializes");
    }
    Ok(doc.to_string())
}
