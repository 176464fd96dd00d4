// gaussvid's viewer (docs/REPORT.md): flies through a 3DGS model along the scene's cameras.
// The page that gaussvid writes (src/report/viewer.c) holds, besides this code bundled with
// three.js and Spark:
//   <script id="gv-path" type="application/json">  the cameras, OpenGL camera-to-world
//   <script id="gv-model" type="application/octet-stream">  the .splat file, base64
// so it opens from file:// with no server and no network.
import * as THREE from "three";
import { SparkRenderer, SplatMesh, SplatFileType } from "@sparkjsdev/spark";

const FRAMES_PER_SECOND = 10; // path speed at 1x: the scene's frames are a video's
const LOOK_RADIANS_PER_PIXEL = 0.004;

function base64Bytes(text) {
  const binary = atob(text.trim());
  const bytes = new Uint8Array(binary.length);
  for (let i = 0; i < binary.length; i++) bytes[i] = binary.charCodeAt(i);
  return bytes;
}

// The page's load event waits until the model is on the canvas, so whatever waits for "load"
// (a user's browser, a headless --screenshot, a test) sees the model and not an empty canvas:
// Spark decodes and sorts the Gaussians in a worker, after the page itself has loaded. A
// hidden frame whose document is open delays its parent's load event until it is closed; it
// is closed at the first frame that shows anything, on an error, or after LOAD_WAIT_MS.
const LOAD_WAIT_MS = 60000;
function holdLoadEvent() {
  const frame = document.createElement("iframe");
  frame.hidden = true;
  document.body.appendChild(frame);
  frame.contentDocument.open();
  let held = true;
  const release = () => {
    if (!held) return;
    held = false;
    frame.contentDocument.close();
    frame.remove();
  };
  setTimeout(release, LOAD_WAIT_MS);
  return { release, held: () => held };
}
const loadHold = holdLoadEvent();

const statusLine = document.getElementById("status");
function say(text) {
  statusLine.textContent = text;
}
window.addEventListener("error", (e) => {
  say(`error: ${e.message}`);
  loadHold.release();
});

const path = JSON.parse(document.getElementById("gv-path").textContent);
const cameras = path.cameras.map((c) => {
  const m = c.rotation; // row-major 3x3, columns are the camera's x, y, z axes in the world
  const basis = new THREE.Matrix4().set(m[0], m[1], m[2], 0, m[3], m[4], m[5], 0, m[6], m[7], m[8], 0, 0, 0, 0, 1);
  return {
    frame: c.frame,
    train: c.train,
    fovY: c.fov_y,
    position: new THREE.Vector3(...c.position),
    quaternion: new THREE.Quaternion().setFromRotationMatrix(basis),
  };
});

const canvas = document.getElementById("view");
const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, preserveDrawingBuffer: true });
renderer.setClearColor(path.background === "white" ? 0xffffff : 0x000000);
const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(cameras[0].fovY, path.width / path.height, path.near, path.far);
// Frames are drawn only when something changed (playing, a drag, the slider, a resize, or
// Spark finishing a sort), so a paused viewer leaves the processor idle.
let dirty = true;
const redraw = () => (dirty = true);
const spark = new SparkRenderer({ renderer, onDirty: redraw });
scene.add(spark);

// The canvas keeps the scene's aspect ratio, as large as the window allows.
function fit() {
  const bar = document.getElementById("controls").offsetHeight;
  const w = window.innerWidth, h = Math.max(1, window.innerHeight - bar);
  const scale = Math.min(w / path.width, h / path.height);
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setSize(Math.floor(path.width * scale), Math.floor(path.height * scale));
  redraw();
}
window.addEventListener("resize", fit);
fit();

// Where we are: a position along the path in cameras (0 .. n-1), playing or not, and a look
// offset (yaw, pitch) that dragging adds to the path's own direction.
const slider = document.getElementById("position");
slider.max = String(cameras.length - 1);
const playButton = document.getElementById("play");
const speed = document.getElementById("speed");
const state = { s: 0, playing: true, yaw: 0, pitch: 0 };
const hash = new URLSearchParams(location.hash.slice(1)); // #t=0.5&paused: a moment to open at
if (hash.has("t")) state.s = Math.min(1, Math.max(0, Number(hash.get("t")) || 0)) * (cameras.length - 1);
if (hash.has("paused")) state.playing = false;
slider.value = String(state.s);

