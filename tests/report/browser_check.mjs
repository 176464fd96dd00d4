// Opens a page of `gaussvid report` in headless Chromium through the DevTools protocol and
// checks what a user would see (docs/REPORT.md, tests/cli/report_browser.sh):
//   report: no console error, no failed request; the table and the PSNR plot are on screen;
//           every image is a data: URI; writes a screenshot.
//   viewer: no console error; the model loads; the canvas is not blank (luminance variance
//           above a threshold) and changes when the path position moves and when the view is
//           dragged; writes a screenshot.
// Prints one JSON line with the measurements; exits 1 on a failed check, 77 when it cannot
// run (no WebSocket in this Node).
// Usage: node --experimental-websocket browser_check.mjs CHROMIUM report|viewer FILE OUT.png [W,H]
// (W,H: the window, 1280,900 for the report and 480,400 for the viewer by default)
import { spawn } from "node:child_process";
import { mkdtempSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join, resolve } from "node:path";

const [chromium, mode, file, screenshot, size] = process.argv.slice(2);
if (!chromium || !["report", "viewer"].includes(mode) || !file || !screenshot) {
  console.error("usage: node --experimental-websocket browser_check.mjs CHROMIUM report|viewer FILE OUT.png");
  process.exit(2);
}
if (typeof WebSocket === "undefined") {
  console.error("browser_check: this Node has no WebSocket (Node >= 20 with --experimental-websocket)");
  process.exit(77);
}

const profile = mkdtempSync(join(tmpdir(), "gv-chromium-"));
const browser = spawn(chromium, [
  "--headless", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
  "--remote-debugging-port=0", `--user-data-dir=${profile}`, `--window-size=${size ?? (mode === "viewer" ? "480,400" : "1280,900")}`,
  "--no-first-run", "--hide-scrollbars", "about:blank",
], { stdio: ["ignore", "ignore", "pipe"] });
const failures = [];
const result = { mode };
function finish(code) {
  browser.kill("SIGKILL");
  try { rmSync(profile, { recursive: true, force: true }); } catch { /* a profile left in /tmp */ }
  result.failures = failures;
  console.log(JSON.stringify(result));
  process.exit(code);
}
setTimeout(() => { failures.push("timed out after 240 s"); finish(1); }, 240000);

const endpoint = await new Promise((ok, fail) => {
  let text = "";
  browser.stderr.on("data", (chunk) => {
    text += chunk;
    const m = text.match(/DevTools listening on (ws:\/\/\S+)/);
    if (m) ok(m[1]);
  });
  browser.on("exit", (code) => fail(new Error(`chromium exited (${code}): ${text.slice(-400)}`)));
}).catch((e) => { failures.push(e.message); finish(1); });

const socket = new WebSocket(endpoint);
await new Promise((ok) => socket.addEventListener("open", ok));
let nextId = 1;
const pending = new Map();
const listeners = [];
socket.addEventListener("message", (event) => {
  const message = JSON.parse(event.data);
  if (message.id && pending.has(message.id)) {
    const { ok, fail } = pending.get(message.id);
    pending.delete(message.id);
    if (message.error) fail(new Error(message.error.message));
    else ok(message.result);
  } else if (message.method) {
    for (const l of listeners) l(message);
  }
});
let session;
function send(method, params = {}) {
  const id = nextId++;
  socket.send(JSON.stringify({ id, method, params, ...(session ? { sessionId: session } : {}) }));
  return new Promise((ok, fail) => pending.set(id, { ok, fail }));
}
const step = (what) => process.env.GV_BROWSER_DEBUG && console.error(`browser_check: ${what}`);
const sleep = (ms) => new Promise((ok) => setTimeout(ok, ms));
async function evaluate(expression) {
  const r = await send("Runtime.evaluate", { expression, returnByValue: true, awaitPromise: true });
  if (r.exceptionDetails) throw new Error(`${expression.slice(0, 60)}: ${r.exceptionDetails.text}`);
  return r.result.value;
}

// Console errors, uncaught exceptions and failed requests are failures. Chromium's own
// performance notes about reading pixels back (which these checks do) are not.
listeners.push((m) => {
  if (m.method === "Runtime.exceptionThrown")
    failures.push(`exception: ${m.params.exceptionDetails.exception?.description ?? m.params.exceptionDetails.text}`);
  if (m.method === "Runtime.consoleAPICalled" && m.params.type === "error")
    failures.push(`console.error: ${m.params.args.map((a) => a.value ?? a.description).join(" ")}`);
  if (m.method === "Log.entryAdded" && m.params.entry.level === "error")
    failures.push(`log: ${m.params.entry.text}`);
  if (m.method === "Network.loadingFailed") failures.push(`request failed: ${m.params.errorText}`);
  if (m.method === "Network.requestWillBeSent" && !/^(file|data|blob):/.test(m.params.request.url))
    failures.push(`network request: ${m.params.request.url.slice(0, 100)}`);
});

const { targetId } = await send("Target.createTarget", { url: "about:blank" });
session = (await send("Target.attachToTarget", { targetId, flatten: true })).sessionId;
await send("Runtime.enable");
await send("Log.enable");
await send("Page.enable");
await send("Network.enable");
const url = "file://" + resolve(file) + (mode === "viewer" ? "#t=0.25&paused" : "");
const loaded = new Promise((ok) => listeners.push((m) => m.method === "Page.loadEventFired" && ok()));
await send("Page.navigate", { url });
await loaded;

