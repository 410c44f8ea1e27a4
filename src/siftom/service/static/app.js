// siftom web page: plain JS, no build step, no third-party code. Talks to the same origin's API.
"use strict";

const $ = (id) => document.getElementById(id);
const SVG = "http://www.w3.org/2000/svg";
const state = { scenario: null, step: 0, result: null, timer: null, recorder: null, live: null, request: 0, stale: 0 };

function svg(tag, attrs, parent, text) {
  const el = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attrs || {})) el.setAttribute(k, String(v));
  if (text !== undefined) el.textContent = text;
  if (parent) parent.appendChild(el);
  return el;
}

function setStatus(text, isError) {
  const s = $("status");
  s.textContent = text || "";
  s.classList.toggle("error", Boolean(isError));
}

// Help for a microphone that cannot be used goes to a role=alert region (as on the recording page).
function showAlert(text) {
  const a = $("alert");
  a.textContent = text || "";
  a.hidden = !text;
}

function microphoneProblem(e, button) {
  const name = e && e.name;
  if (name === "NotAllowedError" || name === "SecurityError") {
    return "The microphone is blocked for this page, so nothing was recorded. Allow the microphone " +
      `(the camera/microphone icon in the address bar, or the browser's site settings), then press ${button} again.`;
  }
  if (name === "NotFoundError" || name === "OverconstrainedError") {
    return `No microphone was found. Connect one (or choose it in the system's sound settings), then press ${button} again.`;
  }
  if (name === "NotReadableError" || name === "AbortError") {
    return `The microphone could not be started: another program may be using it. Close that program, then press ${button} again.`;
  }
  return `The microphone could not be used (${(e && e.message) || e}). Press ${button} to try again.`;
}

const NO_MICROPHONE_HERE = "This browser cannot use the microphone here. Open the page at http://127.0.0.1 or " +
  "http://localhost (browsers allow the microphone only there or over https), in a current Chrome, Firefox or Safari.";

// Answers are shown in the order they were asked for: each request takes a number, and an answer
// that comes back after a newer request was made is dropped (counted in body[data-stale]).
function newRequest() {
  state.request += 1;
  return state.request;
}

function isCurrent(id) {
  if (id === state.request) return true;
  state.stale += 1;
  document.body.dataset.stale = String(state.stale);
  return false;
}

async function api(path, options) {
  const resp = await fetch(path, options);
  const type = resp.headers.get("content-type") || "";
  if (!resp.ok) {
    let detail = resp.statusText;
    if (type.includes("json")) detail = (await resp.json()).detail || detail;
    throw new Error(`${resp.status}: ${detail}`);
  }
  return type.includes("json") ? resp.json() : resp.blob();
}

// ----- scenarios and the map ---------------------------------------------------------------
async function loadScenarios() {
  const { scenarios } = await api("/v1/scenarios");
  const sel = $("scenario");
  for (const s of scenarios) {
    const opt = document.createElement("option");
    opt.value = s.id;
    opt.textContent = `${s.id} (${s.num_actions} actions)`;
    sel.appendChild(opt);
  }
  const wanted = new URLSearchParams(location.search).get("scenario");
  sel.value = scenarios.some((s) => s.id === wanted) ? wanted : (scenarios.find((s) => s.id === "kitchen-cereal-v0") || scenarios[0]).id;
  await selectScenario(sel.value);
}

async function selectScenario(id) {
  stopPlay();
  newRequest();  // an answer still on its way is about the scenario left
  state.scenario = await api(`/v1/scenarios/${id.split("/").map(encodeURIComponent).join("/")}`);
  state.result = null;
  $("result").hidden = true;
  $("scenario-desc").textContent = state.scenario.description;
  const n = state.scenario.actions.length;
  $("step").max = n;
  setStep(n);
  const list = $("actions");
  list.replaceChildren();
  for (const a of state.scenario.actions) {
    const li = document.createElement("li");
    li.textContent = a;
    list.appendChild(li);
  }
  markActions();
}

function setStep(t) {
  state.step = t;
  $("step").value = t;
  $("step-out").textContent = `${t}/${state.scenario.actions.length}`;
  markActions();
  drawMap();
}

function markActions() {
  const items = $("actions").children;
  for (let i = 0; i < items.length; i++) {
    items[i].classList.toggle("seen", i < state.step);
    items[i].classList.toggle("now", i === state.step - 1);
  }
}

