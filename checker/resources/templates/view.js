// The 3-D view of a checked job (checker/view): reads the scene JSON of the page, draws it with
// three.js and reports its state in the DOM for tests and tools:
//   body[data-ready]        "1" once the first frame is drawn
//   body[data-first-frame]  ms from navigation start to the end of the first frame
//   body[data-camera]       {view, proj (column-major 4x4), width, height, left, top (CSS px)}
//   body[data-selected]     the pose shown with the tool: {table, row, index, line, tip, axis, cam}
// Part frame, mm, Z up.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const S = JSON.parse(document.getElementById('scene').textContent);
const COLOURS = {
  rapid: '#e0a800', feed: '#1f5fa8', gouge: '#d62728', interference: '#ff7f0e',
  holder: '#9467bd', crash: '#8b0000', part: '#b4bcc6', stock: '#c9a27a', fixture: '#6b8e6b',
  axis: '#2f6fd0', cam: '#c2185b', body: '#00a5a5', shank: '#9aa0a6', holderPiece: '#4b525a',
};
const MARKER_PX = S.findings.count > 1000 ? 7 : 10;

const bytes = (b64) => {
  const s = atob(b64);
  const out = new Uint8Array(s.length);
  for (let i = 0; i < s.length; i++) out[i] = s.charCodeAt(i);
  return out;
};
const f32 = (b64) => new Float32Array(bytes(b64).buffer);
const u32 = (b64) => new Uint32Array(bytes(b64).buffer);
const $ = (id) => document.getElementById(id);
const fmt = (x, d = 3) => (x === null || x === undefined ? '–' : Number(x).toFixed(d));

const canvas = $('view');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio || 1);
renderer.localClippingEnabled = true;
const scene = new THREE.Scene();
scene.background = new THREE.Color('#f4f5f7');
const camera = new THREE.PerspectiveCamera(35, 1, 1, 1000);
camera.up.set(0, 0, 1);
const controls = new OrbitControls(camera, canvas);
scene.add(new THREE.HemisphereLight(0xffffff, 0x667080, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 1.8);
camera.add(sun);
sun.position.set(0.3, 0.6, 1);
scene.add(camera);

const lo = new THREE.Vector3(...S.box[0]);
const hi = new THREE.Vector3(...S.box[1]);
const section = new THREE.Plane(new THREE.Vector3(0, 0, -1), 1e9);
const clipped = [section];

// the machined stock coloured by its deviation to the design (mm; + left, - over-cut):
// over-cut beyond the tolerance red, within it green, material left light to dark blue
function deviationColours(d, tol) {
  const over = new THREE.Color('#d62728'), ok = new THREE.Color('#2ca02c');
  const thin = new THREE.Color('#9ecae1'), thick = new THREE.Color('#08306b');
  let top = tol;
  for (const x of d) if (x > top) top = x;
  const out = new Float32Array(d.length * 3);
  const c = new THREE.Color();
  for (let i = 0; i < d.length; i++) {
    if (d[i] < -tol) c.copy(over);
    else if (d[i] <= tol) c.copy(ok);
    else c.copy(thin).lerp(thick, Math.min(1, (d[i] - tol) / Math.max(top - tol, 1e-9)));
    out[3 * i] = c.r; out[3 * i + 1] = c.g; out[3 * i + 2] = c.b;
  }
  return out;
}

function meshOf(m, colour, opacity = 1) {
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(f32(m.positions), 3));
  g.setIndex(new THREE.BufferAttribute(u32(m.index), 1));
  g.computeVertexNormals();
  const coloured = Boolean(m.deviation);
  if (coloured) {
    g.setAttribute('color', new THREE.BufferAttribute(
      deviationColours(f32(m.deviation), S.job.tolerance), 3));
  }
  const mat = new THREE.MeshStandardMaterial({
    color: coloured ? '#ffffff' : colour, vertexColors: coloured,
    flatShading: true, side: THREE.DoubleSide, metalness: 0.1, roughness: 0.7,
    clippingPlanes: clipped, transparent: opacity < 1, opacity,
    polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1,
  });
  return new THREE.Mesh(g, mat);
}

// the part
const part = S.part ? meshOf(S.part, COLOURS.part) : null;
if (part) scene.add(part);

