// oimi operator console: the thesis's main activity screen (5.1), a live view of the
// arena and the joystick. It keeps no state of its own: everything it shows comes from
// the server (the same command layer as the TCP App Interface), over one WebSocket.
"use strict";

const $ = (id) => document.getElementById(id);
const LABELS = { get_ready: "Get Ready", loading: "Loading…", start: "Start", stop: "Stop" };
const STATE_LABELS = { current: "current", completed: "completed", not_yet_completed: "not yet completed" };
const HEARTBEAT_MS = 200;
const KEEPALIVE_MS = 30000; // the server closes a connection silent for 300 s

let ws = null;
let nextId = 1;
const pending = new Map(); // request id -> callback(reply)
let state = null; // the last SessionState
let scene = null; // the arena (hello)
let frame = null; // the last WorldMessage
let catalogue = [];
let busy = 0; // operator commands sent and not yet answered

// ------------------------------------------------------------------ connection

function connect() {
  const token = new URLSearchParams(location.search).get("token");
  ws = new WebSocket(`ws://${location.host}/ws`);
  ws.onopen = () => {
    setLink(true);
    if (token) request({ cmd: "auth", token });
    request({ cmd: "subscribe", world: true });
    request({ cmd: "list" }, (reply) => {
      if (reply.ok) catalogue = reply.catalogue || [];
      listKey = "";
      render();
    });
  };
  ws.onmessage = (event) => receive(JSON.parse(event.data));
  ws.onclose = () => {
    setLink(false);
    pending.clear();
    busy = 0;
    setTimeout(connect, 1000);
  };
}

function setLink(up) {
  $("link").textContent = up ? "connected" : "disconnected";
  $("link").className = up ? "up" : "down";
  document.body.dataset.link = up ? "up" : "down";
}

function request(body, callback) {
  if (!ws || ws.readyState !== WebSocket.OPEN) return false;
  const id = nextId++;
  if (callback) pending.set(id, callback);
  ws.send(JSON.stringify({ id, ...body }));
  return true;
}

// An operator command: the command button shows "Loading…" until the reply.
function command(body) {
  const sent = request(body, (reply) => {
    busy = Math.max(0, busy - 1);
    say(reply.ok ? reply.reason : `Refused: ${reply.reason}`, !reply.ok);
    render();
  });
  if (sent) { busy += 1; render(); }
}

function say(text, refused) {
  $("message").textContent = text || "";
  $("message").className = refused ? "refused" : "";
}

function receive(msg) {
  switch (msg.type) {
    case "hello": // on a guarded port the first hello is bare; the full one follows auth
      if (msg.scene) scene = msg.scene;
      if (msg.scenario) $("scenario").textContent = msg.scenario;
      if (msg.session) showFields(msg.session);
      break;
    case "reply": {
      const callback = pending.get(msg.id);
      pending.delete(msg.id);
      if (callback) callback(msg);
      else if (!msg.ok) say(`Refused: ${msg.reason}`, true);
      break;
    }
    case "state":
      state = msg.state;
      render();
      break;
    case "world":
      frame = msg;
      showClock();
      drawWorld();
      break;
  }
}

// ------------------------------------------------------------ activity screen

function buttonFace() {
  if (!state) return "get_ready";
  return busy > 0 ? "loading" : state.button;
}

function render() {
  if (!state) return;
  const face = buttonFace();
  const button = $("command");
  button.textContent = LABELS[face];
  button.className = `command ${face}`;
  button.dataset.button = face;
  button.disabled = face === "loading";
  const still = face === "loading" || face === "stop";
  $("restart").disabled = still;
  $("clear").disabled = still;
  $("plus").disabled = still;
  showClock();

  // Rebuild the list only when it changed (a drag in progress survives other updates).
  const key = JSON.stringify([state.activities, still, state.paused_by]);
  if (key === listKey) return;
  listKey = key;
  const list = $("selected");
  list.replaceChildren();
  state.activities.forEach((activity, index) => list.append(activityItem(activity, index, still)));
  $("empty").hidden = state.activities.length > 0;
}
let listKey = "";

