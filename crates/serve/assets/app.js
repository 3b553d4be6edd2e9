// orch serve's page: plain JavaScript, no build step. It uses the server's JSON API (the
// README's "The web page: `orch serve`") and its WebSocket of live state.
"use strict";

const $ = (id) => document.getElementById(id);
const OUTCOMES = ["on_time", "late", "early", "unison", "joined", "dropped", "skipped", "unmatched"];
const DROPS = ["channel", "percussion", "unmapped", "range", "power", "too_fast", "monophonic", "too_soft", "cracked", "cancelled", "stopped"];
const BLACK = new Set([1, 3, 6, 8, 10]);

let song = null;      // the song shown (the API's song object)
let state = null;     // the last state told
let keyboard = null;  // "low-high" the keys were drawn for
// Every key drawn down or up: {note, down, t} (t: ms since the epoch, at the frame that drew
// it), for tests and the latency figure.
window.orchKeyLog = [];
window.orchStates = 0;

function showError(message) {
  const e = $("error");
  e.textContent = message || "";
  e.hidden = !message;
}

async function api(method, path, body, type) {
  const opts = { method, headers: {} };
  if (body !== undefined) {
    opts.headers["Content-Type"] = type || "application/json";
    opts.body = type ? body : JSON.stringify(body);
  }
  const r = await fetch(path, opts);
  let data = null;
  try { data = await r.json(); } catch (_) { data = null; }
  if (!r.ok) {
    const why = (data && data.error) || `${r.status} ${r.statusText}`;
    throw new Error(r.status === 413 ? `The file is too large: ${why}` : why);
  }
  return data;
}

async function command(cmd) {
  try {
    const r = await api("POST", "/api/command", cmd);
    showError("");
    render(r.state);
    return r.state;
  } catch (e) {
    showError(e.message);
    return null;
  }
}

// The song chosen: its analysis, the notes that will go wrong, the roll.
async function showSong(s) {
  song = s;
  $("song-name").textContent = `${s.name}: ${s.bars} bars, ${s.seconds.toFixed(1)} s`;
  $("bar-input").max = s.bars;
  const a = s.analysis;
  const ul = $("outcomes");
  ul.textContent = "";
  const o = a.outcomes;
  // Every reason the report gives, known here or not.
  const dropped = Object.values(o.dropped).reduce((n, k) => n + (k || 0), 0);
  const count = { ...o, dropped, unmatched: a.unmatched };
  const item = (name, label, n) => {
    const li = document.createElement("li");
    const l = document.createElement("span");
    l.textContent = label;
    const c = document.createElement("span");
    c.className = "count";
    c.dataset.testid = `outcome-${name}`;
    c.textContent = String(n);
    li.append(l, c);
    ul.append(li);
  };
  for (const name of OUTCOMES) item(name, name.replace("_", " "), count[name] || 0);
  for (const d of DROPS) {
    if (o.dropped[d]) item(`dropped-${d}`, `  dropped: ${d.replace("_", " ")}`, o.dropped[d]);
  }
  const body = $("went-wrong").tBodies[0];
  body.textContent = "";
  const shown = a.went_wrong.slice(0, 50);
  for (const w of shown) {
    const tr = document.createElement("tr");
    let what = w.outcome;
    if (w.ms !== undefined) what += ` by ${w.ms.toFixed(1)} ms`;
    if (w.sounded_velocity !== undefined) what += ` (velocity ${w.velocity}, sounds ${w.sounded_velocity})`;
    for (const t of [`${w.bar}:${w.beat}`, w.note, w.channel, what]) {
      const td = document.createElement("td");
      td.textContent = String(t);
      tr.append(td);
    }
    body.append(tr);
  }
  $("went-wrong-more").textContent = a.went_wrong.length > shown.length
    ? `… and ${a.went_wrong.length - shown.length} more` : (a.went_wrong.length ? "" : "none");
  $("analysis").textContent = s.text;
  $("analysis-section").hidden = false;
  const roll = $("roll");
  roll.textContent = "";
  try {
    const r = await fetch(s.roll);
    if (r.ok) {
      // The server's own SVG (orch-roll escapes every text in it).
      roll.innerHTML = await r.text();
    }
  } catch (_) { /* the roll is an extra: the rest stands without it */ }
  updateButtons();
}

