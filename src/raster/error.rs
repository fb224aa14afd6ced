//! Why a raster cannot be read or fitted: [`RasterError`].
//!
//! Invariant: each message says what is wrong with the file or the
//! mission in the user's terms (a band count, an EPSG code, a pixel's row
//! and column) and, where a library failed, hands that failure on as
//! `source()` without repeating its text (`seacover::chain`).

use std::path::PathBuf;

/// A raster refused, or one that could not be read.
#[derive(Debug, thiserror::Error)]
pub enum RasterError {
    /// The file could not be opened or read.
    #[error("reading {path}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// Not a TIFF the decoder can read, or its tags are malformed.
    #[error("{path}: not a readable GeoTIFF")]
    Tiff {
        path: PathBuf,
        source: tiff::TiffError,
    },
    /// More than one band (samples per pixel).
    #[error(
        "{path}: has {bands} bands; a risk map is a single band (export one band in QGIS: Raster ▸ Conversion ▸ Translate, or gdal_translate -b N)"
    )]
    Bands { path: PathBuf, bands: u16 },
    /// GDAL's NoData tag holds no number.
    #[error("{path}: its NoData value {text:?} is not a number")]
    NoData { path: PathBuf, text: String },
    /// No georeferencing: no GeoKeys, or no pixel-to-model transform.
    #[error("{path}: not georeferenced ({what} missing)")]
    NotGeoreferenced { path: PathBuf, what: &'static str },
    /// A coordinate reference system other than EPSG:4326 or a WGS84 UTM
    /// zone.
    #[error(
        "{path}: coordinate reference system {crs} is not supported; reproject to EPSG:4326 or the WGS84 UTM zone (EPSG:326xx/327xx) of the mission"
    )]
    Crs { path: PathBuf, crs: String },
    /// A transform with rotation or shear, or a tie-point grid.
    #[error(
        "{path}: {what}; only north-up rasters are supported (warp it to north-up first, e.g. gdalwarp)"
    )]
    NotNorthUp { path: PathBuf, what: String },
    /// A pixel value that cannot be a risk density.
    #[error(
        "{path}: pixel at row {row}, column {column} is {value}; a risk density must be finite, ≥ 0 and at most 1e12 (set negative cells to 0 or to NoData first)"
    )]
    Value {
        path: PathBuf,
        row: usize,
        column: usize,
        value: f64,
    },
    /// The raster has no valid pixel inside the mission's region's box.
    #[error("{path}: no pixel with data lies inside the mission's region")]
    Outside { path: PathBuf },
    /// The mission has no origin, so the raster cannot be placed.
    #[error(
        "the mission has no origin: a raster in WGS84 or UTM is placed in the mission's plane by its origin (`origin = {{ lat, lon }}`)"
    )]
    NoOrigin,
    /// A UTM coordinate the projection could not invert.
    #[error("{path}: pixel at ({easting}, {northing}) cannot be placed in WGS84")]
    Projection {
        path: PathBuf,
        easting: f64,
        northing: f64,
        source: proj4rs::errors::Error,
    },
    /// The document naming a raster is not a valid mission once the
    /// raster's place is taken by a flat risk.
    #[error("the document naming the raster")]
    Mission {
        source: crate::mission::MissionError,
    },
    /// The fit's lattice spacing does not suit the region.
    #[error("the fit's lattice")]
    Spacing { source: crate::coverage::InputError },
}
