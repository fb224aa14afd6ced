// The replay bar, started only on a page `seacover replay` served (the
// server marks it, `<html data-mode="replay">`; a coordinator's page never
// asks for GET /api/v1/replay, which it would answer 404). Play and pause,
// speed, and a time slider that seeks (PUT /api/v1/replay); the replay's
// next snapshot, on the same stream as a live coordinator's, moves the map.

const $ = (id) => document.getElementById(id);

/**
 * Starts the bar; `seeking` is called before a seek, `sought` once the
 * replay is at the new time.
 */
export async function startReplayBar({ seeking = () => {}, sought = () => {} } = {}) {
  let status;
  try {
    const r = await fetch("/api/v1/replay");
    if (!r.ok) return null;
    status = await r.json();
  } catch {
    return null;
  }
  document.body.dataset.replay = "true";
  $("replay-bar").hidden = false;
  $("replay-file").textContent = status.file.split("/").pop();
  const slider = $("replay-time");
  slider.min = String(status.start);
  slider.max = String(status.end);
  slider.step = "0.1";
  let dragging = false;
  // The time of the snapshot on screen: the label and the slider say it,
  // as the header does, rather than the replay clock polled between
  // snapshots (which runs ahead of what is shown).
  let shownTime = null;

  function show() {
    const time = shownTime ?? status.time;
    $("replay-play").textContent = status.playing ? "pause" : "play";
    if (!dragging) slider.value = String(time);
    $("replay-label").textContent = `${time.toFixed(1)} / ${status.end.toFixed(1)} s`;
    $("replay-speed").value = String(status.speed);
  }

  async function put(body) {
    const r = await fetch("/api/v1/replay", {
      method: "PUT",
      headers: { "content-type": "application/json" },
      body: JSON.stringify(body),
    });
    if (r.ok) {
      status = await r.json();
      show();
    }
    return status;
  }

  async function seek(time) {
    shownTime = null;
    seeking();
    const answer = await put({ time });
    sought();
    return answer;
  }

  $("replay-play").addEventListener("click", () => put({ playing: !status.playing }));
  $("replay-speed").addEventListener("change", () => put({ speed: Number($("replay-speed").value) }));
  slider.addEventListener("input", () => {
    dragging = true;
    $("replay-label").textContent = `${Number(slider.value).toFixed(1)} / ${status.end.toFixed(1)} s`;
  });
  slider.addEventListener("change", async () => {
    await seek(Number(slider.value));
    dragging = false;
  });
  setInterval(async () => {
    try {
      const r = await fetch("/api/v1/replay");
      if (r.ok) {
        status = await r.json();
        show();
      }
    } catch {
      // The stream's status shows a lost server.
    }
  }, 500);
  show();
  /** The stream showed the snapshot of mission time `t`. */
  function shown(t) {
    shownTime = t;
    show();
  }
  return { seek, put, shown, status: () => status };
}