async function upload(file) {
  showError("");
  if (!file) return;
  try {
    const bytes = await file.arrayBuffer();
    const s = await api("POST", `/api/songs?name=${encodeURIComponent(file.name)}`, bytes, "application/octet-stream");
    await showSong(s);
  } catch (e) {
    showError(e.message);
  }
}

async function openLibrary() {
  const name = $("library").value;
  if (!name) return;
  showError("");
  try {
    await showSong(await api("POST", "/api/library", { name }));
  } catch (e) {
    showError(e.message);
  }
}

async function loadLibrary() {
  try {
    const l = await api("GET", "/api/library");
    const sel = $("library");
    sel.textContent = "";
    for (const f of l.files) {
      const o = document.createElement("option");
      o.value = f;
      o.textContent = f;
      sel.append(o);
    }
    $("library-row").hidden = l.files.length === 0;
  } catch (e) {
    showError(e.message);
  }
}

function drawKeyboard(low, high) {
  // White keys side by side; each black key over the line between two white ones.
  const keys = $("keys");
  keys.textContent = "";
  let whites = 0;
  for (let n = low; n <= high; n++) if (!BLACK.has(n % 12)) whites++;
  const w = 100 / Math.max(whites, 1);
  let white = 0;
  for (let n = low; n <= high; n++) {
    const k = document.createElement("div");
    const black = BLACK.has(n % 12);
    k.className = black ? "key black" : "key";
    k.dataset.testid = `key-${n}`;
    k.dataset.note = String(n);
    k.dataset.down = "false";
    if (black) {
      k.style.left = `${(white * w - w * 0.3).toFixed(3)}%`;
      k.style.width = `${(w * 0.6).toFixed(3)}%`;
    } else {
      k.style.left = `${(white * w).toFixed(3)}%`;
      k.style.width = `${w.toFixed(3)}%`;
      white++;
    }
    keys.append(k);
  }
  keyboard = `${low}-${high}`;
}

let pendingLog = [];
function logAtFrame(entries) {
  if (!entries.length) return;
  pendingLog.push(...entries);
  requestAnimationFrame(() => {
    const t = performance.timeOrigin + performance.now();
    for (const e of pendingLog) window.orchKeyLog.push({ ...e, t });
    pendingLog = [];
  });
}

function updateButtons() {
  const p = state && state.playing;
  $("play").disabled = !song || !!p;
  $("queue-add").disabled = !song;
  $("pause").disabled = !p || !!p.paused;
  $("resume").disabled = !p || !p.paused;
  $("tap").disabled = !p;
  $("jump").disabled = !p && !song;
}

function render(s) {
  if (!s || (state && s.seq < state.seq)) return;
  state = s;
  window.orchStates++;
  const kb = `${s.keyboard.low}-${s.keyboard.high}`;
  if (kb !== keyboard) drawKeyboard(s.keyboard.low, s.keyboard.high);
  const p = s.playing;
  const down = new Set(p && p.down ? p.down : []);
  const changed = [];
  for (const k of $("keys").children) {
    const n = Number(k.dataset.note);
    const d = down.has(n) ? "true" : "false";
    if (k.dataset.down !== d) {
      k.dataset.down = d;
      changed.push({ note: n, down: d === "true" });
    }
  }
  logAtFrame(changed);
  if (p && p.bar !== undefined) {
    $("status").textContent = `${p.paused ? "paused" : "playing"}: ${p.name}`;
    $("bar-beat").textContent = `${p.bar}:${p.beat}`;
    $("bpm").textContent = `${p.bpm.toFixed(0)} ×${p.tempo.toFixed(2)}`;
    $("notes").textContent = `${p.notes_sent} / ${p.notes}`;
    $("progress").firstElementChild.style.width = `${(p.progress * 100).toFixed(1)}%`;
    const g = p.guard;
    $("guard-counters").textContent =
      `cut by hold limit ${g.cut_by_hold_limit}, by duty limit ${g.cut_by_duty_limit}, ` +
      `by watchdog ${g.cut_by_watchdog}; refused by power budget ${g.dropped_power}, ` +
      `too fast ${g.dropped_too_fast}; most keys down ${g.peak_keys_down}`;
  } else if (p) {
    $("status").textContent = `starting: ${p.name}`;
  } else {
    $("status").textContent = s.ended ? `${s.ended.stopped ? "stopped" : "ended"}: ${s.ended.name}` : "ready";
    $("progress").firstElementChild.style.width = "0";
  }
  $("guard").textContent = s.guard === "on" ? "on" : "OFF";
  if (document.activeElement !== $("tempo")) $("tempo").value = String(s.tempo);
  const q = $("queue");
  q.textContent = "";
  $("queue-empty").hidden = s.queue.length > 0;
  s.queue.forEach((e, i) => {
    const li = document.createElement("li");
    li.textContent = e.name;
    const b = document.createElement("button");
    b.type = "button";
    b.textContent = "Remove";
    b.onclick = () => command({ cmd: "unqueue", index: i });
    li.append(b);
    q.append(li);
  });
  if (s.ended) {
    $("report").textContent = s.ended.text;
    $("report-section").hidden = false;
  } else {
    $("report-section").hidden = true;
  }
  if (s.failure) showError(s.failure);
  updateButtons();
}

