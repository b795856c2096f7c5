// diffreg serve: the editing page. Talks to the JSON API of modules/serve/api.h; draws with
// three.js (Debian's libjs-three, served by the tool as /three/three.module.js).
import * as THREE from '/three/three.module.js';

const $ = (id) => document.getElementById(id);

// ---- API ----------------------------------------------------------------------------------

async function api(method, path, body) {
  const init = { method, headers: {} };
  if (body !== undefined) {
    init.body = typeof body === 'string' ? body : JSON.stringify(body);
    init.headers['Content-Type'] = 'application/json';
  }
  const res = await fetch(path, init);
  if (!res.ok) {
    let message = `HTTP ${res.status}`;
    try { message = (await res.json()).error || message; } catch (e) { /* not JSON */ }
    const error = new Error(message);
    error.status = res.status;
    throw error;
  }
  return res;
}

// Edits go out one at a time; while one is in flight, later edits of the same kind replace
// each other (a drag sends only its latest position), so the server never works on stale ones.
const queue = { busy: false, pending: new Map(), idleWaiters: [] };

function edit(key, method, path, body) {
  if (queue.pending.has(key) && method === 'PATCH' && path === '/api/params') {
    body = Object.assign({}, queue.pending.get(key).body, body);
  }
  queue.pending.delete(key);
  queue.pending.set(key, { method, path, body });
  pump();
}

async function pump() {
  if (queue.busy) return;
  const next = queue.pending.entries().next();
  if (next.done) {
    const waiters = queue.idleWaiters.splice(0);
    waiters.forEach((resolve) => resolve());
    return;
  }
  const [key, request] = next.value;
  queue.pending.delete(key);
  queue.busy = true;
  setStatus('solving\u2026');
  try {
    const res = await api(request.method, request.path, request.body);
    const state = await res.json();
    if (request.onState) request.onState(state);
    await showState(state);
    setStatus('ready');
  } catch (error) {
    toast(error.message);
    setStatus('ready');
    try { await showState(await (await api('GET', '/api/state')).json()); } catch (e) { /* keep */ }
  } finally {
    queue.busy = false;
    pump();
  }
}

function whenIdle() {
  if (!queue.busy && queue.pending.size === 0) return Promise.resolve();
  return new Promise((resolve) => queue.idleWaiters.push(resolve));
}

// ---- Colour maps --------------------------------------------------------------------------

const VIRIDIS = [[68, 1, 84], [72, 40, 120], [62, 73, 137], [49, 104, 142], [38, 130, 142],
  [31, 158, 137], [53, 183, 121], [110, 206, 88], [253, 231, 37]];

function viridis(s) {
  s = Math.min(1, Math.max(0, Number.isFinite(s) ? s : 0)) * (VIRIDIS.length - 1);
  const i = Math.min(VIRIDIS.length - 2, Math.floor(s));
  const f = s - i;
  return VIRIDIS[i].map((c, k) => (c + f * (VIRIDIS[i + 1][k] - c)) / 255);
}

function turbo(s) {  // polynomial fit of Turbo, without its darkest tenth (as modules/render)
  const x = 0.1 + 0.9 * Math.min(1, Math.max(0, Number.isFinite(s) ? s : 0));
  const r = 0.13572138 + x * (4.6153926 + x * (-42.66032258 + x * (132.13108234 + x * (-152.94239396 + x * 59.28637943))));
  const g = 0.09140261 + x * (2.19418839 + x * (4.84296658 + x * (-14.18503333 + x * (4.27729857 + x * 2.82956604))));
  const b = 0.1066733 + x * (12.64194608 + x * (-60.58204836 + x * (110.36276771 + x * (-89.90310912 + x * 27.34824973))));
  return [r, g, b].map((c) => Math.min(1, Math.max(0, c)));
}

// ---- Scene --------------------------------------------------------------------------------

const canvas = $('canvas');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio || 1);
renderer.setClearColor(0xf4f5f7);
const scene = new THREE.Scene();
const camera = new THREE.OrthographicCamera(-1, 1, 1, -1, -1000, 1000);
const raycaster = new THREE.Raycaster();