async function saveScreenshot() {
  const shot = await send("Page.captureScreenshot", { format: "png", captureBeyondViewport: mode === "report" });
  writeFileSync(screenshot, Buffer.from(shot.data, "base64"));
}

if (mode === "report") {
  const seen = await evaluate(`(() => {
    const visible = (e) => !!e && e.getBoundingClientRect().width > 0 && e.getBoundingClientRect().height > 0;
    const imgs = [...document.images];
    return {
      table_rows: document.querySelectorAll("table.metrics tbody tr").length,
      table_visible: visible(document.querySelector("table.metrics")),
      plots: document.querySelectorAll("svg.psnr-plot").length,
      plot_visible: visible(document.querySelector("svg.psnr-plot")),
      plot_lines: document.querySelectorAll("svg.psnr-plot polyline").length,
      images: imgs.length,
      images_decoded: imgs.filter((i) => i.complete && i.naturalWidth > 0).length,
      images_not_data: imgs.filter((i) => !i.src.startsWith("data:")).length,
      scripts: document.scripts.length,
    };
  })()`);
  Object.assign(result, seen);
  if (!seen.table_visible || seen.table_rows < 1) failures.push("the metrics table is not on screen");
  if (seen.plots > 0 && !seen.plot_visible) failures.push("the PSNR plot is not on screen");
  if (seen.images_decoded !== seen.images) failures.push(`${seen.images - seen.images_decoded} images do not decode`);
  if (seen.images_not_data) failures.push(`${seen.images_not_data} images are not embedded`);
  await saveScreenshot();
  finish(failures.length ? 1 : 0);
}

// The viewer: luminance statistics of the canvas and a 32x32 thumbnail to compare views.
const sample = `(() => {
  const c = document.getElementById("view");
  const t = document.createElement("canvas");
  t.width = 32; t.height = 32;
  const g = t.getContext("2d");
  g.drawImage(c, 0, 0, 32, 32);
  const d = g.getImageData(0, 0, 32, 32).data;
  const lum = [];
  for (let i = 0; i < d.length; i += 4) lum.push(0.299 * d[i] + 0.587 * d[i + 1] + 0.114 * d[i + 2]);
  const mean = lum.reduce((a, b) => a + b, 0) / lum.length;
  const variance = lum.reduce((a, b) => a + (b - mean) * (b - mean), 0) / lum.length;
  return { mean, variance, lum, state: document.body.dataset.state, status: document.getElementById("status").textContent };
})()`;
const difference = (a, b) => a.lum.reduce((s, v, i) => s + Math.abs(v - b.lum[i]), 0) / a.lum.length;
const VARIANCE_MIN = 20; // a blank or uniform canvas has ~0; a room has hundreds
const CHANGE_MIN = 2; // mean |difference| in luminance levels over the 32x32 thumbnail

let first;
for (let waited = 0; waited < 60000; waited += 500) {
  first = await evaluate(sample);
  if (first.state === "loaded" && first.variance > VARIANCE_MIN) break;
  await sleep(500);
}
result.state = first.state;
result.status = first.status;
result.variance = first.variance;
if (first.state !== "loaded") failures.push("the model did not load");
if (!(first.variance > VARIANCE_MIN)) failures.push(`the canvas is blank (luminance variance ${first.variance.toFixed(2)})`);
step("first view sampled");
await saveScreenshot();
step("screenshot written");

// Along the path: move the position slider as a user would.
await evaluate(`(() => { const s = document.getElementById("position");
  s.value = String(Number(s.max) * 0.75); s.dispatchEvent(new Event("input")); })()`);
await sleep(1500);
const moved = await evaluate(sample);
step("moved along the path");
result.change_along_path = difference(first, moved);
if (!(result.change_along_path > CHANGE_MIN)) failures.push(`moving along the path does not change the view (${result.change_along_path.toFixed(2)})`);

// Drag to look: a mouse drag across the canvas.
const box = await evaluate(`(() => { const r = document.getElementById("view").getBoundingClientRect();
  return { x: r.x + r.width / 2, y: r.y + r.height / 2 }; })()`);
// (pointer events dispatched in the page: Input.dispatchMouseEvent waits for a compositor
// frame, which a software-rendered WebGL page under load may not give for minutes)
await evaluate(`(() => {
  const c = document.getElementById("view");
  const at = (type, dx) => new PointerEvent(type, { bubbles: true, clientX: ${box.x} + dx, clientY: ${box.y}, pointerId: 1, buttons: 1 });
  c.dispatchEvent(at("pointerdown", 0));
  for (let k = 1; k <= 10; k++) window.dispatchEvent(at("pointermove", 12 * k));
  window.dispatchEvent(at("pointerup", 120));
})()`);
await sleep(1500);
const looked = await evaluate(sample);
result.change_by_drag = difference(moved, looked);
if (!(result.change_by_drag > CHANGE_MIN)) failures.push(`dragging does not change the view (${result.change_by_drag.toFixed(2)})`);
finish(failures.length ? 1 : 0);