/** The session's time: the latest the server sent, in the operator's state (sent when
 * it changes) or a frame of the room (ten a second). */
function showClock() {
  const ms = Math.max(state ? state.time_ms : 0, frame ? frame.time_ms : 0);
  $("clock").textContent = `t = ${(ms / 1000).toFixed(1)} s`;
}

function activityItem(activity, index, still) {
  // The current activity waits while a rule's switch runs another script (paused_by).
  const paused = activity.state === "current" && Boolean(state.paused_by);
  const li = document.createElement("li");
  li.className = paused ? "current paused" : activity.state;
  li.dataset.name = activity.name;
  li.dataset.state = activity.state;
  li.dataset.index = index;
  const handle = document.createElement("span");
  handle.className = "handle";
  handle.textContent = "≡";
  handle.title = "Drag to reorder";
  li.draggable = !still;
  const name = document.createElement("span");
  name.className = "name";
  name.textContent = titleOf(activity.name);
  const options = document.createElement("span");
  options.className = "options";
  options.textContent = Object.entries(activity.options).map(([k, v]) => `${k} ${v}`).join(" · ");
  name.append(options);
  const badge = document.createElement("span");
  badge.className = paused ? "state paused" : `state ${activity.state}`;
  badge.textContent = paused
    ? `paused: ${titleOf(state.paused_by)} runs`
    : STATE_LABELS[activity.state] || activity.state;
  if (paused) badge.title = "A rule switched to another script; this activity resumes after it";
  name.append(badge);
  // Reordering by buttons too: a tablet's browser may not drag list items.
  const up = moveButton("▲", `Move ${activity.name} up`, index - 1, activity.name);
  up.className = "up";
  up.disabled = still || index === 0;
  const down = moveButton("▼", `Move ${activity.name} down`, index + 1, activity.name);
  down.className = "down";
  down.disabled = still || index === state.activities.length - 1;
  const trash = document.createElement("button");
  trash.className = "trash";
  trash.textContent = "✕";
  trash.title = `Remove ${activity.name}`;
  trash.setAttribute("aria-label", `Remove ${activity.name}`);
  trash.disabled = still;
  trash.onclick = () => command({ cmd: "remove", activity: activity.name });
  li.append(handle, name, up, down, trash);

  li.addEventListener("dragstart", (e) => {
    e.dataTransfer.setData("text/plain", activity.name);
    e.dataTransfer.effectAllowed = "move";
  });
  li.addEventListener("dragover", (e) => { e.preventDefault(); li.classList.add("drop-target"); });
  li.addEventListener("dragleave", () => li.classList.remove("drop-target"));
  li.addEventListener("drop", (e) => {
    e.preventDefault();
    li.classList.remove("drop-target");
    const moved = e.dataTransfer.getData("text/plain");
    if (moved && moved !== activity.name) {
      command({ cmd: "reorder", activity: moved, position: index });
    }
  });
  return li;
}

function moveButton(text, label, position, activity) {
  const button = document.createElement("button");
  button.textContent = text;
  button.title = label;
  button.setAttribute("aria-label", label);
  button.onclick = () => command({ cmd: "reorder", activity, position });
  return button;
}

function titleOf(name) {
  const info = catalogue.find((c) => c.name === name);
  return info ? info.title : name;
}

$("command").onclick = () => {
  const face = buttonFace();
  if (face !== "loading") command({ cmd: face });
};
$("restart").onclick = () => command({ cmd: "restart" });
$("clear").onclick = () => command({ cmd: "clear" });

// ------------------------------------------------------- selection and options

$("plus").onclick = () => {
  request({ cmd: "list" }, (reply) => {
    if (reply.ok) catalogue = reply.catalogue || [];
    // Only while the list is still shown: an activity chosen meanwhile keeps its options.
    if (!$("catalogue").hidden) showCatalogue();
  });
  $("picker").showModal();
  showCatalogue();
};

