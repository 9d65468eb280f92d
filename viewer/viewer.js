// wellmesh viewer: pick a job, follow its progress, then see its ore-body shells and drill
// holes in 3D (three.js GLTFLoader + OrbitControls), toggle them, and read each body's
// volume and area from the job's summary.
//
// State for tests and scripts: window.wellmeshViewer = {loaded, error, meshes, job, status}
// and <body data-viewer-state="idle|loading|loaded|error">.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

export const BACKGROUND = 0x1d2126;
const POLL_MS = 1000;
const FINAL = new Set(['successful', 'failed', 'dismissed']);

const viewer = {
  loaded: false,
  error: null,
  meshes: 0,
  job: null,
  status: null,
  // The grade–tonnage chart's natural size once drawn (null when the job has none).
  chart: null,
};
window.wellmeshViewer = viewer;

const $ = (id) => document.getElementById(id);
const canvas = $('canvas');

const renderer = new THREE.WebGLRenderer({ canvas, antialias: true });
renderer.setPixelRatio(window.devicePixelRatio);
renderer.setClearColor(BACKGROUND);
const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(45, 1, 0.1, 1e7);
camera.position.set(100, 100, 100);
scene.add(camera);
scene.add(new THREE.HemisphereLight(0xffffff, 0x30302c, 1.2));
const headlight = new THREE.DirectionalLight(0xffffff, 2.5);
headlight.position.set(-1, 1.2, 0.3);
camera.add(headlight);
// Aim the headlight along the view, from above-left: the light follows the camera.
headlight.target.position.set(0, 0, -1);
camera.add(headlight.target);
const controls = new OrbitControls(camera, canvas);
controls.enableDamping = true;

function resize() {
  const { clientWidth: w, clientHeight: h } = canvas;
  if (w === 0 || h === 0) return;
  renderer.setSize(w, h, false);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
}
window.addEventListener('resize', resize);
resize();
renderer.setAnimationLoop(() => {
  controls.update();
  renderer.render(scene, camera);
});

let model = null;
let openToken = 0;

function setState(state) {
  document.body.dataset.viewerState = state;
}

function overlay(text, isError = false) {
  const el = $('overlay');
  el.hidden = !text;
  el.textContent = text ?? '';
  el.classList.toggle('error', isError);
}

function fail(message) {
  viewer.error = message;
  viewer.loaded = false;
  setState('error');
  overlay(message, true);
}

async function getJson(url) {
  const response = await fetch(url, { headers: { Accept: 'application/json' } });
  let body = null;
  try {
    body = await response.json();
  } catch {
    // Not JSON: reported below by status.
  }
  if (!response.ok) {
    const detail = body?.detail ?? body?.title ?? response.statusText;
    throw new Error(`${url}: HTTP ${response.status} ${detail}`);
  }
  return body;
}

const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

function unitLabel(unit) {
  return unit === 'ft' ? 'ft' : 'm';
}

function formatNumber(x) {
  if (typeof x !== 'number' || !Number.isFinite(x)) return '–';
  const digits = Math.abs(x) >= 100 ? 0 : Math.abs(x) >= 1 ? 2 : 4;
  return x.toLocaleString('en', { maximumFractionDigits: digits });
}

// ---- job list ---------------------------------------------------------------------------

async function loadJobs() {
  const select = $('jobs');
  let jobs = [];
  try {
    jobs = (await getJson('/jobs?limit=100')).jobs ?? [];
  } catch (err) {
    select.replaceChildren(new Option(`(cannot list jobs: ${err.message})`, ''));
    return;
  }
  const options = [new Option(jobs.length ? '(pick a job)' : '(no jobs yet)', '')];
  for (const job of jobs) {
    const when = (job.created ?? '').replace('T', ' ').slice(0, 19);
    options.push(new Option(`${when} ${job.jobID.slice(0, 8)} ${job.status}`, job.jobID));
  }
  if (viewer.job && !jobs.some((j) => j.jobID === viewer.job)) {
    options.push(new Option(viewer.job, viewer.job));
  }
  select.replaceChildren(...options);
  select.value = viewer.job ?? '';
}

$('jobs').addEventListener('change', (event) => {
  const id = event.target.value;
  if (!id) return;
  const url = new URL(window.location.href);
  url.searchParams.set('job', id);
  window.history.replaceState(null, '', url);
  openJob(id);
});
$('refresh').addEventListener('click', loadJobs);

