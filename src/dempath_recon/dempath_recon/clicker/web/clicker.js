// dempath clicker page: both cameras side by side, click a marker centre, zoom, undo, step.
// Image coordinates: pixel centres at integers (OpenCV); a pixel i covers [i - 0.5, i + 0.5].
// A view maps canvas CSS pixels to image coordinates: x = ox + cx / s - 0.5.
'use strict';

// The session token comes in the address's fragment (#token=...), printed on the terminal
// only: a fragment is never sent to the server, and the page never contains the token.
const TOKEN = (() => {
  const given = new URLSearchParams(location.hash.slice(1)).get('token');
  if (given) {
    sessionStorage.setItem('clicker-token', given);
    history.replaceState(null, '', location.pathname + location.search);
  }
  return given || sessionStorage.getItem('clicker-token') || '';
})();
const COLOURS = ['#ff5050', '#50ff50', '#50a0ff', '#ffd030', '#ff50ff', '#50ffff', '#ff9040',
                 '#b080ff', '#a0ff60', '#ff80b0', '#40ffb0', '#ffffff', '#c0c040', '#40c0c0',
                 '#c08040'];
const state = { session: null, frame: 0, data: null, views: [], images: [], updates: 0 };
window.clicker = state;  // for the browser test and the curious

const $ = (id) => document.getElementById(id);

function status(text, isError = false) {
  $('status').textContent = text;
  $('status').className = isError ? 'error' : '';
}

async function post(path, body) {
  const reply = await fetch(path, {
    method: 'POST', body: JSON.stringify(body),
    headers: { 'Content-Type': 'application/json', 'X-Clicker-Token': TOKEN } });
  const value = await reply.json();
  if (!reply.ok) { status(value.error || reply.statusText, true); return null; }
  state.data = value;
  state.updates += 1;
  draw();
  return value;
}

function colour(marker) { return COLOURS[(marker - 1 + COLOURS.length) % COLOURS.length]; }

function fit(view) {
  const [w, h] = state.session.sizes[view.camera];
  const rect = view.canvas.getBoundingClientRect();
  view.s = Math.min(rect.width / w, rect.height / h);
  view.ox = (w - rect.width / view.s) / 2;
  view.oy = (h - rect.height / view.s) / 2;
}

function toImage(view, cx, cy) {
  return [view.ox + cx / view.s - 0.5, view.oy + cy / view.s - 0.5];
}

function toCanvas(view, x, y) {
  return [(x + 0.5 - view.ox) * view.s, (y + 0.5 - view.oy) * view.s];
}

function makeView(camera) {
  const box = document.createElement('div');
  box.className = 'view';
  const title = document.createElement('h3');
  const [w, h] = state.session.sizes[camera];
  title.textContent = `${state.session.cameras[camera]} (${w}x${h} px)`;
  const canvas = document.createElement('canvas');
  canvas.id = `canvas${camera}`;
  box.append(title, canvas);
  $('views').append(box);
  const view = { camera, canvas, s: 1, ox: 0, oy: 0, drag: null, cursor: null };
  canvas.addEventListener('contextmenu', (e) => e.preventDefault());
  canvas.addEventListener('wheel', (e) => { e.preventDefault(); wheel(view, e); },
                          { passive: false });
  canvas.addEventListener('mousedown', (e) => {
    view.drag = { x: e.clientX, y: e.clientY, moved: false, pan: e.button !== 0 || e.shiftKey };
  });
  canvas.addEventListener('mousemove', (e) => move(view, e));
  canvas.addEventListener('mouseup', (e) => release(view, e));
  canvas.addEventListener('mouseleave', () => { view.drag = null; view.cursor = null; draw(); });
  return view;
}

function local(view, e) {
  const rect = view.canvas.getBoundingClientRect();
  return [e.clientX - rect.left, e.clientY - rect.top];
}

