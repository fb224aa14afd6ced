// The map: one canvas, redrawn once per animation frame when something
// changed. World coordinates are metres, x east and y north; the view maps
// them to CSS pixels with a uniform scale (y flipped). Nothing on the map is a
// DOM node, so 1000 vessels cost one canvas, not 1000 elements.

const TRAIL = 60; // points of trail per vessel
const PALETTE = [
  "#4fb3ff", "#ffb84f", "#7be07b", "#ff7bd5", "#b99cff", "#ffe25a", "#5ae0d8", "#ff8a6b",
  "#9fd16b", "#6b9fff", "#e0a15a", "#d16b9f",
];

export function colourOf(index) {
  // Beyond the palette, spread hues by the golden angle.
  if (index < PALETTE.length) return PALETTE[index];
  return `hsl(${(index * 137.508) % 360} 70% 62%)`;
}

/** Whether (x, y) lies in `ring`, a closed polygon's vertices (even-odd). */
function inRing(ring, x, y) {
  let inside = false;
  for (let i = 0, j = ring.length - 1; i < ring.length; j = i++) {
    const [xi, yi] = ring[i];
    const [xj, yj] = ring[j];
    if ((yi > y) !== (yj > y) && x < ((xj - xi) * (y - yi)) / (yj - yi) + xi) inside = !inside;
  }
  return inside;
}

/** Whether (x, y) is water of the task region Q: inside it, off its islands. */
export function inRegion(region, x, y) {
  return inRing(region.polygon, x, y) && !region.holes.some((hole) => inRing(hole, x, y));
}

/** Φ at (x, y): base plus Gaussian objects (paper eq. 5). */
export function density(risk, x, y) {
  let phi = risk.base;
  for (const o of risk.objects) {
    const dx = x - o.x;
    const dy = y - o.y;
    phi += o.alpha * Math.exp(-(dx * dx + dy * dy) / (2 * o.sigma * o.sigma));
  }
  return phi;
}

function bounds(polygon) {
  let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
  for (const [x, y] of polygon) {
    x0 = Math.min(x0, x); y0 = Math.min(y0, y);
    x1 = Math.max(x1, x); y1 = Math.max(y1, y);
  }
  return { x0, y0, x1, y1 };
}

/** A colour ramp from deep blue through teal and yellow to red, t in [0, 1]. */
export function ramp(t) {
  const stops = [
    [0.0, [20, 30, 70]],
    [0.35, [20, 110, 140]],
    [0.65, [220, 200, 60]],
    [1.0, [210, 50, 40]],
  ];
  t = Math.min(1, Math.max(0, t));
  for (let i = 1; i < stops.length; i++) {
    if (t <= stops[i][0]) {
      const [ta, a] = stops[i - 1];
      const [tb, b] = stops[i];
      const u = (t - ta) / (tb - ta);
      return [0, 1, 2].map((k) => Math.round(a[k] + u * (b[k] - a[k])));
    }
  }
  return stops[stops.length - 1][1];
}

