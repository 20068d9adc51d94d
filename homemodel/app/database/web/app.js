// The database page: a table of the models (searched, sorted and paged by the server), a 3D
// view with a slider per joint (moving the node as the glTF's extras.joint says), the gate's
// report, and a home's semantic map. Every value from the index goes into the DOM as text or
// as an attribute, never as HTML. The view is drawn only when something changed.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

const PAGE_ROWS = 100;
const SEARCH_DELAY_MS = 120;
const STATUSES = new Set(['valid', 'invalid', 'failed']);
const list = { q: '', status: '', sort: 'id', descending: false, offset: 0, matched: 0 };
// What the browser tests read: the chosen and the drawn model, its joint nodes, whether it
// has loaded, how many frames were drawn, and what the table shows.
const hm = { ready: false, chosen: null, drawn: null, joints: {}, frames: 0, listed: false, shown: null };
window.homemodel = hm;

const $ = (id) => document.getElementById(id);
const viewer = $('viewer');
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
viewer.prepend(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0xf4f4f4);
scene.add(new THREE.HemisphereLight(0xffffff, 0x888888, 2.0));
const sun = new THREE.DirectionalLight(0xffffff, 1.5);
sun.position.set(3, 5, 4);
scene.add(sun);
const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 100);
const controls = new OrbitControls(camera, renderer.domElement);
hm.memory = () => renderer.info.memory; // geometries and textures held on the GPU
let current = null;
const graspMarkers = [];

let frameQueued = false;
function render() {
  if (frameQueued) return;
  frameQueued = true;
  requestAnimationFrame(() => {
    frameQueued = false;
    renderer.render(scene, camera);
    hm.frames += 1;
  });
}
controls.addEventListener('change', render);

function resize() {
  const { clientWidth: w, clientHeight: h } = viewer;
  if (!w || !h) return;
  renderer.setSize(w, h);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
  render();
}
new ResizeObserver(resize).observe(viewer);

const text = (value) => (value === null || value === undefined ? '-' : String(value));
const fixed = (value, digits) => (typeof value === 'number' ? value.toFixed(digits) : '-');

function cell(value, className) {
  const td = document.createElement('td');
  td.textContent = value;
  td.title = value; // the whole text where the column cuts it
  if (className) td.className = className;
  return td;
}

function rowElement(row) {
  const tr = document.createElement('tr');
  tr.dataset.id = row.id;
  tr.tabIndex = 0;
  if (row.id === hm.chosen) tr.classList.add('chosen');
  const thumb = document.createElement('td');
  if (typeof row.thumbnail === 'string' && row.thumbnail.startsWith('/db/')) {
    const img = Object.assign(document.createElement('img'), { alt: '', loading: 'lazy' });
    img.src = row.thumbnail;
    thumb.append(img);
  }
  const status = String(row.status);
  tr.append(thumb, cell(text(row.id)), cell(text(row.category)), cell(text(row.source), 'source'),
    cell(status, STATUSES.has(status) ? status : 'unknown'), cell(text(row.triangles), 'number'),
    cell(text(row.joints), 'number'), cell(fixed(row.build_s, 2), 'number build'));
  if (row.error) tr.title = String(row.error);
  return tr;
}

function showTable(page) {
  list.matched = page.matched;
  $('models').tBodies[0].replaceChildren(...page.rows.map(rowElement));
  document.querySelectorAll('th[data-key]').forEach((th) => {
    th.classList.toggle('sorted', th.dataset.key === list.sort);
    th.classList.toggle('desc', th.dataset.key === list.sort && list.descending);
    th.setAttribute('aria-sort', th.dataset.key !== list.sort ? 'none' : list.descending ? 'descending' : 'ascending');
  });
  const last = Math.min(page.offset + page.rows.length, page.matched);
  $('page').textContent = page.matched ? `${page.offset + 1}-${last} of ${page.matched}` : 'none';
  $('previous').disabled = page.offset === 0;
  $('next').disabled = last >= page.matched;
  $('summary').textContent = `${page.matched} of ${page.total} models`;
  hm.shown = { q: list.q, status: list.status, sort: list.sort, offset: page.offset, rows: page.rows.length, matched: page.matched };
}

function showMessage(element, message) {
  element.textContent = message || '';
  element.hidden = !message;
}

// Only the newest list request is shown: an older one is aborted, and ignored if it answers.
let listController = null;
async function loadList() {
  listController?.abort();
  const controller = new AbortController();
  listController = controller;
  const params = new URLSearchParams({
    q: list.q, sort: list.sort, order: list.descending ? 'desc' : 'asc', offset: list.offset, limit: PAGE_ROWS,
  });
  if (list.status) params.set('status', list.status);
  try {
    const response = await fetch(`/api/models?${params}`, { signal: controller.signal });
    const page = await response.json();
    if (controller !== listController) return;
    if (!response.ok) throw new Error(page.error || `HTTP ${response.status}`);
    showMessage($('list-message'), '');
    showTable(page);
  } catch (error) {
    if (error.name !== 'AbortError' && controller === listController) {
      showMessage($('list-message'), `cannot list the models: ${error.message}`);
    }
  }
}

