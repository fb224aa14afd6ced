#!/usr/bin/env python3
"""Writes a single-band GeoTIFF of a known risk field, for the raster tests
(tests/it/risk_raster.rs), with rasterio (GDAL), independently of seacover's
code.

The field is given in the local East-North-Up plane of ``--origin LAT LON``
(WGS84), metres east and north: ``--field '{"base": B, "objects": [{"x",
"y", "alpha", "sigma"}, ...]}'``, Φ = B + Σ α exp(−d² / 2σ²). Each pixel's
value is Φ at its centre's place in that plane: the centre's model
coordinates go to WGS84 through PROJ (rasterio.warp.transform) when the CRS
is projected, then to ECEF and ENU on the WGS84 ellipsoid (the formulas
below, written from the textbook, not from seacover's).

The raster is north-up, ``--half H`` metres either side of the origin (as
near as the CRS's grid allows), pixels ``--pixel P`` metres (in degrees for
EPSG:4326: P over the metres of one degree at the origin), Float32, as QGIS
writes an exported raster. Options for the refusal tests: ``--bands N``
(every band the same), ``--rotate DEG`` (the grid rotated about its top-left
corner), ``--negative`` (the field minus its peak, so most values are
below 0), and ``--nodata-box X0 Y0 X1 Y1`` (pixels whose centre is in that
box of the plane hold the NoData value −9999).
"""

import argparse
import json
import math

import numpy as np
import rasterio
from rasterio.transform import Affine
from rasterio.warp import transform as reproject_points

A = 6378137.0
F = 1 / 298.257223563
E2 = F * (2 - F)
NODATA = -9999.0


def ecef(lat, lon):
    """ECEF [m] of points on the ellipsoid at latitudes, longitudes [deg]."""
    phi, lam = np.radians(lat), np.radians(lon)
    n = A / np.sqrt(1 - E2 * np.sin(phi) ** 2)
    return (
        n * np.cos(phi) * np.cos(lam),
        n * np.cos(phi) * np.sin(lam),
        n * (1 - E2) * np.sin(phi),
    )


def east_north(origin, lat, lon):
    """East and north [m] of points in the tangent plane at ``origin``."""
    x0, y0, z0 = ecef(*origin)
    x, y, z = ecef(lat, lon)
    dx, dy, dz = x - x0, y - y0, z - z0
    phi, lam = math.radians(origin[0]), math.radians(origin[1])
    east = -math.sin(lam) * dx + math.cos(lam) * dy
    north = (
        -math.sin(phi) * math.cos(lam) * dx
        - math.sin(phi) * math.sin(lam) * dy
        + math.cos(phi) * dz
    )
    return east, north


def field(doc, east, north):
    value = np.full(east.shape, float(doc["base"]))
    for o in doc["objects"]:
        d2 = (east - o["x"]) ** 2 + (north - o["y"]) ** 2
        value += o["alpha"] * np.exp(-d2 / (2 * o["sigma"] ** 2))
    return value


def grid(crs, origin, half, pixel):
    """(west, north, xres, yres, width, height) of a north-up grid."""
    lat, lon = origin
    if crs == "EPSG:4326":
        metres = 111_320.0
        yres = pixel / metres
        xres = pixel / (metres * math.cos(math.radians(lat)))
        n = int(math.ceil(2 * half / pixel))
        west = lon - half / (metres * math.cos(math.radians(lat)))
        north = lat + half / metres
        return west, north, xres, yres, n, n
    xs, ys = reproject_points("EPSG:4326", crs, [lon], [lat])
    n = int(math.ceil(2 * half / pixel))
    return xs[0] - half, ys[0] + half, pixel, pixel, n, n


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out")
    p.add_argument("--crs", required=True)
    p.add_argument("--origin", nargs=2, type=float, required=True)
    p.add_argument("--half", type=float, required=True)
    p.add_argument("--pixel", type=float, required=True)
    p.add_argument("--field", required=True)
    p.add_argument("--bands", type=int, default=1)
    p.add_argument("--rotate", type=float, default=0.0)
    p.add_argument("--negative", action="store_true")
    p.add_argument("--nodata-box", nargs=4, type=float)
    args = p.parse_args()
    origin = tuple(args.origin)
    west, north, xres, yres, width, height = grid(
        args.crs, origin, args.half, args.pixel
    )
    transform = Affine.translation(west, north) * Affine.scale(xres, -yres)
    if args.rotate:
        transform = transform * Affine.rotation(args.rotate)
    cols, rows = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    xs, ys = transform * (cols.ravel(), rows.ravel())
    if args.crs == "EPSG:4326":
        lon, lat = np.asarray(xs), np.asarray(ys)
    else:
        lon, lat = (np.asarray(v) for v in reproject_points(args.crs, "EPSG:4326", xs, ys))
    east, north_m = east_north(origin, lat, lon)
    doc = json.loads(args.field)
    values = field(doc, east, north_m)
    if args.negative:
        values = values - values.max()
    if args.nodata_box:
        x0, y0, x1, y1 = args.nodata_box
        inside = (east >= x0) & (east <= x1) & (north_m >= y0) & (north_m <= y1)
        values[inside] = NODATA
    band = values.reshape(height, width).astype("float32")
    with rasterio.open(
        args.out,
        "w",
        driver="GTiff",
        width=width,
        height=height,
        count=args.bands,
        dtype="float32",
        crs=args.crs,
        transform=transform,
        nodata=NODATA if args.nodata_box else None,
    ) as dst:
        for b in range(1, args.bands + 1):
            dst.write(band, b)
    print(json.dumps({"width": width, "height": height}))


if __name__ == "__main__":
    main()
