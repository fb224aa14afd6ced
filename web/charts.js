// Small time-series charts on canvases: a bounded buffer of (t, values...)
// per chart, drawn with auto-scaled axes. No library: a line chart is a few
// dozen lines, and the page must not depend on a registry.

export class Series {
  /**
   * At most `capacity` points. Past it, the oldest point goes (`thin`
   * false), or every other point does (`thin` true: the series keeps its
   * start and spans all it was given, as the coordinator's H history does).
   */
  constructor(capacity = 600, { thin = false } = {}) {
    this.capacity = capacity;
    this.thin = thin;
    this.points = [];
  }
  push(t, ...values) {
    const last = this.points[this.points.length - 1];
    if (last && t < last[0]) this.points = []; // the mission clock restarted
    if (last && t === last[0]) return;
    this.points.push([t, ...values]);
    this.bound();
  }
  /** Puts the `points` older than the series' first before it. */
  prepend(points) {
    const first = this.points[0];
    const older = first ? points.filter((p) => p[0] < first[0]) : points;
    this.points = older.concat(this.points);
    this.bound();
  }
  last() {
    return this.points[this.points.length - 1];
  }
  bound() {
    if (!this.thin) {
      if (this.points.length > this.capacity) this.points.splice(0, this.points.length - this.capacity);
      return;
    }
    while (this.points.length > this.capacity) {
      const n = this.points.length;
      this.points = this.points.filter((_, i) => i % 2 === 0 || i === n - 1);
    }
  }
  clear() {
    this.points = [];
  }
}

/**
 * Draws `series` on `canvas`: one line per value column, with `labels`,
 * `colours` and line `dashes` (none by default) for each. The first column
 * is drawn last, on top.
 */
export function drawChart(canvas, series, labels, colours, dashes = []) {
  const r = canvas.getBoundingClientRect();
  const dpr = window.devicePixelRatio || 1;
  const w = Math.max(1, r.width);
  const h = Math.max(1, r.height);
  if (canvas.width !== Math.round(w * dpr) || canvas.height !== Math.round(h * dpr)) {
    canvas.width = Math.round(w * dpr);
    canvas.height = Math.round(h * dpr);
  }
  const ctx = canvas.getContext("2d");
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.clearRect(0, 0, w, h);
  const pts = series.points;
  ctx.font = "10px system-ui, sans-serif";
  ctx.fillStyle = "#8da2b5";
  if (pts.length < 2) {
    ctx.fillText("waiting for data…", 8, h / 2);
    return;
  }
  const t0 = pts[0][0];
  const t1 = pts[pts.length - 1][0];
  let lo = Infinity, hi = -Infinity;
  for (const p of pts) {
    for (let k = 1; k < p.length; k++) {
      if (Number.isFinite(p[k])) {
        lo = Math.min(lo, p[k]);
        hi = Math.max(hi, p[k]);
      }
    }
  }
  if (!(hi > lo)) {
    hi = lo + 1;
    lo -= 1;
  }
  const pad = (hi - lo) * 0.08;
  lo -= pad;
  hi += pad;
  const left = 44, right = 6, top = 14, bottom = 14;
  const X = (t) => left + ((t - t0) / Math.max(t1 - t0, 1e-9)) * (w - left - right);
  const Y = (v) => top + (1 - (v - lo) / (hi - lo)) * (h - top - bottom);
  ctx.strokeStyle = "#2a3a4a";
  ctx.lineWidth = 1;
  ctx.beginPath();
  ctx.moveTo(left, top);
  ctx.lineTo(left, h - bottom);
  ctx.lineTo(w - right, h - bottom);
  ctx.stroke();
  ctx.fillText(fmt(hi, hi - lo), 2, top + 4);
  ctx.fillText(fmt(lo, hi - lo), 2, h - bottom);
  ctx.fillText(`${t0.toFixed(0)} s`, left, h - 2);
  ctx.fillText(`${t1.toFixed(0)} s`, w - right - 34, h - 2);
  for (let k = pts[0].length - 1; k >= 1; k--) {
    ctx.strokeStyle = colours[k - 1];
    ctx.lineWidth = 1.4;
    ctx.setLineDash(dashes[k - 1] || []);
    ctx.beginPath();
    let started = false;
    for (const p of pts) {
      if (!Number.isFinite(p[k])) continue;
      if (!started) ctx.moveTo(X(p[0]), Y(p[k]));
      else ctx.lineTo(X(p[0]), Y(p[k]));
      started = true;
    }
    ctx.stroke();
    ctx.setLineDash([]);
    ctx.fillStyle = colours[k - 1];
    ctx.fillText(labels[k - 1], left + 6 + (k - 1) * 70, top - 3);
  }
}

/** `v` with enough decimals to tell the axis ends apart over `span`. */
function fmt(v, span) {
  if (v !== 0 && Math.abs(v) < 1e-3 && span < 1e-2) return v.toExponential(1);
  const decimals = Math.min(6, Math.max(0, 2 - Math.floor(Math.log10(span || 1))));
  return v.toFixed(decimals);
}
