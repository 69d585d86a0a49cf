// ragdoll view: draws what the server streams (WebGL2: lit capsules, the skinned mesh
// skinned on the GPU, a ground with shadows, joint-limit overlays) and sends what the user
// does. Plain JavaScript, no build step: the server embeds this file as it is.
'use strict';

// ---------------------------------------------------------------- small maths (column-major)
const V = {
  sub: (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]],
  add: (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]],
  scale: (a, s) => [a[0] * s, a[1] * s, a[2] * s],
  dot: (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2],
  cross: (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]],
  len: (a) => Math.hypot(a[0], a[1], a[2]),
  norm: (a) => { const l = Math.hypot(a[0], a[1], a[2]) || 1; return [a[0] / l, a[1] / l, a[2] / l]; },
};
// Quaternions are [x, y, z, w], as the server sends them.
const Q = {
  rotate(q, v) {
    const [x, y, z, w] = q;
    const t = V.scale(V.cross([x, y, z], v), 2);
    return V.add(V.add(v, V.scale(t, w)), V.cross([x, y, z], t));
  },
  conj: (q) => [-q[0], -q[1], -q[2], q[3]],
  mul(a, b) {
    return [
      a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1],
      a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0],
      a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3],
      a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2],
    ];
  },
  axisAngle(axis, angle) {
    const s = Math.sin(angle / 2);
    return [axis[0] * s, axis[1] * s, axis[2] * s, Math.cos(angle / 2)];
  },
};
// A rigid transform {t: [3], q: [4]} from 7 floats at offset i.
function tr(arr, i) {
  return { t: [arr[i], arr[i + 1], arr[i + 2]], q: [arr[i + 3], arr[i + 4], arr[i + 5], arr[i + 6]] };
}
const T = {
  apply: (a, p) => V.add(a.t, Q.rotate(a.q, p)),
  mul: (a, b) => ({ t: V.add(a.t, Q.rotate(a.q, b.t)), q: Q.mul(a.q, b.q) }),
};
const M4 = {
  fromTr(a) {
    const [x, y, z, w] = a.q;
    const m = new Float32Array(16);
    m[0] = 1 - 2 * (y * y + z * z); m[1] = 2 * (x * y + z * w); m[2] = 2 * (x * z - y * w);
    m[4] = 2 * (x * y - z * w); m[5] = 1 - 2 * (x * x + z * z); m[6] = 2 * (y * z + x * w);
    m[8] = 2 * (x * z + y * w); m[9] = 2 * (y * z - x * w); m[10] = 1 - 2 * (x * x + y * y);
    m[12] = a.t[0]; m[13] = a.t[1]; m[14] = a.t[2]; m[15] = 1;
    return m;
  },
  mul(a, b) {
    const o = new Float32Array(16);
    for (let c = 0; c < 4; c++) for (let r = 0; r < 4; r++) {
      let s = 0;
      for (let k = 0; k < 4; k++) s += a[k * 4 + r] * b[c * 4 + k];
      o[c * 4 + r] = s;
    }
    return o;
  },
  perspective(fovy, aspect, near, far) {
    const f = 1 / Math.tan(fovy / 2), o = new Float32Array(16);
    o[0] = f / aspect; o[5] = f; o[10] = (far + near) / (near - far); o[11] = -1;
    o[14] = 2 * far * near / (near - far);
    return o;
  },
  ortho(l, r, b, t, n, f) {
    const o = new Float32Array(16);
    o[0] = 2 / (r - l); o[5] = 2 / (t - b); o[10] = -2 / (f - n);
    o[12] = -(r + l) / (r - l); o[13] = -(t + b) / (t - b); o[14] = -(f + n) / (f - n); o[15] = 1;
    return o;
  },
  lookAt(eye, target, up) {
    const z = V.norm(V.sub(eye, target)), x = V.norm(V.cross(up, z)), y = V.cross(z, x);
    const o = new Float32Array(16);
    o[0] = x[0]; o[4] = x[1]; o[8] = x[2];
    o[1] = y[0]; o[5] = y[1]; o[9] = y[2];
    o[2] = z[0]; o[6] = z[1]; o[10] = z[2];
    o[12] = -V.dot(x, eye); o[13] = -V.dot(y, eye); o[14] = -V.dot(z, eye); o[15] = 1;
    return o;
  },
};

// ---------------------------------------------------------------- state
const $ = (id) => document.getElementById(id);
const viewer = {
  size: 1, // the character's size in units of an adult's half height (scales views)
  ready: false, webgl: false, glError: null, connected: false,
  scene: null, specs: null, frame: null, frames: 0, notices: [],
  selected: null, blastAt: null,
};
window.viewer = viewer;

const camera = { target: [0, 0.9, 0], yaw: 0.6, pitch: 0.25, dist: 4.0, eye: [0, 0, 0] };
let viewProj = new Float32Array(16);

// ---------------------------------------------------------------- connection
let ws = null;
function send(msg) {
  if (ws && ws.readyState === 1) ws.send(JSON.stringify(msg));
}
function connect() {
  ws = new WebSocket(`ws://${location.host}/ws`);
  ws.onopen = () => { viewer.connected = true; $('conn').textContent = 'connected'; };
  ws.onclose = () => {
    viewer.connected = false;
    $('conn').textContent = 'disconnected: is `ragdoll view` still running? Reload to reconnect.';
  };
  ws.onmessage = (ev) => {
    let m;
    try { m = JSON.parse(ev.data); } catch (e) { return; }
    if (m.type === 'scene') onScene(m);
    else if (m.type === 'specs') onSpecs(m);
    else if (m.type === 'frame') onFrame(m);
    else if (m.type === 'notice') onNotice(m);
    else if (m.type === 'confirm_overwrite') onConfirmOverwrite(m);
  };
}

