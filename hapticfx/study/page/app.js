// The participant's page: shows what the session says, plays slots, sends answers.
// Nothing here names a stimulus; a draft answer is kept in sessionStorage so a reload keeps it.
"use strict";
const TOKEN = document.querySelector('meta[name="study-token"]').content;
const app = document.getElementById("app");
const statusLine = document.getElementById("status");
let state = null;
let busy = false;

async function call(path, body) {
  const options = body === undefined ? {headers: {"X-Study-Token": TOKEN}} : {
    method: "POST", headers: {"Content-Type": "application/json", "X-Study-Token": TOKEN}, body: JSON.stringify(body)};
  for (let attempt = 0; ; attempt++) {
    let response;
    try {
      response = await fetch(path, options);
    } catch (err) {  // the server is unreachable: keep the answer and try again
      statusLine.textContent = "Connection lost; trying again…";
      await new Promise(r => setTimeout(r, Math.min(5000, 500 * (attempt + 1))));
      continue;
    }
    const data = await response.json();
    statusLine.textContent = response.ok ? "" : data.error;
    if (!response.ok) throw new Error(data.error);
    return data;
  }
}

function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k.startsWith("on")) node.addEventListener(k.slice(2), v);
    else if (v !== false && v !== null && v !== undefined) node.setAttribute(k, v === true ? "" : v);
  }
  for (const c of children) node.append(c);
  return node;
}

function draftKey() { return `draft:${state.participant}:${state.trial.index}`; }
function loadDraft() { return JSON.parse(sessionStorage.getItem(draftKey()) || "{}"); }
function saveDraft(draft) { sessionStorage.setItem(draftKey(), JSON.stringify(draft)); }

function progressBar() {
  const p = state.progress;
  return el("div", {class: "progress", title: `${p.answered} of ${p.total}`},
            el("div", {style: `width:${(100 * p.answered / p.total).toFixed(1)}%`}));
}

async function act(path, body) {
  if (busy) return;
  busy = true;
  render();
  try {
    const data = await call(path, body);
    if (data.screen) state = data;
  } catch (err) { /* shown in the status line */ }
  busy = false;
  render();
}

function renderInstructions() {
  const t = state.trial;
  app.append(el("h1", {}, state.resumed ? "Welcome back" : "Instructions"),
             el("p", {id: "instructions"}, state.instructions),
             el("button", {id: "proceed", disabled: busy, onclick: () => act("/api/proceed", {trial: t.index, screen: "instructions"})},
                state.resumed ? "Continue" : "Start"));
}

function renderBreak() {
  const t = state.trial;
  let left = Math.ceil(state.break_s_left);
  const button = el("button", {id: "proceed", disabled: busy || left > 0,
                               onclick: () => act("/api/proceed", {trial: t.index, screen: "break"})}, "Continue");
  const note = el("p", {class: "muted"}, left > 0 ? `You can continue in ${left} s.` : "Continue when you are ready.");
  app.append(el("h1", {}, "Take a break"), note, button);
  if (left > 0) {
    const timer = setInterval(() => {
      left -= 1;
      note.textContent = left > 0 ? `You can continue in ${left} s.` : "Continue when you are ready.";
      if (left <= 0) { clearInterval(timer); button.disabled = busy; }
    }, 1000);
  }
}

function slotLabel(name) { return name === "target" ? "Target" : name === "stimulus" ? "Impact" : `Impact ${name}`; }

function renderTrial() {
  const t = state.trial;
  const draft = loadDraft();
  const allPlayed = t.slots.every(s => s.plays > 0);
  const nextToPlay = t.slots.find(s => s.plays === 0);
  app.append(el("h1", {}, `Trial ${t.number} of ${t.of} `, t.practice ? el("span", {class: "practice"}, "practice") : ""));
  const slots = el("div", {class: "slots"});
  for (const s of t.slots) {
    const canPlay = !busy && (t.replay ? true : (s.plays === 0 && nextToPlay === s));
    const box = el("div", {class: "slot" + (draft.choice === s.name ? " chosen" : "")},
                   el("div", {}, slotLabel(s.name)),
                   el("button", {id: `play-${s.name}`, class: "play", disabled: !canPlay,
                                 onclick: () => act("/api/play", {trial: t.index, slot: s.name})},
                      s.plays ? (t.replay ? "Play again" : "Played") : "Play"));
    if (t.type === "matching" && s.name !== "target") {
      const chosen = draft.choice === s.name;  // marked by a frame, a check mark and words, not by colour alone
      box.prepend(el("span", {class: "mark", "aria-hidden": "true"}, chosen ? "\u2713 Chosen" : ""));
      box.append(el("br"), el("button", {id: `choose-${s.name}`, class: "choose secondary", "aria-pressed": String(chosen),
                                          disabled: busy || !allPlayed,
                                          onclick: () => { saveDraft({choice: s.name}); render(); }},
                              chosen ? `\u2713 Chosen ${s.name}` : `Choose ${s.name}`));
    } else if (t.type === "matching") {
      box.prepend(el("span", {class: "mark", "aria-hidden": "true"}, ""));
    }
    slots.append(box);
  }
  app.append(slots);
  let complete;
  if (t.type === "matching") {
    app.append(el("p", {}, t.questions[0].text));
    complete = () => !!draft.choice;
  } else {
    const ratings = draft.ratings || {};
    for (const q of t.questions) {
      const input = el("input", {type: "range", id: `rating-${q.id}`, min: q.low, max: q.high, step: "any",
                                  class: q.id in ratings ? "" : "untouched", disabled: busy || !allPlayed,
                                  "aria-label": q.text, "aria-valuetext": q.id in ratings ? null : "no answer yet"});
      input.value = q.id in ratings ? ratings[q.id] : (q.low + q.high) / 2;
      input.addEventListener("input", () => {
        ratings[q.id] = Number(input.value);
        input.classList.remove("untouched");
        input.removeAttribute("aria-valuetext");
        saveDraft({ratings});
        submit.disabled = busy || !complete();
      });
      const anchors = el("div", {class: "anchors"});
      for (const a of q.anchors) {
        const at = 100 * (a.at - q.low) / (q.high - q.low);
        const where = at === 100 ? "right:0" : `left:${at}%`;
        anchors.append(el("span", {class: at === 0 ? "low" : at === 100 ? "high" : "", style: where}, a.label));
      }
      app.append(el("div", {class: "question"}, el("label", {for: `rating-${q.id}`}, q.text), input, anchors));
    }
    complete = () => t.questions.every(q => q.id in ratings);
  }
  const submit = el("button", {id: "submit", disabled: busy || !allPlayed || !complete(), onclick: () => {
    const answer = t.type === "matching" ? {choice: loadDraft().choice} : {ratings: loadDraft().ratings};
    act("/api/answer", {trial: t.index, response: answer}).then(() => sessionStorage.removeItem(`draft:${state.participant}:${t.index}`));
  }}, "Next");
  app.append(submit);
  if (!allPlayed) app.append(el("p", {class: "muted"}, "Play every impact before answering."));
}

function render() {
  app.replaceChildren();
  if (!state) return;
  app.append(progressBar());
  if (state.screen === "done") {
    app.append(el("h1", {id: "done"}, "Thank you!"), el("p", {}, "The study is complete. You can take the helmet off."));
  } else if (state.screen === "instructions") renderInstructions();
  else if (state.screen === "break") renderBreak();
  else renderTrial();
  app.dataset.screen = busy ? "busy" : state.screen;
}

call("/api/state").then(s => { state = s; render(); });
