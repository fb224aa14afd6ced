//! Reading a single-band GeoTIFF into a [`Raster`]: its pixel values (no
//! data as NaN), the model coordinates of every pixel's centre and its
//! coordinate reference system.
//!
//! The `tiff` crate (image-rs) decodes the pixels and the tags; the
//! GeoTIFF part is small and read here: the georeferencing tags (a pixel
//! scale and tie point, or a transformation matrix), GDAL's NoData tag and
//! the few GeoKeys that name the CRS ([`GeoKeys`]). georust's `geotiff`
//! crate was tried first: it keeps its transform to itself (so a rotated
//! grid cannot be told from a north-up one), reads no NoData, and is built
//! on an older `tiff` that cannot decode the horizontal predictor on
//! floating-point bands, which QGIS's "high compression" profile writes.
//!
//! Invariants: a [`Raster`] has one band, a north-up axis-aligned grid (a
//! pixel scale and one tie point, or a transformation matrix without
//! rotation or shear), a supported [`Crs`], and every value that is not
//! NaN is finite, ≥ 0 and at most [`MAX_DENSITY`]: anything else is
//! refused here, before any pixel is placed.

use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use tiff::decoder::{Decoder, DecodingResult};
use tiff::tags::Tag;

use super::RasterError;
use super::crs::{Crs, GeoKeys};
use crate::coverage::density::MAX_DENSITY;

/// A single-band, north-up, georeferenced grid of risk values.
#[derive(Debug)]
pub struct Raster {
    path: PathBuf,
    width: usize,
    height: usize,
    /// Row-major, row 0 first (the file's order); NaN where there is no data.
    values: Vec<f64>,
    grid: Grid,
    crs: Crs,
}

/// Where pixel centres are in model space: column i, row j is at
/// (x0 + i·dx, y0 + j·dy).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Grid {
    x0: f64,
    dx: f64,
    y0: f64,
    dy: f64,
}

impl Raster {
    /// Reads and checks `path` (see the module's invariants).
    pub fn read(path: &Path) -> Result<Raster, RasterError> {
        Raster::from_reader(path, BufReader::new(open(path)?))
    }

    /// Checks a GeoTIFF already in memory (an upload), named `name` in
    /// its errors, as [`Raster::read`] checks a file.
    pub fn decode(name: &Path, bytes: &[u8]) -> Result<Raster, RasterError> {
        Raster::from_reader(name, std::io::Cursor::new(bytes))
    }

    fn from_reader<R: std::io::Read + std::io::Seek>(
        path: &Path,
        reader: R,
    ) -> Result<Raster, RasterError> {
        let tiff_error = |source| RasterError::Tiff {
            path: path.to_path_buf(),
            source,
        };
        let mut decoder = Decoder::new(reader).map_err(tiff_error)?;
        let tags = Tags::read(path, &mut decoder)?;
        let crs = Crs::from_keys(&tags.keys).map_err(|crs| RasterError::Crs {
            path: path.to_path_buf(),
            crs,
        })?;
        // Raster space puts a pixel's centre at +½ when pixels are areas
        // (GDAL's default) and at the integer when they are points.
        let half = if tags.keys.pixel_is_point() { 0.0 } else { 0.5 };
        let corner = tags.transform;
        let grid = Grid {
            x0: corner.x0 + half * corner.dx,
            dx: corner.dx,
            y0: corner.y0 + half * corner.dy,
            dy: corner.dy,
        };
        let (width, height) = decoder.dimensions().map_err(tiff_error)?;
        let (width, height) = (width as usize, height as usize);
        let pixels = as_f64(decoder.read_image().map_err(tiff_error)?);
        let mut values = Vec::with_capacity(width * height);
        for (i, value) in pixels.into_iter().enumerate().take(width * height) {
            values.push(check(path, tags.nodata, i / width, i % width, value)?);
        }
        if values.len() != width * height {
            return Err(RasterError::NotGeoreferenced {
                path: path.to_path_buf(),
                what: "a pixel for every row and column",
            });
        }
        Ok(Raster {
            path: path.to_path_buf(),
            width,
            height,
            values,
            grid,
            crs,
        })
    }

    /// The file it was read from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Columns and rows.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The value at `column`, `row`; NaN where there is no data.
    pub fn value(&self, column: usize, row: usize) -> f64 {
        self.values[row * self.width + column]
    }

    /// The model coordinates (the CRS's x and y) of a pixel's centre, also
    /// for fractional and out-of-grid indices.
    pub fn center(&self, column: f64, row: f64) -> (f64, f64) {
        (
            self.grid.x0 + column * self.grid.dx,
            self.grid.y0 + row * self.grid.dy,
        )
    }

