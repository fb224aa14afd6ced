// WGS84 latitude and longitude ⇄ the mission's local plane, the same maths
// as the engine's crates/engine/src/geometry/geodesy.rs: the plane is the East-North-Up
// plane tangent to the ellipsoid at the mission's origin (x east, y north,
// metres). Forward through ECEF; back in closed form (the line through the
// plane point along the origin's up meets the ellipsoid where a quadratic
// vanishes). The browser test checks this file against geographiclib.

const A = 6378137.0;
const F = 1 / 298.257223563;
const E2 = F * (2 - F);
const RAD = Math.PI / 180;

function ecef(lat, lon) {
  const s = Math.sin(lat), c = Math.cos(lat);
  const n = A / Math.sqrt(1 - E2 * s * s);
  return [n * c * Math.cos(lon), n * c * Math.sin(lon), n * (1 - E2) * s];
}

export class LocalFrame {
  /** The plane at an origin given in degrees. */
  constructor(lat, lon) {
    this.lat = lat;
    this.lon = lon;
    const f = lat * RAD, l = lon * RAD;
    this.sf = Math.sin(f); this.cf = Math.cos(f);
    this.sl = Math.sin(l); this.cl = Math.cos(l);
    this.o = ecef(f, l);
  }

  /** [x, y] of a position in degrees. */
  toLocal(lat, lon) {
    const p = ecef(lat * RAD, lon * RAD);
    const d = [p[0] - this.o[0], p[1] - this.o[1], p[2] - this.o[2]];
    const { sf, cf, sl, cl } = this;
    return [-sl * d[0] + cl * d[1], -sf * cl * d[0] - sf * sl * d[1] + cf * d[2]];
  }

  /** { lat, lon } in degrees of the plane point (x, y). */
  toGeodetic(x, y) {
    const { sf, cf, sl, cl } = this;
    const w = [-sl * x - sf * cl * y, cl * x - sf * sl * y, cf * y];
    const up = [cf * cl, cf * sl, sf];
    // ⟨p, q⟩ = p₀q₀ + p₁q₁ + p₂q₂ / (1 − e²): the ellipsoid is ⟨P, P⟩ = a²,
    // and ⟨O, U⟩ = N, ⟨O, w⟩ = 0 at the origin O (see geodesy.rs).
    const k = 1 / (1 - E2);
    const dot = (p, q) => p[0] * q[0] + p[1] * q[1] + k * p[2] * q[2];
    const n = A / Math.sqrt(1 - E2 * sf * sf);
    const a = dot(up, up), b = n + dot(w, up), c = dot(w, w);
    const u = -c / (b + Math.sqrt(Math.max(0, b * b - a * c)));
    const p = [0, 1, 2].map((i) => this.o[i] + w[i] + u * up[i]);
    const lat = Math.atan2(p[2], (1 - E2) * Math.hypot(p[0], p[1]));
    let lon = Math.atan2(p[1], p[0]) / RAD;
    if (lon <= -180) lon += 360;
    return { lat: lat / RAD, lon };
  }

  /**
   * The direction of true north at the plane point (x, y), as an angle in
   * degrees clockwise from the plane's +y. Zero at the origin; elsewhere
   * the meridians converge (about Δλ sin φ).
   */
  northAt(x, y) {
    const g = this.toGeodetic(x, y);
    // A step small enough to be a direction, large enough for doubles.
    const step = 1e-4;
    const lat = g.lat + step < 90 ? g.lat + step : g.lat - step;
    const [nx, ny] = this.toLocal(lat, g.lon);
    const sign = lat > g.lat ? 1 : -1;
    return Math.atan2(sign * (nx - x), sign * (ny - y)) / RAD;
  }
}

/** "35.3632610° S" style, 7 decimals (about a centimetre). */
export function formatLat(lat) {
  return `${Math.abs(lat).toFixed(7)}° ${lat < 0 ? "S" : "N"}`;
}

export function formatLon(lon) {
  return `${Math.abs(lon).toFixed(7)}° ${lon < 0 ? "W" : "E"}`;
}