let backoff = 250;
function connect() {
  const ws = new WebSocket(`ws://${location.host}/api/ws`);
  ws.onmessage = (m) => {
    backoff = 250;
    try { render(JSON.parse(m.data)); } catch (e) { showError(`bad state: ${e.message}`); }
  };
  ws.onclose = () => {
    $("status").textContent = "disconnected: trying again…";
    setTimeout(connect, backoff);
    backoff = Math.min(backoff * 2, 4000);
  };
}

// A shared Link session (orch serve --link): its peers, tempo and start/stop, looked at
// every second; the section stays hidden on a server without one.
function showSession(s) {
  $("session-section").hidden = false;
  const others = s.peers === 1 ? "1 other peer" : `${s.peers} other peers`;
  $("session-line").textContent = `${s.playing ? "Playing" : "Stopped"} at ${s.bpm.toFixed(1)} BPM, ${others}`;
  if (document.activeElement !== $("session-bpm")) $("session-bpm").value = s.bpm.toFixed(1);
}

async function session(body) {
  try {
    const s = body === undefined ? await api("GET", "/api/session") : await api("POST", "/api/session", body);
    showSession(s);
    if (body !== undefined) showError("");
    return true;
  } catch (e) {
    if (body !== undefined) showError(e.message);
    return false;
  }
}

async function watchSession() {
  if (!(await session())) return;
  setInterval(() => session(), 1000);
}

function jumpTo(bar) {
  if (!Number.isInteger(bar) || bar < 1) {
    showError("give a bar number, from 1");
    return;
  }
  if (state && state.playing) command({ cmd: "jump", bar });
  else if (song) command({ cmd: "play", song: song.id, bar });
}

document.addEventListener("DOMContentLoaded", () => {
  $("stop").onclick = () => command({ cmd: "stop" });
  $("upload").onchange = (e) => upload(e.target.files[0]);
  $("open").onclick = openLibrary;
  $("play").onclick = () => song && command({ cmd: "play", song: song.id });
  $("pause").onclick = () => command({ cmd: "pause" });
  $("resume").onclick = () => command({ cmd: "resume" });
  $("queue-add").onclick = () => song && command({ cmd: "queue", song: song.id });
  $("tap").onclick = () => command({ cmd: "tap" });
  $("tempo").onchange = () => command({ cmd: "tempo", factor: Number($("tempo").value) });
  $("jump").onclick = () => jumpTo(Number($("bar-input").value));
  $("bar-input").onkeydown = (e) => { if (e.key === "Enter") jumpTo(Number($("bar-input").value)); };
  $("roll").onclick = (e) => {
    const g = e.target.closest && e.target.closest("g.bar");
    if (g) jumpTo(Number(g.dataset.bar));
  };
  $("session-start").onclick = () => session({ start: true });
  $("session-stop").onclick = () => session({ stop: true });
  $("session-bpm").onchange = () => session({ bpm: Number($("session-bpm").value) });
  loadLibrary();
  watchSession();
  connect();
});
