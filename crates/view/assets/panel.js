// The side panel: view toggles, the object table (id, palette colour, the name given by an edit or
// suggested by `view --names`, Gaussian count, bounding box), selection actions, export, the edit
// tools of a run (merge, split by a box or a lasso, a Gaussian selection painted with a brush, grown
// or shrunk and moved to an object, rename, undo, redo, save), and the strip of
// the capture's overlays (a click there selects the object under it in 3D).

function el(tag, attrs = {}, children = []) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === 'text') e.textContent = v;
    else if (k.startsWith('on')) e.addEventListener(k.slice(2), v);
    else e.setAttribute(k, v);
  }
  children.forEach((c) => e.appendChild(c));
  return e;
}

const hex = (rgb) => '#' + rgb.map((v) => v.toString(16).padStart(2, '0')).join('');
const fmt = (v) => v.map((x) => x.toFixed(2)).join(', ');

export class Panel {
  constructor(viewer) {
    this.viewer = viewer;
    const m = viewer.manifest;
    document.getElementById('title').textContent = `${m.name} · ${m.gaussians.toLocaleString()} Gaussians · ${m.objects.length} objects`;
    this.buildControls();
    this.buildTable();
    this.buildStrip();
    this.refresh();
  }

  status(text) {
    document.getElementById('status').textContent = text;
  }

  buildControls() {
    const v = this.viewer;
    const box = document.getElementById('controls');
    const button = (id, label, action) => el('button', { id, text: label, onclick: action });
    const cameras = el('select', { id: 'camera-select', onchange: (e) => v.setCamera(Number(e.target.value)) },
      v.manifest.cameras.map((c, i) => el('option', { value: String(i), text: c.name })));
    box.append(
      el('div', { class: 'row' }, [
        button('mode-orbit', 'Orbit', () => v.setMode('orbit')),
        button('mode-fly', 'Fly', () => v.setMode('fly')),
        button('toggle-frusta', 'Cameras', () => v.setFrusta(!v.frusta)),
        button('toggle-palette', 'Palette', () => v.setPalette(!v.palette)),
        cameras,
      ]),
      el('div', { class: 'row' }, [
        button('hide', 'Hide', () => v.hide(v.ids(v.selected))),
        button('isolate', 'Isolate', () => v.isolate(v.ids(v.selected))),
        button('show-all', 'Show all', () => v.showAll()),
        el('input', { id: 'recolour', type: 'color', value: '#ff3366', title: 'recolour the selection',
          onchange: (e) => v.recolour(v.ids(v.selected), this.rgb(e.target.value)) }),
        button('reset-colour', 'Reset colour', () => v.recolour(v.ids(v.selected), null)),
      ]),
      el('div', { class: 'row' }, [
        button('export-extract', 'Export selection', () => this.export('extract')),
        button('export-remove', 'Export all but selection', () => this.export('remove')),
      ]),
      el('div', { class: 'row' }, [
        button('export-crop', 'Export box crop', () => this.export('crop')),
        button('export-coloured', 'Export coloured by object', () => this.export('coloured')),
      ]),
      el('div', { id: 'export-result', class: 'note' }),
    );
    if (v.editor) this.buildEditing(box);
    if (v.manifest.search) this.buildSearch(box);
    if (!v.manifest.labelled) this.note('This PLY has no object_id: it is one object, and export needs `splatseg run` first.');
  }