function jointSlider(node, joint) {
  const rest = { position: node.position.clone(), quaternion: node.quaternion.clone() };
  const axis = new THREE.Vector3(...joint.axis).normalize();
  const [lower, upper] = joint.type === 'continuous' ? [-Math.PI, Math.PI] : [Number(joint.lower), Number(joint.upper)];
  const label = document.createElement('label');
  const name = Object.assign(document.createElement('span'), { textContent: `${joint.name} (${joint.type})` });
  const input = Object.assign(document.createElement('input'), { type: 'range', min: lower, max: upper, step: (upper - lower) / 200 });
  input.value = 0;
  input.dataset.joint = joint.name;
  const output = Object.assign(document.createElement('output'), { textContent: '0' });
  label.append(name, input, output);
  // The joint frame is the child link's frame: move the node about its rest transform.
  input.addEventListener('input', () => {
    const q = Number(input.value);
    if (joint.type === 'prismatic') {
      node.position.copy(rest.position).add(axis.clone().multiplyScalar(q).applyQuaternion(rest.quaternion));
    } else {
      node.quaternion.copy(rest.quaternion).multiply(new THREE.Quaternion().setFromAxisAngle(axis, q));
    }
    output.textContent = joint.type === 'prismatic' ? `${q.toFixed(3)} m` : `${(q * 180 / Math.PI).toFixed(0)}°`;
    render();
  });
  return label;
}

function addGraspMarkers(root) {
  const info = root.userData.homemodel || {};
  for (const g of Array.isArray(info.grasp_points) ? info.grasp_points : []) {
    const link = root.getObjectByName(g.link);
    if (!link) continue;
    const marker = new THREE.Mesh(new THREE.SphereGeometry(0.012), new THREE.MeshBasicMaterial({ color: 0xff2266 }));
    marker.add(new THREE.AxesHelper(0.05));
    marker.position.fromArray(g.translation || [0, 0, 0]);
    marker.quaternion.fromArray(g.rotation || [0, 0, 0, 1]);
    marker.name = `grasp:${g.name}`;
    marker.visible = $('show-grasps').checked;
    link.add(marker);
    graspMarkers.push(marker);
  }
}

function frame(object) {
  const box = new THREE.Box3().setFromObject(object);
  const centre = box.getCenter(new THREE.Vector3());
  const radius = box.getSize(new THREE.Vector3()).length() / 2 || 1;
  controls.target.copy(centre);
  // The front is +x of the model, which glTF's y-up root turns to three.js's +x.
  camera.position.copy(centre).add(new THREE.Vector3(1.6, 0.9, 1.2).multiplyScalar(radius * 1.4));
  camera.near = radius / 100;
  camera.far = radius * 100;
  camera.updateProjectionMatrix();
  controls.update();
}

// Frees what a model holds on the GPU: geometries, materials and their textures.
function dispose(root) {
  root.traverse((object) => {
    object.geometry?.dispose();
    const materials = Array.isArray(object.material) ? object.material : object.material ? [object.material] : [];
    for (const material of materials) {
      for (const value of Object.values(material)) {
        if (value && value.isTexture) {
          value.source?.data?.close?.(); // an ImageBitmap
          value.dispose();
        }
      }
      material.dispose();
    }
  });
}

function clearModel() {
  if (current) {
    scene.remove(current);
    dispose(current);
  }
  current = null;
  hm.drawn = null;
  graspMarkers.length = 0;
  hm.joints = {};
  $('sliders').replaceChildren();
  render();
}

function showFacts(row) {
  $('title').textContent = `${row.id} — ${row.category} (${row.source}, ${row.status})`;
  const facts = [`built ${text(row.built_at)} in ${fixed(row.build_s, 2)} s`, `links ${text(row.links)}, joints ${text(row.joints)}, `
    + `grasp points ${text(row.grasp_points)}, triangles ${text(row.triangles)}`];
  Object.entries(row.properties || {}).forEach(([k, v]) => facts.push(`${k} = ${v}`));
  (row.repairs || []).forEach((r) => facts.push(`repaired ${r}`));
  if (row.error) facts.push(`error: ${row.error}`);
  $('facts').textContent = facts.join('\n');
  $('report').textContent = row.validation
    || (row.checks || []).map((c) => `${c.passed ? 'PASS' : 'FAIL'}  ${c.name}  ${c.detail}`).join('\n') || '(no report)';
}

// The glb, read with progress; `signal` aborts it when another model is chosen.
async function fetchModel(url, signal) {
  const response = await fetch(url, { signal });
  if (!response.ok) throw new Error(response.status === 404 ? 'the model file is missing' : `HTTP ${response.status}`);
  const size = Number(response.headers.get('content-length')) || 0;
  const reader = response.body.getReader();
  const chunks = [];
  let received = 0;
  for (;;) {
    const { done, value } = await reader.read();
    if (done) break;
    chunks.push(value);
    received += value.length;
    if (size) $('progress').value = received / size;
  }
  return new Blob(chunks).arrayBuffer();
}

