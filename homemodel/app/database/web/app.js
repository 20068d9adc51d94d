// The database page: a table of every model, a 3D view with a slider per joint (moving the
// node as the glTF's extras.joint says), the gate's report, and a home's semantic map.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

const state = { rows: [], sortKey: 'id', ascending: true };
// What the browser test reads: the chosen model's joint nodes, and whether it has loaded.
window.homemodel = { ready: false, chosen: null, joints: {} };

const viewer = document.getElementById('viewer');
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
viewer.appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0xf4f4f4);
scene.add(new THREE.HemisphereLight(0xffffff, 0x888888, 2.0));
const sun = new THREE.DirectionalLight(0xffffff, 1.5);
sun.position.set(3, 5, 4);
scene.add(sun);
const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 100);
const controls = new OrbitControls(camera, renderer.domElement);
let current = null;
const graspMarkers = [];

function resize() {
  const { clientWidth: w, clientHeight: h } = viewer;
  renderer.setSize(w, h);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
}
window.addEventListener('resize', resize);
resize();
renderer.setAnimationLoop(() => { controls.update(); renderer.render(scene, camera); });

const text = (value) => (value === null || value === undefined ? '-' : String(value));

function matches(row, words) {
  const hay = [row.id, row.category, row.source, row.status, ...Object.entries(row.properties).map(([k, v]) => `${k}=${v}`)]
    .join(' ').toLowerCase();
  return words.every((w) => hay.includes(w));
}

function renderTable() {
  const words = document.getElementById('search').value.toLowerCase().split(/\s+/).filter(Boolean);
  const key = state.sortKey;
  const rows = state.rows.filter((r) => matches(r, words)).sort((a, b) => {
    const [x, y] = [a[key], b[key]];
    const order = typeof x === 'number' || typeof y === 'number' ? (x ?? -1) - (y ?? -1) : text(x).localeCompare(text(y));
    return state.ascending ? order : -order;
  });
  const body = document.querySelector('#models tbody');
  body.replaceChildren(...rows.map((r) => {
    const tr = document.createElement('tr');
    tr.dataset.id = r.id;
    if (r.id === window.homemodel.chosen) tr.classList.add('chosen');
    const thumb = r.thumbnail ? `<img alt="" src="/db/${r.thumbnail.replace(/^models\//, '')}">` : '';
    tr.innerHTML = `<td>${thumb}</td><td></td><td></td><td></td><td class="${r.status}">${r.status}</td>` +
      `<td>${text(r.triangles)}</td><td>${text(r.joints)}</td><td>${r.build_s.toFixed(2)}</td>`;
    [r.id, r.category, r.source].forEach((v, i) => { tr.children[i + 1].textContent = v; });
    tr.addEventListener('click', () => choose(r.id));
    return tr;
  }));
  document.querySelectorAll('th[data-key]').forEach((th) => {
    th.classList.toggle('sorted', th.dataset.key === key);
    th.classList.toggle('desc', th.dataset.key === key && !state.ascending);
  });
  document.getElementById('summary').textContent = `${rows.length} of ${state.rows.length} models`;
}

function jointSlider(node, joint) {
  const rest = { position: node.position.clone(), quaternion: node.quaternion.clone() };
  const axis = new THREE.Vector3(...joint.axis).normalize();
  const [lower, upper] = joint.type === 'continuous' ? [-Math.PI, Math.PI] : [joint.lower, joint.upper];
  const label = document.createElement('label');
  label.innerHTML = `<span></span><input type="range"><output>0</output>`;
  label.querySelector('span').textContent = `${joint.name} (${joint.type})`;
  const input = label.querySelector('input');
  Object.assign(input, { min: lower, max: upper, step: (upper - lower) / 200, value: 0 });
  input.dataset.joint = joint.name;
  // The joint frame is the child link's frame: move the node about its rest transform.
  input.addEventListener('input', () => {
    const q = Number(input.value);
    if (joint.type === 'prismatic') {
      node.position.copy(rest.position).add(axis.clone().multiplyScalar(q).applyQuaternion(rest.quaternion));
    } else {
      node.quaternion.copy(rest.quaternion).multiply(new THREE.Quaternion().setFromAxisAngle(axis, q));
    }
    label.querySelector('output').textContent = joint.type === 'prismatic' ? `${q.toFixed(3)} m` : `${(q * 180 / Math.PI).toFixed(0)}°`;
  });
  return label;
}

