// The annotation page: consent, then one stimulus per page: look, listen, type, choose, submit.
"use strict";

const st = { annotator: null, key: null, view: null, shown: 0 };

// The annotator's own link: the key travels in the fragment, which is never sent to the server.
function keyFromLink() {
  const m = /(?:^|[#&])key=([A-Za-z0-9_-]{16,100})/.exec(location.hash);
  return m ? m[1] : null;
}

function ownLink() {
  return `${location.origin}${location.pathname}#key=${st.key}`;
}

async function init() {
  const info = await api("/api/annotation");
  $("consent-text").textContent = info.consent;
  st.viewer = new FrameViewer("scene");
  const key = keyFromLink();
  if (key) {  // coming back with one's own link: go on where one stopped
    st.key = key;
    const v = await api(`/api/annotators/${key}/next`);
    st.annotator = v.annotator;
    $("consent-panel").hidden = true;
    show(v);
  }
}

async function start(ev) {
  ev.preventDefault();
  showError("");
  const id = $("annotator").value.trim();
  if (id && !/^[A-Za-z0-9_-]{1,32}$/.test(id)) {
    showError("An annotator id has 1 to 32 letters, digits, _ or -; or leave it empty to get a new one.");
    $("annotator").focus();
    return;
  }
  if (!$("agree").checked) {
    showError("Tick the box to agree before starting, or close the page to stop.");
    $("agree").focus();
    return;
  }
  try {
    const v = await api("/api/annotators", {
      method: "POST", headers: { "Content-Type": "application/json" },
      body: JSON.stringify({ annotator: id || null, agree: true }),
    });
    st.annotator = v.annotator;
    st.key = v.key;
    $("consent-panel").hidden = true;
    show(v);
  } catch (e) { showError(e.message); }
}

function option(sel, value, text) {
  const o = document.createElement("option");
  o.value = value;
  o.textContent = text;
  sel.appendChild(o);
}

function show(v) {
  st.view = v;
  if (v.done) {
    $("task-panel").hidden = true;
    $("done-panel").hidden = false;
    $("done-text").textContent = `All ${v.total} answers are saved (annotator ${v.annotator}). You can close this page.`;
    setStatus("all answers saved");
    focusHeading("done-title");
    return;
  }
  const base = `/api/annotators/${encodeURIComponent(st.key)}/${v.position}`;
  $("task-title").textContent = `Recording ${v.answered + 1} of ${v.total}`;
  $("who").textContent = `Your annotator id is ${v.annotator}. To continue later, keep this link (it is yours alone): ${ownLink()}`;
  st.viewer.load((step) => `${base}/frames/${step}.png`, v.actions);
  $("player").src = `${base}/audio.wav`;
  $("typed").value = "";
  const item = $("item");
  item.replaceChildren();
  option(item, "", "choose…");
  for (const c of v.form.classes) option(item, c, c.replace(/_/g, " "));
  option(item, "none", "nothing (I would not bring anything)");
  const count = $("count");
  count.replaceChildren();
  const counted = v.form.verb === "deliver";
  $("count-label").hidden = !counted;
  count.hidden = !counted;
  if (counted) {
    option(count, "", "choose…");
    for (let n = 1; n <= v.form.max_count; n++) option(count, String(n), String(n));
  }
  st.shown = performance.now();
  $("task-panel").hidden = false;
  setStatus(`recording ${v.answered + 1} of ${v.total}`);
  focusHeading("task-title");
}

async function submit(ev) {
  ev.preventDefault();
  showError("");
  const typed = $("typed").value.trim();
  const item = $("item").value;
  const counted = st.view.form.verb === "deliver" && item !== "none";
  if (!typed) { showError("Type what you heard (write ... for words you could not make out)."); $("typed").focus(); return; }
  if (!item) { showError("Choose what you would bring (or 'nothing')."); $("item").focus(); return; }
  if (counted && !$("count").value) { showError("Choose how many to bring."); $("count").focus(); return; }
  const body = { position: st.view.position, typed, item, seconds: (performance.now() - st.shown) / 1000 };
  if (counted) body.count = Number($("count").value);
  setStatus("saving…");
  try {
    show(await api(`/api/annotators/${encodeURIComponent(st.key)}/answers`, {
      method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body),
    }));
  } catch (e) { showError(`Not saved: ${e.message}`); setStatus(""); }
}

window.addEventListener("DOMContentLoaded", () => {
  $("consent-form").addEventListener("submit", start);
  $("answer-form").addEventListener("submit", submit);
  $("play").addEventListener("click", () => {
    const p = $("player");
    p.currentTime = 0;
    p.play().catch((e) => showError(`The recording could not be played (${e.message}); use the player's controls.`));
  });
  init().then(() => { document.body.dataset.ready = "1"; }).catch((e) => showError(e.message));
});
