// The database page: a table of the models (searched, sorted and paged by the server), the
// chosen model in a 3D view (`viewer.js`, imported beside the list so the list need not wait
// for three.js), the gate's report, and a home's semantic map. Every value from the index
// goes into the DOM as text or as an attribute, never as HTML.
const PAGE_ROWS = 100;
const SEARCH_DELAY_MS = 120;
const STATUSES = new Set(['valid', 'invalid', 'failed']);
const list = { q: '', status: '', sort: 'id', descending: false, offset: 0, matched: 0 };
// What the browser tests read: the chosen and the drawn model, its joint nodes, whether it
// has loaded, how many frames were drawn, and what the table shows.
const hm = { ready: false, chosen: null, drawn: null, joints: {}, frames: 0, listed: false, listedMs: null, shown: null };
window.homemodel = hm;

const $ = (id) => document.getElementById(id);
const viewing = import('/viewer.js').then(({ createViewer }) => {
  const viewer = createViewer($('viewer'), $('sliders'), hm);
  viewer.showGrasps($('show-grasps').checked);
  return viewer;
});

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
  hm.drawn = null;
  document.querySelectorAll('#models tbody tr').forEach((tr) => tr.classList.toggle('chosen', tr.dataset.id === id));
  if (decodeURIComponent(location.hash.slice(1)) !== id) history.pushState(null, '', `#${encodeURIComponent(id)}`);
  showMessage($('message'), '');
  const progress = $('progress');
  let viewer = null;
  try {
    viewer = await viewing;
    if (stale()) return;
    viewer.clear();
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
    if (await viewer.show(data, stale)) hm.drawn = id;
  } catch (error) {
    if (error.name === 'AbortError' || stale()) return;
    showMessage($('message'), `cannot show ${id}: ${error.message}`);
  } finally {
    if (!stale()) {
      progress.hidden = true;
      hm.ready = true;
      viewer?.render();
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
$('show-grasps').addEventListener('change', async (event) => { (await viewing).showGrasps(event.target.checked); });

await loadList();
hm.listed = true;
hm.listedMs = performance.now(); // since the page was asked for
fromHash();
const tree = await (await fetch('/api/map')).json();
if (tree && !tree.error) {
  $('map').hidden = false;
  $('tree').replaceChildren(mapItem(tree));
}