function showCatalogue() {
  $("picker-title").textContent = "Add an activity";
  $("picker-message").textContent = "";
  $("options").hidden = true;
  $("picker-add").hidden = true;
  $("picker-back").hidden = true;
  const list = $("catalogue");
  list.hidden = false;
  list.replaceChildren();
  for (const info of catalogue) {
    const li = document.createElement("li");
    const button = document.createElement("button");
    button.type = "button";
    button.dataset.activity = info.name;
    button.textContent = info.title;
    const small = document.createElement("small");
    small.textContent = info.description;
    button.append(small);
    button.onclick = () => showOptions(info);
    li.append(button);
    list.append(li);
  }
}

function showOptions(info) {
  $("picker-title").textContent = info.title;
  $("catalogue").hidden = true;
  $("picker-back").hidden = false;
  $("picker-add").hidden = false;
  const form = $("options");
  form.hidden = false;
  form.replaceChildren();
  for (const spec of info.options) form.append(optionField(spec));
  if (!info.options.length) {
    const p = document.createElement("p");
    p.className = "hint";
    p.textContent = "No options.";
    form.append(p);
  }
  $("picker-add").onclick = () => {
    const options = {};
    for (const input of form.querySelectorAll("[data-option]")) {
      options[input.dataset.option] = input.value.trim();
    }
    const shown = form.firstChild; // this activity's options (a later choice replaces them)
    request({ cmd: "add", activity: info.name, options }, (reply) => {
      const still = $("picker").open && form.firstChild === shown && !form.hidden;
      if (reply.ok) {
        if (still) $("picker").close(); // not a picker reopened for another choice meanwhile
        say(reply.reason, false);
      } else if (still) {
        $("picker-message").textContent = reply.reason;
      } else {
        say(`Refused: ${reply.reason}`, true);
      }
    });
  };
}

function optionField(spec) {
  const label = document.createElement("label");
  label.textContent = spec.name.replaceAll("_", " ");
  let input;
  if (spec.kind === "choice" && spec.min == null && !spec.multiple) {
    input = document.createElement("select");
    for (const choice of spec.choices) input.append(new Option(choice, choice));
  } else {
    input = document.createElement("input");
    if (spec.kind === "number" && !spec.multiple) {
      input.type = "number";
      if (spec.min != null) input.min = spec.min;
      if (spec.max != null) input.max = spec.max;
      input.step = spec.integer ? "1" : "any";
    } else {
      input.type = "text";
    }
    const hints = spec.kind === "colour"
      ? ["red", "green", "blue", "yellow", "cyan", "magenta", "white", "orange", "purple", "pink"]
      : spec.choices;
    if (hints.length) {
      const list = document.createElement("datalist");
      list.id = `choices-${spec.name}`;
      for (const h of hints) list.append(new Option(h, h));
      label.append(list);
      input.setAttribute("list", list.id);
    }
  }
  input.value = spec.default;
  input.dataset.option = spec.name;
  input.name = spec.name;
  label.append(input);
  if (spec.kind === "colour") {
    const swatches = document.createElement("span");
    swatches.className = "colours";
    const paint = () => {
      swatches.replaceChildren();
      for (const c of input.value.split(",")) {
        const s = document.createElement("span");
        s.className = "swatch";
        s.style.background = c.trim();
        swatches.append(s);
      }
    };
    input.addEventListener("input", paint);
    paint();
    label.append(swatches);
  }
  const range = spec.min != null ? ` (${spec.min}–${spec.max})` : "";
  const help = document.createElement("small");
  help.textContent = `${spec.help}${range}`;
  label.append(help);
  return label;
}

$("picker-back").onclick = showCatalogue;
$("picker-cancel").onclick = () => $("picker").close();

// ------------------------------------------------------------- session record

