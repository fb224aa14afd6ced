//! A raster's values as the mission's risk: pixel centres placed in the
//! mission's plane, averaged into samples, fitted by the engine's learner
//! (docs/learning.md, "The model") into a base plus Gaussians, and the
//! fit's error measured at every pixel it used (docs/rasters.md).
//!
//! Invariants: the result is a valid [`RiskField`] (base and weights ≥ 0);
//! the fit and its error depend only on the raster, the mission's origin
//! and region, and the spacing (the learner sums samples in an order of
//! its own); nothing is read or written here.

use super::{Raster, RasterError};
use crate::coverage::density::MAX_DENSITY;
use crate::coverage::{RiskField, RiskObject};
use crate::geometry::Point;
use crate::geometry::geodesy::{LatLon, LocalFrame};
use crate::learning::{Lattice, Learner, Params, Sample};
use crate::mission::Mission;

/// Without `--spacing`, the lattice has at most this many Gaussians along
/// the region's longer side: 30 × 30 Gaussians at most, a fit of well
/// under a second and a density the engine integrates in milliseconds
/// (docs/learning.md, "Cost in the tick").
const DEFAULT_ACROSS: f64 = 30.0;
/// A Gaussian no narrower than this many pixels: narrower ones would be
/// pinned by a pixel or two and swing between them.
const PIXELS_PER_SPREAD: f64 = 3.0;
/// Samples about this many to a spacing along each axis: enough that
/// every Gaussian is seen by a dozen or more, few enough that a large
/// raster's fit costs what a small one's does.
const SAMPLES_PER_SPREAD: f64 = 3.0;
/// Each sample's σ, a share of the raster's largest value: small against
/// the prior's spreads (1 for the base, 5 for a weight, in those units), so
/// the fit follows the raster, and large enough that a pixel the lattice
/// cannot follow (an edge sharper than a spacing) is not an outlier to
/// Huber's weights unless it is off by more than 3 % of that value.
const SAMPLE_SD: f64 = 0.01;

/// A raster's fit and how well it matches the raster.
#[derive(Debug, Clone)]
pub struct Fit {
    /// The fitted risk, in the raster's units.
    pub risk: RiskField,
    /// The lattice's spacing, each Gaussian's σ [m].
    pub spacing: f64,
    /// Gaussians in the lattice (the risk keeps those not negligible).
    pub gaussians: usize,
    /// Pixels with data in the region's bounding box (each one in a sample).
    pub pixels: usize,
    /// Pixels inside the region, where the error is measured.
    pub measured: usize,
    /// Samples given to the learner (block means of the pixels).
    pub samples: usize,
    /// Side of a sample's block of pixels.
    pub block: usize,
    /// The raster's smallest and largest value over the measured pixels.
    pub min: f64,
    pub max: f64,
    /// RMS of fit − raster over the measured pixels, over max − min.
    pub rms: f64,
    /// Largest |fit − raster| there, over max − min.
    pub worst: f64,
}

/// One pixel with data in the plane.
struct Placed {
    column: usize,
    row: usize,
    at: Point,
    value: f64,
}

/// Fits `raster` as the risk of `mission`, with a lattice of `spacing`
/// metres (or the default: see [`spacing`]).
pub fn fit(raster: &Raster, mission: &Mission, spacing: Option<f64>) -> Result<Fit, RasterError> {
    let frame = mission.frame().ok_or(RasterError::NoOrigin)?;
    let region = mission.region();
    let (min, max) = region.bounds();
    let placed = place(raster, &frame, min, max)?;
    if placed.is_empty() {
        return Err(RasterError::Outside {
            path: raster.path().to_path_buf(),
        });
    }
    let pixel = pixel_size(raster, &frame, &placed[placed.len() / 2])?;
    let h = spacing.unwrap_or_else(|| default_spacing(min, max, pixel));
    let lattice = Lattice::over(min, max, h).map_err(|source| RasterError::Spacing { source })?;
    let block = if pixel > 0.0 {
        ((h / (SAMPLES_PER_SPREAD * pixel)).floor() as usize).max(1)
    } else {
        1
    };
    let scale = placed.iter().map(|p| p.value).fold(0.0, f64::max);
    let scale = if scale > 0.0 { scale } else { 1.0 };
    let samples = samples(&placed, block, scale);
    let gaussians = lattice.len();
    let prior = RiskField::new(0.0, Vec::new()).expect("a flat zero field is valid");
    let mut learner = Learner::new(lattice, prior, Params::default());
    let count = samples.len();
    for s in samples {
        learner.add(s);
    }
    let unit = learner.fit().density(0.0);
    let risk = scaled(&unit, scale);
    let inside: Vec<&Placed> = placed.iter().filter(|p| region.contains(p.at)).collect();
    let (lo, hi, rms, worst) = error(&risk, &inside);
    Ok(Fit {
        risk,
        spacing: h,
        gaussians,
        pixels: placed.len(),
        measured: inside.len(),
        samples: count,
        block,
        min: lo,
        max: hi,
        rms,
        worst,
    })
}