const app = {
  mesh: null,          // GET /api/mesh
  state: null,         // last state document
  positions: null,     // Float32Array, 3 n
  field: 'weight',
  values: null,        // Float32Array of the field
  range: [0, 1],
  selected: -1,        // selected handle id
  handleOf: new Map(), // vertex -> handle id
  view: { yaw: 30, pitch: -20, center: new THREE.Vector3(), zoom: 1, radius: 1 },
};

let surface, wire, dots, dotsSelected;

function circleTexture() {
  const c = document.createElement('canvas');
  c.width = c.height = 64;
  const g = c.getContext('2d');
  g.beginPath();
  g.arc(32, 32, 26, 0, 2 * Math.PI);
  g.fillStyle = '#ffffff';
  g.fill();
  g.lineWidth = 7;
  g.strokeStyle = '#202020';
  g.stroke();
  return new THREE.CanvasTexture(c);
}

function buildScene() {
  const m = app.mesh;
  const F = m.faces.length / 3;
  const planar = m.kind === 'planar';
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(F * 9), 3));
  geometry.setAttribute('color', new THREE.BufferAttribute(new Float32Array(F * 9), 3));
  const material = planar
    ? new THREE.MeshBasicMaterial({ vertexColors: THREE.VertexColors, side: THREE.DoubleSide,
      polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1 })
    : new THREE.MeshLambertMaterial({ vertexColors: THREE.VertexColors, side: THREE.DoubleSide,
      polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1 });
  surface = new THREE.Mesh(geometry, material);
  scene.add(surface);
  if (!planar) {
    scene.add(new THREE.AmbientLight(0xffffff, 0.45));
    const light = new THREE.DirectionalLight(0xffffff, 0.65);
    light.position.set(0.3, 0.5, 1);
    camera.add(light);
    scene.add(camera);
  }

  // Wireframe: each edge once.
  const edges = new Set();
  const index = [];
  for (let f = 0; f < F; ++f) {
    for (let c = 0; c < 3; ++c) {
      const a = m.faces[3 * f + c], b = m.faces[3 * f + ((c + 1) % 3)];
      const key = a < b ? a * m.vertices + b : b * m.vertices + a;
      if (!edges.has(key)) { edges.add(key); index.push(a, b); }
    }
  }
  const wireGeometry = new THREE.BufferGeometry();
  wireGeometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3 * m.vertices), 3));
  wireGeometry.setIndex(index);
  wire = new THREE.LineSegments(wireGeometry,
    new THREE.LineBasicMaterial({ color: 0x202020, transparent: true, opacity: 0.35 }));
  scene.add(wire);

  const texture = circleTexture();
  const dotMaterial = (color) => new THREE.PointsMaterial({ color, size: 13, sizeAttenuation: false,
    map: texture, alphaTest: 0.5, transparent: false });
  dots = new THREE.Points(new THREE.BufferGeometry(), dotMaterial(0xe11d48));
  dotsSelected = new THREE.Points(new THREE.BufferGeometry(), dotMaterial(0xf59e0b));
  dots.renderOrder = dotsSelected.renderOrder = 2;
  scene.add(dots, dotsSelected);
  $('hint-drag').textContent = planar ? 'pan' : 'rotate';
  $('wire').checked = F <= 5000;  // dense meshes read better without edges
}