  // The edit tools (a run's output folder): each acts on the selection and is previewed at once.
  buildEditing(box) {
    const v = this.viewer;
    const ed = v.editor;
    const button = (id, label, action) => el('button', { id, text: label, onclick: action });
    const selected = () => v.ids(v.selected).filter((id) => id >= 1);
    const one = () => {
      const ids = selected();
      if (ids.length !== 1) throw new Error('select one object first');
      return ids[0];
    };
    const act = (f) => async () => {
      try { await f(); } catch (e) { this.editStatus(String(e.message || e)); }
    };
    const name = el('input', { id: 'edit-name', type: 'text', placeholder: 'name', autocomplete: 'off' });
    const number = (id) => el('input', { id, type: 'number', step: 'any', class: 'boxfield',
      oninput: () => v.setBox(this.boxFromFields()) });
    this.boxFields = ['box-cx', 'box-cy', 'box-cz', 'box-hx', 'box-hy', 'box-hz'].map(number);
    const frontMost = el('input', { id: 'lasso-front', type: 'checkbox', title: 'only the Gaussians seen in front' });
    const opacityBelow = el('input', { id: 'filter-opacity', type: 'number', step: 'any', min: '0', max: '1', class: 'boxfield',
      title: "the selected objects' Gaussians less opaque than this (0–1)" });
    const sizeAbove = el('input', { id: 'filter-size', type: 'number', step: 'any', min: '0', class: 'boxfield',
      title: "the selected objects' Gaussians whose largest scale (world units) is above this" });
    const brushRadius = el('input', { id: 'brush-radius', type: 'number', step: 'any', min: '0', value: '12', class: 'boxfield',
      title: 'the brush radius, canvas pixels' });
    const neighbourRadius = el('input', { id: 'sel-radius', type: 'number', step: 'any', min: '0', class: 'boxfield',
      value: ed.neighbourRadius ? String(Number(ed.neighbourRadius.toPrecision(3))) : '',
      title: 'grow / shrink: Gaussians whose centres lie within this distance (world units) are neighbours' });
    const moveTo = el('input', { id: 'move-to', type: 'text', placeholder: 'new', autocomplete: 'off', class: 'boxfield',
      title: 'an object id, -1 for none, empty for a new object' });
    this.neighbourRadius = () => {
      const r = Number(neighbourRadius.value);
      if (!(r > 0)) throw new Error('give the neighbour radius (world units) to grow or shrink by');
      return r;
    };
    this.moveTarget = () => {
      const t = moveTo.value.trim();
      if (t === '' || t === 'new') return 'new';
      if (!/^-?\d+$/.test(t)) throw new Error(`move to: an object id, -1 or empty (a new object), got "${t}"`);
      return Number(t);
    };
    this.filter = () => {
      const f = {};
      if (opacityBelow.value !== '') f.opacity_below = Number(opacityBelow.value);
      if (sizeAbove.value !== '') f.size_above = Number(sizeAbove.value);
      if (!Object.keys(f).length) throw new Error('give an opacity or a size to select Gaussians by');
      return f;
    };
    box.append(
      el('h2', { text: 'Edit' }),
      el('div', { class: 'row' }, [
        button('edit-merge', 'Merge', act(() => {
          if (selected().length < 2) throw new Error('select two or more objects to merge (shift-click adds)');
          return ed.merge(selected());
        })),
        name,
        button('edit-rename', 'Rename', act(() => ed.rename(one(), name.value.trim()))),
      ]),
      el('div', { class: 'row' }, [
        button('edit-box', 'Box', act(() => { v.setBox(v.boxAround([one()])); this.fillBoxFields(); })),
        el('span', { class: 'note', text: 'centre' }), ...this.boxFields.slice(0, 3),
      ]),
      el('div', { class: 'row' }, [
        el('span', { class: 'note', text: 'half size' }), ...this.boxFields.slice(3),
        button('edit-split-box', 'Split by box', act(async () => {
          if (!v.box) throw new Error('place a box first (Box)');
          await ed.splitBox(one(), v.box);
          v.setBox(null);
        })),
      ]),
      el('div', { class: 'row' }, [
        button('edit-lasso', 'Lasso', () => this.setTool(this.tool === 'lasso' ? null : 'lasso')),
        el('label', {}, [frontMost, document.createTextNode(' front-most only')]),
        button('edit-undo', 'Undo', act(() => ed.undo())),
        button('edit-redo', 'Redo', act(() => ed.redo())),
        button('edit-save', 'Save', act(() => ed.save())),
      ]),
      el('div', { class: 'row' }, [
        el('span', { class: 'note', text: 'opacity <' }), opacityBelow,
        el('span', { class: 'note', text: 'size >' }), sizeAbove,
        button('edit-filter-new', '→ new object', act(() => ed.moveFiltered(selected(), this.filter(), false))),
        button('edit-filter-none', '→ none', act(() => ed.moveFiltered(selected(), this.filter(), true))),
      ]),
      el('div', { class: 'row' }, [
        button('edit-brush', 'Brush', () => this.setTool(this.tool === 'brush' ? null : 'brush')),
        el('span', { class: 'note', text: 'radius px' }), brushRadius,
        button('sel-grow', 'Grow', act(() => ed.growSelection(1, this.neighbourRadius()))),
        button('sel-shrink', 'Shrink', act(() => ed.growSelection(-1, this.neighbourRadius()))),
        el('span', { class: 'note', text: 'by' }), neighbourRadius,
        button('sel-clear', 'Clear', () => ed.clearSelection()),
      ]),
      el('div', { class: 'row' }, [
        el('span', { class: 'note', text: 'move selection to' }), moveTo,
        button('sel-move', 'Move', act(() => ed.moveSelection(this.moveTarget()))),
      ]),
      el('div', { id: 'selection-status', class: 'note' }),
      el('div', { id: 'edit-status', class: 'note' }),
    );
    this.brushRadius = brushRadius;
    this.frontMost = frontMost;
    this.nameField = name;
    this.buildLassoOverlay(act);
    // Ctrl+Z undoes, Ctrl+Shift+Z or Ctrl+Y redoes (not while typing in a field)
    // + grows the Gaussian selection, - shrinks it, Escape clears it (not while typing in a field)
    window.addEventListener('keydown', (e) => {
      if (e.ctrlKey || e.metaKey || e.altKey || e.target.tagName === 'INPUT') return;
      if (e.key === '+' || e.key === '=') { e.preventDefault(); act(() => ed.growSelection(1, this.neighbourRadius()))(); }
      else if (e.key === '-') { e.preventDefault(); act(() => ed.growSelection(-1, this.neighbourRadius()))(); }
      else if (e.key === 'Escape') ed.clearSelection();
    });
    window.addEventListener('keydown', (e) => {
      if (!(e.ctrlKey || e.metaKey) || e.target.tagName === 'INPUT') return;
      const key = e.key.toLowerCase();
      if (key === 'z' && !e.shiftKey) { e.preventDefault(); act(() => ed.undo())(); }
      else if (key === 'y' || (key === 'z' && e.shiftKey)) { e.preventDefault(); act(() => ed.redo())(); }
    });
    this.editStatus(ed.note ? `edits.json: ${ed.note}` : undefined);
    this.selectionStatus();
  }