function setPlaying(playing) {
  state.playing = playing;
  redraw();
  playButton.textContent = playing ? "Pause" : "Play";
}
setPlaying(state.playing);
playButton.addEventListener("click", () => setPlaying(!state.playing));
window.addEventListener("keydown", (e) => {
  if (e.code === "Space") {
    setPlaying(!state.playing);
    e.preventDefault();
  }
});
slider.addEventListener("input", () => {
  setPlaying(false);
  state.s = Number(slider.value);
  redraw();
});
speed.addEventListener("change", redraw);

// A drag starts on the canvas and is followed on the window, so it goes on outside the canvas.
let drag = null;
canvas.addEventListener("pointerdown", (e) => {
  drag = { x: e.clientX, y: e.clientY, yaw: state.yaw, pitch: state.pitch };
  e.preventDefault();
});
window.addEventListener("pointermove", (e) => {
  if (!drag) return;
  state.yaw = drag.yaw - (e.clientX - drag.x) * LOOK_RADIANS_PER_PIXEL;
  state.pitch = Math.max(-1.4, Math.min(1.4, drag.pitch - (e.clientY - drag.y) * LOOK_RADIANS_PER_PIXEL));
  redraw();
});
window.addEventListener("pointerup", () => (drag = null));
canvas.addEventListener("dblclick", () => {
  state.yaw = 0;
  state.pitch = 0;
  redraw();
});

// The camera at path position s: centres linearly, rotations by slerp, then the look offset.
const yawQ = new THREE.Quaternion(), pitchQ = new THREE.Quaternion();
const X = new THREE.Vector3(1, 0, 0), Y = new THREE.Vector3(0, 1, 0);
function place(s) {
  s = Number.isFinite(s) ? Math.min(Math.max(s, 0), cameras.length - 1) : 0;
  const i = Math.min(Math.floor(s), cameras.length - 1);
  const j = Math.min(i + 1, cameras.length - 1);
  const f = s - i;
  const a = cameras[i], b = cameras[j];
  camera.position.lerpVectors(a.position, b.position, f);
  camera.quaternion.slerpQuaternions(a.quaternion, b.quaternion, f);
  camera.quaternion.multiply(yawQ.setFromAxisAngle(Y, state.yaw)).multiply(pitchQ.setFromAxisAngle(X, state.pitch));
  camera.fov = a.fovY + (b.fovY - a.fovY) * f;
  camera.updateProjectionMatrix();
  const nearest = f < 0.5 ? a : b;
  say(`frame ${nearest.frame} of ${cameras[cameras.length - 1].frame}` +
      (nearest.train ? " (training view)" : "") + ` \u00b7 ${path.gaussians} Gaussians \u00b7 ${path.title}`);
}

// One animation frame. The clock starts at the first frame: a frame's timestamp can be
// earlier than anything read while the page loaded, and a negative step would move the path
// position below its first camera.
let last = null;
function drawFrame(now) {
  const dt = last === null ? 0 : Math.min(0.1, Math.max(0, (now - last) / 1000));
  last = now;
  if (state.playing && cameras.length > 1) {
    state.s += dt * FRAMES_PER_SECOND * Number(speed.value);
    if (state.s > cameras.length - 1) state.s = 0;
    slider.value = String(state.s);
    dirty = true;
  }
  if (!dirty) return;
  dirty = false;
  place(state.s);
  renderer.render(scene, camera);
  if (loadHold.held() && canvasShowsSomething()) loadHold.release();
}

// Whether any pixel of the canvas differs from the background (read back only while the load
// event is held).
function canvasShowsSomething() {
  const gl = renderer.getContext();
  const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
  const pixels = new Uint8Array(w * h * 4);
  // Spark may leave a pixel-pack buffer bound (its own read-backs), which readPixels into an
  // array refuses: unbind it around the read.
  const packBuffer = gl.getParameter(gl.PIXEL_PACK_BUFFER_BINDING);
  gl.bindBuffer(gl.PIXEL_PACK_BUFFER, null);
  gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, pixels);
  gl.bindBuffer(gl.PIXEL_PACK_BUFFER, packBuffer);
  const bg = path.background === "white" ? 255 : 0;
  for (let i = 0; i < pixels.length; i += 4)
    if (pixels[i] !== bg || pixels[i + 1] !== bg || pixels[i + 2] !== bg) return true;
  return false;
}

// The model comes last, when the path, the scene, the camera and the controls all exist, and
// the animation loop starts only when the model has loaded: nothing depends on how fast the
// page or the model loads.
const modelElement = document.getElementById("gv-model");
const model = new SplatMesh({
  fileBytes: base64Bytes(modelElement.textContent),
  fileType: SplatFileType.SPLAT,
  onLoad: () => {
    document.body.dataset.state = "loaded";
    redraw();
    renderer.setAnimationLoop(drawFrame);
  },
});
scene.add(model);