/// The default spacing: [`DEFAULT_ACROSS`] Gaussians along the box's
/// longer side, and no narrower than [`PIXELS_PER_SPREAD`] pixels.
fn default_spacing(min: Point, max: Point, pixel: f64) -> f64 {
    let span = (max.x - min.x).max(max.y - min.y);
    (span / (DEFAULT_ACROSS - 1.0)).max(PIXELS_PER_SPREAD * pixel)
}

/// Every pixel with data whose centre is within the plane's reach of the
/// origin and inside the box [min, max], in the plane.
fn place(
    raster: &Raster,
    frame: &LocalFrame,
    min: Point,
    max: Point,
) -> Result<Vec<Placed>, RasterError> {
    let (width, height) = raster.size();
    let mut placed = Vec::new();
    for row in 0..height {
        for column in 0..width {
            let value = raster.value(column, row);
            if value.is_nan() {
                continue;
            }
            let Some(at) = locate(raster, frame, column as f64, row as f64)? else {
                continue;
            };
            if at.x >= min.x && at.x <= max.x && at.y >= min.y && at.y <= max.y {
                placed.push(Placed {
                    column,
                    row,
                    at,
                    value,
                });
            }
        }
    }
    Ok(placed)
}

/// A pixel centre in the plane; `None` when it is no valid WGS84 position
/// or farther than [`LocalFrame::RANGE`] from the origin (measured along
/// the chord: the plane folds the far side of the globe back onto it).
fn locate(
    raster: &Raster,
    frame: &LocalFrame,
    column: f64,
    row: f64,
) -> Result<Option<Point>, RasterError> {
    let (x, y) = raster.center(column, row);
    let p = raster
        .crs()
        .to_wgs84(x, y)
        .map_err(|source| RasterError::Projection {
            path: raster.path().to_path_buf(),
            easting: x,
            northing: y,
            source,
        })?;
    let Ok(p) = LatLon::new(p.lat, p.lon) else {
        return Ok(None);
    };
    if frame.chord(p) > LocalFrame::RANGE {
        return Ok(None);
    }
    let (x, y) = frame.to_local(p);
    Ok(Some(Point { x, y }))
}

/// A pixel's size in the plane [m] at `pixel`: the larger of its steps
/// along a row and down a column.
fn pixel_size(raster: &Raster, frame: &LocalFrame, pixel: &Placed) -> Result<f64, RasterError> {
    let (c, r) = (pixel.column as f64, pixel.row as f64);
    let step = |dc: f64, dr: f64| -> Result<f64, RasterError> {
        Ok(match locate(raster, frame, c + dc, r + dr)? {
            Some(q) => (q.x - pixel.at.x).hypot(q.y - pixel.at.y),
            None => 0.0,
        })
    };
    Ok(step(1.0, 0.0)?.max(step(0.0, 1.0)?))
}

/// One sample per block of `block` × `block` pixels: the mean of its
/// pixels' values over `scale` at the mean of their centres, each with σ
/// [`SAMPLE_SD`]. A mean rather than one pixel of the block: what lies
/// between samples is averaged in, not aliased.
fn samples(placed: &[Placed], block: usize, scale: f64) -> Vec<Sample> {
    let mut blocks: std::collections::BTreeMap<(usize, usize), (f64, f64, f64, f64)> =
        std::collections::BTreeMap::new();
    for p in placed {
        let b = blocks
            .entry((p.row / block, p.column / block))
            .or_insert((0.0, 0.0, 0.0, 0.0));
        b.0 += p.at.x;
        b.1 += p.at.y;
        b.2 += p.value;
        b.3 += 1.0;
    }
    blocks
        .values()
        // Every mean is in the region's box and in [0, 1]: valid.
        .filter_map(|&(x, y, v, n)| {
            let at = Point { x: x / n, y: y / n };
            Sample::new(at, v / n / scale, SAMPLE_SD).ok()
        })
        .collect()
}

/// `field` with its base and every weight times `scale`, each held to
/// [`MAX_DENSITY`] (reached only by a raster of values near it).
fn scaled(field: &RiskField, scale: f64) -> RiskField {
    let objects = field
        .objects()
        .iter()
        .map(|o| RiskObject {
            alpha: (o.alpha * scale).min(MAX_DENSITY),
            ..*o
        })
        .collect();
    RiskField::new((field.base() * scale).min(MAX_DENSITY), objects)
        .expect("scaled coefficients stay positive and within range")
}

/// The pixels' range (min, max) and the RMS and largest |risk − value|
/// over them, relative to the range (to the largest value for a flat
/// raster, to 1 for an all-zero one).
fn error(risk: &RiskField, pixels: &[&Placed]) -> (f64, f64, f64, f64) {
    if pixels.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN, f64::NAN);
    }
    let lo = pixels.iter().map(|p| p.value).fold(f64::INFINITY, f64::min);
    let hi = pixels.iter().map(|p| p.value).fold(0.0, f64::max);
    let range = if hi > lo {
        hi - lo
    } else if hi > 0.0 {
        hi
    } else {
        1.0
    };
    let (mut sum, mut worst) = (0.0, 0.0_f64);
    for p in pixels {
        let e = risk.value(p.at) - p.value;
        sum += e * e;
        worst = worst.max(e.abs());
    }
    let rms = (sum / pixels.len() as f64).sqrt();
    (lo, hi, rms / range, worst / range)
}