function onScene(m) {
  viewer.scene = m;
  if (gl) for (const r of m.ragdolls) r.gpuMeshes = r.meshes.map((mesh) => makeSkinnedMesh(mesh, r));
  const anyMesh = m.ragdolls.some((r) => r.meshes.length > 0);
  $('show-bodies').checked = !anyMesh;
  $('show-mesh').checked = anyMesh;
}

function onSpecs(m) {
  viewer.specs = m;
  $('backend').value = m.backend;
  if (gl) for (const r of m.ragdolls) {
    r.capsules = r.spec.bodies.map((b) => makeShapeMesh(b.shape));
    r.extras = r.spec.bodies.map((b) => extraShapes(b).map((e) => ({ mesh: makeShapeMesh(e.shape), at: e.at })));
  }
  showSelected();
}

function onFrame(m) {
  const first = !viewer.frame;
  viewer.frame = m;
  viewer.frames++;
  if (first) {
    const c = centreOfMass(0);
    if (c) {
      camera.target = [c[0], Math.max(0.6, c[1]), c[2]];
      // Frame the whole character, whatever its size (some files are in centimetres).
      let extent = 0;
      const poses = m.ragdolls[0].bodies;
      for (let i = 0; i < poses.length; i += 7) extent = Math.max(extent, V.len(V.sub(tr(poses, i).t, c)));
      viewer.size = Math.max(1, extent / 0.9);
      camera.dist = 4 * viewer.size;
    }
  }
  $('time').textContent = `${m.t.toFixed(2)} s / ${m.head_t.toFixed(2)} s`;
  $('play').textContent = m.playing ? 'Pause' : 'Play';
  if (!scrubbing) {
    $('timeline').max = m.head_t;
    $('timeline').value = m.t;
  }
  if (viewer.scene && viewer.specs) viewer.ready = true;
}

function onNotice(m) {
  viewer.notices.push(m);
  if (viewer.notices.length > 100) viewer.notices.shift();
  const n = $('notice');
  n.textContent = m.message;
  n.className = m.level;
  if (m.level === 'error' && viewer.specs) $('backend').value = viewer.specs.backend;
}

// Save found files of the same name: replace them only if the user says so.
function onConfirmOverwrite(m) {
  const files = m.files.join(', ');
  if (window.confirm(`${files} already in ${m.dir}: replace?`)) {
    send({ type: 'save', overwrite: true });
  } else {
    onNotice({ type: 'notice', level: 'info', message: `not saved: ${files} kept as they were` });
  }
}

// Poses of ragdoll r's bodies in the current frame, as {t, q}.
// A body's extra shapes, each with its place in the body frame: the spec places them, as
// the body's own shape, in the bone's rest frame.
function extraShapes(b) {
  const own = { t: b.center_m, q: b.rotation };
  const inv = { t: Q.rotate(Q.conj(own.q), V.scale(own.t, -1)), q: Q.conj(own.q) };
  return (b.extra_shapes || []).map((e) => ({ shape: e.shape, at: T.mul(inv, { t: e.center_m, q: e.rotation }) }));
}
function bodyPose(r, b) {
  const f = viewer.frame;
  if (!f || !f.ragdolls[r]) return null;
  return tr(f.ragdolls[r].bodies, 7 * b);
}
function centreOfMass(r) {
  const s = viewer.specs && viewer.specs.ragdolls[r];
  if (!s || !viewer.frame) return null;
  let m = 0, c = [0, 0, 0];
  s.spec.bodies.forEach((b, i) => {
    const p = bodyPose(r, i);
    if (p) { c = V.add(c, V.scale(p.t, b.mass_kg)); m += b.mass_kg; }
  });
  return m > 0 ? V.scale(c, 1 / m) : null;
}

// ---------------------------------------------------------------- WebGL
const canvas = $('canvas');
let gl = null;
try {
  gl = canvas.getContext('webgl2', { antialias: true });
} catch (e) {
  viewer.glError = String(e);
}
if (!gl) {
  viewer.glError = viewer.glError || 'this browser gave no WebGL2 context';
  $('gl-status').textContent = `WebGL2 is not available (${viewer.glError}): the simulation runs, ` +
    'the controls work, but nothing can be drawn.';
} else {
  viewer.webgl = true;
}

const LIT = `
uniform vec3 uLightDir;
uniform highp sampler2DShadow uShadow;
uniform mat4 uLightVP;
float shadowAt(vec3 world, vec3 n) {
  vec4 p = uLightVP * vec4(world + n * 0.01, 1.0);
  vec3 s = p.xyz / p.w * 0.5 + 0.5;
  if (s.x < 0.0 || s.x > 1.0 || s.y < 0.0 || s.y > 1.0 || s.z > 1.0) return 1.0;
  float sum = 0.0;
  vec2 texel = 1.0 / vec2(textureSize(uShadow, 0));
  for (int x = -1; x <= 1; x++) for (int y = -1; y <= 1; y++)
    sum += texture(uShadow, vec3(s.xy + vec2(x, y) * texel, s.z - 0.0015));
  return sum / 9.0;
}
vec3 shade(vec3 albedo, vec3 n, vec3 world, vec3 eye) {
  float lit = max(dot(n, uLightDir), 0.0) * shadowAt(world, n);
  vec3 v = normalize(eye - world);
  float spec = pow(max(dot(reflect(-uLightDir, n), v), 0.0), 24.0) * 0.25 * lit;
  float sky = 0.5 + 0.5 * n.y;
  return albedo * (0.22 + 0.18 * sky + 0.75 * lit) + spec;
}`;