// the path: one LineSegments, a colour per segment's kind
const P = f32(S.path.positions);
const kinds = bytes(S.path.kinds);
const nseg = kinds.length;
const segPos = new Float32Array(nseg * 6);
const segCol = new Float32Array(nseg * 6);
const kindColour = S.kinds.map((k) => new THREE.Color(COLOURS[k]));
for (let i = 0; i < nseg; i++) {
  for (let c = 0; c < 3; c++) {
    segPos[6 * i + c] = P[3 * i + c];
    segPos[6 * i + 3 + c] = P[3 * i + 3 + c];
  }
  const col = kindColour[kinds[i]];
  segCol.set([col.r, col.g, col.b, col.r, col.g, col.b], 6 * i);
}
function segments(pos, col, colour) {
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(pos, 3));
  if (col) g.setAttribute('color', new THREE.BufferAttribute(col, 3));
  const mat = new THREE.LineBasicMaterial(col ? { vertexColors: true, clippingPlanes: clipped }
    : { color: colour, clippingPlanes: clipped });
  return new THREE.LineSegments(g, mat);
}
// one geometry, one draw: the feeds' segments first, then the rapids', so that hiding the
// rapids is a shorter draw range
const order = new Uint32Array(2 * nseg);
let at = 0;
for (const rapid of [false, true]) {
  for (let i = 0; i < nseg; i++) {
    if ((kinds[i] === 0) === rapid) { order[at++] = 2 * i; order[at++] = 2 * i + 1; }
  }
}
const feedVertices = 2 * kinds.reduce((n, k) => n + (k !== 0), 0);
const pathGeom = new THREE.BufferGeometry();
pathGeom.setAttribute('position', new THREE.BufferAttribute(segPos, 3));
pathGeom.setAttribute('color', new THREE.BufferAttribute(segCol, 3));
pathGeom.setIndex(new THREE.BufferAttribute(order, 1));
const pathLines = new THREE.LineSegments(pathGeom, new THREE.LineBasicMaterial({ vertexColors: true, clippingPlanes: clipped }));
pathLines.name = 'path';
scene.add(pathLines);

// the tool axes along a multi-axis path: as written, and the CAM's where re-oriented
const axes = new THREE.Group();
if (S.axes) {
  const written = segments(f32(S.axes.segments), null, COLOURS.axis);
  written.material.transparent = true;
  written.material.opacity = 0.35;
  axes.add(written);
  if (S.axes.cam_count) {
    const cam = segments(f32(S.axes.cam), null, COLOURS.cam);
    cam.material.transparent = true;
    cam.material.opacity = 0.5;
    axes.add(cam);
  }
}
scene.add(axes);

// the findings: a marker each, drawn over everything at a fixed size on screen
const F = S.findings;
const FINDINGS = S.kinds.slice(2);
const M = F.count ? {
  at: f32(F.at), tip: f32(F.tip), axis: f32(F.axis), verdict: bytes(F.verdict),
  line: new Int32Array(bytes(F.line).buffer), op: new Uint16Array(bytes(F.op).buffer),
  index: u32(F.index),
} : null;
let markers = null;
if (M) {
  const col = new Float32Array(F.count * 3);
  const palette = FINDINGS.map((v) => new THREE.Color(COLOURS[v]));
  for (let i = 0; i < F.count; i++) {
    const c = palette[M.verdict[i]];
    col[3 * i] = c.r; col[3 * i + 1] = c.g; col[3 * i + 2] = c.b;
  }
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(M.at, 3));
  g.setAttribute('color', new THREE.BufferAttribute(col, 3));
  markers = new THREE.Points(g, new THREE.PointsMaterial({
    size: MARKER_PX, sizeAttenuation: false, vertexColors: true, depthTest: false,
    transparent: true, // drawn with the transparent objects, after them (renderOrder)
  }));
  markers.renderOrder = 10;
  scene.add(markers);
}

// the stock after each operation and the fixtures
const stocks = S.stock.map((m) => meshOf(m, COLOURS.stock, 0.55));
stocks.forEach((m, i) => { m.visible = i === stocks.length - 1; scene.add(m); });
const fixtures = S.fixtures.map((m) => meshOf(m, COLOURS.fixture, 0.8));
fixtures.forEach((m) => scene.add(m));

// the real tool of each operation, shown at a selected pose
const Z = new THREE.Vector3(0, 0, 1);
const tools = {};
for (const [op, t] of Object.entries(S.tools)) {
  const group = new THREE.Group();
  for (const p of t.pieces) {
    const g = new THREE.LatheGeometry(p.outline.map(([r, h]) => new THREE.Vector2(r, h)), 48);
    g.rotateX(Math.PI / 2);
    const colour = p.piece === 'holder' ? COLOURS.holderPiece : COLOURS[p.piece];
    group.add(new THREE.Mesh(g, new THREE.MeshStandardMaterial({ color: colour, metalness: 0.4, roughness: 0.4 })));
  }
  group.visible = false;
  group.name = 'tool-' + op;
  tools[op] = group;
  scene.add(group);
}
const poseAxes = new THREE.Group();
scene.add(poseAxes);

const state = { selected: null };
window.pathcheckView = {
  THREE, scene, camera, renderer, controls, state, tools, poseAxes, markerPx: MARKER_PX,
  firstRow: S.findings.rows[0] ?? null,
};

