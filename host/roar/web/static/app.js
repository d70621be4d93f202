// roar web: the page. It sends the stick (joystick, keys or gamepad) over the socket every
// DRIVE_PERIOD while it drives and the page is visible; the server turns silence into neutral.
"use strict";

const $ = (id) => document.getElementById(id);
const PLOT_S = 20;          // [s] of history in the plot
const DEADZONE = 0.1;       // of a gamepad's axis
const roar = window.roar = {  // what the page knows; the suite reads it
  hello: null, state: null, role: "viewer", frames: 0, sent: 0, plotted: 0,
  stick: { throttle: 0, steering: 0 }, lostControl: false,
};
let ws = null, drivePeriodMs = 50, history = [], frameUrl = null, lastSend = 0;
const keys = new Set();
const pad = { active: false, throttle: 0, steering: 0 };

function connect() {
  ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws`);
  ws.binaryType = "blob";
  ws.onmessage = (e) => (typeof e.data === "string" ? onMessage(JSON.parse(e.data)) : onFrame(e.data));
  ws.onclose = () => { $("link").textContent = "disconnected"; $("link").className = "badge bad";
                       roar.role = "viewer"; document.body.className = "viewer"; };
}

function onMessage(m) {
  if (m.t === "hello") {
    roar.hello = m;
    drivePeriodMs = m.drive_period_s * 1000;
    $("car").textContent = m.car;
    $("no-camera").hidden = m.camera;
    const select = $("autopilot");
    for (const name of m.autopilots.slice(1)) select.add(new Option(name, name));
    select.disabled = m.autopilots.length < 2;
    $("record").disabled = !m.can_record;
    if (!m.can_record) $("record").title = "recording needs roar-platform[record]";
  } else if (m.t === "state") {
    onState(m);
  }
}

function onState(s) {
  if (roar.role === "driver" && s.role === "viewer") roar.lostControl = true;
  if (s.role === "driver") roar.lostControl = false;
  roar.role = s.role;
  roar.state = s;
  document.body.className = s.role;
  $("role").textContent = s.role === "driver" ? "you drive" : (s.driver ? "watching" : "nobody drives");
  $("role").className = "badge " + (s.role === "driver" ? "good" : "");
  $("take").hidden = s.role === "driver";
  $("banner").hidden = !roar.lostControl;
  $("banner").textContent = "Another page took over: this one only watches. Press Drive to take back.";
  $("armed").textContent = s.latched === null ? "arming: not reported" : (s.latched ? "latched: send neutral" : "armed");
  $("armed").className = "badge " + (s.latched === null ? "" : s.latched ? "warn" : "good");
  const link = s.link;
  $("link").textContent = link.connected ? "link up" : "link down";
  $("link").className = "badge " + (link.connected ? "good" : "bad");
  $("speed").textContent = fmt(s.speed_m_s, 2, " m/s") + (s.setpoint_m_s != null ? ` (holding ${fmt(s.setpoint_m_s, 2, " m/s")})` : "");
  $("sent").textContent = (s.by_speed ? `speed ${fmt(s.throttle * roar.hello.max_speed_m_s, 2, " m/s")}` :
                           `throttle ${fmt(s.throttle, 2)}`) + `, steering ${fmt(s.steering, 2)}` +
                          (s.autopilot !== "none" ? ` (autopilot ${s.autopilot})` : "");
  $("pulses").textContent = `${s.pulses_us[0]} / ${s.pulses_us[1]} us` +
                            (s.throttle_out_us != null ? `, ESC ${Math.round(s.throttle_out_us)} us` : "");
  $("failsafe").textContent = s.failsafe ?? (s.latched ? "latched" : s.latched === false ? "armed" : "-");
  $("mode").textContent = s.mode ?? "-";
  $("battery").textContent = s.battery_v == null ? "-" : fmt(s.battery_v, 2, " V") + (s.battery_low ? " LOW" : "");
  $("range").textContent = s.range_m == null ? "-" : fmt(s.range_m, 2, " m");
  $("link-stats").textContent = `${link.sent} messages sent, ${link.car_errors} refused by the car` +
                                (link.protocol ? `, protocol ${link.protocol}` : "") + (link.error ? `: ${link.error}` : "");
  $("pages").textContent = `${s.pages} (${s.driver ? "one drives" : "nobody drives"})`;
  $("deadman").textContent = `${s.dead_man_trips} trips (neutral after ${roar.hello ? roar.hello.dead_man_s * 1000 : 250} ms of silence)`;
  $("ignored").textContent = `${s.ignored} messages`;
  $("fps").textContent = `${fmt(s.camera_fps, 1)} fps`;
  $("limit-value").textContent = fmt(s.max_throttle, 2);
  if (document.activeElement !== $("limit")) $("limit").value = s.max_throttle;
  if (document.activeElement !== $("autopilot")) $("autopilot").value = s.autopilot;
  $("record").classList.toggle("on", !!s.recording);
  $("record").textContent = s.recording ? "stop recording" : "record";
  $("record-file").textContent = s.recording;
  $("problem").textContent = s.problem;
  const now = performance.now() / 1000;
  history.push([now, s.speed_m_s ?? 0, s.throttle, s.steering]);
  while (history.length && history[0][0] < now - PLOT_S) history.shift();
  drawPlot(now);
}

function onFrame(blob) {
  const url = URL.createObjectURL(blob);
  $("camera").src = url;
  if (frameUrl) URL.revokeObjectURL(frameUrl);
  frameUrl = url;
  roar.frames += 1;
}

function fmt(x, digits, unit = "") {
  return x == null || !isFinite(x) ? "-" : x.toFixed(digits) + unit;
}

function drawPlot(now) {
  const canvas = $("plot"), g = canvas.getContext("2d");
  const w = canvas.width, h = canvas.height;
  g.fillStyle = "#1b1e24"; g.fillRect(0, 0, w, h);
  g.strokeStyle = "#333"; g.beginPath(); g.moveTo(0, h / 2); g.lineTo(w, h / 2); g.stroke();
  const top = Math.max(1, ...history.map((p) => Math.abs(p[1])));
  const series = [[1, "#4fc3f7", top], [2, "#81c784", 1], [3, "#ffb74d", 1]];
  for (const [i, colour, scale] of series) {
    g.strokeStyle = colour; g.lineWidth = 2; g.beginPath();
    history.forEach((p, k) => {
      const x = w - (now - p[0]) / PLOT_S * w, y = h / 2 - p[i] / scale * (h / 2 - 4);
      k ? g.lineTo(x, y) : g.moveTo(x, y);
    });
    g.stroke();
  }
  g.fillStyle = "#999"; g.font = "12px sans-serif";
  g.fillText(`speed scale +-${top.toFixed(1)} m/s`, 6, 14);
  roar.plotted = history.length;
}

// --- input ---------------------------------------------------------------------------------

function gamepadStick() {
  const pads = navigator.getGamepads ? navigator.getGamepads() : [];
  for (const gp of pads) {
    if (!gp) continue;
    const dz = (v) => (Math.abs(v) < DEADZONE ? 0 : v);
    const steering = dz(gp.axes[0] || 0);
    const triggers = gp.buttons.length > 7 ? (gp.buttons[7].value || 0) - (gp.buttons[6].value || 0) : 0;
    const throttle = Math.abs(triggers) > DEADZONE ? triggers : dz(-(gp.axes[1] || 0));
    if (steering || throttle) return { throttle, steering };
  }
  return null;
}

function stick() {
  if (pad.active) return { throttle: pad.throttle, steering: pad.steering };
  const gp = gamepadStick();
  if (gp) return gp;
  const k = (...names) => names.some((n) => keys.has(n));
  return { throttle: (k("ArrowUp", "w") ? 1 : 0) - (k("ArrowDown", "s") ? 1 : 0),
           steering: (k("ArrowRight", "d") ? 1 : 0) - (k("ArrowLeft", "a") ? 1 : 0) };
}

const clamp = (v) => Math.max(-1, Math.min(1, isFinite(v) ? v : 0));

function send(message) {
  if (ws && ws.readyState === WebSocket.OPEN) { ws.send(JSON.stringify(message)); roar.sent += 1; }
}

function sendStick() {
  if (roar.role !== "driver" || document.hidden) return;
  const s = stick();
  roar.stick = { throttle: clamp(s.throttle), steering: clamp(s.steering) };
  send({ t: "drive", throttle: roar.stick.throttle, steering: roar.stick.steering });
  lastSend = performance.now();
}

function neutral() {
  keys.clear(); pad.active = false; pad.throttle = pad.steering = 0; moveKnob(0, 0);
  send({ t: "stop" });
}

const DRIVE_KEYS = new Set(["ArrowUp", "ArrowDown", "ArrowLeft", "ArrowRight", "w", "a", "s", "d"]);
addEventListener("keydown", (e) => {
  const key = e.key.length === 1 ? e.key.toLowerCase() : e.key;
  if (key === " ") { e.preventDefault(); neutral(); return; }
  if (!DRIVE_KEYS.has(key) || e.target.tagName === "SELECT" || e.target.tagName === "INPUT") return;
  e.preventDefault();
  if (!keys.has(key)) { keys.add(key); sendStick(); }
});
addEventListener("keyup", (e) => {
  const key = e.key.length === 1 ? e.key.toLowerCase() : e.key;
  if (keys.delete(key)) sendStick();
});
addEventListener("blur", () => { keys.clear(); sendStick(); });

function moveKnob(x, y) {
  $("knob").style.transform = `translate(${x * 117}%, ${y * 117}%)`;
}

function padMove(e) {
  const r = $("pad").getBoundingClientRect();
  let x = (e.clientX - r.left) / (r.width / 2) - 1, y = (e.clientY - r.top) / (r.height / 2) - 1;
  const n = Math.hypot(x, y);
  if (n > 1) { x /= n; y /= n; }
  pad.steering = x; pad.throttle = -y;
  moveKnob(x, y);
  sendStick();
}
$("pad").addEventListener("pointerdown", (e) => {
  pad.active = true; $("pad").setPointerCapture(e.pointerId); padMove(e);
});
$("pad").addEventListener("pointermove", (e) => { if (pad.active) padMove(e); });
for (const end of ["pointerup", "pointercancel", "lostpointercapture"]) {
  $("pad").addEventListener(end, () => {
    if (!pad.active) return;
    pad.active = false; pad.throttle = pad.steering = 0; moveKnob(0, 0); sendStick();
  });
}

$("stop").addEventListener("click", neutral);
$("take").addEventListener("click", () => send({ t: "take" }));
$("limit").addEventListener("input", (e) => send({ t: "limit", max_throttle: Number(e.target.value) }));
$("autopilot").addEventListener("change", (e) => send({ t: "autopilot", name: e.target.value }));
// once set, the keys drive again (not the slider or the list)
for (const id of ["limit", "autopilot"]) $(id).addEventListener("change", (e) => e.target.blur());
$("record").addEventListener("click", () => send({ t: "record", on: !(roar.state && roar.state.recording) }));

// Hidden: neutral at once (the server hears "release"); closed: the socket closes.
document.addEventListener("visibilitychange", () => { if (document.hidden) send({ t: "release" }); else sendStick(); });
addEventListener("pagehide", () => { if (ws) ws.close(); });

// The dead man: the stick every DRIVE_PERIOD while driving (sooner when it moves).
setInterval(() => { if (performance.now() - lastSend >= drivePeriodMs * 0.9) sendStick(); }, 10);
connect();