// Each choice aborts the one before; a load that finishes after another choice is dropped.
let modelController = null;
async function choose(id) {
  modelController?.abort();
  const controller = new AbortController();
  modelController = controller;
  const stale = () => controller !== modelController;
  hm.ready = false;
  hm.chosen = id;
  document.querySelectorAll('#models tbody tr').forEach((tr) => tr.classList.toggle('chosen', tr.dataset.id === id));
  if (decodeURIComponent(location.hash.slice(1)) !== id) history.pushState(null, '', `#${encodeURIComponent(id)}`);
  clearModel();
  showMessage($('message'), '');
  const progress = $('progress');
  try {
    const response = await fetch(`/api/models/${encodeURIComponent(id)}`, { signal: controller.signal });
    if (!response.ok) throw new Error(response.status === 404 ? `no model ${id} in the database` : `HTTP ${response.status}`);
    const row = await response.json();
    if (stale()) return;
    showFacts(row);
    if (!row.glb) throw new Error(`${id} was not built (${row.status}): there is no model to show`);
    progress.value = 0;
    progress.hidden = false;
    const data = await fetchModel(row.glb, controller.signal);
    if (stale()) return;
    const gltf = await new GLTFLoader().parseAsync(data, '');
    if (stale()) {
      dispose(gltf.scene);
      return;
    }
    current = gltf.scene;
    scene.add(current);
    current.traverse((node) => {
      const joint = node.userData.joint;
      if (joint && joint.type !== 'fixed' && Array.isArray(joint.axis)) {
        hm.joints[joint.name] = node;
        $('sliders').appendChild(jointSlider(node, joint));
      }
    });
    addGraspMarkers(current.children.find((c) => c.userData.homemodel) || current);
    frame(current);
    hm.drawn = id;
  } catch (error) {
    if (error.name === 'AbortError' || stale()) return;
    showMessage($('message'), `cannot show ${id}: ${error.message}`);
  } finally {
    if (!stale()) {
      progress.hidden = true;
      hm.ready = true;
      render();
    }
  }
}

function mapItem(node) {
  const li = document.createElement('li');
  const name = node.model
    ? Object.assign(document.createElement('a'), { href: `#${encodeURIComponent(node.model)}`, textContent: node.id })
    : document.createTextNode(node.id);
  li.append(name, ` — ${node.kind}: ${node.type}`);
  if (node.children.length) {
    const ul = document.createElement('ul');
    ul.append(...node.children.map(mapItem));
    li.append(ul);
  }
  return li;
}

function fromHash() {
  const id = decodeURIComponent(location.hash.slice(1));
  if (id && id !== hm.chosen) choose(id);
}
window.addEventListener('hashchange', fromHash);
window.addEventListener('popstate', fromHash);

let searchTimer = null;
$('search').addEventListener('input', (event) => {
  clearTimeout(searchTimer);
  searchTimer = setTimeout(() => {
    list.q = event.target.value;
    list.offset = 0;
    loadList();
  }, SEARCH_DELAY_MS);
});
$('status').addEventListener('change', (event) => {
  list.status = event.target.value;
  list.offset = 0;
  loadList();
});
document.querySelectorAll('th[data-key] button').forEach((button) => button.addEventListener('click', () => {
  const key = button.parentElement.dataset.key;
  list.descending = list.sort === key ? !list.descending : false;
  list.sort = key;
  list.offset = 0;
  loadList();
}));
$('previous').addEventListener('click', () => { list.offset = Math.max(0, list.offset - PAGE_ROWS); loadList(); });
$('next').addEventListener('click', () => { list.offset += PAGE_ROWS; loadList(); });

// Rows: a click or Enter/Space chooses one; the arrow keys move between rows.
const tbody = $('models').tBodies[0];
tbody.addEventListener('click', (event) => {
  const tr = event.target.closest('tr');
  if (tr) choose(tr.dataset.id);
});
tbody.addEventListener('keydown', (event) => {
  const tr = event.target.closest('tr');
  if (!tr) return;
  if (event.key === 'Enter' || event.key === ' ') {
    event.preventDefault();
    choose(tr.dataset.id);
  } else if (event.key === 'ArrowDown' || event.key === 'ArrowUp') {
    event.preventDefault();
    (event.key === 'ArrowDown' ? tr.nextElementSibling : tr.previousElementSibling)?.focus();
  }
});
$('show-grasps').addEventListener('change', (event) => {
  graspMarkers.forEach((m) => { m.visible = event.target.checked; });
  render();
});

await loadList();
hm.listed = true;
fromHash();
const tree = await (await fetch('/api/map')).json();
if (tree && !tree.error) {
  $('map').hidden = false;
  $('tree').replaceChildren(mapItem(tree));
}