function updateGeometry() {
  const m = app.mesh, x = app.positions;
  const pos = surface.geometry.attributes.position.array;
  const col = surface.geometry.attributes.color.array;
  const F = m.faces.length / 3;
  const elementSite = app.field === 'distortion' || app.field === 'smoothness';
  const [lo, hi] = app.range;
  const scale = hi > lo ? 1 / (hi - lo) : 0;
  const map = app.field === 'weight' ? viridis : turbo;
  for (let f = 0; f < F; ++f) {
    for (let c = 0; c < 3; ++c) {
      const v = m.faces[3 * f + c];
      const o = 9 * f + 3 * c;
      pos[o] = x[3 * v]; pos[o + 1] = x[3 * v + 1]; pos[o + 2] = x[3 * v + 2];
      let rgb = [0.82, 0.83, 0.86];
      if (app.values && app.field !== 'none') {
        const value = elementSite ? app.values[m.face_element[f]] : app.values[v];
        rgb = map(scale ? (value - lo) * scale : 0.5);
      }
      col[o] = rgb[0]; col[o + 1] = rgb[1]; col[o + 2] = rgb[2];
    }
  }
  surface.geometry.attributes.position.needsUpdate = true;
  surface.geometry.attributes.color.needsUpdate = true;
  surface.geometry.computeBoundingSphere();
  surface.geometry.computeBoundingBox();
  if (m.kind !== 'planar') surface.geometry.computeVertexNormals();
  wire.geometry.attributes.position.array.set(x);
  wire.geometry.attributes.position.needsUpdate = true;
  wire.geometry.computeBoundingSphere();
  wire.visible = $('wire').checked;

  const plain = [], chosen = [];
  for (const h of (app.state ? app.state.handles : [])) {
    for (const v of h.vertices) (h.id === app.selected ? chosen : plain).push(x[3 * v], x[3 * v + 1], x[3 * v + 2]);
  }
  dots.geometry.setAttribute('position', new THREE.Float32BufferAttribute(plain, 3));
  dotsSelected.geometry.setAttribute('position', new THREE.Float32BufferAttribute(chosen, 3));
  render();
}

// ---- View ---------------------------------------------------------------------------------

function viewRotation() {
  const v = app.view;
  if (app.mesh.kind === 'planar') return new THREE.Quaternion();
  const yaw = new THREE.Quaternion().setFromAxisAngle(new THREE.Vector3(0, 1, 0), THREE.Math.degToRad(v.yaw));
  const pitch = new THREE.Quaternion().setFromAxisAngle(new THREE.Vector3(1, 0, 0), THREE.Math.degToRad(v.pitch));
  return yaw.multiply(pitch);
}

function fit() {
  // Fit the current shape into the free part of the view: the vertices its faces use, so that
  // one that no element uses (kept, far away perhaps) does not shrink the mesh to a dot.
  const box = new THREE.Box3();
  const x = app.positions || app.mesh.rest;
  const add = (v) => box.expandByPoint(new THREE.Vector3(x[3 * v], x[3 * v + 1], x[3 * v + 2]));
  if (app.mesh.faces.length > 0) for (const v of app.mesh.faces) add(v);
  else for (let v = 0; v < x.length / 3; ++v) add(v);
  box.getCenter(app.view.center);
  app.view.zoom = 1;
  app.view.box = box;
  placeCamera();
}

/// The part of the canvas the mesh is fitted into (CSS pixels): clear of the colour bar on
/// the right and the hint line at the bottom.
function freeArea() {
  const w = canvas.clientWidth, h = canvas.clientHeight;
  const right = app.field !== 'none' ? 130 : 24;
  return { left: 24, top: 24, width: Math.max(w - 24 - right, 50), height: Math.max(h - 24 - 40, 50) };
}