    /// Its coordinate reference system.
    pub fn crs(&self) -> &Crs {
        &self.crs
    }
}

/// A pixel's value as the raster holds it: NaN for no data (the NoData
/// value, or NaN itself), the value when it can be a density, else refused.
fn check(
    path: &Path,
    nodata: Option<f64>,
    row: usize,
    column: usize,
    value: f64,
) -> Result<f64, RasterError> {
    // GDAL writes NoData as text in the band's own type, so an f32
    // raster's NoData compares equal once both are rounded to f32.
    let is_nodata = nodata.is_some_and(|n| n == value || n as f32 == value as f32);
    if value.is_nan() || is_nodata {
        return Ok(f64::NAN);
    }
    if !(value.is_finite() && (0.0..=MAX_DENSITY).contains(&value)) {
        return Err(RasterError::Value {
            path: path.to_path_buf(),
            row,
            column,
            value,
        });
    }
    Ok(value)
}

/// The decoded band as f64, whatever its sample type (every integer and
/// float type converts exactly but 64-bit integers beyond 2⁵³, far above
/// any density the engine takes).
fn as_f64(image: DecodingResult) -> Vec<f64> {
    fn all<T: Copy>(v: Vec<T>, f: impl Fn(T) -> f64) -> Vec<f64> {
        v.into_iter().map(f).collect()
    }
    match image {
        DecodingResult::U8(v) => all(v, f64::from),
        DecodingResult::U16(v) => all(v, f64::from),
        DecodingResult::U32(v) => all(v, f64::from),
        DecodingResult::U64(v) => all(v, |x| x as f64),
        DecodingResult::I8(v) => all(v, f64::from),
        DecodingResult::I16(v) => all(v, f64::from),
        DecodingResult::I32(v) => all(v, f64::from),
        DecodingResult::I64(v) => all(v, |x| x as f64),
        DecodingResult::F16(v) => all(v, f64::from),
        DecodingResult::F32(v) => all(v, f64::from),
        DecodingResult::F64(v) => v,
    }
}

