// REST calls with the operator's token. The token lives in localStorage; a
// 401 asks for it once (in a dialog) and retries; every other error is shown
// to the operator, never swallowed.

const KEY = "seacover.token";

export function token() {
  return localStorage.getItem(KEY) || "";
}

export function setToken(value) {
  if (value) localStorage.setItem(KEY, value);
  else localStorage.removeItem(KEY);
}

/** Shows an error message for a while. */
export function showError(message) {
  const box = document.getElementById("errors");
  const item = document.createElement("div");
  item.className = "error";
  item.textContent = message;
  box.append(item);
  setTimeout(() => item.remove(), 8000);
  console.info("seacover:", message);
}

/** Opens the token dialog; resolves to the new token, or null if cancelled. */
export function askToken(reason) {
  const dialog = document.getElementById("token-dialog");
  const input = document.getElementById("token-input");
  document.getElementById("token-reason").textContent = reason;
  input.value = token();
  return new Promise((resolve) => {
    const cancel = document.getElementById("token-cancel");
    const done = (value) => {
      dialog.removeEventListener("close", onClose);
      cancel.removeEventListener("click", onCancel);
      resolve(value);
    };
    const onClose = () => {
      if (dialog.returnValue === "ok") {
        setToken(input.value.trim());
        done(input.value.trim());
      } else done(null);
    };
    const onCancel = () => {
      dialog.close("cancel");
    };
    dialog.addEventListener("close", onClose);
    cancel.addEventListener("click", onCancel);
    dialog.returnValue = "";
    dialog.showModal();
    input.focus();
  });
}

/**
 * Sends a write. Returns the parsed answer (or null for 204), or throws after
 * showing the server's error.
 */
export async function write(method, path, body, contentType = "application/json") {
  const json = contentType === "application/json";
  for (let attempt = 0; attempt < 2; attempt++) {
    const headers = { "content-type": contentType };
    const t = token();
    if (t) headers.authorization = `Bearer ${t}`;
    let response;
    try {
      response = await fetch(path, {
        method,
        headers,
        // A file (a raster) goes as it is.
        body: body === undefined ? undefined : json ? JSON.stringify(body) : body,
      });
    } catch (e) {
      showError(`${method} ${path}: the coordinator cannot be reached (${e.message})`);
      throw e;
    }
    if (response.status === 401 && attempt === 0) {
      const given = await askToken(
        t ? "The token was refused. Enter the coordinator's token:" : "This coordinator needs a token for changes:",
      );
      if (given === null) {
        showError("Not changed: the coordinator needs a token (401).");
        throw new Error("unauthorized");
      }
      continue;
    }
    if (response.status === 204) return null;
    let answer = null;
    try {
      answer = await response.json();
    } catch {
      answer = null;
    }
    if (!response.ok) {
      const detail = answer && answer.error ? `${answer.error.code}: ${answer.error.message}` : response.statusText;
      showError(`${method} ${path} refused (${response.status}) — ${detail}`);
      throw new Error(detail);
    }
    return answer;
  }
  showError(`${method} ${path} refused (401) — the token is wrong`);
  throw new Error("unauthorized");
}

export async function read(path) {
  const response = await fetch(path);
  if (!response.ok) throw new Error(`${path}: ${response.status}`);
  return response.json();
}