function placeCamera() {
  const v = app.view;
  const q = viewRotation();
  const dir = new THREE.Vector3(0, 0, 1).applyQuaternion(q);
  camera.quaternion.copy(q);
  const size = v.box.getSize(new THREE.Vector3());
  const radius = Math.max(size.length() / 2, 1e-9);
  camera.position.copy(v.center).addScaledVector(dir, 4 * radius);
  camera.near = 0.01 * radius;
  camera.far = 8 * radius;
  // Half-extents of the box seen from the camera.
  const inv = q.clone().inverse();
  let hx = 0, hy = 0;
  const c = v.box.min, d = v.box.max;
  for (const px of [c.x, d.x]) for (const py of [c.y, d.y]) for (const pz of [c.z, d.z]) {
    const p = new THREE.Vector3(px, py, pz).sub(v.center).applyQuaternion(inv);
    hx = Math.max(hx, Math.abs(p.x)); hy = Math.max(hy, Math.abs(p.y));
  }
  const w = Math.max(canvas.clientWidth, 1), h = Math.max(canvas.clientHeight, 1);
  const area = freeArea();
  // World units per pixel so that the box fills the free area; the box centre at its centre.
  const unit = Math.max((2 * hx) / area.width, (2 * hy) / area.height, 1e-12) / v.zoom;
  const cx = area.left + area.width / 2 - w / 2, cy = area.top + area.height / 2 - h / 2;
  camera.left = -w / 2 * unit - cx * unit; camera.right = w / 2 * unit - cx * unit;
  camera.top = h / 2 * unit + cy * unit; camera.bottom = -h / 2 * unit + cy * unit;
  camera.updateProjectionMatrix();
  camera.updateMatrixWorld();
  render();
}

function resize() {
  const w = canvas.clientWidth, h = canvas.clientHeight;
  renderer.setSize(w, h, false);
  if (app.mesh && app.view.box) placeCamera();
}

function render() { renderer.render(scene, camera); }

// ---- Picking and dragging -----------------------------------------------------------------

function ndc(event) {
  const r = canvas.getBoundingClientRect();
  return new THREE.Vector2(((event.clientX - r.left) / r.width) * 2 - 1,
    -((event.clientY - r.top) / r.height) * 2 + 1);
}

function pick(event) {
  raycaster.setFromCamera(ndc(event), camera);
  const hits = raycaster.intersectObject(surface);
  if (!hits.length) {  // on or just beside the boundary: the nearest vertex within 12 pixels
    const r = canvas.getBoundingClientRect();
    let best = -1, bestD = 12 * 12;
    for (let v = 0; v < app.mesh.vertices; ++v) {
      const p = vertex(v).project(camera);
      const d = (r.left + (p.x + 1) / 2 * r.width - event.clientX) ** 2 +
        (r.top + (1 - p.y) / 2 * r.height - event.clientY) ** 2;
      if (d < bestD) { bestD = d; best = v; }
    }
    return best < 0 ? null : { vertex: best, point: vertex(best) };
  }
  const hit = hits[0];
  const f = hit.faceIndex;
  let best = -1, bestD = Infinity;
  for (let c = 0; c < 3; ++c) {
    const v = app.mesh.faces[3 * f + c];
    const p = vertex(v);
    const d = p.distanceToSquared(hit.point);
    if (d < bestD) { bestD = d; best = v; }
  }
  return { vertex: best, point: hit.point };
}

function vertex(v) {
  const x = app.positions;
  return new THREE.Vector3(x[3 * v], x[3 * v + 1], x[3 * v + 2]);
}

// A handle dot is easier to grab than its triangle's nearest corner: within 10 pixels wins.
function pickHandle(event) {
  if (!app.state) return null;
  const r = canvas.getBoundingClientRect();
  let best = null, bestD = 10 * 10;
  for (const h of app.state.handles) {
    for (const v of h.vertices) {
      const p = vertex(v).project(camera);
      const sx = (p.x + 1) / 2 * r.width + r.left, sy = (1 - p.y) / 2 * r.height + r.top;
      const d = (sx - event.clientX) ** 2 + (sy - event.clientY) ** 2;
      if (d < bestD) { bestD = d; best = { handle: h.id, vertex: v }; }
    }
  }
  return best;
}

function rayOnPlane(event, plane) {
  raycaster.setFromCamera(ndc(event), camera);
  const out = new THREE.Vector3();
  return raycaster.ray.intersectPlane(plane, out) ? out : null;
}

let gesture = null;

