// splatseg view: loads the scene description, streams the Gaussians in chunks, keeps them sorted
// back to front through the worker, draws them and the camera frusta, and holds the object state
// (selection, hidden, colours). `window.viewer` is the page's API, used by the panel and by the
// browser tests.

import { Camera, Controls } from './camera.js';
import { SplatRenderer } from './splats.js';
import { Panel } from './panel.js';
import { Editor } from './edit.js';

const HIDDEN = 1, SELECTED = 2, RECOLOURED = 4, HIGHLIGHT = 8;
// Re-sort when the viewing direction turns by more than ~0.6° or the camera moves more than
// 0.5 % of the scene's size.
const SORT_COS = Math.cos(0.01);
const SORT_MOVE = 0.005;

// fetch with a time limit, tried three times (a stalled connection is given up and reopened).
async function get(url, timeoutMs = 20000) {
  let last = null;
  for (let attempt = 0; attempt < 3; attempt++) {
    const abort = new AbortController();
    const timer = setTimeout(() => abort.abort(), timeoutMs);
    try {
      const r = await fetch(url, { signal: abort.signal, cache: 'no-store' });
      if (!r.ok) throw new Error(`${url}: HTTP ${r.status}`);
      const body = await r.arrayBuffer();
      clearTimeout(timer);
      return body;
    } catch (e) {
      clearTimeout(timer);
      last = e;
      if (!(e && e.name === 'AbortError')) break;
    }
  }
  throw new Error(`${url}: ${last}`);
}

async function text(url) {
  return new TextDecoder().decode(await get(url));
}

class Viewer {
  constructor() {
    this.ready = false;
    this.error = null;
    this.loaded = 0;
    this.sorts = 0;
    this.lastSortMs = 0;
    this.firstFrameMs = null;
    this.palette = false;
    this.frusta = false;
    this.selected = new Set();   // object slots
    this.hidden = new Set();
    this.recoloured = new Map(); // slot → [r, g, b]
    this.box = null;             // the edit box {centre, half_size}, drawn as lines
    this.highlight = -1;
    this.dirty = true;
    this.sortBusy = false;
    this.sortedView = null;
    this.sortedLoaded = 0;
    this.spareIndices = null;
    this.waiters = [];
    this.t0 = performance.now();
  }

  async start() {
    const params = new URLSearchParams(location.search);
    this.native = params.get('canvas') === 'native';
    this.phase = 'fetching the scene description and shaders';
    const [manifest, splatVert, splatFrag, linesVert, linesFrag] = await Promise.all([
      text('/api/scene.json').then((t) => JSON.parse(t)),
      text('/assets/splat.vert'), text('/assets/splat.frag'), text('/assets/lines.vert'), text('/assets/lines.frag'),
    ]);
    this.manifest = manifest;
    this.slotOfId = new Map(manifest.objects.map((o, slot) => [o.id, slot]));
    const [lo, hi] = manifest.bbox;
    this.radius = Math.max(1e-3, Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) / 2);
    this.canvas = document.getElementById('canvas');
    const gl = this.canvas.getContext('webgl2', { antialias: false, alpha: false, preserveDrawingBuffer: true });
    if (!gl) throw new Error('this browser has no WebGL2');
    this.gl = gl;
    this.renderer = new SplatRenderer(gl, { splatVert, splatFrag, linesVert, linesFrag }, manifest.gaussians, manifest.objects.length);
    this.stateBytes = new Uint8Array(4 * manifest.objects.length);
    this.uploadStates();
    this.resize();
    this.camera = new Camera(manifest.cameras[0], this.canvas.width, this.canvas.height);
    const centre = [0, 1, 2].map((k) => 0.5 * (lo[k] + hi[k]));
    const forward = this.camera.axis(2);
    const along = Math.max(0.1 * this.radius, [0, 1, 2].reduce((s, k) => s + (centre[k] - this.camera.c[k]) * forward[k], 0));
    const target = [0, 1, 2].map((k) => this.camera.c[k] + along * forward[k]);
    this.controls = new Controls(this.canvas, this.camera, this.radius, target, () => this.changed(), (x, y, add) => this.click(x, y, add));
    this.updateLines();
    window.addEventListener('resize', () => { this.resize(); this.changed(); });