const SRC = {
  staticVS: `#version 300 es
layout(location=0) in vec3 aPos; layout(location=1) in vec3 aNormal;
uniform mat4 uModel, uVP;
out vec3 vWorld, vNormal;
void main() {
  vec4 w = uModel * vec4(aPos, 1.0);
  vWorld = w.xyz; vNormal = mat3(uModel) * aNormal;
  gl_Position = uVP * w;
}`,
  skinVS: `#version 300 es
layout(location=0) in vec3 aPos; layout(location=1) in vec3 aNormal;
layout(location=2) in uvec4 aJoints; layout(location=3) in vec4 aWeights;
uniform mat4 uVP;
uniform highp sampler2D uBones;
out vec3 vWorld, vNormal;
mat4 bone(uint j) {
  int r = int(j);
  return mat4(texelFetch(uBones, ivec2(0, r), 0), texelFetch(uBones, ivec2(1, r), 0),
              texelFetch(uBones, ivec2(2, r), 0), texelFetch(uBones, ivec2(3, r), 0));
}
void main() {
  mat4 m = aWeights.x * bone(aJoints.x) + aWeights.y * bone(aJoints.y)
         + aWeights.z * bone(aJoints.z) + aWeights.w * bone(aJoints.w);
  vec4 w = m * vec4(aPos, 1.0);
  vWorld = w.xyz; vNormal = mat3(m) * aNormal;
  gl_Position = uVP * w;
}`,
  litFS: `#version 300 es
precision highp float;
in vec3 vWorld, vNormal;
uniform vec3 uColor, uEye;
uniform int uGround;
uniform float uScale;
out vec4 outColor;
${LIT}
void main() {
  // Normals come with the meshes (outward); triangle winding varies between files, so
  // it is not used to flip them.
  vec3 n = normalize(vNormal);
  vec3 albedo = uColor;
  if (uGround == 1) {
    vec2 c = floor(vWorld.xz / uScale);
    float k = mod(c.x + c.y, 2.0);
    albedo = mix(vec3(0.36, 0.39, 0.42), vec3(0.43, 0.46, 0.49), k);
    float fade = clamp(length(vWorld.xz) / (30.0 * uScale), 0.0, 1.0);
    albedo = mix(albedo, vec3(0.2, 0.22, 0.25), fade);
  }
  outColor = vec4(shade(albedo, n, vWorld, uEye), 1.0);
}`,
  depthFS: `#version 300 es
precision highp float;
void main() {}`,
  lineVS: `#version 300 es
layout(location=0) in vec3 aPos; layout(location=1) in vec3 aColor;
uniform mat4 uVP;
out vec3 vColor;
void main() { vColor = aColor; gl_Position = uVP * vec4(aPos, 1.0); }`,
  lineFS: `#version 300 es
precision highp float;
in vec3 vColor; out vec4 outColor;
void main() { outColor = vec4(vColor, 1.0); }`,
};

function compile(vs, fs) {
  const p = gl.createProgram();
  for (const [type, src] of [[gl.VERTEX_SHADER, vs], [gl.FRAGMENT_SHADER, fs]]) {
    const s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
    gl.attachShader(p, s);
  }
  gl.linkProgram(p);
  if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
  const u = {};
  const n = gl.getProgramParameter(p, gl.ACTIVE_UNIFORMS);
  for (let i = 0; i < n; i++) {
    const name = gl.getActiveUniform(p, i).name;
    u[name] = gl.getUniformLocation(p, name);
  }
  return { p, u };
}

let prog = null, shadow = null, ground = null, lineBuf = null, lineVao = null;
const SHADOW_SIZE = 2048;
if (gl) {
  try {
    prog = {
      lit: compile(SRC.staticVS, SRC.litFS),
      skin: compile(SRC.skinVS, SRC.litFS),
      depth: compile(SRC.staticVS, SRC.depthFS),
      skinDepth: compile(SRC.skinVS, SRC.depthFS),
      line: compile(SRC.lineVS, SRC.lineFS),
    };
    const tex = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, tex);
    gl.texStorage2D(gl.TEXTURE_2D, 1, gl.DEPTH_COMPONENT24, SHADOW_SIZE, SHADOW_SIZE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_COMPARE_MODE, gl.COMPARE_REF_TO_TEXTURE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_COMPARE_FUNC, gl.LEQUAL);
    const fb = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.TEXTURE_2D, tex, 0);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    shadow = { tex, fb };
    ground = makeMesh(
      [-2000, 0, -2000, 2000, 0, -2000, 2000, 0, 2000, -2000, 0, 2000],
      [0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0],
      [0, 2, 1, 0, 3, 2],
    );
    lineVao = gl.createVertexArray();
    lineBuf = gl.createBuffer();
    gl.bindVertexArray(lineVao);
    gl.bindBuffer(gl.ARRAY_BUFFER, lineBuf);
    gl.enableVertexAttribArray(0);
    gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 24, 0);
    gl.enableVertexAttribArray(1);
    gl.vertexAttribPointer(1, 3, gl.FLOAT, false, 24, 12);
    gl.bindVertexArray(null);
  } catch (e) {
    viewer.webgl = false;
    viewer.glError = String(e);
    $('gl-status').textContent = `WebGL2 setup failed: ${e}`;
    gl = null;
  }
}

function makeMesh(positions, normals, indices) {
  const vao = gl.createVertexArray();
  gl.bindVertexArray(vao);
  const buf = (data, loc, size) => {
    const b = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, b);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(data), gl.STATIC_DRAW);
    gl.enableVertexAttribArray(loc);
    gl.vertexAttribPointer(loc, size, gl.FLOAT, false, 0, 0);
  };
  buf(positions, 0, 3);
  buf(normals, 1, 3);
  const ib = gl.createBuffer();
  gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, ib);
  gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, new Uint32Array(indices), gl.STATIC_DRAW);
  gl.bindVertexArray(null);
  return { vao, count: indices.length };
}