fn open(path: &Path) -> Result<File, RasterError> {
    File::open(path).map_err(|source| RasterError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// The GeoTIFF tags: where the pixels are, which value means no data and
/// the CRS's keys.
struct Tags {
    /// Raster-space corner coordinates to model space, north-up.
    transform: Grid,
    nodata: Option<f64>,
    keys: GeoKeys,
}

impl Tags {
    fn read<R: std::io::Read + std::io::Seek>(
        path: &Path,
        decoder: &mut Decoder<R>,
    ) -> Result<Tags, RasterError> {
        let tiff_error = |source| RasterError::Tiff {
            path: path.to_path_buf(),
            source,
        };
        let bands = decoder
            .find_tag_unsigned::<u16>(Tag::SamplesPerPixel)
            .map_err(tiff_error)?
            .unwrap_or(1);
        if bands != 1 {
            return Err(RasterError::Bands {
                path: path.to_path_buf(),
                bands,
            });
        }
        let mut f64s = |tag| {
            decoder
                .find_tag(tag)
                .and_then(|v| v.map(|v| v.into_f64_vec()).transpose())
                .map_err(tiff_error)
        };
        let matrix = f64s(Tag::ModelTransformationTag)?;
        let scale = f64s(Tag::ModelPixelScaleTag)?;
        let tie = f64s(Tag::ModelTiepointTag)?;
        let transform = transform(path, matrix, scale, tie)?;
        let directory = decoder
            .find_tag(Tag::GeoKeyDirectoryTag)
            .and_then(|v| v.map(|v| v.into_u16_vec()).transpose())
            .map_err(tiff_error)?;
        let not_georeferenced = |what| RasterError::NotGeoreferenced {
            path: path.to_path_buf(),
            what,
        };
        let directory = directory.ok_or_else(|| not_georeferenced("GeoKeyDirectory"))?;
        let keys = GeoKeys::parse(&directory)
            .ok_or_else(|| not_georeferenced("a well-formed GeoKeyDirectory"))?;
        let nodata = decoder
            .find_tag(Tag::GdalNodata)
            .and_then(|v| v.map(|v| v.into_string()).transpose())
            .map_err(tiff_error)?;
        let nodata = match nodata {
            None => None,
            Some(text) => {
                // GDAL's text may end in a NUL.
                let text = text.trim_matches(|c: char| c == '\0' || c.is_whitespace());
                Some(text.parse::<f64>().map_err(|_| RasterError::NoData {
                    path: path.to_path_buf(),
                    text: text.to_string(),
                })?)
            }
        };
        Ok(Tags {
            transform,
            nodata,
            keys,
        })
    }
}

/// The raster-to-model transform of pixel corners, from the GeoTIFF tags:
/// a 4 × 4 matrix, or a pixel scale and one tie point (the y scale is
/// positive and means rows go south).
fn transform(
    path: &Path,
    matrix: Option<Vec<f64>>,
    scale: Option<Vec<f64>>,
    tie: Option<Vec<f64>>,
) -> Result<Grid, RasterError> {
    let refuse = |what: &str| RasterError::NotNorthUp {
        path: path.to_path_buf(),
        what: what.to_string(),
    };
    let grid = match (matrix, scale, tie) {
        (Some(m), _, _) if m.len() == 16 => {
            if m[1] != 0.0 || m[4] != 0.0 {
                return Err(refuse("its transformation matrix rotates or shears"));
            }
            Grid {
                x0: m[3],
                dx: m[0],
                y0: m[7],
                dy: m[5],
            }
        }
        (Some(_), _, _) => return Err(refuse("its transformation matrix is not 4 × 4")),
        (None, Some(s), Some(t)) if s.len() >= 2 && t.len() == 6 => Grid {
            x0: t[3] - t[0] * s[0],
            dx: s[0],
            y0: t[4] + t[1] * s[1],
            dy: -s[1],
        },
        (None, Some(_), Some(t)) if t.len() > 6 => {
            return Err(refuse("it is placed by a grid of tie points"));
        }
        _ => {
            return Err(RasterError::NotGeoreferenced {
                path: path.to_path_buf(),
                what: "ModelPixelScale and ModelTiepoint, or ModelTransformation",
            });
        }
    };
    let usable = |v: f64| v.is_finite();
    if ![grid.x0, grid.dx, grid.y0, grid.dy].into_iter().all(usable)
        || grid.dx == 0.0
        || grid.dy == 0.0
    {
        return Err(refuse("its pixel size is zero or not finite"));
    }
    Ok(grid)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(m: Option<Vec<f64>>, s: Option<Vec<f64>>, t: Option<Vec<f64>>) -> String {
        match transform(Path::new("a.tif"), m, s, t) {
            Ok(g) => format!("{} {} {} {}", g.x0, g.dx, g.y0, g.dy),
            Err(e) => e.to_string(),
        }
    }

    /// GDAL's tie point at the top-left corner with a positive y scale
    /// means rows run south.
    #[test]
    fn a_tie_point_and_a_scale_place_corners() {
        let got = grid(
            None,
            Some(vec![2.0, 3.0, 0.0]),
            Some(vec![0.0, 0.0, 0.0, 500.0, 900.0, 0.0]),
        );
        assert_eq!(got, "500 2 900 -3");
        // A tie point at pixel (10, 20) moves the origin back by that.
        let got = grid(
            None,
            Some(vec![2.0, 3.0, 0.0]),
            Some(vec![10.0, 20.0, 0.0, 500.0, 900.0, 0.0]),
        );
        assert_eq!(got, "480 2 960 -3");
    }

    #[test]
    fn rotations_and_tie_point_grids_are_refused() {
        let mut m = vec![0.0; 16];
        m[0] = 1.0;
        m[5] = -1.0;
        m[15] = 1.0;
        assert_eq!(grid(Some(m.clone()), None, None), "0 1 0 -1");
        m[1] = 0.1;
        assert!(grid(Some(m), None, None).contains("rotates"));
        let twelve = Some(vec![0.0; 12]);
        assert!(grid(None, Some(vec![1.0, 1.0, 0.0]), twelve).contains("tie points"));
        assert!(grid(None, None, None).contains("not georeferenced"));
    }

    #[test]
    fn nodata_and_bad_values() {
        let p = Path::new("a.tif");
        assert!(check(p, Some(-9999.0), 0, 0, -9999.0).unwrap().is_nan());
        assert!(check(p, None, 0, 0, f64::NAN).unwrap().is_nan());
        // An f32 band's NoData written from its f64 text.
        let f32_nodata = -3.4028234663852886e38_f64;
        assert!(
            check(p, Some(f32_nodata), 0, 0, f32::MIN as f64)
                .unwrap()
                .is_nan()
        );
        assert_eq!(check(p, Some(-9999.0), 0, 0, 2.5).unwrap(), 2.5);
        let e = check(p, None, 3, 4, -1.0).unwrap_err().to_string();
        assert!(e.contains("row 3, column 4 is -1"), "{e}");
        assert!(check(p, None, 0, 0, f64::INFINITY).is_err());
    }
}
