/* interaction-tensor viewer: a small self-contained WebGL point/mesh viewer (MIT licence,
 * part of the interaction-tensor package). Reads the JSON in <script id="itensor-data">.
 * WebGL 1 when available, otherwise a Canvas 2D point renderer with a z-buffer. */
(function () {
  "use strict";
  const DATA = JSON.parse(document.getElementById("itensor-data").textContent);

  // ------------------------------------------------------------------ decoding
  function bytes(b64) {
    const s = atob(b64 || "");
    const out = new Uint8Array(s.length);
    for (let i = 0; i < s.length; i++) out[i] = s.charCodeAt(i);
    return out;
  }
  function f32(b64) { const b = bytes(b64); return new Float32Array(b.buffer, 0, b.length / 4); }
  function u32(b64) { const b = bytes(b64); return new Uint32Array(b.buffer, 0, b.length / 4); }
  function u16(b64) { const b = bytes(b64); return new Uint16Array(b.buffer, 0, b.length / 2); }
  function dequant(q) {  // uint16 positions with origin and step per axis
    const v = u16(q.data), out = new Float32Array(v.length);
    for (let i = 0; i < v.length; i++) out[i] = q.origin[i % 3] + v[i] * q.step[i % 3];
    return out;
  }

  // ------------------------------------------------------------------ small matrix kit
  const M = {
    mul(a, b) {  // column-major 4x4
      const o = new Float32Array(16);
      for (let c = 0; c < 4; c++) for (let r = 0; r < 4; r++) {
        let s = 0; for (let k = 0; k < 4; k++) s += a[k * 4 + r] * b[c * 4 + k]; o[c * 4 + r] = s;
      }
      return o;
    },
    perspective(fovy, aspect, near, far) {
      const f = 1 / Math.tan(fovy / 2), o = new Float32Array(16);
      o[0] = f / aspect; o[5] = f; o[10] = (far + near) / (near - far); o[11] = -1;
      o[14] = 2 * far * near / (near - far); return o;
    },
    lookAt(eye, t, up) {
      let z = [eye[0] - t[0], eye[1] - t[1], eye[2] - t[2]]; z = norm(z);
      let x = norm(cross(up, z)); if (!isFinite(x[0])) x = [1, 0, 0];
      const y = cross(z, x), o = new Float32Array(16);
      o[0] = x[0]; o[4] = x[1]; o[8] = x[2]; o[1] = y[0]; o[5] = y[1]; o[9] = y[2];
      o[2] = z[0]; o[6] = z[1]; o[10] = z[2];
      o[12] = -dot(x, eye); o[13] = -dot(y, eye); o[14] = -dot(z, eye); o[15] = 1; return o;
    },
    fromRows(rows) {  // 4x4 row-major nested list -> column-major
      const o = new Float32Array(16);
      for (let r = 0; r < 4; r++) for (let c = 0; c < 4; c++) o[c * 4 + r] = rows[r][c];
      return o;
    },
    identity() { const o = new Float32Array(16); o[0] = o[5] = o[10] = o[15] = 1; return o; },
  };
  function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }
  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  function norm(a) { const n = Math.hypot(a[0], a[1], a[2]); return [a[0] / n, a[1] / n, a[2] / n]; }

  function flatMesh(vertices, faces) {  // non-indexed positions and face normals
    if (!faces || faces.length === 0) return null;
    const n = faces.length, pos = new Float32Array(n * 3), nrm = new Float32Array(n * 3);
    for (let f = 0; f < n; f += 3) {
      const a = faces[f] * 3, b = faces[f + 1] * 3, c = faces[f + 2] * 3;
      const u = [vertices[b] - vertices[a], vertices[b + 1] - vertices[a + 1], vertices[b + 2] - vertices[a + 2]];
      const v = [vertices[c] - vertices[a], vertices[c + 1] - vertices[a + 1], vertices[c + 2] - vertices[a + 2]];
      let nn = cross(u, v); const l = Math.hypot(nn[0], nn[1], nn[2]) || 1; nn = [nn[0] / l, nn[1] / l, nn[2] / l];
      for (let k = 0; k < 3; k++) {
        const src = faces[f + k] * 3, dst = (f + k) * 3;
        pos[dst] = vertices[src]; pos[dst + 1] = vertices[src + 1]; pos[dst + 2] = vertices[src + 2];
        nrm[dst] = nn[0]; nrm[dst + 1] = nn[1]; nrm[dst + 2] = nn[2];
      }
    }
    return { positions: pos, normals: nrm };
  }

  // ------------------------------------------------------------------ renderers
  const VS_POINTS = "attribute vec3 p; attribute vec3 c; uniform mat4 mvp; uniform float size;" +
    "uniform float proj; varying vec3 vc; void main(){ gl_Position = mvp*vec4(p,1.0);" +
    "gl_PointSize = clamp(size*proj/gl_Position.w, 1.0, 16.0); vc = c; }";
  const FS_POINTS = "precision mediump float; varying vec3 vc; void main(){ gl_FragColor = vec4(vc,1.0); }";
  const VS_MESH = "attribute vec3 p; attribute vec3 n; uniform mat4 mvp; uniform mat4 model;" +
    "varying vec3 vn; void main(){ gl_Position = mvp*vec4(p,1.0); vn = mat3(model)*n; }";
  const FS_MESH = "precision mediump float; varying vec3 vn; uniform vec3 color; uniform vec3 view;" +
    "void main(){ vec3 nn = normalize(vn); float l = 0.35 + 0.5*abs(dot(nn, view)) +" +
    "0.2*max(dot(nn, normalize(vec3(0.3,0.5,1.0))), 0.0); gl_FragColor = vec4(color*min(l,1.1),1.0); }";

  class GLRenderer {
    constructor(canvas) {
      const opts = { antialias: true, preserveDrawingBuffer: true };
      const gl = canvas.getContext("webgl", opts) || canvas.getContext("experimental-webgl", opts);
      if (!gl) throw new Error("no WebGL");
      this.gl = gl; this.kind = "webgl";
      this.uint32 = !!gl.getExtension("OES_element_index_uint");
      this.points = this.program(VS_POINTS, FS_POINTS);
      this.mesh = this.program(VS_MESH, FS_MESH);
    }
    program(vs, fs) {
      const gl = this.gl, p = gl.createProgram();
      for (const [type, src] of [[gl.VERTEX_SHADER, vs], [gl.FRAGMENT_SHADER, fs]]) {
        const s = gl.createShader(type); gl.shaderSource(s, src); gl.compileShader(s);
        if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
        gl.attachShader(p, s);
      }
      gl.linkProgram(p);
      if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
      return p;
    }
    buffer(data) {
      const gl = this.gl, b = gl.createBuffer();
      gl.bindBuffer(gl.ARRAY_BUFFER, b); gl.bufferData(gl.ARRAY_BUFFER, data, gl.STATIC_DRAW); return b;
    }
    upload(item) {  // positions Float32Array, colors Float32Array (0..1) or normals
      if (item.gl) return;
      item.gl = { p: this.buffer(item.positions) };
      if (item.colors) item.gl.c = this.buffer(item.colors);
      if (item.normals) item.gl.n = this.buffer(item.normals);
    }
    attrib(prog, name, buf) {
      const gl = this.gl, loc = gl.getAttribLocation(prog, name);
      if (loc < 0) return;
      gl.bindBuffer(gl.ARRAY_BUFFER, buf); gl.enableVertexAttribArray(loc);
      gl.vertexAttribPointer(loc, 3, gl.FLOAT, false, 0, 0);
    }
    draw(view, items) {
      const gl = this.gl, canvas = gl.canvas;
      gl.viewport(0, 0, canvas.width, canvas.height);
      gl.clearColor(1, 1, 1, 1); gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
      gl.enable(gl.DEPTH_TEST);
      for (const it of items) {
        if (it.hidden) continue;
        this.upload(it);
        const mvp = M.mul(view.vp, it.model || M.identity());
        if (it.kind === "mesh") {
          const p = this.mesh; gl.useProgram(p);
          this.attrib(p, "p", it.gl.p); this.attrib(p, "n", it.gl.n);
          gl.uniformMatrix4fv(gl.getUniformLocation(p, "mvp"), false, mvp);
          gl.uniformMatrix4fv(gl.getUniformLocation(p, "model"), false, it.model || M.identity());
          gl.uniform3fv(gl.getUniformLocation(p, "color"), it.color);
          gl.uniform3fv(gl.getUniformLocation(p, "view"), view.dir);
          gl.drawArrays(gl.TRIANGLES, 0, it.positions.length / 3);
        } else {
          const p = this.points; gl.useProgram(p);
          this.attrib(p, "p", it.gl.p); this.attrib(p, "c", it.gl.c);
          gl.uniformMatrix4fv(gl.getUniformLocation(p, "mvp"), false, mvp);
          gl.uniform1f(gl.getUniformLocation(p, "size"), it.size || 0);
          gl.uniform1f(gl.getUniformLocation(p, "proj"), view.proj);
          gl.drawArrays(it.kind === "lines" ? gl.LINES : gl.POINTS, 0, it.positions.length / 3);
        }
      }
    }
  }

  class CanvasRenderer {  // no WebGL: z-buffered square points, meshes as their vertices
    constructor(canvas) { this.ctx = canvas.getContext("2d"); this.kind = "canvas2d"; }
    draw(view, items) {
      const ctx = this.ctx, w = ctx.canvas.width, h = ctx.canvas.height;
      const img = ctx.createImageData(w, h), px = img.data, zb = new Float32Array(w * h).fill(Infinity);
      for (let i = 0; i < px.length; i++) px[i] = 255;
      for (const it of items) {
        if (it.hidden) continue;
        const m = M.mul(view.vp, it.model || M.identity()), p = it.positions;
        const lines = it.kind === "lines";
        const step = lines ? 6 : 3;
        for (let i = 0; i < p.length; i += step) {
          const reps = lines ? 6 : 1;
          for (let t = 0; t < reps; t++) {
            const f = lines ? t / (reps - 1) : 0;
            const x0 = lines ? p[i] + f * (p[i + 3] - p[i]) : p[i];
            const y0 = lines ? p[i + 1] + f * (p[i + 4] - p[i + 1]) : p[i + 1];
            const z0 = lines ? p[i + 2] + f * (p[i + 5] - p[i + 2]) : p[i + 2];
            const cw = m[3] * x0 + m[7] * y0 + m[11] * z0 + m[15];
            if (cw <= 0.01) continue;
            const sx = Math.round(((m[0] * x0 + m[4] * y0 + m[8] * z0 + m[12]) / cw * 0.5 + 0.5) * w);
            const sy = Math.round((0.5 - (m[1] * x0 + m[5] * y0 + m[9] * z0 + m[13]) / cw * 0.5) * h);
            const r = it.kind === "mesh" ? 1 : Math.max(0, Math.min(4, Math.round((it.size || 0) * view.proj / cw / 2)));
            const k = (i / 3) * 3;
            const col = it.colors ? [it.colors[k], it.colors[k + 1], it.colors[k + 2]] : it.color;
            for (let dy = -r; dy <= r; dy++) for (let dx = -r; dx <= r; dx++) {
              const X = sx + dx, Y = sy + dy;
              if (X < 0 || Y < 0 || X >= w || Y >= h) continue;
              const o = Y * w + X;
              if (cw >= zb[o]) continue;
              zb[o] = cw; px[o * 4] = col[0] * 255; px[o * 4 + 1] = col[1] * 255; px[o * 4 + 2] = col[2] * 255;
            }
          }
        }
      }
      ctx.putImageData(img, 0, 0);
    }
  }

  // ------------------------------------------------------------------ a view with orbit controls
  class View {
    constructor(canvas, items, fit) {
      this.canvas = canvas; this.items = items;
      try { this.r = new GLRenderer(canvas); } catch (e) { this.r = new CanvasRenderer(canvas); }
      this.fov = 45 * Math.PI / 180;
      this.home = fit; this.reset();
      this.bind(); this.resize();
      new ResizeObserver(() => this.resize()).observe(canvas);
    }
    reset() { this.lookAt(this.home.target, this.home.radius, -60, 40); }
    lookAt(target, radius, az, el) {
      this.target = target.slice(); this.dist = radius / Math.sin(this.fov / 2) * 0.8;
      if (az !== undefined) { this.az = az * Math.PI / 180; this.el = el * Math.PI / 180; }
      this.redraw();
    }
    resize() {
      const r = window.devicePixelRatio || 1, c = this.canvas;
      const w = Math.max(1, Math.round(c.clientWidth * r)), h = Math.max(1, Math.round(c.clientHeight * r));
      if (c.width !== w || c.height !== h) { c.width = w; c.height = h; }
      this.redraw();
    }
    bind() {
      const c = this.canvas; let last = null, pan = false;
      c.addEventListener("contextmenu", (e) => e.preventDefault());
      c.addEventListener("pointerdown", (e) => { last = [e.clientX, e.clientY]; pan = e.button !== 0 || e.shiftKey; c.setPointerCapture(e.pointerId); });
      c.addEventListener("pointerup", () => { last = null; });
      c.addEventListener("pointermove", (e) => {
        if (!last) return;
        const dx = e.clientX - last[0], dy = e.clientY - last[1]; last = [e.clientX, e.clientY];
        if (pan) {
          const s = this.dist * Math.tan(this.fov / 2) * 2 / c.clientHeight;
          const right = [-Math.sin(this.az), Math.cos(this.az), 0];
          const up = [-Math.sin(this.el) * Math.cos(this.az), -Math.sin(this.el) * Math.sin(this.az), Math.cos(this.el)];
          for (let k = 0; k < 3; k++) this.target[k] += (-dx * right[k] + dy * up[k]) * s;
        } else {
          this.az -= dx * 0.008; this.el = Math.max(-1.5, Math.min(1.5, this.el + dy * 0.008));
        }
        this.redraw();
      });
      c.addEventListener("wheel", (e) => { e.preventDefault(); this.dist *= Math.exp(e.deltaY * 0.001); this.redraw(); }, { passive: false });
      c.addEventListener("dblclick", () => this.reset());
    }
    redraw() {
      if (this.pending) return; this.pending = true;
      requestAnimationFrame(() => { this.pending = false; this.render(); });
    }
    render() {
      const c = this.canvas, ce = Math.cos(this.el);
      const dir = [ce * Math.cos(this.az), ce * Math.sin(this.az), Math.sin(this.el)];
      const eye = [this.target[0] + dir[0] * this.dist, this.target[1] + dir[1] * this.dist, this.target[2] + dir[2] * this.dist];
      const proj = M.perspective(this.fov, c.width / c.height, this.dist * 0.01, this.dist * 20);
      const view = M.lookAt(eye, this.target, [0, 0, 1]);
      this.r.draw({ vp: M.mul(proj, view), dir: dir, proj: c.height / (2 * Math.tan(this.fov / 2)) }, this.items);
      this.frames = (this.frames || 0) + 1;
      document.documentElement.dataset.frames = String((Number(document.documentElement.dataset.frames) || 0) + 1);
    }
  }

  // ------------------------------------------------------------------ building the page
  function colorsOf(b64) { const u = bytes(b64), o = new Float32Array(u.length); for (let i = 0; i < u.length; i++) o[i] = u[i] / 255; return o; }
  function bounds(p) {
    const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
    for (let i = 0; i < p.length; i += 3) for (let k = 0; k < 3; k++) { lo[k] = Math.min(lo[k], p[i + k]); hi[k] = Math.max(hi[k], p[i + k]); }
    const t = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2];
    return { target: t, radius: Math.max(1e-3, Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) / 2) };
  }
  const OBJ = [0.9, 0.24, 0.16], SEL = [1.0, 0.1, 0.85];

  function meshItem(m) {
    const v = f32(m.vertices), f = u32(m.faces), flat = flatMesh(v, f);
    if (flat) return { kind: "mesh", positions: flat.positions, normals: flat.normals, color: OBJ };
    const c = new Float32Array(v.length); for (let i = 0; i < c.length; i += 3) { c[i] = OBJ[0]; c[i + 1] = OBJ[1]; c[i + 2] = OBJ[2]; }
    return { kind: "points", positions: v, colors: c, size: m.size || 0.005 };
  }

  function sceneView() {
    const sc = DATA.scene;
    const items = [{ kind: "points", positions: dequant(sc.positions), colors: colorsOf(sc.colors), size: sc.point_size }];
    const meshes = DATA.meshes.map(meshItem);
    const objects = DATA.predictions.map((p) => {
      const base = meshes[p.mesh];
      const it = Object.assign({}, base, { model: M.fromRows(p.pose), color: OBJ, gl: undefined });
      if (base.kind === "points") it.colors = base.colors;
      items.push(it); return it;
    });
    // share GPU buffers between the posed copies of one mesh
    objects.forEach((o, i) => { o.shared = meshes[DATA.predictions[i].mesh]; });
    const view = new View(document.getElementById("scene-canvas"), items, bounds(items[0].positions));
    for (const o of objects) { if (!o.shared.gl && view.r.upload) view.r.upload(o.shared); o.gl = o.shared.gl; }
    document.documentElement.dataset.renderer = view.r.kind;

    const list = document.getElementById("predictions");
    DATA.predictions.forEach((p, i) => {
      const li = document.createElement("li");
      li.className = "prediction"; li.dataset.rank = String(p.rank);
      const pos = p.position.map((x) => x.toFixed(2)).join(", ");
      const place = p.place ? "<div class=place>place " + p.place.index + ": " +
        [0, 1].map((k) => (p.place.hi[k] - p.place.lo[k]).toFixed(2)).join(" x ") + " m, " +
        p.place.pairs + " poses</div>" : "";
      li.innerHTML = "<b>#" + p.rank + "</b> <span class=score>" + p.score.toFixed(3) + "</span>" +
        "<div class=where>(" + pos + ") m, " + Math.round(p.angle * 180 / Math.PI) + "&deg;</div>" + place;
      li.addEventListener("click", () => select(i));
      list.appendChild(li);
    });
    function select(i) {
      objects.forEach((o, k) => { o.color = k === i ? SEL : OBJ; });
      list.querySelectorAll("li").forEach((li, k) => li.classList.toggle("selected", k === i));
      const p = DATA.predictions[i];
      view.lookAt(p.position, Math.max(DATA.object_size * 2.5, 0.15));
    }
    document.getElementById("reset").addEventListener("click", () => {
      objects.forEach((o) => { o.color = OBJ; }); list.querySelectorAll("li").forEach((li) => li.classList.remove("selected"));
      view.reset();
    });
    document.getElementById("show-objects").addEventListener("change", (e) => { objects.forEach((o) => { o.hidden = !e.target.checked; }); view.redraw(); });
    return view;
  }

  function exampleView() {
    const ex = DATA.example, canvas = document.getElementById("example-canvas");
    if (!ex) { canvas.parentElement.classList.add("missing"); return null; }
    const q = meshItem(ex.query); q.color = [0.47, 0.59, 0.82];
    const items = [q,
      { kind: "points", positions: f32(ex.scene_object), colors: null, size: ex.scene_spacing * 0.5 },
      { kind: "points", positions: f32(ex.bisector), colors: colorsOf(ex.bisector_colors), size: ex.scene_spacing * 0.35, name: "bisector" },
      { kind: "lines", positions: f32(ex.vectors), colors: colorsOf(ex.vector_colors), name: "vectors" },
      { kind: "points", positions: f32(ex.keypoints), colors: colorsOf(ex.keypoint_colors), size: ex.scene_spacing * 0.6 }];
    const so = items[1], n = so.positions.length; so.colors = new Float32Array(n);
    for (let i = 0; i < n; i += 3) { so.colors[i] = 0.8; so.colors[i + 1] = 0.72; so.colors[i + 2] = 0.59; }
    const view = new View(canvas, items, bounds(f32(ex.bisector).length ? f32(ex.bisector) : q.positions));
    view.lookAt(view.home.target, view.home.radius, -90, 15);
    document.getElementById("show-query").addEventListener("change", (e) => { q.hidden = !e.target.checked; view.redraw(); });
    document.getElementById("show-bisector").addEventListener("change", (e) => { items[2].hidden = !e.target.checked; view.redraw(); });
    return view;
  }

  sceneView();
  exampleView();
  document.documentElement.dataset.predictions = String(DATA.predictions.length);
  document.documentElement.dataset.ready = "1";
})();