// A capsule along Y (or a box) in the body's frame.
function makeShapeMesh(shape) {
  const pos = [], nrm = [], idx = [];
  if (shape.kind === 'box') {
    const h = shape.size_m.map((s) => s / 2);
    const faces = [[0, 1], [0, -1], [1, 1], [1, -1], [2, 1], [2, -1]];
    for (const [axis, sgn] of faces) {
      const u = (axis + 1) % 3, v = (axis + 2) % 3, base = pos.length / 3;
      for (const [a, b] of [[-1, -1], [1, -1], [1, 1], [-1, 1]]) {
        const p = [0, 0, 0], n = [0, 0, 0];
        p[axis] = sgn * h[axis]; p[u] = a * h[u]; p[v] = b * h[v]; n[axis] = sgn;
        pos.push(...p); nrm.push(...n);
      }
      if (sgn > 0) idx.push(base, base + 1, base + 2, base, base + 2, base + 3);
      else idx.push(base, base + 2, base + 1, base, base + 3, base + 2);
    }
    return makeMesh(pos, nrm, idx);
  }
  const r = shape.radius_m, half = shape.length_m / 2, seg = 20, rings = 8;
  // Rows from the bottom pole to the top pole; the two hemispheres are offset by ±half.
  const rows = [];
  for (let i = 0; i <= rings; i++) rows.push([-Math.PI / 2 + (i / rings) * Math.PI / 2, -half]);
  for (let i = 0; i <= rings; i++) rows.push([(i / rings) * Math.PI / 2, half]);
  rows.forEach(([lat, off]) => {
    for (let j = 0; j <= seg; j++) {
      const lon = (j / seg) * Math.PI * 2;
      const n = [Math.cos(lat) * Math.cos(lon), Math.sin(lat), Math.cos(lat) * Math.sin(lon)];
      nrm.push(...n);
      pos.push(n[0] * r, n[1] * r + off, n[2] * r);
    }
  });
  for (let i = 0; i < rows.length - 1; i++) for (let j = 0; j < seg; j++) {
    const a = i * (seg + 1) + j, b = a + seg + 1;
    idx.push(a, a + 1, b, b, a + 1, b + 1);
  }
  return makeMesh(pos, nrm, idx);
}

function makeSkinnedMesh(mesh, ragdoll) {
  const n = mesh.positions.length / 3;
  const normals = mesh.normals.length === mesh.positions.length ? mesh.normals : smoothNormals(mesh);
  const vao = gl.createVertexArray();
  gl.bindVertexArray(vao);
  const fbuf = (data, loc, size) => {
    const b = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, b);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(data), gl.STATIC_DRAW);
    gl.enableVertexAttribArray(loc);
    gl.vertexAttribPointer(loc, size, gl.FLOAT, false, 0, 0);
  };
  fbuf(mesh.positions, 0, 3);
  fbuf(normals, 1, 3);
  const jb = gl.createBuffer();
  gl.bindBuffer(gl.ARRAY_BUFFER, jb);
  gl.bufferData(gl.ARRAY_BUFFER, new Uint16Array(mesh.joints), gl.STATIC_DRAW);
  gl.enableVertexAttribArray(2);
  gl.vertexAttribIPointer(2, 4, gl.UNSIGNED_SHORT, 0, 0);
  fbuf(mesh.weights, 3, 4);
  const ib = gl.createBuffer();
  gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, ib);
  gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, new Uint32Array(mesh.indices), gl.STATIC_DRAW);
  gl.bindVertexArray(null);
  const joints = ragdoll.parents.length;
  const tex = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, tex);
  gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA32F, 4, joints);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
  return { vao, count: mesh.indices.length, tex, joints, vertices: n };
}

function smoothNormals(mesh) {
  const p = mesh.positions, out = new Float32Array(p.length);
  for (let i = 0; i < mesh.indices.length; i += 3) {
    const [a, b, c] = [mesh.indices[i], mesh.indices[i + 1], mesh.indices[i + 2]];
    const pa = [p[3 * a], p[3 * a + 1], p[3 * a + 2]];
    const n = V.cross(V.sub([p[3 * b], p[3 * b + 1], p[3 * b + 2]], pa), V.sub([p[3 * c], p[3 * c + 1], p[3 * c + 2]], pa));
    for (const k of [a, b, c]) { out[3 * k] += n[0]; out[3 * k + 1] += n[1]; out[3 * k + 2] += n[2]; }
  }
  return out;
}

// ---------------------------------------------------------------- drawing
function lightSetup() {
  const c = centreOfMass(0) || camera.target;
  const dir = V.norm([0.45, 1.0, 0.3]);
  const k = viewer.size;
  const eye = V.add(c, V.scale(dir, 10 * k));
  const view = M4.lookAt(eye, c, [0, 1, 0]);
  const ext = 4.0 * k;
  return { dir, vp: M4.mul(M4.ortho(-ext, ext, -ext, ext, 0.5 * k, 25 * k), view) };
}

// Skinning matrices (joint now · rest⁻¹, column-major), computed by the server.
function boneMatrices(ragdoll, frameRagdoll) {
  const data = new Float32Array(16 * ragdoll.parents.length);
  data.set(frameRagdoll.skin.slice(0, data.length));
  return data;
}

function groundY() {
  return viewer.scene && viewer.scene.ground !== null ? viewer.scene.ground : 0;
}

