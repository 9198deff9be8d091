// matfit web viewer: WebGL2 preview of a material pack with the same GLSL as the headless EGL
// renderer (render/shaders, fetched over HTTP and concatenated exactly as shader_sources.cc does)
// and the same parameter texels (the pack's viewer/params.bin). No dependencies.
//
// URL parameters: pack=URL/ (folder with material.json; default ../pack/; several packs of one
// sample, comma-separated, get a model switcher), shaders=URL/
// (default ../shaders/), theta, phi (degrees), scene (plane|sphere|cloth), size (pixels), exposure,
// ambient, camera_theta, camera_phi (degrees), select=i (which of several packs to show first), measured=URL (an image shown side by side), probe=1 (after the first frame, write the
// RGBA8 pixels as JSON into #probe for tests), token (a bearer token sent with every request:
// `matfit serve --token-file` without --public-read).
'use strict';

const MODEL_NAMES = ['mean', 'lambert', 'blinn-phong', 'cook-torrance', 'heinrich', 'ptm', 'hsh',
                     'lafortune', 'rbf'];

function fail(message) {
  document.getElementById('error').textContent = 'matfit viewer: ' + message;
  const probe = document.getElementById('probe');
  if (probe) probe.textContent = JSON.stringify({error: message});
  throw new Error(message);
}

const TOKEN = new URLSearchParams(location.search).get('token');

async function fetchOk(url, kind) {
  const r = await fetch(url, TOKEN ? {headers: {Authorization: 'Bearer ' + TOKEN}} : {});
  if (!r.ok) fail(`cannot load ${url}: HTTP ${r.status}`);
  return kind === 'json' ? r.json() : kind === 'buffer' ? r.arrayBuffer() : r.text();
}

function compile(gl, type, source, name) {
  const sh = gl.createShader(type);
  gl.shaderSource(sh, source);
  gl.compileShader(sh);
  if (!gl.getShaderParameter(sh, gl.COMPILE_STATUS))
    fail(`shader ${name} does not compile: ${gl.getShaderInfoLog(sh)}`);
  return sh;
}

// The switcher's name for a pack: a leaf's number (as segmentation.png labels it) and folder,
// else the fit's method (or model).
function packLabel(m, url, i) {
  const method = m.model?.method || m.model?.name || 'pack ' + i;
  const leaf = m.model?.parameters?.leaf_id;
  if (leaf === undefined) return method;
  const folder = url.replace(/\/+$/, '').split('/').pop();
  return `leaf ${leaf} (${folder}, ${method})`;
}

