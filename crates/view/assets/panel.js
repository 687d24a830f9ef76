// The side panel: view toggles, the object table (id, palette colour, the name of `view --names`,
// Gaussian count, bounding box), selection actions, export, and the strip of the capture's overlays
// (a click there selects the object under it in 3D).

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
      el('div', { id: 'export-result', class: 'note' }),
    );
    if (v.manifest.search) this.buildSearch(box);
    if (!v.manifest.labelled) this.note('This PLY has no object_id: it is one object, and export needs `splatseg run` first.');
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
    if (v.selected.size === 0) return this.note('Select objects first (click them; shift-click adds).');
    try {
      const done = await v.exportSelection(mode);
      this.note(`wrote ${done.count.toLocaleString()} Gaussians to ${done.path}`);
      el('a', { href: done.url, download: done.url.split('/').pop() }).click();
    } catch (e) {
      this.note(String(e.message || e));
    }
  }

  buildTable() {
    const v = this.viewer;
    const body = document.getElementById('objects');
    // `view --names FILE`: a column with each object's best match among the names
    const named = v.manifest.objects.some((o) => o.name !== undefined);
    if (named) {
      const idHeader = document.querySelector('#table thead th:nth-child(3)');
      idHeader.after(el('th', { text: 'name' }));
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
        ...(named ? [el('td', { class: 'name', text: o.name ?? '',
          title: o.name === undefined ? '' : `relevancy ${o.name_relevancy.toFixed(3)}` })] : []),
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
    const sel = v.ids(v.selected);
    document.getElementById('selection').textContent = sel.length ? `selected: ${sel.join(', ')}` : 'nothing selected';
  }
}