function roomBoxes(places) {
  const boxes = {};
  for (const p of places) {
    const [x, y] = p.pos;
    const b = boxes[p.room] || (boxes[p.room] = [x, y, x, y]);
    b[0] = Math.min(b[0], x); b[1] = Math.min(b[1], y); b[2] = Math.max(b[2], x); b[3] = Math.max(b[3], y);
  }
  for (const b of Object.values(boxes)) { b[0] -= 1.6; b[1] -= 1.6; b[2] += 1.6; b[3] += 1.6; }
  return boxes;
}

const ROOM_COLOURS = ["#f3efe6", "#e8f1f8", "#eef6ea", "#f8ecef", "#f1ecf8", "#f8f5e6"];

function drawMap() {
  const sc = state.scenario;
  const map = $("map");
  map.replaceChildren();
  const boxes = roomBoxes(sc.places);
  const all = Object.values(boxes);
  const x0 = Math.min(...all.map((b) => b[0])) - 1.2, x1 = Math.max(...all.map((b) => b[2])) + 1.2;  // room for labels
  const y0 = Math.min(...all.map((b) => b[1])) - 0.3, y1 = Math.max(...all.map((b) => b[3])) + 0.3;
  map.setAttribute("viewBox", `${x0} ${-y1} ${x1 - x0} ${y1 - y0}`);  // world y up, SVG y down
  const P = (pos) => [pos[0], -pos[1]];
  const place = Object.fromEntries(sc.places.map((p) => [p.name, p]));
  Object.keys(boxes).sort().forEach((room, k) => {
    const [a, b, c, d] = boxes[room];
    svg("rect", { class: "room", x: a, y: -d, width: c - a, height: d - b, fill: ROOM_COLOURS[k % ROOM_COLOURS.length] }, map);
    svg("text", { class: "room-label", x: a + 0.15, y: -d + 0.55 }, map, room.replace(/_/g, " "));
  });
  const tl = sc.timeline[state.step];
  const cls = Object.fromEntries(sc.objects.map((o) => [o.name, o["class"]]));
  const hlClass = state.result ? commandClass(state.result.command) : null;
  for (const p of sc.places) {
    const [x, y] = P(p.pos);
    const kind = p.name === sc.target ? "place target" : (p.closable ? "place container" : "place");
    svg("rect", { class: kind, x: x - 0.6, y: y - 0.35, width: 1.2, height: 0.7, rx: 0.08 }, map);
    const open = p.closable ? (tl.open.includes(p.name) ? " (open)" : " (closed)") : "";
    svg("text", { class: "place-label", x, y: y + 0.7 }, map, p.name.replace(/_/g, " ") + open);
    const counts = {};
    for (const it of tl.items[p.name] || []) counts[cls[it]] = (counts[cls[it]] || 0) + 1;
    const names = Object.keys(counts).sort();
    let label = names.map((c) => (counts[c] > 1 ? `${counts[c]}×${c}` : c)).join(", ");
    if (label.length > 34) label = label.slice(0, 32) + "…";
    if (label) svg("text", { class: hlClass && counts[hlClass] ? "items hl" : "items", x, y: y - 0.45 }, map, label);
  }
  // the human's walk so far
  const pts = [];
  for (let t = 0; t <= state.step; t++) {
    const at = P(place[sc.timeline[t].agents.human].pos);
    const last = pts[pts.length - 1];
    if (!last || last[0] !== at[0] || last[1] !== at[1]) pts.push(at);
  }
  if (pts.length > 1) svg("polyline", { class: "path-human", points: pts.map((p) => p.join(",")).join(" ") }, map);
  // the robot's plan for the chosen command
  const plan = state.result && state.result.plan;
  if (plan && plan.route.length > 1 && state.result.n_actions === state.step) {
    const rp = plan.route.map((n) => P(place[n].pos)).map(([x, y], i) => [x + 0.12, y + 0.12 + 0.02 * i]);
    svg("polyline", { id: "robot-path", class: "path-robot", points: rp.map((p) => p.join(",")).join(" ") }, map);
  }
  const [hx, hy] = P(place[tl.agents.human].pos);
  const [rx, ry] = P(place[tl.agents.robot].pos);
  svg("circle", { class: "agent-human", cx: hx - 0.35, cy: hy, r: 0.22 }, map);
  svg("rect", { class: "agent-robot", x: rx + 0.15, y: ry - 0.2, width: 0.4, height: 0.4, rx: 0.05 }, map);
  if (tl.held.human) svg("text", { class: "items", x: hx - 0.35, y: hy - 0.3 }, map, `holds ${tl.held.human}`);
}