// Every solid thing, drawn with `p` (lit or depth): ground, capsules, skinned meshes.
function drawScene(p, ps, uniforms, depthOnly) {
  const show = { mesh: $('show-mesh').checked, bodies: $('show-bodies').checked };
  const f = viewer.frame, s = viewer.specs, sc = viewer.scene;
  gl.useProgram(p.p);
  uniforms(p);
  if (!depthOnly && viewer.scene && viewer.scene.ground !== null) {
    gl.uniformMatrix4fv(p.u.uModel, false, M4.fromTr({ t: [0, groundY(), 0], q: [0, 0, 0, 1] }));
    gl.uniform1i(p.u.uGround, 1);
    gl.bindVertexArray(ground.vao);
    gl.drawElements(gl.TRIANGLES, ground.count, gl.UNSIGNED_INT, 0);
  }
  if (!f || !s || !sc) return;
  if (p.u.uGround) gl.uniform1i(p.u.uGround, 0);
  s.ragdolls.forEach((r, ri) => {
    if (!r.capsules || !f.ragdolls[ri]) return;
    const hasMesh = sc.ragdolls[ri] && sc.ragdolls[ri].gpuMeshes && sc.ragdolls[ri].gpuMeshes.length > 0;
    r.capsules.forEach((mesh, bi) => {
      const selected = viewer.selected && viewer.selected.ragdoll === ri && viewer.selected.body === bi;
      if (!(show.bodies || !hasMesh || !show.mesh || selected)) return;
      if (depthOnly && hasMesh && show.mesh) return;
      const pose = bodyPose(ri, bi);
      if (p.u.uColor) gl.uniform3fv(p.u.uColor, selected ? [0.95, 0.62, 0.2] : [0.55, 0.68, 0.8]);
      const shapes = [{ mesh, at: null }].concat((r.extras && r.extras[bi]) || []);
      for (const e of shapes) {
        gl.uniformMatrix4fv(p.u.uModel, false, M4.fromTr(e.at ? T.mul(pose, e.at) : pose));
        gl.bindVertexArray(e.mesh.vao);
        gl.drawElements(gl.TRIANGLES, e.mesh.count, gl.UNSIGNED_INT, 0);
      }
    });
  });
  if (!show.mesh) return;
  gl.useProgram(ps.p);
  uniforms(ps);
  if (ps.u.uGround) gl.uniform1i(ps.u.uGround, 0);
  sc.ragdolls.forEach((r, ri) => {
    if (!r.gpuMeshes || !f.ragdolls[ri]) return;
    const bones = boneMatrices(r, f.ragdolls[ri]);
    for (const m of r.gpuMeshes) {
      gl.activeTexture(gl.TEXTURE1);
      gl.bindTexture(gl.TEXTURE_2D, m.tex);
      gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, 4, m.joints, gl.RGBA, gl.FLOAT, bones);
      gl.uniform1i(ps.u.uBones, 1);
      if (ps.u.uColor) gl.uniform3fv(ps.u.uColor, [0.78, 0.7, 0.62]);
      gl.bindVertexArray(m.vao);
      gl.drawElements(gl.TRIANGLES, m.count, gl.UNSIGNED_INT, 0);
    }
  });
}

// Overlay lines: joint limits (cones and hinge arcs), the charge, the drag.
function overlayLines() {
  const out = [];
  const line = (a, b, c) => out.push(...a, ...c, ...b, ...c);
  const f = viewer.frame, s = viewer.specs;
  if ($('show-joints').checked && f && s) {
    s.ragdolls.forEach((r, ri) => {
      r.joint_frames.forEach((j, ji) => {
        const parent = bodyPose(ri, j.parent), child = bodyPose(ri, j.child);
        if (!parent || !child) return;
        const fp = T.mul(parent, tr(j.frame_parent, 0)), fc = tr(j.frame_child, 0);
        const anchor = T.apply(child, fc.t);
        const kind = r.spec.joints[ji].kind, len = 0.12 * viewer.size;
        const x = Q.rotate(fp.q, [1, 0, 0]);
        // The child's centre seen from the joint at rest, in the joint frame.
        let d = Q.rotate(Q.conj(fc.q), V.scale(fc.t, -1));
        const col = [1.0, 0.85, 0.3];
        if (kind === 'hinge') {
          d = V.norm(V.sub(d, V.scale([1, 0, 0], d[0])));
          const lim = r.spec.joints[ji];
          let prev = null;
          for (let i = 0; i <= 16; i++) {
            const a = (lim.min_deg + (lim.max_deg - lim.min_deg) * i / 16) * Math.PI / 180;
            const p = V.add(anchor, V.scale(Q.rotate(fp.q, Q.rotate(Q.axisAngle([1, 0, 0], a), d)), len));
            if (prev) line(prev, p, col);
            if (i === 0 || i === 16) line(anchor, p, col);
            prev = p;
          }
        } else if (kind === 'swing_twist') {
          const sw = r.spec.joints[ji].swing_deg * Math.PI / 180;
          const y = Q.rotate(fp.q, [0, 1, 0]), z = Q.rotate(fp.q, [0, 0, 1]);
          let prev = null;
          for (let i = 0; i <= 24; i++) {
            const a = i / 24 * Math.PI * 2;
            const dir = V.add(V.scale(x, Math.cos(sw)), V.add(V.scale(y, Math.sin(sw) * Math.cos(a)), V.scale(z, Math.sin(sw) * Math.sin(a))));
            const p = V.add(anchor, V.scale(dir, len));
            if (prev) line(prev, p, col);
            if (i % 6 === 0) line(anchor, p, col);
            prev = p;
          }
        }
      });
    });
  }
  if (viewer.blastAt) {
    const c = [viewer.blastAt[0], groundY() + Number($('height').value), viewer.blastAt[2]];
    const red = [1, 0.3, 0.2];
    for (let i = 0; i < 3; i++) {
      const a = [0, 0, 0]; a[i] = 0.15 * viewer.size;
      line(V.sub(c, a), V.add(c, a), red);
    }
    line(c, [c[0], groundY(), c[2]], red);
    let prev = null;
    for (let i = 0; i <= 32; i++) {
      const a = i / 32 * Math.PI * 2;
      const k = 0.3 * viewer.size;
      const p = [c[0] + k * Math.cos(a), groundY() + 0.005 * viewer.size, c[2] + k * Math.sin(a)];
      if (prev) line(prev, p, red);
      prev = p;
    }
  }
  if (drag && drag.target) {
    const p = bodyPose(drag.ragdoll, drag.body);
    if (p) line(T.apply(p, drag.local), drag.target, [0.4, 1, 0.5]);
  }
  return new Float32Array(out);
}