const FIELDS = ["child", "therapist", "notes"];

function showFields(fields) {
  for (const name of FIELDS) $(`field-${name}`).value = fields[name] || "";
  showSummary(fields);
}

function showSummary(fields) {
  $("session-summary").textContent = [fields.child, fields.therapist].filter(Boolean).join(" · ");
}

let recordOpened = 0; // times the record was opened: a reply knows if it is still the same

$("session").onclick = () => {
  recordOpened += 1;
  $("record-message").textContent = "";
  $("record").showModal();
};
$("record-cancel").onclick = () => $("record").close();
$("record-save").onclick = () => {
  const body = { cmd: "session" };
  for (const name of FIELDS) body[name] = $(`field-${name}`).value.trim();
  const opened = recordOpened;
  const sent = request(body, (reply) => {
    // Not the record reopened meanwhile: what is being typed there stays, open.
    const still = $("record").open && opened === recordOpened;
    if (reply.ok) {
      if (still) {
        showFields(reply.session || body);
        $("record").close();
      } else {
        showSummary(reply.session || body);
      }
      say(reply.reason, false);
    } else if (still) {
      $("record-message").textContent = reply.reason;
    } else {
      say(`Refused: ${reply.reason}`, true);
    }
  });
  if (!sent) $("record-message").textContent = "not connected";
};

// ----------------------------------------------------------------- live view

function drawWorld() {
  const canvas = $("arena");
  const g = canvas.getContext("2d");
  g.clearRect(0, 0, canvas.width, canvas.height);
  if (!scene || !frame) return;
  const margin = 16;
  // Text and lines keep their size on screen however far the drawing is scaled down.
  const k = canvas.width / (canvas.getBoundingClientRect().width || canvas.width);
  const scale = Math.min(
    (canvas.width - 2 * margin) / scene.width_m,
    (canvas.height - 2 * margin) / scene.height_m,
  );
  const X = (x) => margin + x * scale;
  const Y = (y) => canvas.height - margin - y * scale;
  g.strokeStyle = "#889";
  g.lineWidth = 2 * k;
  g.strokeRect(X(0), Y(scene.height_m), scene.width_m * scale, scene.height_m * scale);
  if (scene.door) { // the door people leave by: its opening on the wall
    const [[x0, y0], [x1, y1]] = scene.door;
    g.strokeStyle = paint("door");
    g.lineWidth = 6 * k;
    g.beginPath();
    g.moveTo(X(x0), Y(y0));
    g.lineTo(X(x1), Y(y1));
    g.stroke();
    g.fillStyle = "#333";
    g.font = `${Math.round(13 * k)}px system-ui`;
    const width = g.measureText("door").width;
    const labelX = Math.min(Math.max(X((x0 + x1) / 2) + 6 * k, 2), canvas.width - width - 2);
    g.fillText("door", labelX, Math.max(Y((y0 + y1) / 2) - 6 * k, 14 * k));
  }
  g.fillStyle = paint("obstacle");
  for (const o of scene.obstacles || []) {
    if (o.radius_m > 0) {
      disc(g, X(o.x_m), Y(o.y_m), o.radius_m * scale);
    } else {
      g.save();
      g.translate(X(o.x_m), Y(o.y_m));
      g.rotate(-(o.angle_rad || 0));
      g.fillRect((-o.width_m / 2) * scale, (-o.height_m / 2) * scale, o.width_m * scale, o.height_m * scale);
      g.restore();
    }
  }
  for (const o of frame.objects || []) {
    g.fillStyle = paint("object");
    disc(g, X(o.x_m), Y(o.y_m), Math.max(o.radius_m, 0.06) * scale);
  }
  const seen = {};
  for (const h of frame.humans || []) {
    const index = (seen[h.kind] = (seen[h.kind] ?? -1) + 1);
    g.fillStyle = paint(personColour(h.kind, index));
    disc(g, X(h.x_m), Y(h.y_m), Math.max(h.radius_m, 0.15) * scale);
    g.fillStyle = "#333";
    g.font = `${Math.round(13 * k)}px system-ui`;
    const labelX = Math.min(X(h.x_m) + 0.25 * scale, canvas.width - g.measureText(h.id).width - 2);
    g.fillText(h.id, labelX, Y(h.y_m) - 0.2 * scale);
  }
  const r = frame.robot;
  const led = rgb(frame.led);
  const radius = Math.max(r.radius_m, 0.2) * scale;
  g.fillStyle = paint("robot");
  disc(g, X(r.x_m), Y(r.y_m), radius);
  g.fillStyle = led;
  disc(g, X(r.x_m), Y(r.y_m), radius * 0.6);
  g.strokeStyle = paint("robot-ink");
  g.beginPath();
  g.moveTo(X(r.x_m), Y(r.y_m));
  g.lineTo(X(r.x_m) + Math.cos(r.theta_rad) * radius, Y(r.y_m) - Math.sin(r.theta_rad) * radius);
  g.stroke();

  const b = frame.block || {};
  $("block").textContent = b.activity ? `${b.activity} / ${b.goal} / ${b.action} / ${b.block}` : "–";
  $("led").style.background = led;
  $("led-text").textContent = frame.led.map((v) => v.toFixed(2)).join(", ");
  $("audio").textContent = frame.audio || "–";
  $("fired").textContent = (frame.fired || []).join(", ") || "–";
  const engaged = frame.joystick_engaged
    ? "engaged (operator drives)"
    : frame.released ? `released: ${frame.released}` : "released";
  $("engaged").textContent = engaged;
  const safety = $("safety");
  safety.textContent = safetyText(frame.safety);
  safety.className = frame.safety ? `limiting ${frame.safety.zone}` : "";
  const lockState = $("lock-state");
  lockState.textContent = `Lock ${engaged}`;
  lockState.className = frame.joystick_engaged ? "engaged" : frame.released ? "dropped" : "";
  const log = $("log");
  log.replaceChildren();
  for (const entry of frame.log || []) {
    // newest first: the list is a few lines high, and the newest is what the operator needs
    const li = document.createElement("li");
    li.textContent = `${entry.source}: ${entry.message}`;
    log.prepend(li);
  }
}

