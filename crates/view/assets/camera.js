// The viewer's camera (OpenCV axes: x right, y down, z forward; world_from_cam rotation R whose
// columns are the camera axes in world coordinates, and centre c) and its orbit / fly controls.

export class Camera {
  // entry: a camera of the manifest; width, height: the canvas size in px.
  constructor(entry, width, height) {
    const m = entry.world_from_cam;
    this.r = [m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2], m[2][0], m[2][1], m[2][2]];
    this.c = [m[0][3], m[1][3], m[2][3]];
    this.setIntrinsics(entry, width, height);
    this.camFromWorld = new Float32Array(9);
    this.t = new Float32Array(3);
  }

  // Keeps the entry's vertical field of view and principal point offset at a new canvas size.
  setIntrinsics(entry, width, height) {
    const s = height / entry.height;
    this.width = width;
    this.height = height;
    this.fx = entry.fx * s;
    this.fy = entry.fy * s;
    this.cx = width / 2 + (entry.cx - entry.width / 2) * s;
    this.cy = entry.cy * s;
  }

  axis(k) {
    return [this.r[k], this.r[3 + k], this.r[6 + k]];
  }

  // Fills camFromWorld (column-major mat3 for GLSL: Rᵀ, whose column-major array is R's
  // row-major one) and t = −Rᵀ c.
  update() {
    this.camFromWorld.set(this.r);
    for (let i = 0; i < 3; i++) {
      this.t[i] = -(this.r[i] * this.c[0] + this.r[3 + i] * this.c[1] + this.r[6 + i] * this.c[2]);
    }
  }

  // [r20, r21, r22, t2]: camera z of a world point is r · p + t2.
  depthRow() {
    this.update();
    return [this.r[2], this.r[5], this.r[8], this.t[2]];
  }

  // Projection of a world point to pixel coordinates (corner origin), or null behind the camera.
  project(p) {
    this.update();
    const q = [0, 1, 2].map((i) => this.r[i] * p[0] + this.r[3 + i] * p[1] + this.r[6 + i] * p[2] + this.t[i]);
    if (q[2] <= 0.01) return null;
    return [this.fx * q[0] / q[2] + this.cx, this.fy * q[1] / q[2] + this.cy];
  }
}

// Rotation matrix (row-major) of `angle` about the unit `axis` (Rodrigues).
function rotation(axis, angle) {
  const [x, y, z] = axis;
  const c = Math.cos(angle), s = Math.sin(angle), t = 1 - c;
  return [
    t * x * x + c, t * x * y - s * z, t * x * z + s * y,
    t * x * y + s * z, t * y * y + c, t * y * z - s * x,
    t * x * z - s * y, t * y * z + s * x, t * z * z + c,
  ];
}

function mul(a, b) {
  const out = new Array(9);
  for (let i = 0; i < 3; i++) {
    for (let j = 0; j < 3; j++) out[3 * i + j] = a[3 * i] * b[j] + a[3 * i + 1] * b[3 + j] + a[3 * i + 2] * b[6 + j];
  }
  return out;
}

function apply(m, v) {
  return [0, 1, 2].map((i) => m[3 * i] * v[0] + m[3 * i + 1] * v[1] + m[3 * i + 2] * v[2]);
}

function normalise(v) {
  const n = Math.hypot(v[0], v[1], v[2]) || 1;
  return v.map((x) => x / n);
}

// Orbit (drag: turn about the target; right drag: pan; wheel: dolly) or fly (drag: look
// around; W A S D Q E: move). A click that does not move reports the pixel to `onClick`.
export class Controls {
  constructor(canvas, camera, radius, target, onChange, onClick) {
    this.canvas = canvas;
    this.camera = camera;
    this.radius = radius;
    this.target = target;
    this.up = normalise(camera.axis(1).map((v) => -v));
    this.mode = 'orbit';
    this.onChange = onChange;
    this.onClick = onClick;
    this.drag = null;
    canvas.addEventListener('pointerdown', (e) => this.down(e));
    canvas.addEventListener('pointermove', (e) => this.move(e));
    canvas.addEventListener('pointerup', (e) => this.upEvent(e));
    canvas.addEventListener('contextmenu', (e) => e.preventDefault());
    canvas.addEventListener('wheel', (e) => this.wheel(e), { passive: false });
    window.addEventListener('keydown', (e) => this.key(e));
  }

  // Canvas pixel of a pointer event.
  pixel(e) {
    const rect = this.canvas.getBoundingClientRect();
    return [(e.clientX - rect.left) * this.canvas.width / rect.width, (e.clientY - rect.top) * this.canvas.height / rect.height];
  }

  down(e) {
    this.drag = { x: e.clientX, y: e.clientY, startX: e.clientX, startY: e.clientY, button: e.button, moved: false };
    this.canvas.setPointerCapture?.(e.pointerId);
  }

  move(e) {
    const d = this.drag;
    if (!d) return;
    const dx = e.clientX - d.x, dy = e.clientY - d.y;
    d.x = e.clientX;
    d.y = e.clientY;
    if (Math.abs(e.clientX - d.startX) + Math.abs(e.clientY - d.startY) > 3) d.moved = true;
    if (!d.moved) return;
    if (d.button === 2 || e.ctrlKey) this.pan(dx, dy);
    else this.turn(dx, dy);
    this.onChange();
  }

  upEvent(e) {
    const d = this.drag;
    this.drag = null;
    if (d && !d.moved && d.button === 0) {
      const [x, y] = this.pixel(e);
      this.onClick(x, y, e.shiftKey);
    }
  }

  turn(dx, dy) {
    const cam = this.camera;
    const yaw = rotation(this.up, -0.005 * dx);
    const pitch = rotation(normalise(cam.axis(0)), -0.005 * dy);
    const rot = mul(pitch, yaw);
    cam.r = mul(rot, cam.r);
    if (this.mode === 'orbit') {
      const rel = apply(rot, [0, 1, 2].map((i) => cam.c[i] - this.target[i]));
      cam.c = rel.map((v, i) => v + this.target[i]);
    } else {
      const dist = Math.hypot(...[0, 1, 2].map((i) => cam.c[i] - this.target[i]));
      this.target = cam.axis(2).map((v, i) => cam.c[i] + dist * v);
    }
  }

  pan(dx, dy) {
    const cam = this.camera;
    const dist = Math.hypot(...[0, 1, 2].map((i) => cam.c[i] - this.target[i]));
    const x = cam.axis(0), y = cam.axis(1);
    for (let i = 0; i < 3; i++) {
      const step = -(x[i] * dx / cam.fx + y[i] * dy / cam.fy) * dist;
      cam.c[i] += step;
      this.target[i] += step;
    }
  }

  wheel(e) {
    e.preventDefault();
    const cam = this.camera;
    const scale = Math.exp(0.001 * e.deltaY);
    cam.c = cam.c.map((v, i) => this.target[i] + (v - this.target[i]) * scale);
    this.onChange();
  }

  key(e) {
    if (this.mode !== 'fly' || e.target.tagName === 'INPUT') return;
    const moves = { w: [2, 1], s: [2, -1], d: [0, 1], a: [0, -1], e: [1, -1], q: [1, 1] };
    const m = moves[e.key.toLowerCase()];
    if (!m) return;
    const axis = this.camera.axis(m[0]);
    const step = 0.03 * this.radius * m[1];
    for (let i = 0; i < 3; i++) {
      this.camera.c[i] += axis[i] * step;
      this.target[i] += axis[i] * step;
    }
    this.onChange();
  }
}