function draw() {
  requestAnimationFrame(draw);
  if (!gl) return;
  const w = canvas.clientWidth * devicePixelRatio, h = canvas.clientHeight * devicePixelRatio;
  if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
  // Camera: eases toward the first character's centre of mass when following, so a thrown
  // character stays in view.
  const c = $('follow').checked && !orbit && !drag && centreOfMass(0);
  if (c) {
    const goal = [c[0], Math.max(0.5 * viewer.size, c[1]), c[2]];
    camera.target = V.add(camera.target, V.scale(V.sub(goal, camera.target), 0.08));
  }
  const cp = Math.cos(camera.pitch);
  camera.eye = V.add(camera.target, V.scale([cp * Math.sin(camera.yaw), Math.sin(camera.pitch), cp * Math.cos(camera.yaw)], camera.dist));
  viewProj = M4.mul(M4.perspective(0.8, w / Math.max(h, 1), 0.05 * viewer.size, 400 * viewer.size),
    M4.lookAt(camera.eye, camera.target, [0, 1, 0]));
  const light = lightSetup();
  // Shadow pass.
  gl.bindFramebuffer(gl.FRAMEBUFFER, shadow.fb);
  gl.viewport(0, 0, SHADOW_SIZE, SHADOW_SIZE);
  gl.enable(gl.DEPTH_TEST);
  gl.clear(gl.DEPTH_BUFFER_BIT);
  gl.enable(gl.POLYGON_OFFSET_FILL);
  gl.polygonOffset(2, 4);
  drawScene(prog.depth, prog.skinDepth, (p) => gl.uniformMatrix4fv(p.u.uVP, false, light.vp), true);
  gl.disable(gl.POLYGON_OFFSET_FILL);
  // Main pass.
  gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  gl.viewport(0, 0, w, h);
  gl.clearColor(0.12, 0.14, 0.17, 1);
  gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
  gl.activeTexture(gl.TEXTURE0);
  gl.bindTexture(gl.TEXTURE_2D, shadow.tex);
  drawScene(prog.lit, prog.skin, (p) => {
    gl.uniformMatrix4fv(p.u.uVP, false, viewProj);
    gl.uniformMatrix4fv(p.u.uLightVP, false, light.vp);
    gl.uniform3fv(p.u.uLightDir, light.dir);
    gl.uniform3fv(p.u.uEye, camera.eye);
    gl.uniform1i(p.u.uShadow, 0);
    gl.uniform1f(p.u.uScale, viewer.size);
  }, false);
  const lines = overlayLines();
  if (lines.length) {
    gl.disable(gl.DEPTH_TEST);
    gl.useProgram(prog.line.p);
    gl.uniformMatrix4fv(prog.line.u.uVP, false, viewProj);
    gl.bindVertexArray(lineVao);
    gl.bindBuffer(gl.ARRAY_BUFFER, lineBuf);
    gl.bufferData(gl.ARRAY_BUFFER, lines, gl.DYNAMIC_DRAW);
    gl.drawArrays(gl.LINES, 0, lines.length / 6);
    gl.enable(gl.DEPTH_TEST);
  }
  gl.bindVertexArray(null);
  viewer.drawn = (viewer.drawn || 0) + 1;
}

// ---------------------------------------------------------------- picking and mouse
// Screen position (CSS pixels in the canvas) of a world point: what scripts aim the mouse at.
viewer.project = (p) => {
  const m = viewProj, x = p[0], y = p[1], z = p[2];
  const cx = m[0] * x + m[4] * y + m[8] * z + m[12], cy = m[1] * x + m[5] * y + m[9] * z + m[13];
  const cw = m[3] * x + m[7] * y + m[11] * z + m[15];
  const rect = canvas.getBoundingClientRect();
  return { x: rect.left + (cx / cw * 0.5 + 0.5) * rect.width, y: rect.top + (0.5 - cy / cw * 0.5) * rect.height };
};
viewer.bodyPosition = (r, b) => { const p = bodyPose(r, b); return p ? p.t : null; };

function mouseRay(ev) {
  const rect = canvas.getBoundingClientRect();
  const nx = (ev.clientX - rect.left) / rect.width * 2 - 1, ny = 1 - (ev.clientY - rect.top) / rect.height * 2;
  const w = canvas.width, h = canvas.height;
  const fwd = V.norm(V.sub(camera.target, camera.eye));
  const right = V.norm(V.cross(fwd, [0, 1, 0])), up = V.cross(right, fwd);
  const th = Math.tan(0.4), aspect = w / Math.max(h, 1);
  const dir = V.norm(V.add(fwd, V.add(V.scale(right, nx * th * aspect), V.scale(up, ny * th))));
  return { o: camera.eye, d: dir };
}

// Ray against a capsule along local Y (Inigo Quilez's capsule intersection), in body space.
function hitCapsule(ro, rd, half, r) {
  const pa = [0, -half, 0], ba = [0, 2 * half, 0], oa = V.sub(ro, pa);
  const baba = V.dot(ba, ba), bard = V.dot(ba, rd), baoa = V.dot(ba, oa), rdoa = V.dot(rd, oa), oaoa = V.dot(oa, oa);
  let a = baba - bard * bard, b = baba * rdoa - baoa * bard, c = baba * oaoa - baoa * baoa - r * r * baba;
  let hh = b * b - a * c;
  if (a > 1e-9 && hh >= 0) {
    const t = (-b - Math.sqrt(hh)) / a, y = baoa + t * bard;
    if (y > 0 && y < baba && t > 0) return t;
  }
  let best = null;
  for (const end of [pa, [0, half, 0]]) {
    const oc = V.sub(ro, end);
    b = V.dot(rd, oc); c = V.dot(oc, oc) - r * r; hh = b * b - c;
    if (hh >= 0) {
      const t = -b - Math.sqrt(hh);
      if (t > 0 && (best === null || t < best)) best = t;
    }
  }
  return best;
}
function hitBox(ro, rd, h) {
  let t0 = -Infinity, t1 = Infinity;
  for (let i = 0; i < 3; i++) {
    if (Math.abs(rd[i]) < 1e-9) { if (Math.abs(ro[i]) > h[i]) return null; continue; }
    let a = (-h[i] - ro[i]) / rd[i], b = (h[i] - ro[i]) / rd[i];
    if (a > b) [a, b] = [b, a];
    t0 = Math.max(t0, a); t1 = Math.min(t1, b);
  }
  return t0 <= t1 && t0 > 0 ? t0 : null;
}