canvas.addEventListener('contextmenu', (e) => e.preventDefault());
canvas.addEventListener('pointerdown', (event) => {
  if (!app.mesh) return;
  canvas.setPointerCapture(event.pointerId);
  const start = { x: event.clientX, y: event.clientY };
  if (event.button === 2 || event.button === 1) {
    gesture = { kind: 'pan', start, center: app.view.center.clone() };
    return;
  }
  const grabbed = pickHandle(event);
  if (grabbed) {
    selectHandle(grabbed.handle);
    const h = app.state.handles.find((k) => k.id === grabbed.handle);
    const centroid = new THREE.Vector3();
    h.targets.forEach((t) => centroid.add(new THREE.Vector3(t[0], t[1], t[2])));
    centroid.divideScalar(h.targets.length);
    const normal = app.mesh.kind === 'planar' ? new THREE.Vector3(0, 0, 1)
      : new THREE.Vector3(0, 0, 1).applyQuaternion(camera.quaternion);
    const plane = new THREE.Plane().setFromNormalAndCoplanarPoint(normal, centroid);
    gesture = { kind: 'drag', start, handle: h.id, centroid, plane, from: rayOnPlane(event, plane) };
    return;
  }
  gesture = { kind: app.mesh.kind === 'planar' ? 'pan' : 'rotate', start, shift: event.shiftKey,
    center: app.view.center.clone(), yaw: app.view.yaw, pitch: app.view.pitch, moved: false };
});

canvas.addEventListener('pointermove', (event) => {
  if (!gesture) return;
  const dx = event.clientX - gesture.start.x, dy = event.clientY - gesture.start.y;
  if (Math.abs(dx) + Math.abs(dy) > 3) gesture.moved = true;
  if (gesture.kind === 'drag') {
    const to = rayOnPlane(event, gesture.plane);
    if (!to || !gesture.from) return;
    const c = gesture.centroid.clone().add(to.sub(gesture.from));
    edit('move:' + gesture.handle, 'PATCH', '/api/handles/' + gesture.handle, { move_to: [c.x, c.y, c.z] });
  } else if (gesture.kind === 'rotate' && gesture.moved) {
    app.view.yaw = gesture.yaw - dx * 0.4;
    app.view.pitch = Math.max(-89, Math.min(89, gesture.pitch - dy * 0.4));
    placeCamera();
  } else if (gesture.kind === 'pan' && gesture.moved) {
    const r = canvas.getBoundingClientRect();
    const sx = (camera.right - camera.left) / r.width, sy = (camera.top - camera.bottom) / r.height;
    const offset = new THREE.Vector3(-dx * sx, dy * sy, 0).applyQuaternion(camera.quaternion);
    app.view.center.copy(gesture.center).add(offset);
    placeCamera();
  }
});

canvas.addEventListener('pointerup', (event) => {
  const g = gesture;
  gesture = null;
  if (g && g.kind === 'drag') { whenIdle().then(fitIfOutside); return; }
  if (!g || g.moved || event.button !== 0) return;
  const hit = pick(event);
  if (!hit) { selectHandle(-1); return; }
  const owner = app.handleOf.get(hit.vertex);
  if (owner !== undefined) { selectHandle(owner); return; }
  if (event.shiftKey && app.selected >= 0) {
    edit('add:' + hit.vertex, 'PATCH', '/api/handles/' + app.selected, { add_vertices: [hit.vertex] });
  } else {
    queue.pending.set('new:' + hit.vertex, { method: 'POST', path: '/api/handles',
      body: { vertices: [hit.vertex] }, onState: (s) => { if (s.created !== undefined) app.selected = s.created; } });
    pump();
  }
});

canvas.addEventListener('wheel', (event) => {
  event.preventDefault();
  app.view.zoom *= Math.exp(-event.deltaY * 0.0015);
  app.view.zoom = Math.min(50, Math.max(0.05, app.view.zoom));
  placeCamera();
}, { passive: false });

window.addEventListener('keydown', (event) => {
  if (event.target.tagName === 'INPUT' || event.target.tagName === 'SELECT') return;
  if ((event.key === 'Delete' || event.key === 'Backspace') && app.selected >= 0) {
    deleteHandle(app.selected);
  } else if (event.key === 'f' || event.key === 'F') {
    fit();
  }
});