function addGraspMarkers(root) {
  const info = root.userData.homemodel || {};
  for (const g of info.grasp_points || []) {
    const link = root.getObjectByName(g.link);
    if (!link) continue;
    const marker = new THREE.Mesh(new THREE.SphereGeometry(0.012), new THREE.MeshBasicMaterial({ color: 0xff2266 }));
    marker.add(new THREE.AxesHelper(0.05));
    marker.position.fromArray(g.translation || [0, 0, 0]);
    marker.quaternion.fromArray(g.rotation || [0, 0, 0, 1]);
    marker.name = `grasp:${g.name}`;
    marker.visible = document.getElementById('show-grasps').checked;
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
}

async function choose(id) {
  window.homemodel.ready = false;
  window.homemodel.chosen = id;
  renderTable();
  const row = await (await fetch(`/api/models/${encodeURIComponent(id)}`)).json();
  document.getElementById('title').textContent = `${row.id} — ${row.category} (${row.source}, ${row.status})`;
  const facts = [`built ${row.built_at} in ${row.build_s.toFixed(2)} s`, `links ${text(row.links)}, joints ${text(row.joints)}, ` +
    `grasp points ${text(row.grasp_points)}, triangles ${text(row.triangles)}`];
  Object.entries(row.properties).forEach(([k, v]) => facts.push(`${k} = ${v}`));
  row.repairs.forEach((r) => facts.push(`repaired ${r}`));
  if (row.error) facts.push(`error: ${row.error}`);
  document.getElementById('facts').textContent = facts.join('\n');
  document.getElementById('report').textContent = row.validation ||
    row.checks.map((c) => `${c.passed ? 'PASS' : 'FAIL'}  ${c.name}  ${c.detail}`).join('\n') || '(no report)';
  const sliders = document.getElementById('sliders');
  sliders.replaceChildren();
  if (current) scene.remove(current);
  current = null;
  graspMarkers.length = 0;
  window.homemodel.joints = {};
  if (!row.path) { window.homemodel.ready = true; return; }
  const gltf = await new GLTFLoader().loadAsync(`/db/${row.path.replace(/^models\//, '')}/model.glb`);
  current = gltf.scene;
  scene.add(current);
  current.traverse((node) => {
    const joint = node.userData.joint;
    if (joint && joint.type !== 'fixed') {
      window.homemodel.joints[joint.name] = node;
      sliders.appendChild(jointSlider(node, joint));
    }
  });
  const root = current.children.find((c) => c.userData.homemodel) || current;
  addGraspMarkers(root);
  frame(current);
  window.homemodel.ready = true;
}

function mapItem(node) {
  const li = document.createElement('li');
  const name = node.model ? Object.assign(document.createElement('a'), { href: '#', textContent: node.id }) : document.createTextNode(node.id);
  if (node.model) name.addEventListener('click', (event) => { event.preventDefault(); choose(node.model); });
  li.append(name, ` — ${node.kind}: ${node.type}`);
  if (node.children.length) {
    const ul = document.createElement('ul');
    ul.append(...node.children.map(mapItem));
    li.append(ul);
  }
  return li;
}

document.getElementById('search').addEventListener('input', renderTable);
document.querySelectorAll('th[data-key]').forEach((th) => th.addEventListener('click', () => {
  state.ascending = state.sortKey === th.dataset.key ? !state.ascending : true;
  state.sortKey = th.dataset.key;
  renderTable();
}));
document.getElementById('show-grasps').addEventListener('change', (event) => {
  graspMarkers.forEach((m) => { m.visible = event.target.checked; });
});

state.rows = await (await fetch('/api/models')).json();
renderTable();
const tree = await (await fetch('/api/map')).json();
if (tree) {
  document.getElementById('map').hidden = false;
  document.getElementById('tree').replaceChildren(mapItem(tree));
}
window.homemodel.listed = true;
