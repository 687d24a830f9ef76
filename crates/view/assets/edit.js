// Editing a run's objects: the list of operations of `edits.json` (merge, split_box, split_lasso,
// assign, move, rename), undo and redo, and Save. A Gaussian selection is built by brush strokes
// (front-most only: the rows the index pass shows under the stroke) and grown or shrunk by 3D
// neighbours; the server says which rows it holds (`/api/edits/select`, drawn tinted), and "move"
// appends it, as data (strokes with their camera, steps), to the operations. Gaussians picked by opacity or size (`/api/edits/select`)
// or in front inside a lasso are moved by an `assign` of their rows. Every change asks the server for its effect
// (`POST /api/edits/preview`: the operations applied to the run's own ids by `splatseg apply`'s
// code), which comes back as the objects by slot and each Gaussian's slot; the page then draws
// and lists them. Save writes the list as the run's `edits.json` (`POST /api/edits`).

const LASSO_MAX_VERTICES = 128;
const STROKE_MAX_VERTICES = 256;

function token() {
  return document.querySelector('meta[name="splatseg-token"]')?.content ?? '';
}

async function post(url, body) {
  return fetch(url, {
    method: 'POST',
    headers: { 'Content-Type': 'application/json', 'X-Splatseg-Token': token() },
    body: JSON.stringify(body),
  });
}

// The reply of /api/edits/preview: u32 length L, L bytes of JSON, padding to 4, [N] u32 slots.
function parsePreview(buffer) {
  const view = new DataView(buffer);
  const length = view.getUint32(0, true);
  const head = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, length)));
  const start = Math.ceil((4 + length) / 4) * 4;
  return { ...head, slots: new Uint32Array(buffer, start) };
}

// Keeps at most `max` vertices of a polygon (every k-th).
function thin(polygon, max) {
  if (polygon.length <= max) return polygon;
  const step = polygon.length / max;
  const out = [];
  for (let i = 0; i < max; i++) out.push(polygon[Math.floor(i * step)]);
  return out;
}

export class Editor {
  constructor(viewer, entry) {
    this.viewer = viewer;
    this.inputs = entry.inputs;
    this.path = entry.path;
    this.note = entry.note ?? null;
    this.ops = entry.operations.slice();
    this.nextId = entry.next_id;
    this.undone = [];
    this.saved = JSON.stringify(this.ops);
    this.busy = Promise.resolve();
    this.lastError = null;
    // the Gaussian selection being built: a `move`'s `select` ({objects?, parts, neighbours}), or null
    this.selection = null;
    this.selectionCount = 0;
    this.neighbourRadius = entry.neighbour_radius ?? null;
  }

  get dirty() {
    return JSON.stringify(this.ops) !== this.saved;
  }

  // The pinhole camera the page draws with, as `split_lasso` takes it (canvas pixels).
  lassoCamera() {
    const c = this.viewer.camera;
    const r = c.r;
    return {
      fx: c.fx, fy: c.fy, cx: c.cx, cy: c.cy,
      world_from_cam: [
        [r[0], r[1], r[2], c.c[0]],
        [r[3], r[4], r[5], c.c[1]],
        [r[6], r[7], r[8], c.c[2]],
        [0, 0, 0, 1],
      ],
    };
  }

  // Asks the server for the effect of `ops` and shows it; throws the server's words.
  async preview(ops) {
    const r = await post('/api/edits/preview', { operations: ops });
    if (!r.ok) {
      const answer = await r.json().catch(() => ({}));
      throw new Error(answer.error || `preview failed (HTTP ${r.status})`);
    }
    const preview = parsePreview(await r.arrayBuffer());
    this.viewer.setObjects(preview.objects, preview.slots);
    this.changed = preview.changed;
    this.nextId = preview.next_id;
    return preview;
  }

  // Runs `change` (which edits this.ops) after the changes before it, previews, and undoes it
  // when the server refuses it.
  queue(change) {
    const run = async () => {
      const before = this.ops.slice();
      const beforeUndone = this.undone.slice();
      change();
      try {
        await this.preview(this.ops);
        this.lastError = null;
        if (this.selection) await this.showSelection(this.selection).catch(() => this.clearSelection());
      } catch (e) {
        this.ops = before;
        this.undone = beforeUndone;
        this.lastError = String(e.message || e);
        this.viewer.panel?.editStatus(this.lastError);
        throw e;
      }
      this.viewer.panel?.editStatus();
      return this.state();
    };
    const done = this.busy.then(run, run);
    this.busy = done.catch(() => {});
    return done;
  }

  push(op) {
    return this.queue(() => {
      this.ops.push(op);
      this.undone = [];
    });
  }

  merge(ids) {
    return this.push({ op: 'merge', ids: ids.slice().sort((a, b) => a - b) });
  }

  splitBox(object, box) {
    return this.push({ op: 'split_box', object, box: { centre: box.centre, half_size: box.half_size } });
  }

  // `polygon`: [[x, y], …] in canvas pixels of the current view. `frontMost`: only the Gaussians
  // drawn in front inside the polygon (an `assign` of their rows to a new id).
  splitLasso(object, polygon, frontMost = false) {
    const vertices = thin(polygon, LASSO_MAX_VERTICES).map(([x, y]) => [Math.round(x * 10) / 10, Math.round(y * 10) / 10]);
    if (frontMost) {
      const rows = this.viewer.frontRows(object, vertices);
      if (!rows.length) return Promise.reject(new Error(`no Gaussian of object ${object} is in front inside the lasso`));
      return this.push({ op: 'assign', ranges: rowRanges(rows), id: this.nextId });
    }
    return this.push({ op: 'split_lasso', object, camera: this.lassoCamera(), polygon_px: vertices });
  }