    this.worker = new Worker('/assets/sort-worker.js');
    this.worker.onmessage = (e) => this.sorted(e.data);
    this.worker.postMessage({ type: 'init', count: manifest.gaussians });
    // names suggested by `view --names`, kept when an edit's preview replaces the objects
    this.suggested = new Map(manifest.objects.filter((o) => o.name !== undefined).map((o) => [o.id, [o.name, o.name_relevancy]]));
    this.editor = manifest.editing ? new Editor(this, manifest.editing) : null;
    // with editing, the page shows what the operations make of the run's own ids (the served PLY
    // may hold ids an earlier apply wrote): asked once everything is loaded
    this.editsShown = !this.editor;
    this.panel = new Panel(this);
    requestAnimationFrame(() => this.frame());
    this.phase = 'loading Gaussians';
    await this.load();
    if (!this.editsShown) {
      this.phase = 'showing the edits';
      await this.editor.preview(this.editor.ops);
      this.editsShown = true;
    }
    this.phase = 'loaded';
  }

  resize() {
    const cam = this.manifest.cameras[0];
    if (this.native) {
      this.canvas.width = cam.width;
      this.canvas.height = cam.height;
      this.canvas.style.width = `${cam.width}px`;
      this.canvas.style.height = `${cam.height}px`;
    } else {
      const box = this.canvas.parentElement.getBoundingClientRect();
      const dpr = window.devicePixelRatio || 1;
      this.canvas.width = Math.max(1, Math.round(box.width * dpr));
      this.canvas.height = Math.max(1, Math.round(box.height * dpr));
      this.canvas.style.width = `${box.width}px`;
      this.canvas.style.height = `${box.height}px`;
    }
    if (this.camera) this.camera.setIntrinsics(this.cameraEntry || cam, this.canvas.width, this.canvas.height);
  }

  // Streams the chunks: each is uploaded to the texture, its centres go to the worker.
  async load() {
    const m = this.manifest;
    this.slotsOfRows = new Uint32Array(m.gaussians);
    for (let k = 0; k < m.chunks; k++) {
      const words = new Uint32Array(await get(`/api/gaussians/${k}.bin`, 60000));
      const offset = k * m.chunk_gaussians;
      const n = words.length / 12;
      this.renderer.uploadChunk(offset, words);
      for (let i = 0; i < n; i++) this.slotsOfRows[offset + i] = words[12 * i + 3];
      this.worker.postMessage({ type: 'positions', offset, words }, [words.buffer]);
      this.loaded = offset + n;
      this.panel.status(`loaded ${this.loaded.toLocaleString()} / ${m.gaussians.toLocaleString()} Gaussians`);
      this.requestSort(true);
    }
  }

  changed() {
    this.dirty = true;
    this.requestSort(false);
  }

  // Asks the worker for a new order if the view moved enough (or `force`) and it is idle.
  requestSort(force) {
    if (this.sortBusy) {
      this.sortPending = this.sortPending || force;
      return;
    }
    const view = this.camera.depthRow();
    const c = this.camera.c.slice();
    const s = this.sortedView;
    const stale = !s || this.sortedLoaded !== this.loaded
      || s.row[0] * view[0] + s.row[1] * view[1] + s.row[2] * view[2] < SORT_COS
      || Math.hypot(c[0] - s.c[0], c[1] - s.c[1], c[2] - s.c[2]) > SORT_MOVE * this.radius;
    if (!force && !stale) return;
    this.sortBusy = true;
    this.sortPending = false;
    this.pendingView = { row: view, c };
    const msg = { type: 'sort', view, loaded: this.loaded };
    if (this.spareIndices) {
      msg.indices = this.spareIndices;
      this.spareIndices = null;
      this.worker.postMessage(msg, [msg.indices.buffer]);
    } else {
      this.worker.postMessage(msg);
    }
  }

  sorted(msg) {
    if (msg.type === 'bench') {
      this.benchDone?.(msg.ms);
      return;
    }
    this.renderer.setOrder(msg.indices, msg.visible);
    this.spareIndices = msg.indices;
    this.sortBusy = false;
    this.sorts++;
    this.lastSortMs = msg.ms;
    this.sortedView = this.pendingView;
    this.sortedLoaded = msg.loaded;
    this.dirty = true;
    if (this.sortPending) this.requestSort(true);
    else this.requestSort(false);
  }

  frame() {
    if (this.dirty) {
      this.dirty = false;
      this.renderer.draw(this.camera, this.palette);
      const complete = this.sortedLoaded === this.manifest.gaussians && !this.sortBusy && this.editsShown;
      if (complete && !this.ready) {
        this.ready = true;
        this.firstFrameMs = performance.now() - this.t0;
        this.panel.status(`${this.manifest.gaussians.toLocaleString()} Gaussians, first frame in ${(this.firstFrameMs / 1000).toFixed(2)} s`);
      }
      if (complete) {
        const waiters = this.waiters;
        this.waiters = [];
        waiters.forEach((w) => w());
      }
    }
    requestAnimationFrame(() => this.frame());
  }

  // Resolves after the next frame drawn with a complete, current sort.
  whenDrawn() {
    this.dirty = true;
    return new Promise((resolve) => this.waiters.push(resolve));
  }

  uploadStates() {
    const bytes = this.stateBytes;
    this.manifest.objects.forEach((o, slot) => {
      const colour = this.recoloured.get(slot) || o.colour;
      let flags = 0;
      if (this.hidden.has(slot)) flags |= HIDDEN;
      if (this.selected.has(slot)) flags |= SELECTED;
      if (this.recoloured.has(slot)) flags |= RECOLOURED;
      if (this.highlight === slot) flags |= HIGHLIGHT;
      bytes.set([colour[0], colour[1], colour[2], flags], 4 * slot);
    });
    this.renderer.setObjectStates(bytes);
    this.dirty = true;
  }

  click(x, y, add) {
    const id = this.pickAt(x, y);
    if (id === null) {
      if (!add) this.select([], false);
    } else {
      this.select([id], add, add);
    }
  }

  // The lines drawn over the splats: the capture's frusta when shown, and the edit box.
  updateLines() {
    const frusta = this.frusta ? this.frustumSegments() : new Float32Array(0);
    const box = this.box ? boxSegments(this.box) : new Float32Array(0);
    const lines = new Float32Array(frusta.length + box.length);
    lines.set(frusta);
    lines.set(box, frusta.length);
    this.renderer.setLines(lines);
    this.dirty = true;
  }

  frustumSegments() {
    const m = this.manifest;
    if (!m.capture_cameras) return new Float32Array(0);
    const out = [];
    const s = 0.08 * this.radius;
    for (const cam of m.cameras) {
      const w = cam.world_from_cam;
      const world = (x, y, z) => [0, 1, 2].map((i) => w[i][0] * x + w[i][1] * y + w[i][2] * z + w[i][3]);
      const corner = (u, v) => world((u - cam.cx) / cam.fx * s, (v - cam.cy) / cam.fy * s, s);
      const o = world(0, 0, 0);
      const k = [corner(0, 0), corner(cam.width, 0), corner(cam.width, cam.height), corner(0, cam.height)];
      for (let i = 0; i < 4; i++) out.push(...o, ...k[i], ...k[i], ...k[(i + 1) % 4]);
    }
    return new Float32Array(out);
  }

  // ---- the API (panel and tests) ----------------------------------------------------------

  ids(slots) {
    return [...slots].map((s) => this.manifest.objects[s].id).sort((a, b) => a - b);
  }

  slots(ids) {
    return ids.map((id) => this.slotOfId.get(id)).filter((s) => s !== undefined);
  }

  state() {
    return {
      ready: this.ready,
      error: this.error,
      phase: this.phase,
      loaded: this.loaded,
      gaussians: this.manifest?.gaussians,
      visible: this.renderer?.visible,
      selected: this.ids(this.selected),
      hidden: this.ids(this.hidden),
      palette: this.palette,
      frusta: this.frusta,
      objects: this.manifest?.objects.map((o) => o.id),
      names: Object.fromEntries((this.manifest?.objects ?? []).filter((o) => o.edited_name).map((o) => [o.id, o.edited_name])),
      edits: this.editor?.state() ?? null,
      picked: this.editor?.selectionState() ?? null,
      mode: this.controls?.mode,
      sorts: this.sorts,
      lastSortMs: this.lastSortMs,
      firstFrameMs: this.firstFrameMs,
      width: this.canvas?.width,
      height: this.canvas?.height,
    };
  }

  // Resolves with the state once the first complete frame is drawn; rejects on an error or
  // after `timeoutMs`.
  whenReady(timeoutMs = 300000) {
    const start = performance.now();
    return new Promise((resolve, reject) => {
      const poll = () => {
        if (this.error) reject(new Error(this.error));
        else if (performance.now() - start > timeoutMs) reject(new Error(`not ready after ${timeoutMs} ms: ${JSON.stringify(this.state())}`));
        else if (this.ready) resolve(this.state());
        else setTimeout(poll, 50);
      };
      poll();
    });
  }

  // The object id under canvas pixel (x, y) from the id pass, or null.
  pickAt(x, y) {
    const slot = this.renderer.pick(this.camera, x, y);
    return slot >= 0 ? this.manifest.objects[slot].id : null;
  }

  // Selects `ids` (replacing the selection, or adding; `toggle` flips ids already selected).
  select(ids, add = false, toggle = false) {
    if (!add) this.selected.clear();
    for (const s of this.slots(ids)) {
      if (toggle && this.selected.has(s)) this.selected.delete(s);
      else this.selected.add(s);
    }
    this.uploadStates();
    this.panel?.refresh();
  }

  hide(ids) {
    this.slots(ids).forEach((s) => this.hidden.add(s));
    this.uploadStates();
    this.panel?.refresh();
  }

  show(ids) {
    this.slots(ids).forEach((s) => this.hidden.delete(s));
    this.uploadStates();
    this.panel?.refresh();
  }

  // Hides every object but `ids`.
  isolate(ids) {
    const keep = new Set(this.slots(ids));
    this.hidden = new Set(this.manifest.objects.map((_, s) => s).filter((s) => !keep.has(s)));
    this.uploadStates();
    this.panel?.refresh();
  }

  showAll() {
    this.hidden.clear();
    this.uploadStates();
    this.panel?.refresh();
  }

  setHighlight(id) {
    this.highlight = id === null ? -1 : (this.slotOfId.get(id) ?? -1);
    this.uploadStates();
  }

  recolour(ids, rgb) {
    this.slots(ids).forEach((s) => (rgb ? this.recoloured.set(s, rgb) : this.recoloured.delete(s)));
    this.uploadStates();
    this.panel?.refresh();
  }

  setPalette(on) {
    this.palette = !!on;
    this.dirty = true;
    this.panel?.refresh();
  }

  setFrusta(on) {
    this.frusta = !!on;
    this.updateLines();
    this.panel?.refresh();
  }

  setMode(mode) {
    this.controls.mode = mode;
    this.panel?.refresh();
  }

  // The edit box ({centre: [x, y, z], half_size: [x, y, z]}, world units) shown as lines, or null.
  setBox(box) {
    this.box = box ? { centre: box.centre.map(Number), half_size: box.half_size.map(Number) } : null;
    this.updateLines();
    this.panel?.refresh();
  }

  // The box around the centres of objects `ids` (their bounding boxes', a little larger), or null.
  boxAround(ids) {
    const objects = ids.map((id) => this.manifest.objects[this.slotOfId.get(id)]).filter((o) => o);
    if (!objects.length) return null;
    const lo = [0, 1, 2].map((k) => Math.min(...objects.map((o) => o.bbox_min[k])));
    const hi = [0, 1, 2].map((k) => Math.max(...objects.map((o) => o.bbox_max[k])));
    const centre = [0, 1, 2].map((k) => 0.5 * (lo[k] + hi[k]));
    const half = [0, 1, 2].map((k) => 0.5 * (hi[k] - lo[k]) * 1.02 + 1e-4);
    return { centre, half_size: half };
  }

  // Replaces the objects (by slot) and every Gaussian's slot (an edit's preview); the selection,
  // hidden objects and colours follow their ids.
  setObjects(objects, slots) {
    const idsOf = (set) => new Set([...set].map((s) => this.manifest.objects[s]?.id));
    const [selected, hidden] = [idsOf(this.selected), idsOf(this.hidden)];
    const recoloured = new Map([...this.recoloured].map(([s, rgb]) => [this.manifest.objects[s]?.id, rgb]));
    for (const o of objects) {
      o.edited_name = o.name ?? null;
      const suggestion = this.suggested.get(o.id);
      if (!o.name && suggestion) [o.name, o.name_relevancy] = suggestion;
      if (!o.name) delete o.name;
    }
    this.manifest.objects = objects;
    this.slotOfId = new Map(objects.map((o, slot) => [o.id, slot]));
    const slotsOf = (ids) => new Set([...ids].map((id) => this.slotOfId.get(id)).filter((s) => s !== undefined));
    this.selected = slotsOf(selected);
    this.hidden = slotsOf(hidden);
    this.recoloured = new Map([...recoloured].filter(([id]) => this.slotOfId.has(id)).map(([id, rgb]) => [this.slotOfId.get(id), rgb]));
    this.highlight = -1;
    this.renderer.setObjectCount(objects.length);
    this.stateBytes = new Uint8Array(4 * objects.length);
    this.slotsOfRows = slots;
    this.uploadRowSlots();
    this.uploadStates();
    this.panel?.rebuildTable();
    this.panel?.refresh();
  }

  // Rows of the Gaussians of object `id` drawn in front at the pixels inside `polygon` (canvas
  // pixels, the current view), by the id pass's rule.
  frontRows(id, polygon) {
    const slot = this.slotOfId.get(id);
    if (slot === undefined) return [];
    const xs = polygon.map((p) => p[0]), ys = polygon.map((p) => p[1]);
    return this.frontRowsIn([Math.min(...xs), Math.min(...ys), Math.max(...xs), Math.max(...ys)],
      (x, y) => insidePolygon(x, y, polygon), new Set([slot]));
  }

  // Rows of the Gaussians drawn in front at the pixels within `radius` of the polyline `stroke`
  // (canvas pixels; one point: a disc), of the objects `ids` (all objects when null).
  frontRowsNear(stroke, radius, ids) {
    const xs = stroke.map((p) => p[0]), ys = stroke.map((p) => p[1]);
    const slots = ids ? new Set(this.slots(ids)) : null;
    return this.frontRowsIn([Math.min(...xs) - radius, Math.min(...ys) - radius, Math.max(...xs) + radius, Math.max(...ys) + radius],
      (x, y) => nearStroke(x, y, stroke, radius), slots);
  }

  // Rows of the Gaussians drawn in front (the index pass) at the pixels of the rectangle
  // [x0, y0, x1, y1] whose centres pass `test`, of the slots in `slots` (any when null).
  frontRowsIn([fx0, fy0, fx1, fy1], test, slots) {
    const x0 = Math.max(0, Math.floor(fx0)), y0 = Math.max(0, Math.floor(fy0));
    const x1 = Math.min(this.canvas.width, Math.ceil(fx1)), y1 = Math.min(this.canvas.height, Math.ceil(fy1));
    if (x1 <= x0 || y1 <= y0) return [];
    const [w, h] = [x1 - x0, y1 - y0];
    const indices = this.renderer.frontIndices(this.camera, x0, y0, w, h);
    const rowSlots = this.slotsOfRows;
    const rows = new Set();
    for (let y = 0; y < h; y++) {
      for (let x = 0; x < w; x++) {
        const i = indices[y * w + x];
        if (i && test(x0 + x + 0.5, y0 + y + 0.5) && (!slots || slots.has(rowSlots[i - 1]))) rows.add(i - 1);
      }
    }
    return [...rows];
  }

  // Marks the rows in `ranges` ([start, end) pairs; null: none) as the Gaussian selection, drawn
  // tinted.
  setPickedRows(ranges) {
    this.pickedRanges = ranges && ranges.length ? ranges : null;
    this.uploadRowSlots();
    this.dirty = true;
  }

  // Uploads every Gaussian's slot, with bit 31 set on the rows of the Gaussian selection.
  uploadRowSlots() {
    let slots = this.slotsOfRows;
    if (this.pickedRanges) {
      slots = slots.slice();
      for (const [start, end] of this.pickedRanges) {
        for (let i = start; i < end; i++) slots[i] = (slots[i] | 0x80000000) >>> 0;
      }
    }
    this.renderer.uploadSlots(0, slots);
  }

  // Moves to capture camera `index` (its intrinsics, scaled to the canvas).
  setCamera(index) {
    const entry = this.manifest.cameras[index];
    this.cameraEntry = entry;
    const fresh = new Camera(entry, this.canvas.width, this.canvas.height);
    this.camera.r = fresh.r;
    this.camera.c = fresh.c;
    this.camera.setIntrinsics(entry, this.canvas.width, this.canvas.height);
    this.changed();
  }

  // The objects ranked against `text` by the server (`/api/find`, with the page's token): [{id, relevancy}].
  async find(text) {
    const token = document.querySelector('meta[name="splatseg-token"]')?.content ?? '';
    const r = await fetch(`/api/find?q=${encodeURIComponent(text)}`, { headers: { 'X-Splatseg-Token': token } });
    const body = await r.json();
    if (!r.ok) throw new Error(body.error || `search failed (${r.status})`);
    return body.matches;
  }

  // Asks the server to write the selection (`extract`), everything else (`remove`), the Gaussians
  // in the edit box or else the selection's box (`crop`), or every Gaussian coloured by its object
  // (`coloured`), with the token the page was served with (the server refuses changes without it).
  async exportSelection(mode = 'extract') {
    const ids = this.ids(this.selected);
    const request = { ids, mode };
    if (mode === 'crop') {
      request.box = this.box || this.boxAround(ids);
      if (!request.box) throw new Error('place a box (Box) or select objects first');
    }
    const token = document.querySelector('meta[name="splatseg-token"]')?.content ?? '';
    const r = await fetch('/api/export', {
      method: 'POST',
      headers: { 'Content-Type': 'application/json', 'X-Splatseg-Token': token },
      body: JSON.stringify(request),
    });
    const answer = await r.json();
    if (!r.ok) throw new Error(answer.error || `export failed (${r.status})`);
    return answer;
  }

  // The canvas as base64 RGB bytes, rows top to bottom (after a complete frame).
  async readPixels() {
    await this.whenDrawn();
    const gl = this.gl;
    const [w, h] = [this.canvas.width, this.canvas.height];
    const rgba = new Uint8Array(4 * w * h);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, rgba);
    const rgb = new Uint8Array(3 * w * h);
    for (let y = 0; y < h; y++) {
      const src = (h - 1 - y) * w * 4, dst = y * w * 3;
      for (let x = 0; x < w; x++) {
        rgb[dst + 3 * x] = rgba[src + 4 * x];
        rgb[dst + 3 * x + 1] = rgba[src + 4 * x + 1];
        rgb[dst + 3 * x + 2] = rgba[src + 4 * x + 2];
      }
    }
    let binary = '';
    for (let i = 0; i < rgb.length; i += 0x8000) binary += String.fromCharCode.apply(null, rgb.subarray(i, i + 0x8000));
    return { width: w, height: h, rgb: btoa(binary) };
  }

  // Times the worker's sort on `count` random centres: milliseconds per sort, `repeats` times.
  benchSort(count, repeats) {
    const worker = new Worker('/assets/sort-worker.js');
    return new Promise((resolve) => {
      worker.onmessage = (e) => {
        worker.terminate();
        resolve(e.data.ms);
      };
      worker.postMessage({ type: 'bench', count, repeats });
    });
  }
}

