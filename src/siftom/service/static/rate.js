// The rating page: /rate?session=ID; three 7-point statements about the robot's last trial.
"use strict";

const session = new URLSearchParams(location.search).get("session") || "";
let statements = [];

async function init() {
  if (!/^[A-Za-z0-9_-]{1,64}$/.test(session)) {
    throw new Error("This page needs the session to rate: open /rate?session=ID with the id of the robot's session.");
  }
  const s = await api(`/v1/sessions/${session}`);
  const last = s.last_instruction;
  $("trial").textContent = !last ? `Session ${session}`
    : last.command ? `The robot did: ${last.command}`
    : last.action === "ask" ? `The robot asked: ${last.decision.question}`
    : `The robot did nothing (heard as ${last.top_command}: ${last.decision.reason})`;
  const info = await api("/v1/ratings/statements");
  statements = info.statements;
  const box = $("statements");
  statements.forEach((text, k) => {
    const fs = document.createElement("fieldset");
    const lg = document.createElement("legend");
    lg.textContent = `${k + 1}. ${text}`;
    fs.appendChild(lg);
    const scale = document.createElement("div");
    scale.className = "scale";
    for (let v = info.scale[0]; v <= info.scale[1]; v++) {
      const lab = document.createElement("label");
      const r = document.createElement("input");
      r.type = "radio";
      r.name = `s${k}`;
      r.value = String(v);
      r.id = `s${k}-${v}`;
      lab.htmlFor = r.id;
      lab.appendChild(r);
      lab.appendChild(document.createTextNode(info.labels[String(v)] ? `${v} (${info.labels[String(v)]})` : String(v)));
      scale.appendChild(lab);
    }
    fs.appendChild(scale);
    box.appendChild(fs);
  });
}

async function send(ev) {
  ev.preventDefault();
  showError("");
  const scores = [];
  for (let k = 0; k < statements.length; k++) {
    const r = document.querySelector(`input[name="s${k}"]:checked`);
    if (!r) { showError(`Choose a rating for statement ${k + 1}.`); document.getElementById(`s${k}-1`).focus(); return; }
    scores.push(Number(r.value));
  }
  const body = { scores };
  const rater = $("rater").value.trim();
  if (rater) body.rater = rater;
  try {
    await api(`/v1/sessions/${session}/rating`, {
      method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body),
    });
    $("rate-panel").hidden = true;
    $("done-panel").hidden = false;
    setStatus("ratings saved");
    focusHeading("done-title");
  } catch (e) { showError(`Not saved: ${e.message}`); }
}

window.addEventListener("DOMContentLoaded", () => {
  $("rate-form").addEventListener("submit", send);
  init().then(() => { document.body.dataset.ready = "1"; }).catch((e) => showError(e.message));
});