// After a drag: fit again when part of the mesh has left the view.
function fitIfOutside() {
  const x = app.positions;
  const r = canvas.getBoundingClientRect();
  for (let i = 0; i < x.length; i += 3) {
    const p = new THREE.Vector3(x[i], x[i + 1], x[i + 2]).project(camera);
    const sx = (p.x + 1) / 2 * r.width, sy = (1 - p.y) / 2 * r.height;
    if (sx < 0 || sy < 0 || sx > r.width || sy > r.height) { fit(); return; }
  }
}

function deleteHandle(id) {
  edit('delete:' + id, 'DELETE', '/api/handles/' + id);
  if (app.selected === id) app.selected = -1;
}

function selectHandle(id) {
  app.selected = id;
  renderHandles();
  if (app.positions) updateGeometry();
}

// ---- Panel --------------------------------------------------------------------------------

const fmt = (x) => (x === null || x === undefined ? '\u2013'
  : Math.abs(x) >= 1000 || (Math.abs(x) < 0.001 && x !== 0) ? x.toExponential(2) : x.toPrecision(3));

function setStatus(text) { $('status').textContent = text; }

let toastTimer = null;
function toast(message) {
  const t = $('toast');
  t.textContent = message;
  t.hidden = false;
  clearTimeout(toastTimer);
  toastTimer = setTimeout(() => { t.hidden = true; }, 5000);
}

function renderHandles() {
  const list = $('handles');
  const handles = app.state ? app.state.handles : [];
  $('handle-count').textContent = handles.length ? String(handles.length) : '';
  $('no-handles').hidden = handles.length > 0;
  // Keep rows whose sliders are being dragged: rebuild only when the set of handles changed.
  const signature = handles.map((h) => `${h.id}:${h.vertices.length}`).join(',');
  if (list.dataset.signature !== signature) {
    list.dataset.signature = signature;
    list.textContent = '';
    for (const h of handles) {
      const li = document.createElement('li');
      li.dataset.id = h.id;
      li.innerHTML = `<div class="title"><span class="dot"></span><span class="name"></span>
        <span class="n"></span><button title="delete">\u00d7</button></div>
        <div class="sliders"><label title="range r">r <input type="range" class="range" min="-1" max="1" step="0.02">
          <output class="range-out"></output></label>
        <label title="magnitude m">m <input type="range" class="magnitude" min="0" max="1" step="0.01">
          <output class="magnitude-out"></output></label></div>`;
      li.querySelector('.name').textContent = h.name;
      li.querySelector('.n').textContent = `${h.vertices.length} vert${h.vertices.length > 1 ? 'ices' : 'ex'}`;
      li.querySelector('button').addEventListener('click', (e) => { e.stopPropagation(); deleteHandle(h.id); });
      li.addEventListener('click', () => selectHandle(h.id));
      const range = li.querySelector('.range'), magnitude = li.querySelector('.magnitude');
      range.addEventListener('input', () => {
        const r = 10 ** Number(range.value);
        li.querySelector('.range-out').textContent = fmt(r);
        edit('range:' + h.id, 'PATCH', '/api/handles/' + h.id, { range: r });
      });
      magnitude.addEventListener('input', () => {
        li.querySelector('.magnitude-out').textContent = Number(magnitude.value).toFixed(2);
        edit('magnitude:' + h.id, 'PATCH', '/api/handles/' + h.id, { magnitude: Number(magnitude.value) });
      });
      list.appendChild(li);
    }
  }
  for (const li of list.children) {
    const h = handles.find((k) => String(k.id) === li.dataset.id);
    li.classList.toggle('selected', h.id === app.selected);
    const range = li.querySelector('.range'), magnitude = li.querySelector('.magnitude');
    if (document.activeElement !== range) range.value = Math.log10(h.range);
    if (document.activeElement !== magnitude) magnitude.value = h.magnitude;
    li.querySelector('.range-out').textContent = fmt(h.range);
    li.querySelector('.magnitude-out').textContent = h.magnitude.toFixed(2);
  }
}