function pick(ray) {
  let best = null;
  const s = viewer.specs;
  if (s && viewer.frame) s.ragdolls.forEach((r, ri) => r.spec.bodies.forEach((b, bi) => {
    const pose = bodyPose(ri, bi);
    if (!pose) return;
    for (const e of [{ shape: b.shape, at: null }].concat(extraShapes(b))) {
      const at = e.at ? T.mul(pose, e.at) : pose;
      const qi = Q.conj(at.q), ro = Q.rotate(qi, V.sub(ray.o, at.t)), rd = Q.rotate(qi, ray.d);
      const t = e.shape.kind === 'box' ? hitBox(ro, rd, e.shape.size_m.map((x) => x / 2))
        : hitCapsule(ro, rd, e.shape.length_m / 2, e.shape.radius_m);
      if (t !== null && (!best || t < best.t)) {
        // The grab point in the body's own frame, where a drag holds it.
        const hit = T.apply(at, V.add(ro, V.scale(rd, t)));
        best = { t, ragdoll: ri, body: bi, local: Q.rotate(Q.conj(pose.q), V.sub(hit, pose.t)) };
      }
    }
  }));
  return best;
}

// The body under a screen point (CSS pixels), as a click there would pick it.
viewer.pickAt = (x, y) => {
  const hit = pick(mouseRay({ clientX: x, clientY: y }));
  return hit ? { ragdoll: hit.ragdoll, body: hit.body } : null;
};

let drag = null, orbit = null, scrubbing = false, lastMove = 0;
canvas.addEventListener('contextmenu', (e) => e.preventDefault());
canvas.addEventListener('mousedown', (ev) => {
  const ray = mouseRay(ev);
  const hit = ev.button === 0 && !ev.shiftKey ? pick(ray) : null;
  if (hit) {
    const world = V.add(ray.o, V.scale(ray.d, hit.t));
    drag = { ragdoll: hit.ragdoll, body: hit.body, local: hit.local, target: world,
      planeN: V.norm(V.sub(camera.eye, camera.target)), planeP: world };
    viewer.selected = { ragdoll: hit.ragdoll, body: hit.body };
    showSelected();
    send({ type: 'drag_start', ragdoll: hit.ragdoll, body: hit.body, local: hit.local, target: world });
    return;
  }
  orbit = { x: ev.clientX, y: ev.clientY, x0: ev.clientX, y0: ev.clientY,
    pan: ev.button === 2 || ev.shiftKey, ray };
});
window.addEventListener('mousemove', (ev) => {
  if (drag) {
    const ray = mouseRay(ev), denom = V.dot(ray.d, drag.planeN);
    if (Math.abs(denom) < 1e-6) return;
    const t = V.dot(V.sub(drag.planeP, ray.o), drag.planeN) / denom;
    if (t <= 0) return;
    drag.target = V.add(ray.o, V.scale(ray.d, t));
    drag.target[1] = Math.max(drag.target[1], groundY() + 0.02);
    const now = performance.now();
    if (now - lastMove > 12) { lastMove = now; send({ type: 'drag_move', target: drag.target }); }
    return;
  }
  if (!orbit) return;
  const dx = ev.clientX - orbit.x, dy = ev.clientY - orbit.y;
  orbit.x = ev.clientX; orbit.y = ev.clientY;
  if (orbit.pan) {
    $('follow').checked = false; // the user moves the camera's target now
    const fwd = V.norm(V.sub(camera.target, camera.eye));
    const right = V.norm(V.cross(fwd, [0, 1, 0])), up = V.cross(right, fwd);
    const k = camera.dist * 0.0015;
    camera.target = V.add(camera.target, V.add(V.scale(right, -dx * k), V.scale(up, dy * k)));
  } else {
    camera.yaw -= dx * 0.006;
    camera.pitch = Math.min(1.5, Math.max(-0.1, camera.pitch + dy * 0.006));
  }
});
window.addEventListener('mouseup', (ev) => {
  if (drag) {
    if (drag.target) send({ type: 'drag_move', target: drag.target });
    send({ type: 'drag_end' });
    drag = null;
    return;
  }
  if (!orbit) return;
  const moved = Math.hypot(ev.clientX - orbit.x0, ev.clientY - orbit.y0);
  // A click (no drag) on the ground places the charge there.
  if (moved < 4 && !orbit.pan && orbit.ray.d[1] < -1e-4) {
    const t = (groundY() - orbit.ray.o[1]) / orbit.ray.d[1];
    if (t > 0) placeBlast(V.add(orbit.ray.o, V.scale(orbit.ray.d, t)));
  }
  orbit = null;
});
canvas.addEventListener('wheel', (ev) => {
  ev.preventDefault();
  camera.dist = Math.min(60 * viewer.size, Math.max(0.5 * viewer.size, camera.dist * Math.exp(ev.deltaY * 0.001)));
}, { passive: false });