function wheel(view, e) {
  const [cx, cy] = local(view, e);
  const [x, y] = toImage(view, cx, cy);
  const factor = Math.exp(-e.deltaY * (e.deltaMode === 1 ? 0.1 : 0.002));
  view.s = Math.min(64, Math.max(0.05, view.s * factor));
  view.ox = x + 0.5 - cx / view.s;  // the image point under the cursor stays there
  view.oy = y + 0.5 - cy / view.s;
  draw();
}

function move(view, e) {
  view.cursor = local(view, e);
  const d = view.drag;
  if (d && (Math.abs(e.clientX - d.x) + Math.abs(e.clientY - d.y) > 3 || d.moved) && d.pan) {
    view.ox -= (e.clientX - d.x) / view.s;
    view.oy -= (e.clientY - d.y) / view.s;
    d.x = e.clientX; d.y = e.clientY; d.moved = true;
  }
  draw();
}

function release(view, e) {
  const d = view.drag;
  view.drag = null;
  if (!d || d.moved || d.pan || e.button !== 0) return;
  const [cx, cy] = local(view, e);
  const [x, y] = toImage(view, cx, cy);
  const marker = Number($('marker').value);
  post('/api/click', { frame: state.frame, camera: view.camera, marker, x, y }).then((ok) => {
    if (ok) status(`marker ${marker} on ${state.session.cameras[view.camera]}: ` +
                   `(${x.toFixed(2)}, ${y.toFixed(2)}) px, saved`);
  });
}

function drawCross(ctx, view, x, y, text, style, dashed) {
  const [cx, cy] = toCanvas(view, x, y);
  ctx.strokeStyle = style; ctx.fillStyle = style; ctx.lineWidth = 1.5;
  ctx.setLineDash(dashed ? [4, 3] : []);
  ctx.beginPath();
  if (dashed) {
    ctx.arc(cx, cy, Math.max(7, 5 * view.s), 0, 2 * Math.PI);
  } else {
    ctx.moveTo(cx - 9, cy); ctx.lineTo(cx - 2, cy); ctx.moveTo(cx + 2, cy); ctx.lineTo(cx + 9, cy);
    ctx.moveTo(cx, cy - 9); ctx.lineTo(cx, cy - 2); ctx.moveTo(cx, cy + 2); ctx.lineTo(cx, cy + 9);
  }
  ctx.stroke();
  if (text) ctx.fillText(text, cx + 8, cy - 8);
}

function drawView(view) {
  const canvas = view.canvas, dpr = window.devicePixelRatio || 1;
  const rect = canvas.getBoundingClientRect();
  if (canvas.width !== Math.round(rect.width * dpr)) {
    canvas.width = Math.round(rect.width * dpr); canvas.height = Math.round(rect.height * dpr);
  }
  const ctx = canvas.getContext('2d');
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  const img = state.images[view.camera];
  ctx.setTransform(dpr * view.s, 0, 0, dpr * view.s, -dpr * view.s * view.ox,
                   -dpr * view.s * view.oy);
  ctx.imageSmoothingEnabled = view.s < 2;
  if (img && img.complete && img.naturalWidth) ctx.drawImage(img, 0, 0);
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.font = '12px system-ui';
  if (!img || img.failed) { ctx.fillStyle = '#888'; ctx.fillText('no image in this frame', 12, 20); }
  const cam = state.session.cameras[view.camera];
  for (const d of (state.data ? state.data.detections : []).filter((d) => d.camera === cam)) {
    drawCross(ctx, view, d.x, d.y, d.marker > 0 ? `(${d.marker})` : '', '#00e5ff', true);
  }
  for (const c of (state.data ? state.data.clicks : []).filter((c) => c.camera === cam)) {
    drawCross(ctx, view, c.x, c.y, String(c.marker), colour(c.marker), false);
  }
  if (view.cursor) {
    const [x, y] = toImage(view, ...view.cursor);
    ctx.fillStyle = '#fff'; ctx.setLineDash([]);
    ctx.fillText(`(${x.toFixed(2)}, ${y.toFixed(2)}) px  zoom ${view.s.toFixed(2)}`, 8, rect.height - 8);
  }
}

