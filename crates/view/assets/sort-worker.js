// Depth sort in a Web Worker: a counting sort on 16-bit depth keys, far to near, so the page can
// blend back to front. Buffers are allocated once for the scene's size; the index array goes
// back and forth between the page and this worker (transferred, not copied).
//
// Messages in:  {type: 'init', count}                      — size the buffers
//               {type: 'positions', offset, words}         — a chunk of the wire layout (12 u32 per Gaussian)
//               {type: 'sort', view: [r20, r21, r22, t2], loaded, indices?}
//               {type: 'bench', count, repeats}            — time sorts of random centres
// Messages out: {type: 'sorted', indices, visible, loaded, ms, view}
//               {type: 'bench', ms: [..]}

'use strict';

const BUCKETS = 65536;
let positions = null;   // Float32Array [3N]
let depths = null;      // Float32Array [N]
let keys = null;        // Uint16Array [N]
let counts = new Uint32Array(BUCKETS);
let spare = null;       // an index buffer to reuse when the page did not send one back

function init(count) {
  positions = new Float32Array(3 * count);
  depths = new Float32Array(count);
  keys = new Uint16Array(count);
  spare = null;
}

function addPositions(offset, words) {
  const f = new Float32Array(words.buffer, words.byteOffset, words.length);
  const n = words.length / 12;
  for (let i = 0; i < n; i++) {
    positions[3 * (offset + i)] = f[12 * i];
    positions[3 * (offset + i) + 1] = f[12 * i + 1];
    positions[3 * (offset + i) + 2] = f[12 * i + 2];
  }
}

// Sorts the first `loaded` Gaussians by camera z = r2 · p + t2, far first, dropping those at
// z ≤ near. Returns the number written to `out`.
function sortByDepth(view, loaded, out) {
  const [r0, r1, r2, t] = view;
  const near = 0.01;
  let min = Infinity, max = -Infinity;
  for (let i = 0; i < loaded; i++) {
    const z = r0 * positions[3 * i] + r1 * positions[3 * i + 1] + r2 * positions[3 * i + 2] + t;
    depths[i] = z;
    if (z > near) {
      if (z < min) min = z;
      if (z > max) max = z;
    }
  }
  if (!(max >= min)) return 0;
  const scale = max > min ? (BUCKETS - 1) / (max - min) : 0;
  counts.fill(0);
  for (let i = 0; i < loaded; i++) {
    const z = depths[i];
    if (z > near) {
      // far = key 0, so ascending keys are back to front
      const key = ((max - z) * scale) | 0;
      keys[i] = key;
      counts[key]++;
    }
  }
  let sum = 0;
  for (let k = 0; k < BUCKETS; k++) {
    const c = counts[k];
    counts[k] = sum;
    sum += c;
  }
  for (let i = 0; i < loaded; i++) {
    if (depths[i] > near) out[counts[keys[i]]++] = i;
  }
  return sum;
}

self.onmessage = (event) => {
  const msg = event.data;
  if (msg.type === 'init') {
    init(msg.count);
  } else if (msg.type === 'positions') {
    addPositions(msg.offset, msg.words);
  } else if (msg.type === 'sort') {
    let indices = msg.indices || spare;
    if (!indices || indices.length < depths.length) indices = new Uint32Array(depths.length);
    spare = null;
    const start = performance.now();
    const visible = sortByDepth(msg.view, msg.loaded, indices);
    const ms = performance.now() - start;
    self.postMessage({ type: 'sorted', indices, visible, loaded: msg.loaded, ms, view: msg.view }, [indices.buffer]);
  } else if (msg.type === 'bench') {
    init(msg.count);
    let seed = 12345;
    const random = () => ((seed = (Math.imul(seed, 1103515245) + 12345) >>> 0) / 4294967296);
    for (let i = 0; i < 3 * msg.count; i++) positions[i] = 4 * random() - 2;
    const out = new Uint32Array(msg.count);
    const ms = [];
    for (let r = 0; r < msg.repeats; r++) {
      const angle = 0.1 * r;
      const view = [Math.sin(angle), 0, Math.cos(angle), 5];
      const start = performance.now();
      sortByDepth(view, msg.count, out);
      ms.push(performance.now() - start);
    }
    self.postMessage({ type: 'bench', ms });
  }
};