/** What the safety supervisor is doing, in words ("–": it limits nothing). */
function safetyText(episode) {
  if (!episode) return "–";
  const who = episode.human.startsWith("Obstacle/") ? "someone the sonar hears" : episode.human;
  const by = ` (${episode.source})`;
  switch (episode.zone) {
    case "stop":
      return `protective stop: nothing moves towards ${who}${by}`;
    case "slow":
      return `slowing near ${who}${by}`;
    case "stale":
      return `slow: a person's position is old${by}`;
    default: {
      const still = episode.allowed[0] === 0 && episode.allowed[1] === 0;
      return still ? `only turning: no sensor on${by}` : `slow: a sensor is off${by}`;
    }
  }
}

function disc(g, x, y, radius) {
  g.beginPath();
  g.arc(x, y, radius, 0, 2 * Math.PI);
  g.fill();
}

/** The palette's name for the index-th person of a kind: person-child, person-child-2...,
 * person-other for a kind without its own colours (the rule of recorder/palette.py). */
function personColour(kind, index) {
  if (!paint(`person-${kind}`)) return "person-other";
  const shades = [`person-${kind}`];
  while (paint(`person-${kind}-${shades.length + 1}`)) shades.push(`person-${kind}-${shades.length + 1}`);
  return shades[index % shades.length];
}

/** A colour of the shared palette (recorder/palette.py, generated into console.css). */
function paint(name) {
  return getComputedStyle(document.documentElement).getPropertyValue(`--oimi-${name}`).trim();
}

function rgb(c) {
  const [r, g, b] = (c || [0, 0, 0]).map((v) => Math.round(Math.max(0, Math.min(1, v)) * 255));
  return `rgb(${r}, ${g}, ${b})`;
}

