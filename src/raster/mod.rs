//! Risk maps from GIS rasters (docs/rasters.md): a single-band GeoTIFF, as
//! QGIS or GDAL write it, read ([`Raster::read`]) and fitted as a mission's
//! risk, a base plus Gaussians ([`fit()`]), with the fit's error against
//! the raster.
//!
//! Its parts: `read` (the file: one band, north-up, NoData, values that can
//! be a density), `crs` (the GeoKeys; EPSG:4326 and the WGS84 UTM zones, to
//! WGS84),
//! `fit` (pixels into the mission's plane, samples, the engine's learner,
//! the error), `document` (a mission or scenario document naming a raster
//! for its risk or truth, [`resolve`]) and `error` ([`RasterError`]).
//!
//! Invariants: whatever is not supported (several bands, another CRS, a
//! rotated grid, a value that is negative or not finite) is refused with a
//! [`RasterError`] that says what and how to fix it, never read as
//! something else; negative values are refused, not clipped, since a
//! raster of them is a map of something other than risk (a depth, a
//! difference) and clipping would hide it. The only I/O is reading the
//! file.

mod crs;
mod document;
mod error;
mod fit;
mod read;

pub use crs::Crs;
pub use document::resolve;
pub use error::RasterError;
pub use fit::{Fit, fit};
pub use read::Raster;