  boxFromFields() {
    const n = this.boxFields.map((f) => Number(f.value));
    if (n.some((x) => !Number.isFinite(x)) || n.slice(3).some((x) => x <= 0)) return this.viewer.box;
    return { centre: n.slice(0, 3), half_size: n.slice(3) };
  }

  fillBoxFields() {
    const b = this.viewer.box;
    if (!b) return;
    [...b.centre, ...b.half_size].forEach((x, i) => { this.boxFields[i].value = x.toFixed(4); });
  }

  // An SVG over the canvas: in lasso mode, a drag draws the polygon; on release the selected
  // object is split by it. In brush mode, a drag (or a click) paints a stroke of the brush's
  // radius, added to the Gaussian selection on release.
  buildLassoOverlay(act) {
    const v = this.viewer;
    const ns = 'http://www.w3.org/2000/svg';
    const svg = document.createElementNS(ns, 'svg');
    svg.id = 'lasso';
    const path = document.createElementNS(ns, 'polyline');
    svg.appendChild(path);
    document.getElementById('stage').appendChild(svg);
    let points = null;
    const canvasPoint = (e) => {
      const r = v.canvas.getBoundingClientRect();
      return [(e.clientX - r.left) * v.canvas.width / r.width, (e.clientY - r.top) * v.canvas.height / r.height, e.clientX - r.left, e.clientY - r.top];
    };
    svg.addEventListener('pointerdown', (e) => {
      points = [canvasPoint(e)];
      path.style.strokeWidth = '';
      try { svg.setPointerCapture(e.pointerId); } catch (_) { /* a synthetic pointer */ }
    });
    svg.addEventListener('pointermove', (e) => {
      if (!points) return;
      points.push(canvasPoint(e));
      path.setAttribute('points', points.map((p) => `${p[2]},${p[3]}`).join(' '));
      if (this.tool === 'brush') {
        const scale = v.canvas.getBoundingClientRect().width / v.canvas.width;
        path.style.strokeWidth = `${2 * Number(this.brushRadius.value) * scale}px`;
      }
    });
    svg.addEventListener('pointerup', act(async () => {
      const drawn = points;
      points = null;
      path.setAttribute('points', '');
      if (this.tool === 'brush') {
        if (!drawn || !drawn.length) return;
        await v.editor.addStroke(drawn.map((p) => [p[0], p[1]]), Number(this.brushRadius.value), this.frontMost.checked, v.ids(v.selected));
        return;
      }
      if (!drawn || drawn.length < 3) return;
      const ids = v.ids(v.selected).filter((id) => id >= 1);
      if (ids.length !== 1) throw new Error('select the one object to split, then draw the lasso');
      await v.editor.splitLasso(ids[0], drawn.map((p) => [p[0], p[1]]), this.frontMost.checked);
      this.setTool(null);
    }));
    this.lassoSvg = svg;
  }