export class MapView {
  constructor(canvas) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d");
    this.scale = 1;
    this.ox = 0;
    this.oy = 0;
    this.fitted = false;
    // Whether the view is still the fitted one (no pan or zoom since):
    // then it is fitted again when the canvas or its overlays change.
    this.autoFit = false;
    this.fitKey = "";
    // The bands at the top and bottom of the canvas [CSS px] that overlays
    // (buttons, legend, hints) cover; app.js measures them.
    this.insets = () => ({ top: 0, bottom: 0 });
    this.mission = null;
    this.vessels = [];
    // Each vessel's colour, by the order the page first saw it: a vessel
    // that joins or leaves changes no other vessel's colour.
    this.colours = new Map();
    this.trails = new Map();
    this.selectedObject = null;
    this.selectedVessel = null;
    this.follow = false;
    this.heat = null; // { canvas, x0, y0, x1, y1, min, max }
    this.heatKey = "";
    // What the heat map shows (belief.js): the mission's risk, the belief
    // the fleet covers (GET /api/v1/risk) or its uncertainty; and the
    // newest samples (GET /api/v1/samples) as dots in the heat's colours.
    this.layer = "mission";
    this.belief = null;
    this.samples = [];
    this.showSamples = true;
    this.dirty = true;
    this.dragObject = null; // { id, x, y } while an object is dragged
    new ResizeObserver(() => this.resize()).observe(canvas);
    this.resize();
    const frame = () => {
      if (this.dirty) {
        this.dirty = false;
        const started = performance.now();
        this.draw();
        this.onDraw?.();
        // An overlay shown or resized by that draw (the scale bar appears
        // with an origin): fitted again at once, in the same frame, so
        // that nothing reads the view and its overlays out of step.
        if (this.autoFit && this.mission && JSON.stringify(this.insets()) !== this.fitKey) {
          this.fit();
          this.dirty = false;
          this.draw();
          this.onDraw?.();
        }
        // Cost of the last draws (ms, moving average), for the console and
        // the smoothness measurement in the README.
        const ms = performance.now() - started;
        this.drawMs = this.drawMs === undefined ? ms : 0.9 * this.drawMs + 0.1 * ms;
        this.draws = (this.draws || 0) + 1;
      }
      requestAnimationFrame(frame);
    };
    requestAnimationFrame(frame);
  }

  resize() {
    const r = this.canvas.getBoundingClientRect();
    const dpr = window.devicePixelRatio || 1;
    this.width = Math.max(1, r.width);
    this.height = Math.max(1, r.height);
    this.canvas.width = Math.round(this.width * dpr);
    this.canvas.height = Math.round(this.height * dpr);
    this.dpr = dpr;
    if (!this.fitted || this.autoFit) this.fit();
    this.dirty = true;
  }

  toScreen(x, y) {
    return [this.ox + this.scale * x, this.oy - this.scale * y];
  }

  toWorld(sx, sy) {
    return [(sx - this.ox) / this.scale, (this.oy - sy) / this.scale];
  }

  /**
   * Fits the whole region, with a margin, into the canvas between the bands
   * its overlays cover at the top and the bottom, so that none hides any of
   * it.
   */
  fit() {
    if (!this.mission) return;
    const b = bounds(this.mission.region.polygon);
    const w = Math.max(b.x1 - b.x0, 1e-9);
    const h = Math.max(b.y1 - b.y0, 1e-9);
    const insets = this.insets();
    this.fitKey = JSON.stringify(insets);
    const margin = 16;
    // The free band; on a canvas too short for it, the whole canvas.
    let top = insets.top + margin;
    let bottom = this.height - insets.bottom - margin;
    if (bottom - top < this.height / 3) {
      top = margin;
      bottom = this.height - margin;
    }
    this.scale = Math.min((this.width - 2 * margin) / w, (bottom - top) / h);
    if (!(this.scale > 0)) this.scale = 1;
    this.ox = this.width / 2 - this.scale * (b.x0 + w / 2);
    this.oy = (top + bottom) / 2 + this.scale * (b.y0 + h / 2);
    this.fitted = true;
    this.autoFit = true;
    this.dirty = true;
  }

  /** Zooms by `factor` keeping the world point under (sx, sy) in place. */
  zoom(factor, sx = this.width / 2, sy = this.height / 2) {
    const [wx, wy] = this.toWorld(sx, sy);
    this.scale *= factor;
    this.ox = sx - this.scale * wx;
    this.oy = sy + this.scale * wy;
    this.autoFit = false;
    this.dirty = true;
  }

  pan(dx, dy) {
    this.ox += dx;
    this.oy += dy;
    this.autoFit = false;
    this.dirty = true;
  }

  /** A vessel's colour on the map (and its trail's). */
  colourFor(id) {
    if (!this.colours.has(id)) this.colours.set(id, this.colours.size);
    return colourOf(this.colours.get(id));
  }

  setSnapshot(snapshot) {
    const first = !this.mission;
    this.mission = snapshot.mission;
    this.vessels = snapshot.vessels;
    for (const v of snapshot.vessels) {
      if (!v.pose) continue;
      let trail = this.trails.get(v.id);
      if (!trail) this.trails.set(v.id, (trail = []));
      const last = trail[trail.length - 1];
      if (!last || Math.hypot(last[0] - v.pose.x, last[1] - v.pose.y) > 0.05) {
        trail.push([v.pose.x, v.pose.y]);
        if (trail.length > TRAIL) trail.shift();
      }
    }
    if (first) this.fit();
    if (this.follow && this.selectedVessel) {
      const v = this.vessels.find((v) => v.id === this.selectedVessel);
      if (v && v.pose) {
        const [sx, sy] = this.toScreen(v.pose.x, v.pose.y);
        this.pan(this.width / 2 - sx, this.height / 2 - sy);
      }
    }
    this.dirty = true;
  }

  /** The risk object under a screen point, if any. */
  objectAt(sx, sy) {
    if (!this.mission) return null;
    let best = null;
    let bestD = Infinity;
    for (const o of this.mission.risk.objects) {
      const [ox, oy] = this.toScreen(o.x, o.y);
      const d = Math.hypot(sx - ox, sy - oy);
      const reach = Math.max(10, Math.min(this.scale * o.sigma, 40));
      if (d <= reach && d < bestD) {
        best = o;
        bestD = d;
      }
    }
    return best;
  }

  /**
   * The field the heat map shows at (x, y): the mission's Φ, the belief's,
   * or the belief's σ (its grid's values at cell centres, interpolated
   * bilinearly, held at the edges).
   */
  field() {
    const b = this.belief;
    if (this.layer === "belief" && b) return (x, y) => density(b.risk, x, y);
    if (this.layer === "uncertainty" && b && b.uncertainty) {
      const u = b.uncertainty;
      const at = (i, j) => u.sd[Math.min(u.ny - 1, Math.max(0, j)) * u.nx + Math.min(u.nx - 1, Math.max(0, i))];
      return (x, y) => {
        const fx = (x - u.x0) / u.step - 0.5;
        const fy = (y - u.y0) / u.step - 0.5;
        const i = Math.floor(fx), j = Math.floor(fy);
        const a = fx - i, b = fy - j;
        return (1 - b) * ((1 - a) * at(i, j) + a * at(i + 1, j)) + b * ((1 - a) * at(i, j + 1) + a * at(i + 1, j + 1));
      };
    }
    const risk = this.mission.risk;
    return (x, y) => density(risk, x, y);
  }

  /** Recomputes the heat map image when the field or region changed. */
  heatImage() {
    const m = this.mission;
    const belief = this.belief;
    const shown = this.layer === "mission" || !belief
      ? ["mission", m.risk]
      : [this.layer, belief.fits, belief.fitted_at, belief.risk.objects.length];
    const key = JSON.stringify([shown, m.region.polygon]);
    if (key === this.heatKey && this.heat) return this.heat;
    const phiAt = this.field();
    const b = bounds(m.region.polygon);
    const n = 160;
    const aspect = (b.y1 - b.y0) / Math.max(b.x1 - b.x0, 1e-9);
    const nx = aspect > 1 ? Math.max(8, Math.round(n / aspect)) : n;
    const ny = aspect > 1 ? n : Math.max(8, Math.round(n * aspect));
    const values = new Float64Array(nx * ny);
    let min = Infinity, max = -Infinity;
    for (let j = 0; j < ny; j++) {
      const y = b.y1 - ((j + 0.5) / ny) * (b.y1 - b.y0);
      for (let i = 0; i < nx; i++) {
        const x = b.x0 + ((i + 0.5) / nx) * (b.x1 - b.x0);
        const phi = phiAt(x, y);
        values[j * nx + i] = phi;
        min = Math.min(min, phi);
        max = Math.max(max, phi);
      }
    }
    const off = document.createElement("canvas");
    off.width = nx;
    off.height = ny;
    const octx = off.getContext("2d");
    const img = octx.createImageData(nx, ny);
    const span = max - min || 1;
    for (let k = 0; k < values.length; k++) {
      const [r, g, bl] = ramp((values[k] - min) / span);
      img.data[4 * k] = r;
      img.data[4 * k + 1] = g;
      img.data[4 * k + 2] = bl;
      img.data[4 * k + 3] = 255;
    }
    octx.putImageData(img, 0, 0);
    this.heat = { canvas: off, ...b, min, max };
    this.heatKey = key;
    this.onLegend?.(min, max, shown[0]);
    return this.heat;
  }

  ring(ctx, points) {
    points.forEach(([x, y], i) => {
      const [sx, sy] = this.toScreen(x, y);
      if (i === 0) ctx.moveTo(sx, sy);
      else ctx.lineTo(sx, sy);
    });
    ctx.closePath();
  }

  /**
   * A curved cell's exact boundary (the snapshot's `edges`: closed loops of
   * segments and arcs, the cell on the left of each, angles in radians
   * counter-clockwise from +x) as one path of subpaths. The view is a
   * uniform scale with y flipped, so a world circle is a circle on screen;
   * the flip turns a world angle θ into the canvas angle −θ, and an arc
   * that runs counter-clockwise in the world (sweep > 0) runs towards
   * smaller canvas angles: canvas's `anticlockwise` flag. Pieces run
   * counter-clockwise and holes clockwise, so the path fills the cell with
   * either fill rule.
   */
  edges(ctx, loops) {
    const s = this.scale;
    for (const loop of loops) {
      if (!loop.length) continue;
      const first = loop[0];
      const start = first.kind === "arc"
        ? [first.centre[0] + first.radius * Math.cos(first.start),
           first.centre[1] + first.radius * Math.sin(first.start)]
        : first.from;
      ctx.moveTo(...this.toScreen(start[0], start[1]));
      for (const e of loop) {
        if (e.kind === "arc") {
          const [cx, cy] = this.toScreen(e.centre[0], e.centre[1]);
          // The arc begins with a line from the current point to its start:
          // a no-op where the loop is continuous.
          ctx.arc(cx, cy, s * e.radius, -e.start, -(e.start + e.sweep), e.sweep > 0);
        } else {
          ctx.lineTo(...this.toScreen(e.to[0], e.to[1]));
        }
      }
      ctx.closePath();
    }
  }

  draw() {
    const ctx = this.ctx;
    ctx.setTransform(this.dpr, 0, 0, this.dpr, 0, 0);
    ctx.fillStyle = "#0b1118";
    ctx.fillRect(0, 0, this.width, this.height);
    const m = this.mission;
    if (!m) return;

    // Heat map clipped to Q (outer ring minus holes, even-odd).
    const heat = this.heatImage();
    ctx.save();
    ctx.beginPath();
    this.ring(ctx, m.region.polygon);
    for (const hole of m.region.holes) this.ring(ctx, hole);
    ctx.clip("evenodd");
    const [hx, hy] = this.toScreen(heat.x0, heat.y1);
    ctx.imageSmoothingEnabled = true;
    ctx.globalAlpha = 0.85;
    ctx.drawImage(heat.canvas, hx, hy, this.scale * (heat.x1 - heat.x0), this.scale * (heat.y1 - heat.y0));
    ctx.restore();

    // Region outline and holes.
    ctx.lineWidth = 1.5;
    ctx.strokeStyle = "#d8e2ea";
    ctx.beginPath();
    this.ring(ctx, m.region.polygon);
    ctx.stroke();
    ctx.fillStyle = "#27323d";
    for (const hole of m.region.holes) {
      ctx.beginPath();
      this.ring(ctx, hole);
      ctx.fill();
      ctx.stroke();
    }

    // Cells, each in its vessel's colour.
    ctx.lineWidth = 1;
    for (const v of this.vessels) {
      if (!v.polygon) continue;
      const colour = this.colourFor(v.id);
      ctx.beginPath();
      // Curved cells (vessels with different β) with their true arcs, every
      // piece and hole; straight ones by their outline.
      if (v.edges && v.edges.length) this.edges(ctx, v.edges);
      else this.ring(ctx, v.polygon);
      ctx.globalAlpha = v.id === this.selectedVessel ? 0.35 : 0.16;
      ctx.fillStyle = colour;
      ctx.fill("evenodd");
      ctx.globalAlpha = 0.9;
      ctx.strokeStyle = colour;
      ctx.stroke();
    }
    ctx.globalAlpha = 1;

    // Samples: dots in the heat map's colours (for its own field: the
    // value measured against the belief's range), ringed so that a sample
    // that agrees with the map still shows.
    if (this.showSamples && this.layer !== "mission" && this.samples.length) {
      const span = heat.max - heat.min || 1;
      const radius = Math.max(2, Math.min(4, this.scale * 0.8));
      ctx.lineWidth = 1;
      ctx.strokeStyle = "rgba(255,255,255,0.8)";
      for (const s of this.samples) {
        const [sx, sy] = this.toScreen(s.x, s.y);
        const t = this.layer === "belief" ? Math.min(1, Math.max(0, (s.value - heat.min) / span)) : 0;
        const [r, g, bl] = ramp(t);
        ctx.beginPath();
        ctx.arc(sx, sy, radius, 0, 2 * Math.PI);
        ctx.fillStyle = `rgb(${r},${g},${bl})`;
        ctx.fill();
        ctx.stroke();
      }
    }

    // Risk objects: circles of radius σ, centre dot.
    for (const o of m.risk.objects) {
      const dragged = this.dragObject && this.dragObject.id === o.id ? this.dragObject : o;
      const [sx, sy] = this.toScreen(dragged.x, dragged.y);
      ctx.beginPath();
      ctx.arc(sx, sy, Math.max(3, this.scale * o.sigma), 0, 2 * Math.PI);
      ctx.setLineDash([5, 4]);
      ctx.lineWidth = o.id === this.selectedObject ? 2.5 : 1.2;
      ctx.strokeStyle = o.id === this.selectedObject ? "#ffffff" : "rgba(255,255,255,0.7)";
      ctx.stroke();
      ctx.setLineDash([]);
      ctx.beginPath();
      ctx.arc(sx, sy, 3, 0, 2 * Math.PI);
      ctx.fillStyle = "#fff";
      ctx.fill();
    }

    // Trails, centroids, errors and boats. Glyph size in pixels, not metres,
    // so a boat stays visible at any zoom; thinned out for huge fleets.
    const many = this.vessels.length > 200;
    for (const v of this.vessels) {
      if (!v.pose) continue;
      const colour = this.colourFor(v.id);
      const trail = this.trails.get(v.id);
      if (trail && trail.length > 1 && !many) {
        for (let k = 1; k < trail.length; k++) {
          const [ax, ay] = this.toScreen(...trail[k - 1]);
          const [bx, by] = this.toScreen(...trail[k]);
          ctx.globalAlpha = (k / trail.length) * 0.8;
          ctx.strokeStyle = colour;
          ctx.lineWidth = 1.5;
          ctx.beginPath();
          ctx.moveTo(ax, ay);
          ctx.lineTo(bx, by);
          ctx.stroke();
        }
        ctx.globalAlpha = 1;
      }
      const [px, py] = this.toScreen(v.pose.x, v.pose.y);
      if (v.centroid) {
        const [cx, cy] = this.toScreen(v.centroid[0], v.centroid[1]);
        ctx.strokeStyle = colour;
        ctx.lineWidth = 1;
        ctx.setLineDash([3, 3]);
        ctx.beginPath();
        ctx.moveTo(px, py);
        ctx.lineTo(cx, cy);
        ctx.stroke();
        ctx.setLineDash([]);
        ctx.beginPath();
        ctx.moveTo(cx - 4, cy - 4);
        ctx.lineTo(cx + 4, cy + 4);
        ctx.moveTo(cx - 4, cy + 4);
        ctx.lineTo(cx + 4, cy - 4);
        ctx.stroke();
      }
      // The boat: a pointed hull along the heading (screen y is flipped).
      const size = many ? 5 : 9;
      const c = Math.cos(v.pose.psi);
      const s = Math.sin(v.pose.psi);
      const pt = (fx, fy) => [px + size * (fx * c - fy * s), py - size * (fx * s + fy * c)];
      ctx.beginPath();
      ctx.moveTo(...pt(1.2, 0));
      ctx.lineTo(...pt(0.2, 0.55));
      ctx.lineTo(...pt(-0.9, 0.5));
      ctx.lineTo(...pt(-0.9, -0.5));
      ctx.lineTo(...pt(0.2, -0.55));
      ctx.closePath();
      ctx.fillStyle = v.connected ? colour : "#777";
      ctx.fill();
      ctx.lineWidth = v.id === this.selectedVessel ? 2.5 : 1;
      ctx.strokeStyle = v.id === this.selectedVessel ? "#fff" : "#0b1118";
      ctx.stroke();
      if (!many) {
        ctx.fillStyle = "#e8eef3";
        ctx.font = "11px system-ui, sans-serif";
        ctx.fillText(v.id, px + 10, py - 8);
      }
    }
  }
}