// ---------------------------------------------------------------- panel
function placeBlast(p) {
  viewer.blastAt = p;
  $('detonate').disabled = false;
  $('blast-where').textContent = `Charge at x ${p[0].toFixed(2)} m, z ${p[2].toFixed(2)} m.`;
}
function slider(id, unit, digits) {
  const el = $(id), out = $(`${id}-out`);
  const show = () => { out.textContent = `${Number(el.value).toFixed(digits)} ${unit}`; };
  el.addEventListener('input', show);
  show();
  // `range(lo, hi)` fits the slider to the value being edited (characters differ in size
  // by orders of magnitude), so setting a value never clamps it.
  return { el, show, set(v) { el.value = v; show(); }, get value() { return Number(el.value); },
    range(lo, hi) { el.min = lo; el.max = hi; el.step = 'any'; } };
}
const ui = {
  tnt: slider('tnt', 'kg', 1), height: slider('height', 'm', 2), delay: slider('delay', 's', 1),
  radius: slider('radius', 'm', 3), length: slider('length', 'm', 2), cx: slider('cx', 'm', 2),
  cy: slider('cy', 'm', 2), cz: slider('cz', 'm', 2), mass: slider('mass', 'kg', 1),
  jmin: slider('jmin', '°', 0), jmax: slider('jmax', '°', 0), swing: slider('swing', '°', 0),
  tmin: slider('tmin', '°', 0), tmax: slider('tmax', '°', 0),
};
$('detonate').addEventListener('click', () => {
  if (!viewer.blastAt) return;
  const p = [viewer.blastAt[0], groundY() + ui.height.value, viewer.blastAt[2]];
  send({ type: 'blast', position: p, tnt_kg: ui.tnt.value, delay_s: ui.delay.value });
  if (viewer.frame && !viewer.frame.playing) send({ type: 'play' });
});
$('play').addEventListener('click', () => send({ type: viewer.frame && viewer.frame.playing ? 'pause' : 'play' }));
$('step').addEventListener('click', () => send({ type: 'step' }));
$('reset').addEventListener('click', () => send({ type: 'reset' }));
$('save').addEventListener('click', () => send({ type: 'save' }));
$('backend').addEventListener('change', () => send({ type: 'backend', kind: $('backend').value }));
const timeline = $('timeline');
timeline.addEventListener('pointerdown', () => { scrubbing = true; });
window.addEventListener('pointerup', () => { scrubbing = false; });
timeline.addEventListener('input', () => send({ type: 'scrub', time_s: Number(timeline.value) }));

function showSelected() {
  const sel = viewer.selected, s = viewer.specs;
  const body = sel && s && s.ragdolls[sel.ragdoll] && s.ragdolls[sel.ragdoll].spec.bodies[sel.body];
  $('body-panel').classList.toggle('hidden', !body);
  $('body-none').classList.toggle('hidden', !!body);
  if (!body) return;
  const spec = s.ragdolls[sel.ragdoll].spec;
  $('body-name').textContent = body.name;
  $('body-shape').textContent = body.shape.kind;
  const radius = body.shape.kind === 'capsule' ? body.shape.radius_m : Math.min(...body.shape.size_m) / 2;
  const length = body.shape.kind === 'capsule' ? body.shape.length_m : body.shape.size_m[1];
  const size = Math.max(radius, length);
  // The server refuses edits past its bounds (relative to the file's ragdoll): the
  // sliders stop there.
  const eb = s.ragdolls[sel.ragdoll].edit_bounds;
  ui.radius.range(0.005 * size, Math.min(3 * size, eb.max_extent_m / 2)); ui.radius.set(radius);
  ui.length.range(0, Math.min(3 * size, eb.max_extent_m)); ui.length.set(length);
  const reach = Math.min(2 * size, eb.max_extent_m);
  for (const [k, i] of [['cx', 0], ['cy', 1], ['cz', 2]]) {
    ui[k].range(-reach, reach);
    ui[k].set(body.center_m[i]);
  }
  ui.mass.range(Math.max(body.mass_kg / 20, eb.min_mass_kg), Math.min(body.mass_kg * 5, eb.max_mass_kg));
  ui.mass.set(body.mass_kg);
  const ji = spec.joints.findIndex((j) => j.child === body.name);
  const joint = spec.joints[ji];
  $('joint-panel').classList.toggle('hidden', !joint || (joint.kind !== 'hinge' && joint.kind !== 'swing_twist'));
  if (!joint) return;
  $('joint-name').textContent = `joint to ${joint.parent} (${joint.kind.replace('_', '-')})`;
  $('hinge-limits').classList.toggle('hidden', joint.kind !== 'hinge');
  $('cone-limits').classList.toggle('hidden', joint.kind !== 'swing_twist');
  if (joint.kind === 'hinge') { ui.jmin.set(joint.min_deg); ui.jmax.set(joint.max_deg); }
  if (joint.kind === 'swing_twist') {
    ui.swing.set(joint.swing_deg); ui.tmin.set(joint.twist_deg[0]); ui.tmax.set(joint.twist_deg[1]);
  }
  viewer.selected.joint = ji;
}
for (const k of ['radius', 'length', 'cx', 'cy', 'cz', 'mass']) {
  ui[k].el.addEventListener('change', () => {
    const sel = viewer.selected;
    if (!sel) return;
    send({ type: 'edit_body', ragdoll: sel.ragdoll, body: sel.body, radius_m: ui.radius.value,
      length_m: ui.length.value, center_m: [ui.cx.value, ui.cy.value, ui.cz.value], mass_kg: ui.mass.value });
  });
}
for (const k of ['jmin', 'jmax']) {
  ui[k].el.addEventListener('change', () => {
    const sel = viewer.selected;
    if (!sel || sel.joint < 0) return;
    send({ type: 'edit_joint', ragdoll: sel.ragdoll, joint: sel.joint,
      min_deg: Math.min(ui.jmin.value, ui.jmax.value), max_deg: Math.max(ui.jmin.value, ui.jmax.value) });
  });
}
for (const k of ['swing', 'tmin', 'tmax']) {
  ui[k].el.addEventListener('change', () => {
    const sel = viewer.selected;
    if (!sel || sel.joint < 0) return;
    send({ type: 'edit_joint', ragdoll: sel.ragdoll, joint: sel.joint, swing_deg: ui.swing.value,
      twist_deg: [Math.min(ui.tmin.value, ui.tmax.value), Math.max(ui.tmin.value, ui.tmax.value)] });
  });
}

// Space plays or pauses, "." steps, "f" follows the character again.
window.addEventListener('keydown', (ev) => {
  if (ev.target instanceof HTMLInputElement || ev.target instanceof HTMLSelectElement) return;
  if (ev.key === ' ') { ev.preventDefault(); $('play').click(); }
  else if (ev.key === '.') send({ type: 'step' });
  else if (ev.key === 'f') $('follow').checked = true;
});

connect();
requestAnimationFrame(draw);