function commandClass(cmd) {
  const m = /^\s*\w+\(\s*([A-Za-z_]\w*)/.exec(cmd || "");
  return m ? m[1] : null;
}

function togglePlay() {
  if (state.timer) { stopPlay(); return; }
  const n = state.scenario.actions.length;
  if (state.step >= n) setStep(0);
  $("play").textContent = "❚❚ Pause";
  state.timer = setInterval(() => {
    if (state.step >= n) { stopPlay(); return; }
    setStep(state.step + 1);
  }, 600);
}

function stopPlay() {
  if (state.timer) clearInterval(state.timer);
  state.timer = null;
  $("play").textContent = "▶ Play";
}

// ----- inference and results ---------------------------------------------------------------
function bars(el, rows, key) {
  el.replaceChildren();
  rows.slice(0, 8).forEach((r, i) => {
    const row = document.createElement("div");
    row.className = i === 0 ? "bar-row top" : "bar-row";
    const label = document.createElement("span");
    label.className = "label";
    label.textContent = r[key];
    label.title = r[key];
    const track = document.createElement("span");
    track.className = "track";
    const fill = document.createElement("span");
    fill.className = "fill";
    fill.style.display = "block";
    fill.style.width = `${(100 * r.prob).toFixed(1)}%`;
    track.appendChild(fill);
    const value = document.createElement("span");
    value.className = "value";
    value.textContent = r.prob.toFixed(2);
    row.append(label, track, value);
    el.appendChild(row);
  });
}

function showResult(res) {
  state.result = res;
  $("result").hidden = false;
  // what the robot does is the decision the server took (the same rule at every door)
  const d = res.decision || {};
  const act = $("action");
  act.dataset.action = res.action || "";
  act.textContent = res.action === "act" ? `carries out ${res.command}`
    : res.action === "ask" ? "asks a question" : "does nothing";
  $("command").textContent = res.top_command || "";
  $("top-prob").textContent = res.top_prob !== undefined ? `(P = ${res.top_prob.toFixed(2)})` : "";
  const q = $("question");
  q.hidden = !(res.action === "ask" || d.declined);
  q.textContent = res.action === "ask" ? `Robot asks: “${d.question}”` : d.declined ? `Robot says: “${d.declined}”` : "";
  $("reason").textContent = res.message || d.reason || "";
  const nb = $("nbest");
  nb.replaceChildren();
  const heard = res.nbest.length ? res.nbest : [{ text: "(nothing heard: actions only)", score: 0 }];
  for (const h of heard.slice(0, 5)) {
    const li = document.createElement("li");
    li.textContent = h.text;
    nb.appendChild(li);
  }
  const wh = $("whisper");
  const ev = res.evidence || {};
  wh.hidden = ev.whisper_heard === undefined;
  const use = { carrier: "a second carrier: it placed the object words",
    guesses: "no object word heard by either: guesses around its words" }[ev.whisper_use] || "no object word in it: not used";
  wh.textContent = wh.hidden ? "" : `Whisper heard: “${ev.whisper_heard}” (${use})`;
  bars($("commands-chart"), res.commands, "command");
  bars($("goals-chart"), res.goals, "goal");
  const plan = $("plan");
  plan.replaceChildren();
  const steps = res.plan ? res.plan.actions
    : res.action === "ask" ? ["(waits for the answer to its question)"] : ["(nothing to do)"];
  for (const a of steps) {
    const li = document.createElement("li");
    li.textContent = a;
    plan.appendChild(li);
  }
  drawMap();
  setStatus(`inferred in ${(1000 * res.seconds).toFixed(0)} ms from ${res.n_actions} actions`);
}

async function inferText(ev) {
  ev.preventDefault();
  const id = newRequest();
  const text = $("instruction").value.trim();
  const body = { scenario: state.scenario.id, n_actions: state.step };
  if (text) body.transcript = text;
  setStatus("inferring…");
  try {
    const res = await api("/v1/infer", {
      method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body),
    });
    if (isCurrent(id)) showResult(res);
  } catch (e) { if (isCurrent(id)) setStatus(e.message, true); }
}

async function inferAudio(blob, name, id) {
  const form = new FormData();
  form.append("scenario", state.scenario.id);
  form.append("n_actions", String(state.step));
  form.append("audio", blob, name);
  form.append("likelihood", $("acoustic").checked ? "acoustic" : "phonetic");  // the box decides
  setStatus("transcribing and inferring…");
  try {
    const res = await api("/v1/infer", { method: "POST", body: form });
    if (!isCurrent(id)) return;
    if (res.asr) $("instruction").value = res.asr.text;
    showResult(res);
  } catch (e) { if (isCurrent(id)) setStatus(e.message, true); }
}