  // Moves the Gaussians of `objects` whose opacity is below `filter.opacity_below` and / or whose
  // largest scale is above `filter.size_above` to a new object, or to none (`toNone`): the server
  // finds their rows (after the operations so far), an `assign` moves them.
  async moveFiltered(objects, filter, toNone = false) {
    await this.busy;
    const r = await post('/api/edits/select', { operations: this.ops, objects, ...filter });
    const answer = await r.json().catch(() => ({}));
    if (!r.ok) throw new Error(answer.error || `selection failed (HTTP ${r.status})`);
    if (!answer.count) throw new Error('no Gaussian of the selected objects passes the filter');
    return this.push({ op: 'assign', ranges: answer.ranges, id: toNone ? -1 : this.nextId });
  }

  // Adds a brush stroke (`stroke`: [[x, y], …] canvas pixels of the current view, `radius` px) to
  // the Gaussian selection; `frontMost`: only the Gaussians drawn in front under it. The first
  // part limits the selection to the selected objects `objects` (none: any Gaussian).
  async addStroke(stroke, radius, frontMost = false, objects = []) {
    if (!(radius > 0)) throw new Error(`the brush radius must be above 0 px, got ${radius}`);
    if (!stroke.length) throw new Error('the brush stroke has no point');
    const points = thin(stroke, STROKE_MAX_VERTICES).map(([x, y]) => [Math.round(x * 10) / 10, Math.round(y * 10) / 10]);
    const selection = this.selection
      ? { ...this.selection, parts: this.selection.parts.slice() }
      : { ...(objects.length ? { objects: objects.slice().sort((a, b) => a - b) } : {}), parts: [], neighbours: [] };
    if (selection.neighbours.length) throw new Error('clear the grown or shrunk selection before painting again');
    if (frontMost) {
      const rows = this.viewer.frontRowsNear(points, radius, selection.objects ?? null);
      if (!rows.length) throw new Error('no Gaussian is drawn in front under the stroke');
      selection.parts.push({ by: 'rows', ranges: rowRanges(rows) });
    } else {
      selection.parts.push({ by: 'brush', camera: this.lassoCamera(), stroke_px: points, radius_px: radius });
    }
    return this.withSelection(selection);
  }

  // Grows (`steps` > 0) or shrinks (< 0) the Gaussian selection by 3D neighbours within `radius`
  // (world units; default: the server's suggestion), one ring per step.
  async growSelection(steps = 1, radius = this.neighbourRadius) {
    if (!this.selection) throw new Error('paint a selection first (Brush)');
    if (!(radius > 0)) throw new Error(`the neighbour radius must be above 0, got ${radius}`);
    const step = steps > 0 ? { grow: radius } : { shrink: radius };
    const more = Array.from({ length: Math.abs(steps) }, () => ({ ...step }));
    return this.withSelection({ ...this.selection, neighbours: [...this.selection.neighbours, ...more] });
  }

  // Asks the server for the rows of `selection` (after the operations) and draws them.
  async showSelection(selection) {
    const r = await post('/api/edits/select', { operations: this.ops, selection });
    const answer = await r.json().catch(() => ({}));
    if (!r.ok) throw new Error(answer.error || `selection failed (HTTP ${r.status})`);
    this.viewer.setPickedRows(answer.ranges);
    this.selectionCount = answer.count;
    return answer;
  }

  async withSelection(selection) {
    await this.busy;
    await this.showSelection(selection);
    this.selection = selection;
    this.viewer.panel?.selectionStatus();
    return this.selectionState();
  }

  clearSelection() {
    this.selection = null;
    this.selectionCount = 0;
    this.viewer.setPickedRows(null);
    this.viewer.panel?.selectionStatus();
  }

  // Moves the Gaussian selection to object `to` (an id, −1: none, 'new': a new object), as a
  // `move` operation, and clears it.
  async moveSelection(to) {
    if (!this.selection) throw new Error('paint a selection first (Brush)');
    if (!this.selectionCount) throw new Error('the selection holds no Gaussian');
    const selection = this.selection;
    const done = await this.push({ op: 'move', select: selection, to });
    this.clearSelection();
    return done;
  }

  selectionState() {
    return { selection: this.selection, count: this.selectionCount };
  }

  rename(id, name) {
    return this.push({ op: 'rename', id, name });
  }

  undo() {
    return this.queue(() => {
      if (this.ops.length) this.undone.push(this.ops.pop());
    });
  }

  redo() {
    return this.queue(() => {
      if (this.undone.length) this.ops.push(this.undone.pop());
    });
  }

  // Writes the operations as the run's edits.json; resolves with {path, operations}.
  async save() {
    await this.busy;
    const r = await post('/api/edits', { inputs: this.inputs, operations: this.ops });
    const answer = await r.json().catch(() => ({}));
    if (!r.ok) throw new Error(answer.error || `save failed (HTTP ${r.status})`);
    this.saved = JSON.stringify(this.ops);
    this.viewer.panel?.editStatus(`saved ${answer.operations} operations to ${answer.path}`);
    return answer;
  }

  state() {
    return { operations: this.ops.slice(), undone: this.undone.length, dirty: this.dirty, error: this.lastError };
  }
}

// Sorted rows as [start, end) ranges.
function rowRanges(rows) {
  const sorted = Uint32Array.from(rows).sort();
  const ranges = [];
  for (const r of sorted) {
    const last = ranges[ranges.length - 1];
    if (last && last[1] === r) last[1] = r + 1;
    else if (!last || last[1] < r) ranges.push([r, r + 1]);
  }
  return ranges;
}