function fit() {
  const centre = lo.clone().add(hi).multiplyScalar(0.5);
  const radius = Math.max(hi.clone().sub(lo).length() / 2, 1e-3);
  const dist = radius / Math.sin(THREE.MathUtils.degToRad(camera.fov / 2));
  const dir = new THREE.Vector3(1, -1.4, 1.1).normalize();
  camera.position.copy(centre).addScaledVector(dir, dist);
  camera.near = dist / 100;
  camera.far = dist * 10;
  controls.target.copy(centre);
  camera.updateProjectionMatrix();
  controls.update();
  draw();
}

function resize() {
  const w = canvas.parentElement.clientWidth;
  const h = canvas.parentElement.clientHeight;
  renderer.setSize(w, h, false);
  camera.aspect = w / Math.max(h, 1);
  camera.updateProjectionMatrix();
  draw();
}

function report() {
  camera.updateMatrixWorld();
  const r = canvas.getBoundingClientRect();
  document.body.dataset.camera = JSON.stringify({
    view: Array.from(camera.matrixWorldInverse.elements),
    proj: Array.from(camera.projectionMatrix.elements),
    width: r.width, height: r.height, left: r.left, top: r.top,
  });
}

let pending = false;
function draw() {
  if (pending) return;
  pending = true;
  requestAnimationFrame(() => {
    pending = false;
    renderer.render(scene, camera);
    report();
    if (!document.body.dataset.ready) {
      document.body.dataset.firstFrame = performance.now().toFixed(1);
      document.body.dataset.ready = '1';
    }
  });
}
controls.addEventListener('change', draw);

function axisLine(from, dir, length, colour) {
  const a = new THREE.Vector3(...from);
  const b = a.clone().addScaledVector(new THREE.Vector3(...dir).normalize(), length);
  const g = new THREE.BufferGeometry().setFromPoints([a, b]);
  return new THREE.Line(g, new THREE.LineBasicMaterial({ color: colour }));
}

// show the tool of operation `op` at `tip` along `axis`; `cam` the CAM's axis when re-oriented
function showPose(sel) {
  Object.values(tools).forEach((g) => { g.visible = false; });
  poseAxes.clear();
  const tool = tools[String(sel.op)] || Object.values(tools)[0];
  if (tool) {
    tool.position.set(...sel.tip);
    tool.quaternion.setFromUnitVectors(Z, new THREE.Vector3(...sel.axis).normalize());
    tool.visible = true;
  }
  if (part) { // the tool is often inside the material: the part seen through
    part.material.transparent = true;
    part.material.opacity = 0.3;
    part.material.depthWrite = false;
    part.material.needsUpdate = true;
  }
  const reach = S.axis_reach * 2;
  poseAxes.add(axisLine(sel.tip, sel.axis, reach, COLOURS.axis));
  if (sel.cam) poseAxes.add(axisLine(sel.cam_tip ?? sel.tip, sel.cam, reach, COLOURS.cam));
  state.selected = sel;
  document.body.dataset.selected = JSON.stringify(sel);
  $('pose').textContent = `line ${sel.line ?? '–'}  ${sel.verdict ?? ''}  op ${sel.op}\n` +
    `tip ${sel.tip.map((x) => fmt(x)).join(', ')}\naxis ${sel.axis.map((x) => fmt(x, 4)).join(', ')}` +
    (sel.cam ? `\nCAM axis ${sel.cam.map((x) => fmt(x, 4)).join(', ')}` : '');
  document.querySelectorAll('tr.selected').forEach((tr) => tr.classList.remove('selected'));
  const row = document.querySelector(`#${sel.table} tbody tr[data-row="${sel.row}"]`);
  if (row) row.classList.add('selected');
  draw();
}

function pose(table, row) {
  if (table === 'markers') {
    const v = (a, i) => [a[3 * i], a[3 * i + 1], a[3 * i + 2]];
    const k = F.rows.findIndex((r) => r.marker === row);
    return { table: k >= 0 ? 'findings' : 'markers', row: k >= 0 ? k : row, index: M.index[row],
      line: M.line[row] < 0 ? null : M.line[row], op: M.op[row], verdict: FINDINGS[M.verdict[row]],
      tip: v(M.tip, row), axis: v(M.axis, row), cam: null };
  }
  const f = table === 'findings' ? F.rows[row] : S.reoriented[row];
  return { table, row, index: f.index, kind: f.kind ?? 'cl', line: f.line, op: f.op,
    verdict: f.verdict, tip: f.tip, axis: f.axis, cam: f.cam ?? null, cam_tip: f.cam_tip ?? null };
}

