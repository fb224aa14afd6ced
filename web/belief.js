// A learning coordinator's side of the map (docs/learning.md): the belief
// the fleet covers, its uncertainty and the newest samples, fetched from
// GET /api/v1/risk and GET /api/v1/samples every two seconds. A coordinator
// that does not learn says so in its first answer, and the panel stays
// hidden; so does a replay's (its coordinator answers the recorded
// mission's risk).

import { read } from "./api.js";

const EVERY_MS = 2000;
const $ = (id) => document.getElementById(id);

/** Starts polling; shows the learning panel once the coordinator learns. */
export async function startLearning(view) {
  let first;
  try {
    first = await read("/api/v1/risk");
  } catch {
    return; // An older coordinator, or one going away: no learning view.
  }
  if (!first.learning) return;
  $("learning-panel").hidden = false;
  view.layer = $("layer-select").value;
  $("layer-select").addEventListener("change", () => {
    view.layer = $("layer-select").value;
    view.dirty = true;
  });
  $("samples-toggle").addEventListener("change", () => {
    view.showSamples = $("samples-toggle").checked;
    view.dirty = true;
  });
  const show = (belief, samples) => {
    view.belief = belief;
    view.samples = samples;
    view.dirty = true;
    const at = belief.fitted_at === undefined ? "no fit yet" : `fitted at ${belief.fitted_at.toFixed(1)} s`;
    // The optimism fades with the samples' age (docs/learning.md): two digits say how far.
    const optimism = belief.kappa > 0 ? ` · κ = ${belief.kappa.toFixed(2)}` : "";
    $("learning-readout").textContent =
      `${belief.samples} samples held · ${belief.fits} fits · ${at} · ${belief.risk.objects.length} Gaussians${optimism}`;
  };
  const poll = async () => {
    try {
      const [belief, recent] = await Promise.all([read("/api/v1/risk"), read("/api/v1/samples")]);
      show(belief, recent.samples);
    } catch (e) {
      console.info("seacover: learning view:", String(e));
    }
    setTimeout(poll, EVERY_MS);
  };
  show(first, []);
  poll();
}
