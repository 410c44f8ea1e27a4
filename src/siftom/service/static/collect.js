// The recording page: consent, then one scenario at a time: look, record, listen, type, save.
"use strict";

const st = { info: null, participant: null, key: null, done: new Set(), index: 0, wav: null, recorder: null };

async function init() {
  st.info = await api("/api/collection");
  $("consent-text").textContent = st.info.consent;
  if (st.info.participant) {
    $("participant").value = st.info.participant;
    $("participant").readOnly = true;
  }
  st.recorder = new Recorder(st.info.max_seconds);
  st.viewer = new FrameViewer("scene");
}

async function start(ev) {
  ev.preventDefault();
  showError("");
  const pid = $("participant").value.trim();
  if (!/^[A-Za-z0-9_-]{1,32}$/.test(pid)) {
    showError("Type your participant id: 1 to 32 letters, digits, _ or - (not your name).");
    $("participant").focus();
    return;
  }
  if (!$("agree").checked) {
    showError("Tick the box to agree before starting, or close the page to stop.");
    $("agree").focus();
    return;
  }
  try {
    const r = await api("/api/participants", {
      method: "POST", headers: { "Content-Type": "application/json" },
      // the key of this participant, if this tab has recorded for them before (a reload)
      body: JSON.stringify({ participant: pid, agree: true, key: sessionStorage.getItem(`siftom-key:${pid}`) }),
    });
    st.participant = pid;
    st.key = r.key;
    sessionStorage.setItem(`siftom-key:${pid}`, r.key);
    st.done = new Set(r.done);
    $("consent-panel").hidden = true;
    await next();
  } catch (e) { showError(e.message); }
}

async function next() {
  let k = 0;
  while (k < st.info.scenarios && st.done.has(k)) k++;
  if (k >= st.info.scenarios) {
    $("task-panel").hidden = true;
    $("done-panel").hidden = false;
    $("done-text").textContent = `All ${st.info.scenarios} recordings are saved. You can close this page.`;
    setStatus("all recordings saved");
    focusHeading("done-title");
    return;
  }
  st.index = k;
  st.wav = null;
  const p = await api(`/api/prompts/${k}`);
  $("task-title").textContent = `Scenario ${k + 1} of ${st.info.scenarios}`;
  $("goal").textContent = `Your goal: ${p.goal}`;
  $("ask").textContent = p.ask;
  st.viewer.load((step) => `/api/prompts/${k}/frames/${step}.png`, p.actions);
  $("take").hidden = true;
  $("said").value = "";
  $("record").innerHTML = "&#9679; Record";
  $("task-panel").hidden = false;
  setStatus(`scenario ${k + 1} of ${st.info.scenarios}`);
  focusHeading("task-title");
}

async function toggleRecord() {
  const btn = $("record");
  showError("");
  if (st.recorder.recording) { st.recorder.stop(); return; }
  try {
    await st.recorder.start((wav, err) => {
      btn.classList.remove("recording");
      btn.innerHTML = "&#9679; Record again";
      if (err) { showError(err.message); setStatus(""); return; }
      st.wav = wav;
      $("playback").src = URL.createObjectURL(wav);
      $("take").hidden = false;
      setStatus("recorded: listen to it, type what you said, then save (or record again)");
      $("said").focus();
    });
    btn.classList.add("recording");
    btn.innerHTML = "&#9632; Stop";
    setStatus("recording… press Stop when you are done");
  } catch (e) {
    btn.classList.remove("recording");
    showError(e.message);
    setStatus("not recording");
  }
}

async function save(ev) {
  ev.preventDefault();
  showError("");
  const said = $("said").value.trim();
  if (!st.wav) { showError("Record your request first (press Record)."); $("record").focus(); return; }
  if (!said) { showError("Type what you said, word for word, before saving."); $("said").focus(); return; }
  const form = new FormData();
  form.append("participant", st.participant);
  form.append("key", st.key);
  form.append("index", String(st.index));
  form.append("reference", said);
  form.append("audio", st.wav, "recording.wav");
  setStatus("saving…");
  try {
    const r = await api("/api/recordings", { method: "POST", body: form });
    st.done = new Set(r.done);
    setStatus(`saved ${r.id} (${r.duration_s.toFixed(1)} s)`);
    await next();
  } catch (e) { showError(`Not saved: ${e.message}`); setStatus(""); }
}

window.addEventListener("DOMContentLoaded", () => {
  $("consent-form").addEventListener("submit", start);
  $("record").addEventListener("click", toggleRecord);
  $("save-form").addEventListener("submit", save);
  init().then(() => { document.body.dataset.ready = "1"; }).catch((e) => showError(e.message));
});