async function main() {
  const q = new URLSearchParams(location.search);
  const packs = (q.get('pack') || '../pack/').split(',').filter((p) => p);
  const shaders = q.get('shaders') || '../shaders/';
  const [preamble, shading, frag, vert, ...materials] = await Promise.all([
    fetchOk(shaders + 'preamble.glsl'), fetchOk(shaders + 'shading.glsl'),
    fetchOk(shaders + 'material.frag'), fetchOk(shaders + 'fullscreen.vert'),
    ...packs.map((p) => fetchOk(p + 'material.json', 'json')),
  ]);
  materials.forEach((m, i) => {
    if (!m.viewer || !m.viewer.params)
      fail(`${packs[i]}material.json has no "viewer" section; re-write the pack with this matfit`);
  });
  let v = materials[0].viewer;  // the pack on screen
  const state = {
    theta: Number(q.get('theta') ?? 30), phi: Number(q.get('phi') ?? 45),
    scene: {plane: 0, sphere: 1, cloth: 2}[q.get('scene') || 'plane'] ?? 0, exposure: Number(q.get('exposure') ?? 1),
    ambient: Number(q.get('ambient') ?? 0), tonemap: 0,
    cameraTheta: Number(q.get('camera_theta') ?? 0), cameraPhi: Number(q.get('camera_phi') ?? 0),
  };
  const canvas = document.getElementById('canvas');
  const size = Number(q.get('size') || 512);
  canvas.width = canvas.height = size;
  const gl = canvas.getContext('webgl2', {antialias: false, preserveDrawingBuffer: true,
                                          premultipliedAlpha: false});
  if (!gl) fail('this browser has no WebGL2');

  const program = gl.createProgram();
  gl.attachShader(program, compile(gl, gl.VERTEX_SHADER, preamble + vert, 'fullscreen.vert'));
  gl.attachShader(program, compile(gl, gl.FRAGMENT_SHADER, preamble + shading + frag,
                                   'material.frag'));
  gl.linkProgram(program);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS))
    fail('shader program does not link: ' + gl.getProgramInfoLog(program));
  const tex = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D_ARRAY, tex);
  gl.texParameteri(gl.TEXTURE_2D_ARRAY, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D_ARRAY, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
  // rbf: the basis table, one R32F layer per term (texture unit 1).
  const table = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D_ARRAY, table);
  gl.texParameteri(gl.TEXTURE_2D_ARRAY, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D_ARRAY, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
  gl.texImage3D(gl.TEXTURE_2D_ARRAY, 0, gl.R32F, 1, 1, 1, 0, gl.RED, gl.FLOAT,
                new Float32Array(1));  // complete until an rbf pack replaces it
  // Uploads pack i's parameter planes (fetched once, then cached).
  const cache = new Map();
  async function loadPack(i) {
    const mv = materials[i].viewer;
    if (!cache.has(i)) {
      const texels = new Float32Array(await fetchOk(packs[i] + mv.params, 'buffer'));
      if (texels.length !== mv.layers * mv.width * mv.height * 4)
        fail(`${packs[i]}${mv.params} has ${texels.length} floats, expected ` +
             `${mv.layers * mv.width * mv.height * 4}`);
      let basis = null;
      if (mv.table_size > 0) {
        basis = new Float32Array(await fetchOk(packs[i] + mv.basis_table, 'buffer'));
        if (basis.length !== mv.table_size * mv.table_size * mv.terms)
          fail(`${packs[i]}${mv.basis_table} has ${basis.length} floats, expected ` +
               `${mv.table_size * mv.table_size * mv.terms}`);
      }
      cache.set(i, {texels, basis});
    }
    gl.bindTexture(gl.TEXTURE_2D_ARRAY, tex);
    gl.texImage3D(gl.TEXTURE_2D_ARRAY, 0, gl.RGBA32F, mv.width, mv.height, mv.layers, 0, gl.RGBA,
                  gl.FLOAT, cache.get(i).texels);
    if (cache.get(i).basis) {
      gl.bindTexture(gl.TEXTURE_2D_ARRAY, table);
      gl.texImage3D(gl.TEXTURE_2D_ARRAY, 0, gl.R32F, mv.table_size, mv.table_size, mv.terms, 0,
                    gl.RED, gl.FLOAT, cache.get(i).basis);
    }
    v = mv;
    const model = MODEL_NAMES[v.model_index] || materials[i].model?.name;
    const leaf = materials[i].model?.parameters?.leaf_id !== undefined;
    document.getElementById('title').textContent =
        `matfit viewer: ${leaf ? packLabel(materials[i], packs[i], i) : model}`;
    const summary = materials[i].report_summary || {};
    document.getElementById('info').textContent =
        `${v.width} × ${v.height} texels, model ${model}` +
        (summary.rmse !== undefined ? `, fit RMSE ${Number(summary.rmse).toFixed(4)}` : '');
    return model;
  }
  const vao = gl.createVertexArray();
  const U = (name) => gl.getUniformLocation(program, name);

  function draw() {
    const t = state.theta * Math.PI / 180, p = state.phi * Math.PI / 180;
    gl.viewport(0, 0, size, size);
    gl.clearColor(0, 0, 0, 0);
    gl.clear(gl.COLOR_BUFFER_BIT);
    gl.useProgram(program);
    gl.uniform1i(U('u_params'), 0);
    gl.uniform1i(U('u_basis_table'), 1);
    gl.uniform1i(U('u_table_size'), v.table_size || 0);
    gl.uniform2i(U('u_texels'), v.width, v.height);
    gl.uniform1i(U('u_size'), size);
    gl.uniform1i(U('u_scene'), state.scene);
    gl.uniform1i(U('u_model'), v.model_index);
    gl.uniform1i(U('u_terms'), v.terms);
    gl.uniform1i(U('u_coef_channels'), v.coef_channels);
    gl.uniform1i(U('u_basis_srgb'), v.basis_srgb ? 1 : 0);
    gl.uniform1i(U('u_heinrich_specular'), v.heinrich_specular ? 1 : 0);
    gl.uniform1i(U('u_flat_normal'), v.flat_normal ? 1 : 0);
    gl.uniform1i(U('u_leaf_base'), v.leaf_base ?? -1);
    gl.uniform1i(U('u_leaf_hl2'), v.leaf_hl2 ? 1 : 0);
    gl.uniform3f(U('u_light'), Math.sin(t) * Math.cos(p), Math.sin(t) * Math.sin(p), Math.cos(t));
    // render/render_options.cc MakeCamera: v toward the camera, r right, u up.
    const ct = Math.cos(state.cameraTheta * Math.PI / 180), st = Math.sin(state.cameraTheta * Math.PI / 180);
    const cp = Math.cos(state.cameraPhi * Math.PI / 180), sp = Math.sin(state.cameraPhi * Math.PI / 180);
    const et = [ct * cp, ct * sp, -st], ep = [-sp, cp, 0];
    gl.uniform3f(U('u_cam_v'), st * cp, st * sp, ct);
    gl.uniform3f(U('u_cam_r'), et[0] * cp - ep[0] * sp, et[1] * cp - ep[1] * sp, et[2] * cp - ep[2] * sp);
    gl.uniform3f(U('u_cam_u'), et[0] * sp + ep[0] * cp, et[1] * sp + ep[1] * cp, et[2] * sp + ep[2] * cp);
    gl.uniform3f(U('u_intensity'), 1, 1, 1);
    gl.uniform3f(U('u_ambient'), state.ambient, state.ambient, state.ambient);
    gl.uniform1f(U('u_exposure'), state.exposure);
    gl.uniform1i(U('u_tonemap'), state.tonemap);
    gl.uniform1i(U('u_display'), 1);
    gl.activeTexture(gl.TEXTURE1);
    gl.bindTexture(gl.TEXTURE_2D_ARRAY, table);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D_ARRAY, tex);
    gl.bindVertexArray(vao);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    document.getElementById('light').textContent =
        `light θ ${state.theta.toFixed(1)}°, φ ${state.phi.toFixed(1)}°`;
    lightTheta.value = String(state.theta);
    lightPhi.value = String(state.phi);
  }
  // Light sliders: θ from the zenith (up to 180° for two-sided leaves: lit from behind), φ.
  const lightTheta = document.getElementById('light-theta');
  const lightPhi = document.getElementById('light-phi');
  const rimOf = () => (v.leaf_base >= 0 ? 180 : 85);
  lightTheta.addEventListener('input', () => { state.theta = Number(lightTheta.value); draw(); });
  lightPhi.addEventListener('input', () => { state.phi = Number(lightPhi.value); draw(); });

  // The light follows the pointer: distance from the centre → θ (0–85°), angle → φ.
  canvas.addEventListener('pointermove', (e) => {
    const r = canvas.getBoundingClientRect();
    const x = 2 * (e.clientX - r.left) / r.width - 1, y = 1 - 2 * (e.clientY - r.top) / r.height;
    // Leaves are two-sided: past the rim the light goes behind the leaf (θ up to 180°).
    state.theta = Math.min(1, Math.hypot(x, y)) * rimOf();
    state.phi = Math.atan2(y, x) * 180 / Math.PI;
    draw();
  });
  const bind = (id, key, map) => {
    const el = document.getElementById(id);
    el.addEventListener('input', () => { state[key] = map(el.value); draw(); });
  };
  document.getElementById('scene').value = String(state.scene);
  bind('scene', 'scene', Number);
  bind('tonemap', 'tonemap', Number);
  bind('exposure', 'exposure', (x) => Math.pow(2, Number(x)));
  bind('ambient', 'ambient', Number);
  document.getElementById('camera-theta').value = String(state.cameraTheta);
  document.getElementById('camera-phi').value = String(state.cameraPhi);
  bind('camera-theta', 'cameraTheta', Number);
  bind('camera-phi', 'cameraPhi', Number);

  const select = document.getElementById('model');
  materials.forEach((m, i) => {
    const opt = document.createElement('option');
    opt.value = String(i);
    opt.textContent = packLabel(m, packs[i], i);
    select.appendChild(opt);
  });
  const anyLeaf = materials.some((m) => m.model?.parameters?.leaf_id !== undefined);
  document.getElementById('model-label').firstChild.textContent = anyLeaf ? 'leaf ' : 'model ';
  document.getElementById('model-label').hidden = materials.length < 2;
  async function choose(i) {
    select.value = String(i);
    await loadPack(i);
    // The θ range follows the pack: up to 180° for leaves (light from behind), else 85°.
    lightTheta.max = String(rimOf());
    state.theta = Math.min(state.theta, rimOf());
    draw();
  }
  select.addEventListener('input', () => choose(Number(select.value)));
  // Keyboard: arrows move the light (Shift: 1° steps), [ and ] step through the packs.
  document.addEventListener('keydown', (e) => {
    if (e.target instanceof HTMLInputElement || e.target instanceof HTMLSelectElement) return;
    const step = e.shiftKey ? 1 : 5;
    const wrap = (a) => ((a + 540) % 360) - 180;
    if (e.key === 'ArrowLeft') state.phi = wrap(state.phi - step);
    else if (e.key === 'ArrowRight') state.phi = wrap(state.phi + step);
    else if (e.key === 'ArrowUp') state.theta = Math.max(0, state.theta - step);
    else if (e.key === 'ArrowDown') state.theta = Math.min(rimOf(), state.theta + step);
    else if (e.key === '[' || e.key === ']') {
      const n = materials.length, i = Number(select.value);
      if (n > 1) choose((i + (e.key === ']' ? 1 : n - 1)) % n);
      e.preventDefault();
      return;
    } else return;
    e.preventDefault();
    draw();
  });
  const first = Math.min(materials.length - 1, Math.max(0, Number(q.get('select') || 0)));
  select.value = String(first);
  const model = await loadPack(first);
  lightTheta.max = String(rimOf());
  if (q.get('measured')) {
    document.getElementById('measured').src = q.get('measured');
    document.getElementById('measured-figure').hidden = false;
  }
  draw();

  if (q.get('probe')) {
    const px = new Uint8Array(size * size * 4);
    gl.readPixels(0, 0, size, size, gl.RGBA, gl.UNSIGNED_BYTE, px);
    const rows = [];  // top row first, as the other renderers store images
    for (let y = size - 1; y >= 0; --y) rows.push(px.subarray(y * size * 4, (y + 1) * size * 4));
    let bin = '';
    for (const row of rows) for (let i = 0; i < row.length; ++i) bin += String.fromCharCode(row[i]);
    document.getElementById('probe').textContent = JSON.stringify({
      size, model, renderer: gl.getParameter(gl.RENDERER), rgba8_base64: btoa(bin),
    });
  }
}

main().catch((e) => {
  const probe = document.getElementById('probe');
  if (probe && !probe.textContent) probe.textContent = JSON.stringify({error: String(e)});
  document.getElementById('error').textContent = String(e);
});