// ------------------------------------------------------------------- joystick

// The pad as the robot reads it; sent on change and, while the lock is held, as a heartbeat.
const pad = { left_x: 0, left_y: 0, right_x: 0, buttons: new Set() };
let lastSent = "";
let lastSentAt = 0;

function sendPad(force) {
  const body = {
    cmd: "joystick",
    left_x: round(pad.left_x),
    left_y: round(pad.left_y),
    right_x: round(pad.right_x),
    buttons: [...pad.buttons].sort(),
  };
  const key = JSON.stringify(body);
  const now = performance.now();
  const heartbeat = pad.buttons.has("LB") && now - lastSentAt >= HEARTBEAT_MS;
  if (key !== lastSent || heartbeat || force) {
    if (request(body)) {
      lastSent = key;
      lastSentAt = now;
    }
  }
  $("lock").classList.toggle("held", pad.buttons.has("LB"));
  $("interrupt").classList.toggle("held", pad.buttons.has("X"));
}

function round(v) { return Math.round(v * 100) / 100; }

// Pressed while any of its own pointers (fingers) holds it: another finger on the
// stick or elsewhere neither presses nor releases it. The keyboard holds it as a
// pointer of its own ("key").
const holders = new Map(); // button name -> the pointer ids holding it

function holdBy(name, pointer, down) {
  const set = holders.get(name) || new Set();
  holders.set(name, set);
  if (down) set.add(pointer); else set.delete(pointer);
  if (set.size) pad.buttons.add(name); else pad.buttons.delete(name);
  sendPad();
}

function hold(id, name) {
  const el = $(id);
  el.addEventListener("pointerdown", (e) => {
    e.preventDefault();
    el.setPointerCapture?.(e.pointerId);
    holdBy(name, e.pointerId, true);
  });
  for (const ev of ["pointerup", "pointercancel", "lostpointercapture"]) {
    el.addEventListener(ev, (e) => holdBy(name, e.pointerId, false));
  }
  el.addEventListener("contextmenu", (e) => e.preventDefault()); // a long press is a hold
}
hold("lock", "LB");
hold("interrupt", "X");
$("blocking").onchange = (e) => {
  if (e.target.checked) pad.buttons.add("RB"); else pad.buttons.delete("RB");
  sendPad();
};
$("turn").addEventListener("input", (e) => { pad.right_x = Number(e.target.value); sendPad(); });
for (const ev of ["pointerup", "change"]) {
  $("turn").addEventListener(ev, (e) => { e.target.value = 0; pad.right_x = 0; sendPad(); });
}

(function stick() {
  const area = $("stick");
  const knob = $("knob");
  let active = null; // the pointer driving it; a second finger is ignored
  const move = (e) => {
    const box = area.getBoundingClientRect();
    let x = ((e.clientX - box.left) / box.width) * 2 - 1;
    let y = -(((e.clientY - box.top) / box.height) * 2 - 1);
    const n = Math.hypot(x, y);
    if (n > 1) { x /= n; y /= n; }
    setStick(x, y);
  };
  const centre = (e) => {
    if (e.pointerId !== active) return;
    active = null;
    setStick(0, 0);
  };
  area.addEventListener("pointerdown", (e) => {
    if (active !== null) return;
    e.preventDefault();
    active = e.pointerId;
    area.setPointerCapture(e.pointerId);
    move(e);
  });
  area.addEventListener("pointermove", (e) => { if (e.pointerId === active) move(e); });
  for (const ev of ["pointerup", "pointercancel", "lostpointercapture"]) area.addEventListener(ev, centre);
  area.addEventListener("contextmenu", (e) => e.preventDefault());
})();

function setStick(x, y) {
  pad.left_x = x;
  pad.left_y = y;
  $("knob").style.left = `${58 + x * 58}px`;
  $("knob").style.top = `${58 - y * 58}px`;
  sendPad();
}