// The 12 edges of an axis-aligned box as xyz pairs.
function boxSegments(box) {
  const c = box.centre, h = box.half_size;
  const corner = (i) => [0, 1, 2].map((k) => c[k] + ((i >> k) & 1 ? h[k] : -h[k]));
  const out = [];
  for (let i = 0; i < 8; i++) {
    for (let k = 0; k < 3; k++) {
      if (!((i >> k) & 1)) out.push(...corner(i), ...corner(i | (1 << k)));
    }
  }
  return new Float32Array(out);
}

// Whether (x, y) lies within `radius` of the polyline `stroke` (one point: of it), as `splatseg
// apply` tests a brush.
function nearStroke(x, y, stroke, radius) {
  const r2 = radius * radius;
  if (stroke.length === 1) return (x - stroke[0][0]) ** 2 + (y - stroke[0][1]) ** 2 <= r2;
  for (let k = 1; k < stroke.length; k++) {
    const [ax, ay] = stroke[k - 1], [bx, by] = stroke[k];
    const [dx, dy] = [bx - ax, by - ay];
    const len2 = dx * dx + dy * dy;
    const t = len2 > 0 ? Math.min(1, Math.max(0, ((x - ax) * dx + (y - ay) * dy) / len2)) : 0;
    if ((x - ax - t * dx) ** 2 + (y - ay - t * dy) ** 2 <= r2) return true;
  }
  return false;
}

// Even-odd rule, as `splatseg apply` tests a lasso.
function insidePolygon(x, y, polygon) {
  let inside = false;
  for (let i = 0, j = polygon.length - 1; i < polygon.length; j = i++) {
    const [xi, yi] = polygon[i], [xj, yj] = polygon[j];
    if ((yi > y) !== (yj > y) && x < (xj - xi) * (y - yi) / (yj - yi) + xi) inside = !inside;
  }
  return inside;
}

const viewer = new Viewer();
window.viewer = viewer;
viewer.start().catch((e) => {
  viewer.error = String(e && e.message ? e.message : e);
  const status = document.getElementById('status');
  if (status) status.textContent = `error: ${viewer.error}`;
  console.error(e);
});