async function sayAndInfer() {
  const id = newRequest();
  const text = $("instruction").value.trim() || "can you pass me the cereal";
  const noise = $("noise").value;
  const body = { text, snr: Number($("snr").value) };
  if (noise) body.noise = noise;
  setStatus("synthesising…");
  try {
    const wav = await api("/v1/say", {
      method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body),
    });
    if (!isCurrent(id)) return;
    const player = $("player");
    player.src = URL.createObjectURL(wav);
    player.hidden = false;
    player.play().catch(() => {});  // autoplay may be refused; the controls stay
    await inferAudio(wav, "say.wav", id);
  } catch (e) { if (isCurrent(id)) setStatus(e.message, true); }
}

// ----- microphone: MediaRecorder, decoded and re-encoded as 16 kHz WAV in the page ------------
async function toggleRecord() {
  const btn = $("record");
  if (state.recorder) { state.recorder.stop(); return; }
  showAlert("");
  if (!navigator.mediaDevices || !navigator.mediaDevices.getUserMedia || !window.MediaRecorder) {
    showAlert(NO_MICROPHONE_HERE);
    return;
  }
  let stream;
  try {
    stream = await navigator.mediaDevices.getUserMedia({ audio: true });
  } catch (e) {
    showAlert(microphoneProblem(e, "Record"));
    setStatus("");
    return;
  }
  try {
    const chunks = [];
    const rec = new MediaRecorder(stream);
    rec.ondataavailable = (e) => chunks.push(e.data);
    rec.onstop = async () => {
      stream.getTracks().forEach((t) => t.stop());
      state.recorder = null;
      btn.classList.remove("recording");
      btn.textContent = "● Record";
      const id = newRequest();
      const wav = await toWav16k(new Blob(chunks, { type: rec.mimeType }));
      $("player").src = URL.createObjectURL(wav);
      $("player").hidden = false;
      await inferAudio(wav, "recording.wav", id);
    };
    rec.start();
    state.recorder = rec;
    btn.classList.add("recording");
    btn.textContent = "■ Stop";
    setStatus("recording… press Stop when done");
    setTimeout(() => { if (state.recorder === rec) rec.stop(); }, 15000);
  } catch (e) { setStatus(`microphone: ${e.message}`, true); }
}

async function toWav16k(blob) {
  const ctx = new AudioContext();
  const decoded = await ctx.decodeAudioData(await blob.arrayBuffer());
  ctx.close();
  const rate = 16000;
  const off = new OfflineAudioContext(1, Math.ceil(decoded.duration * rate), rate);
  const src = off.createBufferSource();
  src.buffer = decoded;
  src.connect(off.destination);
  src.start();
  const pcm = (await off.startRendering()).getChannelData(0);
  const buf = new ArrayBuffer(44 + 2 * pcm.length);
  const v = new DataView(buf);
  const str = (o, s) => { for (let i = 0; i < s.length; i++) v.setUint8(o + i, s.charCodeAt(i)); };
  str(0, "RIFF"); v.setUint32(4, 36 + 2 * pcm.length, true); str(8, "WAVE"); str(12, "fmt ");
  v.setUint32(16, 16, true); v.setUint16(20, 1, true); v.setUint16(22, 1, true); v.setUint32(24, rate, true);
  v.setUint32(28, 2 * rate, true); v.setUint16(32, 2, true); v.setUint16(34, 16, true); str(36, "data");
  v.setUint32(40, 2 * pcm.length, true);
  for (let i = 0; i < pcm.length; i++) v.setInt16(44 + 2 * i, Math.max(-1, Math.min(1, pcm[i])) * 32767, true);
  return new Blob([buf], { type: "audio/wav" });
}