function renderParams() {
  const p = app.state.params;
  const set = (id, value) => { if (document.activeElement !== $(id)) $(id).value = value; };
  set('energy', p.energy);
  set('regularization', p.regularization);
  set('beta', p.beta);
  $('beta-out').textContent = p.beta.toFixed(2);
  $('beta-row').hidden = p.regularization !== 'uniform';
  set('iterations', p.iterations);
  set('seconds', p.seconds);
  $('reference').checked = p.reference;
  $('continue').checked = p.continue_drags;
  set('scheme', p.scheme === 'rbf' ? 'rbf' : 'diffusion:' + p.order);
  set('t', Math.log10(p.t));
  $('t-out').textContent = fmt(p.t);
  set('sigma', p.sigma);
  $('sigma-out').textContent = p.sigma.toFixed(2);
  $('t-row').hidden = p.scheme === 'rbf';
  $('sigma-row').hidden = p.scheme !== 'rbf';
}

function renderMetrics() {
  const m = app.state.metrics;
  $('m-dmax').textContent = fmt(m.d_max);
  $('m-dave').textContent = fmt(m.d_ave);
  $('m-ddev').textContent = fmt(m.d_dev);
  $('m-dist').textContent = fmt(m.dist);
  $('m-inv').textContent = String(m.inverted);
  // Unconverged: the run's own energy, an upper bound of the relaxed one.
  $('m-energy').textContent = fmt(m.energy) + (m.energy_relaxed ? '' : ' (not relaxed)');
  const u = app.state.update, t = app.state.totals;
  const rows = [['weights', 'weights'], ['deform', 'deformation'], ['reference', 'reference']];
  $('solver').innerHTML = rows.map(([label, key]) => {
    const work = u[key + '_work'];
    return `<tr><td>${label}</td><td class="work work-${work}">${work}</td>` +
      `<td>${t[key].symbolic}</td><td>${t[key].numeric}</td><td>${t[key].solves}</td></tr>`;
  }).join('');
  $('update-time').textContent = `last update ${(u.seconds * 1000).toFixed(1)} ms`;
  $('update-note').textContent = u.solved ? `last update: ${u.iterations} iteration${u.iterations === 1 ? '' : 's'}, ` +
    (u.converged ? 'converged'
      : u.criterion === null ? 'criterion not measured yet, refining\u2026'
      : `criterion ${fmt(u.criterion)} > ${fmt(app.state.params.tolerance)}, refining\u2026`) +
    '; counts since loading' : `not solved: ${u.message}`;
  $('mesh-info').textContent = `${app.mesh.name} \u00b7 ${app.mesh.kind} \u00b7 ${app.mesh.vertices} vertices`;
}

function renderColorBar() {
  const bar = $('colorbar');
  bar.hidden = app.field === 'none';
  if (bar.hidden) return;
  const g = $('cb-gradient').getContext('2d');
  const map = app.field === 'weight' ? viridis : turbo;
  for (let y = 0; y < 220; ++y) {
    const [r, gg, b] = map(1 - y / 219);
    g.fillStyle = `rgb(${r * 255},${gg * 255},${b * 255})`;
    g.fillRect(0, y, 18, 1);
  }
  const [lo, hi] = app.range;
  $('cb-title').textContent = { weight: 'weight', distortion: 'distortion D_k', smoothness: 'smoothness' }[app.field];
  $('cb-max').textContent = fmt(hi);
  $('cb-mid').textContent = fmt((lo + hi) / 2);
  $('cb-min').textContent = fmt(lo);
}

function updateSaveLinks() {
  const field = app.field;
  const v = app.view;
  const view = app.mesh.kind === 'planar' ? '' : `&yaw=${v.yaw.toFixed(1)}&pitch=${v.pitch.toFixed(1)}`;
  $('save-png').href = `/api/export/image.png?field=${field}&width=1600&height=1000${view}`;
}

// ---- State --------------------------------------------------------------------------------

