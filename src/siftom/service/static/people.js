// Shared by the participant pages (collect, annotate, rate): plain JS, no third-party code.
"use strict";

const $ = (id) => document.getElementById(id);

function setStatus(text) {
  $("status").textContent = text || "";
}

// Errors go to a role=alert region so that screen readers announce them at once.
function showError(text) {
  const a = $("alert");
  a.textContent = text || "";
  a.hidden = !text;
}

async function api(path, options) {
  const resp = await fetch(path, options);
  const type = resp.headers.get("content-type") || "";
  if (!resp.ok) {
    let detail = resp.statusText;
    if (type.includes("json")) detail = (await resp.json()).detail || detail;
    throw new Error(detail);
  }
  return type.includes("json") ? resp.json() : resp.blob();
}

function fillList(el, items) {
  el.replaceChildren();
  for (const text of items) {
    const li = document.createElement("li");
    li.textContent = text;
    el.appendChild(li);
  }
}

// ----- the scene after each action: an image, step buttons and a play button ------------------
class FrameViewer {
  constructor(prefix) {
    this.img = $(`${prefix}-frame`);
    this.range = $(`${prefix}-step`);
    this.out = $(`${prefix}-step-out`);
    this.list = $(`${prefix}-actions`);
    this.playBtn = $(`${prefix}-play`);
    this.url = null;
    this.steps = 0;
    this.timer = null;
    this.range.addEventListener("input", () => { this.stop(); this.show(Number(this.range.value)); });
    $(`${prefix}-prev`).addEventListener("click", () => { this.stop(); this.show(this.step - 1); });
    $(`${prefix}-next`).addEventListener("click", () => { this.stop(); this.show(this.step + 1); });
    this.playBtn.addEventListener("click", () => (this.timer ? this.stop() : this.play()));
  }

  load(url, actions) {  // url(step) -> the PNG of the scene after `step` actions
    this.stop();
    this.url = url;
    this.steps = actions.length;
    this.range.max = String(this.steps);
    fillList(this.list, actions);
    this.show(this.steps);  // the scene when the person speaks
  }

  show(step) {
    this.step = Math.max(0, Math.min(this.steps, step));
    this.range.value = String(this.step);
    this.out.textContent = `${this.step} of ${this.steps}`;
    this.img.alt = this.step === 0 ? "The scene before the person's first action"
      : `The scene after the person's action ${this.step}: ${this.list.children[this.step - 1].textContent}`;
    this.img.src = this.url(this.step);
    const items = this.list.children;
    for (let i = 0; i < items.length; i++) {
      items[i].classList.toggle("seen", i < this.step);
      items[i].classList.toggle("now", i === this.step - 1);
    }
  }

  play() {
    if (this.step >= this.steps) this.show(0);
    this.playBtn.textContent = "Pause";
    const tick = () => {
      if (this.step >= this.steps) { this.stop(); return; }
      this.show(this.step + 1);
      this.timer = setTimeout(tick, 900);
    };
    this.timer = setTimeout(tick, 900);
  }

  stop() {
    if (this.timer) clearTimeout(this.timer);
    this.timer = null;
    this.playBtn.textContent = "Play";
  }
}

// ----- the microphone: MediaRecorder, re-encoded as 16 kHz mono 16-bit WAV in the page ---------
function microphoneProblem(e) {
  const name = e && e.name;
  if (name === "NotAllowedError" || name === "SecurityError") {
    return "The microphone is blocked for this page, so nothing was recorded. Allow the microphone " +
      "(the camera/microphone icon in the address bar, or the browser's site settings), then press Record again.";
  }
  if (name === "NotFoundError" || name === "OverconstrainedError") {
    return "No microphone was found. Connect one (or choose it in the system's sound settings), then press Record again.";
  }
  if (name === "NotReadableError" || name === "AbortError") {
    return "The microphone could not be started: another program may be using it. Close that program, then press Record again.";
  }
  return `The microphone could not be used (${(e && e.message) || e}). Press Record to try again.`;
}

class Recorder {
  constructor(maxSeconds) { this.maxSeconds = maxSeconds || 30; this.rec = null; }

  get recording() { return this.rec !== null; }

  // Resolves when recording has started; onDone(wavBlob) is called after stop().
  async start(onDone) {
    if (!navigator.mediaDevices || !navigator.mediaDevices.getUserMedia || !window.MediaRecorder) {
      throw new Error("This browser cannot record here. Open the page at http://127.0.0.1 or " +
        "http://localhost (browsers allow the microphone only there or over https), in a current Chrome, Firefox or Safari.");
    }
    let stream;
    try {
      stream = await navigator.mediaDevices.getUserMedia({ audio: true });
    } catch (e) {
      throw new Error(microphoneProblem(e));
    }
    const chunks = [];
    const rec = new MediaRecorder(stream);
    rec.ondataavailable = (e) => chunks.push(e.data);
    rec.onstop = async () => {
      stream.getTracks().forEach((t) => t.stop());
      this.rec = null;
      clearTimeout(this.limit);
      try {
        onDone(await toWav16k(new Blob(chunks, { type: rec.mimeType })), null);
      } catch (e) {
        onDone(null, new Error(`The recording could not be decoded (${e.message}); record again.`));
      }
    };
    rec.start();
    this.rec = rec;
    this.limit = setTimeout(() => this.stop(), this.maxSeconds * 1000);
  }

  stop() { if (this.rec && this.rec.state !== "inactive") this.rec.stop(); }
}

async function toWav16k(blob) {
  const ctx = new AudioContext();
  const decoded = await ctx.decodeAudioData(await blob.arrayBuffer());
  ctx.close();
  const rate = 16000;
  const off = new OfflineAudioContext(1, Math.max(1, Math.ceil(decoded.duration * rate)), rate);
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

// Move keyboard focus to a heading (tabindex=-1) when a new step of the page appears.
function focusHeading(id) {
  const h = $(id);
  if (h) h.focus();
}