function fillTables() {
  const body = $('findings').tBodies[0];
  const rows = F.rows.length;
  $('findings-title').textContent = F.count > rows ? `Findings (the ${rows} deepest of ${F.count})` : `Findings (${F.count})`;
  for (let i = 0; i < rows; i++) {
    const f = F.rows[i];
    const tr = body.insertRow();
    tr.dataset.row = i;
    tr.innerHTML = `<td class="n">${i + 1}</td><td class="n">${f.line ?? '–'}</td>` +
      `<td><span class="swatch" style="background:${COLOURS[f.verdict]}"></span>${f.verdict}</td>` +
      `<td>${f.against}${f.rapid ? ' (rapid)' : ''}</td><td class="n">${fmt(f.depth)}</td><td class="n">${f.op}</td>`;
    tr.addEventListener('click', () => showPose(pose('findings', i)));
  }
  if (S.reoriented.length) {
    $('reoriented').hidden = false;
    $('reoriented-title').hidden = false;
    const rb = $('reoriented').tBodies[0];
    S.reoriented.forEach((r, i) => {
      const tr = rb.insertRow();
      tr.dataset.row = i;
      tr.innerHTML = `<td class="n">${i + 1}</td><td class="n">${r.line ?? '–'}</td><td>${r.verdict}</td>` +
        `<td class="n">${fmt(r.angle, 2)}</td><td class="n">${r.op}</td>`;
      tr.addEventListener('click', () => showPose(pose('reoriented', i)));
    });
  }
}

function legend() {
  const items = ['rapid', 'feed', 'gouge', 'interference', 'holder', 'crash'];
  if (S.axes || S.reoriented.length) items.push('axis');
  if (S.reoriented.length) items.push('cam');
  const names = { axis: 'tool axis', cam: "CAM's axis" };
  $('legend').innerHTML = items.map((k) => `<span class="swatch" style="background:${COLOURS[k]}"></span>${names[k] || k}`).join(' &nbsp;');
}

function controlsUi() {
  const toggle = (id, objs) => $(id).addEventListener('change', (e) => {
    objs.filter(Boolean).forEach((o) => { o.visible = e.target.checked; });
    draw();
  });
  toggle('show-part', [part]);
  toggle('show-path', [pathLines]);
  $('show-rapids').addEventListener('change', (e) => {
    pathGeom.setDrawRange(0, e.target.checked ? Infinity : feedVertices);
    draw();
  });
  toggle('show-findings', [markers]);
  toggle('show-axes', [axes, poseAxes]);
  toggle('show-fixtures', fixtures);
  $('show-stock').addEventListener('change', (e) => {
    stocks.forEach((m, i) => { m.visible = e.target.checked && i === Number($('stock-op').value); });
    draw();
  });
  $('fit').addEventListener('click', fit);
  const cut = () => {
    const k = { x: 0, y: 1, z: 2 }[$('section-axis').value];
    const t = Number($('section').value) / 1000;
    const a = lo.getComponent(k), b = hi.getComponent(k);
    const normal = new THREE.Vector3();
    normal.setComponent(k, -1);
    section.normal.copy(normal);
    section.constant = t >= 1 ? 1e9 : a + t * (b - a);
    draw();
  };
  $('section').addEventListener('input', cut);
  $('section-axis').addEventListener('change', cut);
  if (stocks.length) {
    $('stock-control').hidden = false;
    const op = $('stock-op');
    op.max = String(stocks.length - 1);
    op.value = op.max;
    const show = () => {
      stocks.forEach((m, i) => { m.visible = $('show-stock').checked && i === Number(op.value); });
      $('stock-label').textContent = S.stock[Number(op.value)].label;
      draw();
    };
    op.addEventListener('input', show);
    show();
  }
  // a click on a marker selects its finding
  const ray = new THREE.Raycaster();
  let down = null;
  canvas.addEventListener('pointerdown', (e) => { down = [e.clientX, e.clientY]; });
  canvas.addEventListener('pointerup', (e) => {
    if (!markers || !down || Math.hypot(e.clientX - down[0], e.clientY - down[1]) > 3) return;
    const r = canvas.getBoundingClientRect();
    const ndc = new THREE.Vector2(((e.clientX - r.left) / r.width) * 2 - 1, -((e.clientY - r.top) / r.height) * 2 + 1);
    ray.setFromCamera(ndc, camera);
    const dist = camera.position.distanceTo(controls.target);
    ray.params.Points.threshold = (2 * dist * Math.tan(THREE.MathUtils.degToRad(camera.fov / 2)) / r.height) * MARKER_PX;
    const hit = ray.intersectObject(markers)[0];
    if (hit) showPose(pose('markers', hit.index));
  });
}

fillTables();
legend();
controlsUi();
window.addEventListener('resize', resize);
resize();
fit();