// Driving from the keyboard (a mouse and no gamepad): hold Space for the lock, arrows or
// WASD for the stick, Q/E to turn. Letting Space go releases the lock (the robot stops);
// while it is held the heartbeat goes on as for the on-screen lock.
const KEYS = {
  ArrowUp: ["y", 1], KeyW: ["y", 1], ArrowDown: ["y", -1], KeyS: ["y", -1],
  ArrowLeft: ["x", -1], KeyA: ["x", -1], ArrowRight: ["x", 1], KeyD: ["x", 1],
  KeyQ: ["turn", -1], KeyE: ["turn", 1],
};
const keysDown = new Set();

function typing(e) {
  const t = e.target;
  return t instanceof HTMLTextAreaElement || t instanceof HTMLSelectElement
    || (t instanceof HTMLInputElement && !["checkbox", "range", "button"].includes(t.type))
    || document.querySelector("dialog[open]") !== null;
}

function keyStick() {
  const sum = { x: 0, y: 0, turn: 0 };
  for (const code of keysDown) {
    const [axis, sign] = KEYS[code];
    sum[axis] += sign;
  }
  const n = Math.hypot(sum.x, sum.y);
  setStick(n > 1 ? sum.x / n : sum.x, n > 1 ? sum.y / n : sum.y);
  pad.right_x = Math.max(-1, Math.min(1, sum.turn));
  $("turn").value = pad.right_x;
  sendPad();
}

window.addEventListener("keydown", (e) => {
  if (typing(e) || e.ctrlKey || e.altKey || e.metaKey) return;
  if (e.code === "Space") {
    e.preventDefault(); // not a click on the focused button
    if (!e.repeat) holdBy("LB", "key", true);
  } else if (KEYS[e.code]) {
    e.preventDefault(); // not a scroll
    if (!keysDown.has(e.code)) { keysDown.add(e.code); keyStick(); }
  }
});
window.addEventListener("keyup", (e) => {
  if (e.code === "Space") {
    if (!typing(e)) e.preventDefault();
    holdBy("LB", "key", false);
  } else if (keysDown.delete(e.code)) {
    keyStick();
  }
});

// Leaving the page or the window releases everything: never leave the robot moving.
function releaseAll() {
  holders.clear();
  keysDown.clear();
  pad.buttons.clear();
  pad.right_x = 0;
  $("turn").value = 0;
  $("blocking").checked = false;
  setStick(0, 0);
  sendPad(true);
}
window.addEventListener("blur", releaseAll);
document.addEventListener("visibilitychange", () => { if (document.hidden) releaseAll(); });

// An Xbox 360 pad plugged into the tablet (Gamepad API, standard mapping).
const PAD_BUTTONS = { 0: "A", 1: "B", 2: "X", 3: "Y", 4: "LB", 5: "RB", 8: "BACK", 9: "START" };
let gamepadIndex = null;
window.addEventListener("gamepadconnected", (e) => {
  gamepadIndex = e.gamepad.index;
  $("pad-source").textContent = `gamepad: ${e.gamepad.id}`;
});
window.addEventListener("gamepaddisconnected", (e) => {
  if (e.gamepad.index === gamepadIndex) {
    gamepadIndex = null;
    $("pad-source").textContent = "on-screen";
    releaseAll();
  }
});

function poll() {
  const gp = gamepadIndex == null ? null : navigator.getGamepads()[gamepadIndex];
  if (gp) {
    pad.left_x = gp.axes[0] || 0;
    pad.left_y = -(gp.axes[1] || 0);
    pad.right_x = gp.axes[2] || 0;
    pad.buttons = new Set(
      Object.entries(PAD_BUTTONS).filter(([i]) => gp.buttons[i]?.pressed).map(([, n]) => n),
    );
  }
  sendPad();
}
setInterval(poll, 50);
setInterval(() => request({ cmd: "state" }), KEEPALIVE_MS);

connect();