  // The tool the pointer draws with over the canvas: 'lasso', 'brush' or null (the camera).
  setTool(tool) {
    this.tool = tool;
    this.lassoSvg.classList.toggle('on', !!tool);
    this.lassoSvg.classList.toggle('brush', tool === 'brush');
    this.refresh();
  }

  // The Gaussian selection's line: how many Gaussians, of which objects, grown or shrunk how often.
  selectionStatus() {
    const ed = this.viewer.editor;
    const line = document.getElementById('selection-status');
    if (!ed || !line) return;
    const s = ed.selection;
    if (!s) { line.textContent = 'no Gaussian selection (Brush paints one)'; return; }
    const steps = s.neighbours.map((n) => ('grow' in n ? '+' : '−')).join('');
    line.textContent = `Gaussian selection: ${ed.selectionCount.toLocaleString()} Gaussians, ${s.parts.length} strokes`
      + `${s.objects ? ` of ${s.objects.join(', ')}` : ''}${steps ? `, ${steps}` : ''}`;
  }

  // The edit status line: `text`, or the operations and whether they are saved.
  editStatus(text) {
    const ed = this.viewer.editor;
    const line = document.getElementById('edit-status');
    if (!ed || !line) return;
    const summary = `${ed.ops.length} operations${ed.dirty ? ' (not saved)' : ' (saved)'}`;
    line.textContent = text ? `${text} · ${summary}` : summary;
  }

  // The search box (when the server has object embeddings): typing ranks the objects against the
  // text (`/api/find?q=`), marks the matches in the table with their rank and relevancy, best first;
  // Enter selects the best.
  buildSearch(box) {
    const v = this.viewer;
    const results = el('div', { id: 'search-results', class: 'note' });
    let timer = null;
    let asked = 0;
    const run = async (q, selectBest) => {
      const mine = ++asked;
      if (!q.trim()) { this.showMatches([]); results.textContent = ''; return; }
      try {
        const matches = await v.find(q);
        if (mine !== asked) return; // a newer query is on its way
        this.showMatches(matches);
        const names = new Map(v.manifest.objects.map((o) => [o.id, o.name]));
        const label = (m) => (names.get(m.id) ? `${m.id} ${names.get(m.id)}` : String(m.id));
        results.textContent = matches.map((m, i) => `${i + 1}. ${label(m)} (${m.relevancy.toFixed(3)})`).join('  ');
        if (selectBest && matches.length) v.select([matches[0].id]);
      } catch (e) {
        results.textContent = String(e.message || e);
      }
    };
    const input = el('input', { id: 'search', type: 'search', placeholder: 'find: a red mug', autocomplete: 'off' });
    input.addEventListener('input', () => { clearTimeout(timer); timer = setTimeout(() => run(input.value, false), 150); });
    input.addEventListener('keydown', (e) => {
      if (e.key === 'Enter') { clearTimeout(timer); run(input.value, true); }
    });
    box.append(el('div', { class: 'row' }, [input]), results);
  }

  // Marks the rows of `matches` (ranked) and moves them to the top of the table in rank order.
  showMatches(matches) {
    const body = document.getElementById('objects');
    const rank = new Map(matches.map((m, i) => [m.id, i]));
    const rows = this.rows.slice();
    rows.forEach((row) => {
      const id = Number(row.dataset.id);
      row.classList.toggle('match', rank.has(id));
      row.children[2].dataset.rank = rank.has(id) ? String(rank.get(id) + 1) : '';
    });
    rows.sort((a, b) => (rank.get(Number(a.dataset.id)) ?? 1e9) - (rank.get(Number(b.dataset.id)) ?? 1e9));
    rows.forEach((row) => body.appendChild(row));
    this.matches = matches;
  }

  rgb(value) {
    return [1, 3, 5].map((i) => parseInt(value.slice(i, i + 2), 16));
  }

  note(text) {
    document.getElementById('export-result').textContent = text;
  }

  async export(mode) {
    const v = this.viewer;
    const needsSelection = mode === 'extract' || mode === 'remove' || (mode === 'crop' && !v.box);
    if (needsSelection && v.selected.size === 0) return this.note('Select objects first (click them; shift-click adds).');
    try {
      const done = await v.exportSelection(mode);
      this.note(`wrote ${done.count.toLocaleString()} Gaussians to ${done.path}`);
      el('a', { href: done.url, download: done.url.split('/').pop() }).click();
    } catch (e) {
      this.note(String(e.message || e));
    }
  }

