// WebGL2 drawing: the Gaussians as instanced quads (colour pass and id pass) and camera frusta.
// Per-Gaussian data lives in an RGBA32UI texture (the wire layout as is, 3 texels per
// Gaussian), each Gaussian's object slot in an R32UI texture (the wire layout's, replaced by an
// edit's preview); per-object state (colour override, flags) in a small RGBA8 texture; the order is an
// instanced attribute of Gaussian indices, replaced whenever the worker's sort comes back.

const PER_ROW = 1024;

function compile(gl, vertexSource, fragmentSource) {
  const shader = (type, source) => {
    const s = gl.createShader(type);
    gl.shaderSource(s, source);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
    return s;
  };
  const program = gl.createProgram();
  gl.attachShader(program, shader(gl.VERTEX_SHADER, vertexSource));
  gl.attachShader(program, shader(gl.FRAGMENT_SHADER, fragmentSource));
  gl.linkProgram(program);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(program));
  const uniforms = {};
  const n = gl.getProgramParameter(program, gl.ACTIVE_UNIFORMS);
  for (let i = 0; i < n; i++) {
    const name = gl.getActiveUniform(program, i).name;
    uniforms[name] = gl.getUniformLocation(program, name);
  }
  return { program, uniforms };
}

export class SplatRenderer {
  constructor(gl, shaders, count, objectCount) {
    this.gl = gl;
    this.count = count;
    this.splat = compile(gl, shaders.splatVert, shaders.splatFrag);
    this.lines = compile(gl, shaders.linesVert, shaders.linesFrag);
    this.rows = Math.max(1, Math.ceil(count / PER_ROW));

    this.data = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, this.data);
    gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA32UI, 3 * PER_ROW, this.rows);
    this.nearest();

    this.slots = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, this.slots);
    gl.texStorage2D(gl.TEXTURE_2D, 1, gl.R32UI, PER_ROW, this.rows);
    this.nearest();

    this.state = null;
    this.setObjectCount(objectCount);

    this.vao = gl.createVertexArray();
    gl.bindVertexArray(this.vao);
    const corners = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, corners);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 1, -1, -1, 1, 1, 1]), gl.STATIC_DRAW);
    const cornerLoc = gl.getAttribLocation(this.splat.program, 'a_corner');
    gl.enableVertexAttribArray(cornerLoc);
    gl.vertexAttribPointer(cornerLoc, 2, gl.FLOAT, false, 0, 0);
    this.order = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, this.order);
    gl.bufferData(gl.ARRAY_BUFFER, 4 * Math.max(1, count), gl.DYNAMIC_DRAW);
    const indexLoc = gl.getAttribLocation(this.splat.program, 'a_index');
    gl.enableVertexAttribArray(indexLoc);
    gl.vertexAttribIPointer(indexLoc, 1, gl.UNSIGNED_INT, 0, 0);
    gl.vertexAttribDivisor(indexLoc, 1);
    gl.bindVertexArray(null);
    this.visible = 0;

    this.lineVao = gl.createVertexArray();
    gl.bindVertexArray(this.lineVao);
    this.lineBuffer = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, this.lineBuffer);
    const posLoc = gl.getAttribLocation(this.lines.program, 'a_position');
    gl.enableVertexAttribArray(posLoc);
    gl.vertexAttribPointer(posLoc, 3, gl.FLOAT, false, 0, 0);
    gl.bindVertexArray(null);
    this.lineCount = 0;

    this.pickTarget = null;
  }

  // (Re)allocates the per-object state texture for `objectCount` slots (an edit adds objects).
  setObjectCount(objectCount) {
    const gl = this.gl;
    const size = [Math.min(PER_ROW, Math.max(1, objectCount)), Math.max(1, Math.ceil(objectCount / PER_ROW))];
    if (this.state && size[0] === this.stateSize[0] && size[1] === this.stateSize[1]) return;
    if (this.state) gl.deleteTexture(this.state);
    this.stateSize = size;
    this.state = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, this.state);
    gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA8, size[0], size[1]);
    this.nearest();
  }

  // slots: Uint32Array, the object slot of Gaussians `offset`… (offset a multiple of 1024).
  uploadSlots(offset, slots) {
    const gl = this.gl;
    const rows = Math.ceil(slots.length / PER_ROW);
    let data = slots;
    if (slots.length !== rows * PER_ROW) {
      data = new Uint32Array(rows * PER_ROW);
      data.set(slots);
    }
    gl.bindTexture(gl.TEXTURE_2D, this.slots);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 4);
    gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, offset / PER_ROW, PER_ROW, rows, gl.RED_INTEGER, gl.UNSIGNED_INT, data);
  }

  nearest() {
    const gl = this.gl;
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
  }

  // words: Uint32Array of whole Gaussians (12 words each) starting at Gaussian `offset`
  // (a multiple of 1024).
  uploadChunk(offset, words) {
    const gl = this.gl;
    const n = words.length / 12;
    const rows = Math.ceil(n / PER_ROW);
    let data = words;
    if (n % PER_ROW !== 0) {
      data = new Uint32Array(rows * PER_ROW * 12);
      data.set(words);
    }
    gl.bindTexture(gl.TEXTURE_2D, this.data);
    gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, offset / PER_ROW, 3 * PER_ROW, rows, gl.RGBA_INTEGER, gl.UNSIGNED_INT, data);
    const slots = new Uint32Array(n);
    for (let i = 0; i < n; i++) slots[i] = words[12 * i + 3];
    this.uploadSlots(offset, slots);
  }

  // indices: back-to-front Gaussian indices, the first `visible` used.
  setOrder(indices, visible) {
    const gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.order);
    gl.bufferSubData(gl.ARRAY_BUFFER, 0, indices, 0, visible);
    this.visible = visible;
  }

  // bytes: Uint8Array of RGBA per object slot (rgb = colour override, a = flags).
  setObjectStates(bytes) {
    const gl = this.gl;
    const [w, h] = this.stateSize;
    let data = bytes;
    if (bytes.length !== 4 * w * h) {
      data = new Uint8Array(4 * w * h);
      data.set(bytes);
    }
    gl.bindTexture(gl.TEXTURE_2D, this.state);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, data);
  }

  // The line segments drawn over the splats (camera frusta, the edit box): xyz pairs.
  setLines(segments) {
    const gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.lineBuffer);
    gl.bufferData(gl.ARRAY_BUFFER, segments, gl.STATIC_DRAW);
    this.lineCount = segments.length / 3;
  }

  cameraUniforms(u, camera) {
    const gl = this.gl;
    camera.update();
    gl.uniformMatrix3fv(u.u_cam_from_world, false, camera.camFromWorld);
    gl.uniform3fv(u.u_cam_t, camera.t);
    gl.uniform4f(u.u_intrinsics, camera.fx, camera.fy, camera.cx, camera.cy);
    gl.uniform2f(u.u_size, camera.width, camera.height);
  }

  drawSplats(camera, palette, idPass, indexPass = false) {
    const gl = this.gl;
    const { program, uniforms: u } = this.splat;
    gl.useProgram(program);
    this.cameraUniforms(u, camera);
    gl.uniform1i(u.u_palette, palette ? 1 : 0);
    gl.uniform1i(u.u_id_pass, idPass ? 1 : 0);
    gl.uniform1i(u.u_index_pass, indexPass ? 1 : 0);
    gl.uniform1f(u.u_id_alpha, 0.3);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, this.data);
    gl.uniform1i(u.u_data, 0);
    gl.activeTexture(gl.TEXTURE1);
    gl.bindTexture(gl.TEXTURE_2D, this.state);
    gl.uniform1i(u.u_state, 1);
    gl.activeTexture(gl.TEXTURE2);
    gl.bindTexture(gl.TEXTURE_2D, this.slots);
    gl.uniform1i(u.u_slots, 2);
    gl.bindVertexArray(this.vao);
    gl.drawArraysInstanced(gl.TRIANGLE_STRIP, 0, 4, this.visible);
    gl.bindVertexArray(null);
  }

  // The colour pass to the canvas, then the lines (frusta, box) when there are some.
  draw(camera, palette) {
    const gl = this.gl;
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.viewport(0, 0, camera.width, camera.height);
    gl.clearColor(0, 0, 0, 1);
    gl.clear(gl.COLOR_BUFFER_BIT);
    gl.enable(gl.BLEND);
    gl.blendFunc(gl.ONE, gl.ONE_MINUS_SRC_ALPHA);
    this.drawSplats(camera, palette, false);
    if (this.lineCount > 0) {
      const { program, uniforms: u } = this.lines;
      gl.useProgram(program);
      this.cameraUniforms(u, camera);
      gl.uniform4f(u.u_colour, 1.0, 0.55, 0.1, 1.0);
      gl.bindVertexArray(this.lineVao);
      gl.drawArrays(gl.LINES, 0, this.lineCount);
      gl.bindVertexArray(null);
    }
  }

  // The object slot drawn at canvas pixel (x, y) by the id pass into an offscreen target, or −1.
  pick(camera, x, y) {
    const px = this.idPass(camera, Math.floor(x), Math.floor(y), 1, 1, false);
    return (px[0] | (px[1] << 8) | (px[2] << 16)) - 1;
  }

  // The Gaussian index + 1 drawn in front (the id pass's rule) at each canvas pixel of the
  // rectangle x0, y0 (top left), w × h: Uint32Array, rows top to bottom, 0 = none.
  frontIndices(camera, x0, y0, w, h) {
    const px = this.idPass(camera, x0, y0, w, h, true);
    const out = new Uint32Array(w * h);
    for (let y = 0; y < h; y++) {
      for (let x = 0; x < w; x++) {
        const i = 4 * ((h - 1 - y) * w + x);
        out[y * w + x] = (px[i] | (px[i + 1] << 8) | (px[i + 2] << 16) | (px[i + 3] << 24)) >>> 0;
      }
    }
    return out;
  }

  // The id pass (or the index pass) over the canvas rectangle x0, y0 (top left), w × h: its
  // RGBA bytes, rows bottom to top.
  idPass(camera, x0, y0, rw, rh, indexPass) {
    const gl = this.gl;
    const [w, h] = [camera.width, camera.height];
    if (!this.pickTarget || this.pickTarget.w !== w || this.pickTarget.h !== h) {
      if (this.pickTarget) {
        gl.deleteFramebuffer(this.pickTarget.fb);
        gl.deleteTexture(this.pickTarget.tex);
      }
      const tex = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D, tex);
      gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA8, w, h);
      const fb = gl.createFramebuffer();
      gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
      gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
      this.pickTarget = { fb, tex, w, h };
    }
    gl.bindFramebuffer(gl.FRAMEBUFFER, this.pickTarget.fb);
    gl.viewport(0, 0, w, h);
    gl.disable(gl.BLEND);
    // Only the pixels asked for are cleared and shaded: a whole id frame costs seconds where
    // WebGL runs on the CPU (SwiftShader), one pixel nothing.
    const [px0, py0] = [x0, h - y0 - rh];
    gl.enable(gl.SCISSOR_TEST);
    gl.scissor(px0, py0, rw, rh);
    gl.clearColor(0, 0, 0, 0);
    gl.clear(gl.COLOR_BUFFER_BIT);
    this.drawSplats(camera, false, true, indexPass);
    gl.disable(gl.SCISSOR_TEST);
    const px = new Uint8Array(4 * rw * rh);
    gl.readPixels(px0, py0, rw, rh, gl.RGBA, gl.UNSIGNED_BYTE, px);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    return px;
  }
}