async function fetchResults() {
  const [pos, field] = await Promise.all([
    api('GET', '/api/positions?format=f32').then((r) => r.arrayBuffer()),
    app.field === 'none' ? null : api('GET', `/api/field?name=${app.field}&format=f32`).then((r) => r.arrayBuffer()),
  ]);
  app.positions = new Float32Array(pos);
  app.values = field ? new Float32Array(field) : null;
  if (app.values) {
    let hi = 0;
    for (const v of app.values) if (Number.isFinite(v) && v > hi) hi = v;
    app.range = app.field === 'weight' ? [0, 1] : [0, hi > 0 ? hi : 1];
  }
}

async function showState(state) {
  app.state = state;
  app.handleOf = new Map();
  for (const h of state.handles) for (const v of h.vertices) app.handleOf.set(v, h.id);
  if (!state.handles.some((h) => h.id === app.selected)) app.selected = -1;
  if (!state.coalesced) await fetchResults();
  renderParams();
  renderHandles();
  renderMetrics();
  renderColorBar();
  updateSaveLinks();
  updateGeometry();
  // Not converged within the update's iterations: keep iterating while nothing else waits.
  const u = state.update;
  if (u.solved && !u.converged && queue.pending.size === 0) edit('refine', 'POST', '/api/refine', {});
}

function wirePanel() {
  // toBody returns null for an input that says nothing yet (an emptied number field).
  const param = (id, toBody) => $(id).addEventListener('input', () => {
    const body = toBody($(id).value);
    if (body) edit('params', 'PATCH', '/api/params', body);
  });
  param('energy', (v) => ({ energy: v }));
  param('regularization', (v) => ({ regularization: v }));
  param('beta', (v) => { $('beta-out').textContent = Number(v).toFixed(2); return { beta: Number(v) }; });
  param('iterations', (v) => (!(Number(v) >= 1) ? null : { iterations: Math.round(Number(v)) }));  // empty: no change
  param('seconds', (v) => (v === '' ? null : { seconds: Number(v) }));  // empty: no change
  $('reference').addEventListener('change', () => edit('params', 'PATCH', '/api/params', { reference: $('reference').checked }));
  $('continue').addEventListener('change', () => edit('params', 'PATCH', '/api/params', { continue_drags: $('continue').checked }));
  param('t', (v) => { $('t-out').textContent = fmt(10 ** Number(v)); return { t: 10 ** Number(v) }; });
  param('sigma', (v) => ({ sigma: Number(v) }));
  param('scheme', (v) => (v === 'rbf' ? { scheme: 'rbf' } : { scheme: 'diffusion', order: v.split(':')[1] }));
  for (const b of $('field').querySelectorAll('button')) {
    b.addEventListener('click', async () => {
      for (const o of $('field').querySelectorAll('button')) o.classList.toggle('on', o === b);
      app.field = b.dataset.field;
      await fetchResults();
      renderColorBar();
      updateSaveLinks();
      placeCamera();
      updateGeometry();
    });
  }
  $('wire').addEventListener('change', updateGeometry);
}

async function main() {
  try {
    app.mesh = await (await api('GET', '/api/mesh')).json();
    buildScene();
    wirePanel();
    resize();
    const state = await (await api('GET', '/api/state')).json();
    await fetchResults();
    fit();
    await showState(state);
    window.addEventListener('resize', resize);
    setStatus('ready');
    document.body.dataset.ready = 'true';
  } catch (error) {
    setStatus('error: ' + error.message);
    toast(error.message);
  }
}

// For scripts and tests: positions and screen coordinates of vertices.
window.diffreg = {
  positions: () => Array.from(app.positions || []),
  state: () => app.state,
  idle: whenIdle,
  // Page coordinates (CSS pixels) of vertex v at its current position.
  screen: (v) => {
    const r = canvas.getBoundingClientRect();
    const p = vertex(v).project(camera);
    return { x: r.left + (p.x + 1) / 2 * r.width, y: r.top + (1 - p.y) / 2 * r.height };
  },
};

main();