// ----- live microphone: streamed as 16 kHz PCM over WS /v1/sessions/{id}/listen ---------------
// The page opens a session over the scenario's world with the actions seen so far, streams the
// microphone through an AudioWorklet, and shows each decision the server sends when the person
// stops speaking. Press again to stop.
async function toggleStream() {
  if (state.live) { stopStream("stopped"); return; }
  showAlert("");
  if (!navigator.mediaDevices || !navigator.mediaDevices.getUserMedia || !window.AudioWorkletNode) {
    showAlert(NO_MICROPHONE_HERE);
    return;
  }
  const live = { ws: null, ctx: null, media: null, ready: false, pending: [], decided: -1 };
  state.live = live;
  $("stream").classList.add("recording");
  $("stream").textContent = "■ Stop listening";
  try {
    const sess = await api("/v1/sessions/from-scenario", {
      method: "POST", headers: { "Content-Type": "application/json" },
      body: JSON.stringify({ scenario: state.scenario.id, n_actions: state.step }),
    });
    try {
      live.media = await navigator.mediaDevices.getUserMedia({
        audio: { channelCount: 1, echoCancellation: false, noiseSuppression: false, autoGainControl: false },
      });
    } catch (e) {
      showAlert(microphoneProblem(e, "Listen"));
      stopStream("");
      return;
    }
    try {
      live.ctx = new AudioContext({ sampleRate: 16000 });  // the browser resamples the microphone
      live.source = live.ctx.createMediaStreamSource(live.media);
    } catch (e) {  // browsers that cannot: the worklet interpolates from the device rate
      if (live.ctx) live.ctx.close();
      live.ctx = new AudioContext();
      live.source = live.ctx.createMediaStreamSource(live.media);
    }
    await live.ctx.audioWorklet.addModule("/static/pcm-worklet.js");
    const node = new AudioWorkletNode(live.ctx, "pcm16k");
    const proto = location.protocol === "https:" ? "wss:" : "ws:";
    live.ws = new WebSocket(`${proto}//${location.host}/v1/sessions/${encodeURIComponent(sess.id)}/listen?partial=1`);
    live.ws.binaryType = "arraybuffer";
    node.port.onmessage = (e) => {  // until the server is ready, keep the audio (up to 10 s) and send it then
      if (live.ready && live.ws.readyState === WebSocket.OPEN) live.ws.send(e.data);
      else if (live.pending.length < 500) live.pending.push(e.data);
    };
    live.ws.onmessage = (e) => onStreamEvent(JSON.parse(e.data));
    live.ws.onclose = (e) => { if (state.live === live) stopStream(e.code === 1000 ? "stopped" : `stream closed (${e.code}): ${e.reason}`, e.code !== 1000); };
    live.source.connect(node);
    node.connect(live.ctx.destination);  // the worklet writes no output: silence, but it keeps running
  } catch (e) { stopStream(`microphone: ${e.message}`, true); }
}

function onStreamEvent(ev) {
  const live = state.live;
  if (!live) return;
  if (ev.event === "ready") {
    live.ready = true;
    for (const chunk of live.pending) live.ws.send(chunk);
    live.pending = [];
    setStatus("listening… speak, then pause");
  }
  else if (ev.event === "speech_started") setStatus("hearing you…");
  else if (ev.event === "heard" && ev.text && ev.utterance > live.decided) setStatus(`hearing you… “${ev.text}”`);
  else if (ev.event === "speech_ended") setStatus("recognising…");
  else if (ev.event === "no_speech") setStatus("listening… (no words in that)");
  else if (ev.event === "error") setStatus(ev.detail, true);
  else if (ev.event === "decision") {
    newRequest();  // the newest answer: one still on its way from a typed or recorded request is older
    live.decided = ev.utterance;
    $("instruction").value = ev.heard;
    showResult(ev);
    const d = $("stream-decision");
    d.hidden = false;
    const t = ev.timings || {};
    d.textContent = `heard “${ev.heard}” → ${ev.action}` + (t.wait !== undefined ? ` (answered ${(1000 * t.wait).toFixed(0)} ms after the pause was detected)` : "");
    d.dataset.decision = ev.action;
  }
}

function stopStream(message, isError) {
  const live = state.live;
  state.live = null;
  $("stream").classList.remove("recording");
  $("stream").textContent = "🎙 Listen";
  if (live) {
    if (live.ws && live.ws.readyState === WebSocket.OPEN) live.ws.send(JSON.stringify({ type: "end" }));
    if (live.media) live.media.getTracks().forEach((t) => t.stop());
    if (live.ctx) live.ctx.close();
  }
  if (message && !/^inferred/.test($("status").textContent)) setStatus(message, isError);
}

// ----- wiring ----------------------------------------------------------------------------------
window.addEventListener("DOMContentLoaded", () => {
  $("scenario").addEventListener("change", (e) => selectScenario(e.target.value).catch((err) => setStatus(err.message, true)));
  $("step").addEventListener("input", (e) => { stopPlay(); setStep(Number(e.target.value)); });
  $("play").addEventListener("click", togglePlay);
  $("ask-form").addEventListener("submit", inferText);
  $("say").addEventListener("click", sayAndInfer);
  $("record").addEventListener("click", toggleRecord);
  $("stream").addEventListener("click", toggleStream);
  offerAcoustic().then(loadScenarios).then(() => { document.body.dataset.ready = "1"; })
    .catch((e) => setStatus(e.message, true));
});

// the acoustic likelihood (the recording itself scored) is offered, and on, when the server has it
async function offerAcoustic() {
  const health = await api("/healthz");
  const has = (health.likelihoods || []).includes("acoustic");
  $("acoustic-label").hidden = !has;
  $("acoustic").checked = has;
}