// ---- one job ----------------------------------------------------------------------------

function showStatus(info) {
  $('status').hidden = false;
  const progress = Number.isFinite(info.progress) ? info.progress : 0;
  $('status-line').textContent = `${info.status}${info.status === 'running' ? ` — ${progress}%` : ''}`;
  $('progress').value = info.status === 'successful' ? 100 : progress;
  $('message').textContent = info.message ?? '';
}

function clearModel() {
  if (model) {
    scene.remove(model);
    model.traverse((object) => {
      object.geometry?.dispose();
      const materials = Array.isArray(object.material) ? object.material : [object.material];
      materials.forEach((m) => m?.dispose());
    });
    model = null;
  }
  $('layers').hidden = true;
  $('legend').hidden = true;
}

async function openJob(id) {
  const token = ++openToken;
  clearModel();
  Object.assign(viewer, { loaded: false, error: null, meshes: 0, job: id, status: null });
  setState('loading');
  overlay('Loading job…');
  $('jobs').value = id;
  try {
    for (;;) {
      const info = await getJson(`/jobs/${encodeURIComponent(id)}`);
      if (token !== openToken) return;
      viewer.status = info.status;
      showStatus(info);
      if (info.status === 'successful') break;
      if (FINAL.has(info.status)) {
        fail(`Job ${info.status}: ${info.message ?? ''}`);
        return;
      }
      overlay(`Job ${info.status}…`);
      await sleep(POLL_MS);
      if (token !== openToken) return;
    }
    const results = await getJson(`/jobs/${encodeURIComponent(id)}/results`);
    if (token !== openToken) return;
    const href = results.glb?.href;
    if (!href) throw new Error('the job results have no GLB');
    overlay('Loading model…');
    const gltf = await new GLTFLoader().loadAsync(href);
    if (token !== openToken) return;
    showModel(gltf, results.summary ?? null);
    await showChart(results.chart?.href ?? null);
  } catch (err) {
    if (token === openToken) fail(err.message ?? String(err));
  }
}

function showModel(gltf, summary) {
  model = gltf.scene;
  let meshes = 0;
  model.traverse((object) => {
    if (object.isMesh) {
      meshes += 1;
      if (object.material.transparent) {
        // Translucent outer shells: let inner shells show through.
        object.material.depthWrite = false;
        object.renderOrder = 1;
      }
    }
    if (object.isPoints) object.material.size = 4;
  });
  scene.add(model);
  // Samples can hide the bodies on dense drilling: off until asked for.
  for (const node of model.children) {
    if (node.userData?.name === 'samples') node.visible = false;
  }
  const shells = model.children.filter((n) => n.userData?.shell !== undefined);
  fitCamera(shells.length ? shells : [model]);
  buildLayers(model);
  buildLegend(summary ?? null, model);
  overlay(null);
  Object.assign(viewer, { loaded: true, error: null, meshes });
  setState('loaded');
}

function fitCamera(objects) {
  const box = new THREE.Box3();
  for (const object of objects) box.expandByObject(object);
  if (box.isEmpty()) return;
  const centre = box.getCenter(new THREE.Vector3());
  const radius = Math.max(box.getSize(new THREE.Vector3()).length() / 2, 1);
  const distance = radius / Math.sin(THREE.MathUtils.degToRad(camera.fov / 2));
  // From the south-east, above (glTF: x east, y up, z south).
  const direction = new THREE.Vector3(0.6, 0.55, 0.9).normalize();
  camera.position.copy(centre).addScaledVector(direction, distance);
  camera.near = distance / 1000;
  camera.far = distance * 100;
  camera.updateProjectionMatrix();
  controls.target.copy(centre);
  controls.update();
}

function swatchColour(node) {
  let colour = null;
  node.traverse((object) => {
    if (!colour && object.material?.color) colour = `#${object.material.color.getHexString(THREE.SRGBColorSpace)}`;
  });
  return colour ?? '#888';
}

// three.js sanitizes node names; the GLB's own name is kept in userData.
function layerName(node) {
  const { shell, threshold, name } = node.userData ?? {};
  if (shell !== undefined && threshold !== undefined) return `shell ${shell} (≥ ${threshold})`;
  return name ?? node.name ?? 'unnamed';
}