function drawTable() {
  const body = $('table').querySelector('tbody');
  body.replaceChildren();
  for (const c of state.data ? state.data.clicks : []) {
    const row = document.createElement('tr');
    for (const v of [c.camera, c.marker, c.x.toFixed(2), c.y.toFixed(2)]) {
      const td = document.createElement('td'); td.textContent = v; row.append(td);
    }
    const del = document.createElement('button');
    del.textContent = '\u00d7'; del.title = 'delete this click';
    del.onclick = () => post('/api/delete', { frame: state.frame, marker: c.marker,
      camera: state.session.cameras.indexOf(c.camera) });
    const td = document.createElement('td'); td.append(del); row.append(td);
    body.append(row);
  }
  $('undo').disabled = !(state.data && state.data.can_undo);
}

function draw() { state.views.forEach(drawView); drawTable(); }

async function show(frame) {
  const n = state.session.n_frames;
  state.frame = Math.min(n - 1, Math.max(0, Number(frame) || 0));
  $('frame').value = state.frame;
  state.images = state.session.cameras.map((_, camera) => {
    const img = new Image();
    img.onload = draw;
    img.onerror = () => { img.failed = true; draw(); };
    img.src = `/image/${camera}/${state.frame}`;
    return img;
  });
  const reply = await fetch(`/api/frame/${state.frame}`);
  state.data = await reply.json();
  draw();
}

function step(delta) { show(state.frame + delta); }

function keys(e) {
  if (e.target.tagName === 'INPUT' && e.target.type === 'number') return;
  const view = state.views[0];
  if ((e.ctrlKey || e.metaKey) && e.key === 'z') { e.preventDefault(); post('/api/undo', { frame: state.frame }); }
  else if (e.key === 'ArrowRight' || e.key === '.') step(1);
  else if (e.key === 'ArrowLeft' || e.key === ',') step(-1);
  else if (e.key === 'Home') show(0);
  else if (e.key === 'End') show(state.session.n_frames - 1);
  else if (e.key === 'a') acceptAll();
  else if (e.key === '0') { state.views.forEach(fit); draw(); }
  else if (e.key === 'm') { const s = $('marker'); s.selectedIndex = (s.selectedIndex + 1) % s.length; }
  else if (view && (e.key === '+' || e.key === '-')) {
    for (const v of state.views) {
      const r = v.canvas.getBoundingClientRect();
      wheel(v, { clientX: r.left + r.width / 2, clientY: r.top + r.height / 2,
                 deltaY: e.key === '+' ? -200 : 200, deltaMode: 0 });
    }
  }
}

async function acceptAll() {
  for (let camera = 0; camera < state.session.cameras.length; camera++) {
    await post('/api/accept', { frame: state.frame, camera });
  }
}

async function importFile(file) {
  const text = await file.text();
  const ok = await post('/api/import', { frame: state.frame, name: file.name, text });
  if (ok) status(`imported ${file.name}; ${ok.n_clicks} clicks in the session, saved`);
  $('import').value = '';
}

async function start() {
  state.session = await (await fetch('/api/session')).json();
  const s = state.session;
  $('source').textContent = s.source;
  $('nframes').textContent = s.n_frames - 1;
  $('frame').max = s.n_frames - 1;
  $('clickfile').textContent = s.click_file;
  for (const m of s.markers) $('marker').add(new Option(String(m), String(m)));
  state.views = s.cameras.map((_, camera) => makeView(camera));
  state.views.forEach(fit);
  if (s.warnings.length) status(s.warnings.join('; '));
  $('first').onclick = () => show(0);
  $('prev').onclick = () => step(-1);
  $('next').onclick = () => step(1);
  $('last').onclick = () => show(s.n_frames - 1);
  $('frame').onchange = () => show($('frame').value);
  $('undo').onclick = () => post('/api/undo', { frame: state.frame });
  $('accept').onclick = acceptAll;
  $('fit').onclick = () => { state.views.forEach(fit); draw(); };
  $('import').onchange = (e) => { if (e.target.files.length) importFile(e.target.files[0]); };
  document.addEventListener('keydown', keys);
  window.addEventListener('resize', draw);
  await show(0);
  state.ready = true;
}

start();
