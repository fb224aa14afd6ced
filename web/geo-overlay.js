// What a chart has and a plain plot lacks, shown once the mission has a
// WGS84 origin: the pointer's latitude and longitude, a scale bar and a
// north arrow. DOM elements over the map's canvas (a few, not one per
// vessel), updated when the map is drawn and when the pointer moves.

import { LocalFrame, formatLat, formatLon } from "./wgs84.js";

const $ = (id) => document.getElementById(id);

/** The largest 1, 2 or 5 × 10^k not above `x`. */
export function niceLength(x) {
  const p = Math.pow(10, Math.floor(Math.log10(x)));
  for (const m of [5, 2, 1]) if (m * p <= x) return m * p;
  return p;
}

function metres(m) {
  return m >= 1000 ? `${m / 1000} km` : m >= 1 ? `${m} m` : `${m * 100} cm`;
}

export class GeoOverlay {
  constructor(canvas, view) {
    this.canvas = canvas;
    this.view = view;
    this.frame = null;
    this.originKey = "";
    this.pointer = null; // [sx, sy] while the pointer is over the map
    canvas.addEventListener("pointermove", (event) => {
      const r = canvas.getBoundingClientRect();
      this.pointer = [event.clientX - r.left, event.clientY - r.top];
      this.readout();
    });
    canvas.addEventListener("pointerleave", () => {
      this.pointer = null;
      this.readout();
    });
  }

  /** Follows the mission's origin and the view; called after each draw. */
  update() {
    const origin = this.view.mission ? this.view.mission.origin : null;
    const key = origin ? `${origin.lat},${origin.lon}` : "";
    if (key !== this.originKey) {
      this.originKey = key;
      this.frame = origin ? new LocalFrame(origin.lat, origin.lon) : null;
      for (const id of ["geo-readout", "scale-bar", "north-arrow"]) $(id).hidden = !this.frame;
    }
    if (!this.frame) return;
    this.scaleBar();
    this.northArrow();
    this.readout();
  }

  scaleBar() {
    // About 120 px of the map, rounded down to a length one can read.
    const length = niceLength(120 / this.view.scale);
    const bar = $("scale-bar");
    const px = length * this.view.scale;
    bar.querySelector(".bar").style.width = `${px.toFixed(1)}px`;
    bar.querySelector(".label").textContent = metres(length);
    bar.dataset.metres = String(length);
    bar.dataset.pixels = String(px);
  }

  northArrow() {
    const v = this.view;
    const [x, y] = v.toWorld(v.width / 2, v.height / 2);
    const angle = this.frame.northAt(x, y);
    const arrow = $("north-arrow");
    arrow.querySelector("svg").style.transform = `rotate(${angle}deg)`;
    arrow.dataset.rotation = String(angle);
  }

  readout() {
    const box = $("geo-readout");
    if (!this.frame) return;
    if (!this.pointer) {
      box.textContent = "lat, lon under the pointer";
      delete box.dataset.lat;
      delete box.dataset.lon;
      return;
    }
    const [x, y] = this.view.toWorld(...this.pointer);
    const g = this.frame.toGeodetic(x, y);
    box.textContent = `${formatLat(g.lat)}  ${formatLon(g.lon)}`;
    box.dataset.lat = String(g.lat);
    box.dataset.lon = String(g.lon);
  }
}