  // The object table again (an edit changed the objects).
  rebuildTable() {
    document.getElementById('objects').replaceChildren();
    document.querySelector('#table thead th.name')?.remove();
    this.buildTable();
    if (this.matches) this.showMatches(this.matches);
  }

  buildTable() {
    const v = this.viewer;
    const body = document.getElementById('objects');
    // a column with each object's name: given by an edit, or its best match among the names of
    // `view --names FILE`
    const named = v.manifest.objects.some((o) => o.name !== undefined);
    if (named) {
      const idHeader = document.querySelector('#table thead th:nth-child(3)');
      idHeader.after(el('th', { class: 'name', text: 'name' }));
    }
    this.rows = v.manifest.objects.map((o) => {
      const visible = el('input', { type: 'checkbox', title: 'visible',
        onchange: (e) => (e.target.checked ? v.show([o.id]) : v.hide([o.id])) });
      const row = el('tr', {
        'data-id': String(o.id),
        onclick: (e) => { if (e.target !== visible) v.select([o.id], e.shiftKey, e.shiftKey); },
        onmouseenter: () => v.setHighlight(o.id),
        onmouseleave: () => v.setHighlight(null),
      }, [
        el('td', {}, [visible]),
        el('td', {}, [el('span', { class: 'swatch', style: `background:${hex(o.colour)}` })]),
        el('td', { text: o.id < 0 ? 'none' : String(o.id) }),
        ...(named ? [el('td', { class: o.edited_name ? 'name given' : 'name', text: o.name ?? '',
          title: o.edited_name ? 'named by an edit'
            : (o.name === undefined ? '' : `suggested: relevancy ${o.name_relevancy.toFixed(3)}`) })] : []),
        el('td', { class: 'num', text: o.count.toLocaleString() }),
        el('td', { class: 'bbox', text: `${fmt(o.bbox_min)} … ${fmt(o.bbox_max)}` }),
      ]);
      row.visibleBox = visible;
      body.appendChild(row);
      return row;
    });
  }

  buildStrip() {
    const v = this.viewer;
    const strip = document.getElementById('strip');
    v.manifest.views.forEach((view, index) => {
      if (!view.overlay) return;
      const img = el('img', { src: view.overlay, title: view.stem, alt: view.stem });
      img.addEventListener('click', async (e) => {
        const rect = img.getBoundingClientRect();
        const x = Math.floor((e.clientX - rect.left) * img.naturalWidth / rect.width);
        const y = Math.floor((e.clientY - rect.top) * img.naturalHeight / rect.height);
        if (!view.has_labels) return;
        const r = await fetch(`/api/label/${index}/${x}/${y}`);
        const { id } = await r.json();
        if (id !== null && id !== undefined) v.select([id], e.shiftKey, e.shiftKey);
      });
      strip.appendChild(el('figure', {}, [img, el('figcaption', { text: view.stem })]));
    });
  }

  refresh() {
    const v = this.viewer;
    v.manifest.objects.forEach((o, slot) => {
      const row = this.rows[slot];
      row.classList.toggle('selected', v.selected.has(slot));
      row.visibleBox.checked = !v.hidden.has(slot);
    });
    document.getElementById('mode-orbit').classList.toggle('on', v.controls?.mode === 'orbit');
    document.getElementById('mode-fly').classList.toggle('on', v.controls?.mode === 'fly');
    document.getElementById('toggle-frusta').classList.toggle('on', v.frusta);
    document.getElementById('toggle-palette').classList.toggle('on', v.palette);
    document.getElementById('edit-lasso')?.classList.toggle('on', this.tool === 'lasso');
    document.getElementById('edit-brush')?.classList.toggle('on', this.tool === 'brush');
    if (v.editor) this.editStatus();
    const sel = v.ids(v.selected);
    // the rename field suggests the selected object's name: given by an edit, or from `view --names`
    if (this.nameField) {
      const o = sel.length === 1 ? v.manifest.objects[v.slotOfId.get(sel[0])] : null;
      this.nameField.placeholder = o?.name ?? 'name';
    }
    document.getElementById('selection').textContent = sel.length ? `selected: ${sel.join(', ')}` : 'nothing selected';
  }
}