function buildLayers(root) {
  const list = $('layer-list');
  list.replaceChildren();
  for (const node of root.children) {
    const item = document.createElement('li');
    const box = document.createElement('input');
    box.type = 'checkbox';
    box.checked = node.visible;
    box.id = `layer-${node.id}`;
    box.addEventListener('change', () => {
      node.visible = box.checked;
    });
    const swatch = document.createElement('span');
    swatch.className = 'swatch';
    swatch.style.background = swatchColour(node);
    const label = document.createElement('label');
    label.htmlFor = box.id;
    label.textContent = layerName(node);
    item.append(box, swatch, label);
    list.append(item);
  }
  $('layers').hidden = root.children.length === 0;
}

// The job's grade–tonnage chart (SVG) beside the bodies; resolves once it is drawn.
async function showChart(href) {
  const section = $('chart');
  const image = $('chart-image');
  if (!href) {
    section.hidden = true;
    viewer.chart = null;
    return;
  }
  image.src = href;
  $('chart-link').href = href;
  section.hidden = false;
  await image.decode();
  viewer.chart = { width: image.naturalWidth, height: image.naturalHeight };
}

// Tonnes and grade of a body or shell from its `resource` (the summary's report).
function resourceCells(resource, units) {
  if (!resource) return ['', ''];
  const tonnes = resource.tonnes == null ? '–' : `${formatNumber(resource.tonnes)} ${units?.tonnes ?? 't'}`;
  const grade = resource.mean_grade == null ? '–' : `${formatNumber(resource.mean_grade)} ${units?.grade ?? ''}`;
  return [tonnes, grade];
}

function buildLegend(summary, root) {
  const rows = $('legend-rows');
  rows.replaceChildren();
  if (!summary) {
    $('legend').hidden = true;
    return;
  }
  const unit = unitLabel(summary.unit);
  const origin = summary.origin ?? [];
  $('legend-origin').textContent =
    `${summary.method ?? ''} · origin ${origin.map((v) => formatNumber(v)).join(', ')}` +
    `${summary.crs ? ` · ${summary.crs}` : ''}`;
  const cell = (text) => {
    const td = document.createElement('td');
    td.textContent = text;
    return td;
  };
  (summary.shells ?? []).forEach((shell, s) => {
    const shellNode = root.children.find((n) => n.userData?.shell === s + 1);
    const head = document.createElement('tr');
    head.className = 'shell';
    const swatch = document.createElement('span');
    swatch.className = 'swatch';
    swatch.style.background = shellNode ? swatchColour(shellNode) : 'transparent';
    const first = cell(` ≥ ${shell.threshold}`);
    first.prepend(swatch);
    head.append(
      first,
      cell(`${shell.bodies.length}`),
      cell(`${formatNumber(shell.volume)} ${unit}³`),
      cell(`${formatNumber(shell.area)} ${unit}²`),
      ...resourceCells(shell.resource, summary.report?.units).map(cell),
      cell(''),
    );
    rows.append(head);
    shell.bodies.forEach((body, b) => {
      const row = document.createElement('tr');
      const bodyNode = shellNode?.children.find((n) => n.userData?.body === b + 1);
      const toggle = cell('');
      if (bodyNode) {
        const box = document.createElement('input');
        box.type = 'checkbox';
        box.checked = bodyNode.visible;
        box.title = `show shell ${s + 1} body ${b + 1}`;
        box.addEventListener('change', () => {
          bodyNode.visible = box.checked;
        });
        toggle.append(box);
      }
      const flags = [body.closed ? '' : 'open', body.truncated ? 'truncated' : '']
        .filter(Boolean)
        .join(', ');
      row.append(
        toggle,
        cell(`${b + 1}`),
        cell(`${formatNumber(body.volume)} ${unit}³`),
        cell(`${formatNumber(body.area)} ${unit}²`),
        ...resourceCells(body.resource, summary.report?.units).map(cell),
        cell(flags),
      );
      rows.append(row);
    });
  });
  $('legend').hidden = false;
}

// ---- start ------------------------------------------------------------------------------

const initial = new URLSearchParams(window.location.search).get('job');
if (initial) {
  viewer.job = initial;
  openJob(initial);
} else {
  overlay('Pick a job');
}
loadJobs();
