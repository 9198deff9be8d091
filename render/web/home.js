// matfit serve's landing page: pick a folder (packed here as a tar) or an archive, choose a job
// and model, upload with progress, follow the job, then open the viewer or download the pack.
// Talks only to the documented API (docs/server.md, docs/openapi.json). No dependencies.
'use strict';

const $ = (id) => document.getElementById(id);

function token() { return $('token').value.trim(); }
function authHeaders() { return token() ? {Authorization: 'Bearer ' + token()} : {}; }
// Links the browser opens itself (pages, images, downloads) carry the token as ?token= (reads).
function withToken(url) {
  return token() ? url + (url.includes('?') ? '&' : '?') + 'token=' + encodeURIComponent(token())
                 : url;
}

function showError(message) {
  $('error').textContent = message;
  $('submit').disabled = false;
}

// The server's error body is {"error": {"status", "message", "field"}}.
function errorText(status, body) {
  try {
    const e = JSON.parse(body).error;
    if (e && e.message) return `HTTP ${status}: ${e.message}` + (e.field ? ` (${e.field})` : '');
  } catch (_) { /* not JSON */ }
  return `HTTP ${status}: ${body.slice(0, 300)}`;
}

// A POSIX ustar archive of `files` (File objects; their folder-relative paths as the names).
// The server unpacks it like any uploaded tar (server/archive.h: safe extraction).
function ustar(files) {
  const enc = new TextEncoder();
  const parts = [];
  const octal = (n, width) => n.toString(8).padStart(width - 1, '0') + '\0';
  for (const f of files) {
    const path = enc.encode(f.webkitRelativePath || f.name);
    let name = path, prefix = new Uint8Array(0);
    if (path.length > 100) {  // split at a '/' so that prefix ≤ 155 and name ≤ 100 bytes
      let cut = -1;
      for (let i = 0; i < path.length; ++i)
        if (path[i] === 0x2f && i <= 155 && path.length - i - 1 <= 100) { cut = i; break; }
      if (cut < 0) throw new Error(`the path ${f.webkitRelativePath || f.name} is too long for a ` +
                                   'tar archive; upload a zip of the folder instead');
      prefix = path.slice(0, cut), name = path.slice(cut + 1);
    }
    const h = new Uint8Array(512);
    const put = (offset, bytes) => h.set(bytes, offset);
    put(0, name);
    put(100, enc.encode('0000644\0'));
    put(108, enc.encode('0000000\0'));
    put(116, enc.encode('0000000\0'));
    put(124, enc.encode(octal(f.size, 12)));
    put(136, enc.encode(octal(Math.floor((f.lastModified || Date.now()) / 1000), 12)));
    put(148, enc.encode('        '));  // checksum field counts as spaces
    h[156] = 0x30;                      // '0': a regular file
    put(257, enc.encode('ustar\0'));
    put(263, enc.encode('00'));
    put(345, prefix);
    let sum = 0;
    for (const b of h) sum += b;
    put(148, enc.encode(sum.toString(8).padStart(6, '0') + '\0 '));
    parts.push(h, f);
    if (f.size % 512) parts.push(new Uint8Array(512 - (f.size % 512)));
  }
  parts.push(new Uint8Array(1024));  // two zero blocks end the archive
  return new Blob(parts, {type: 'application/x-tar'});
}

function picked() {
  const folder = $('folder').files, archive = $('archive').files;
  if (folder.length) {
    const bytes = Array.from(folder).reduce((s, f) => s + f.size, 0);
    const root = (folder[0].webkitRelativePath || '').split('/')[0] || 'folder';
    return {kind: 'folder', label: `${root}: ${folder.length} files, ` +
            `${(bytes / 1048576).toFixed(1)} MiB`};
  }
  if (archive.length)
    return {kind: 'archive', label: `${archive[0].name}, ` +
            `${(archive[0].size / 1048576).toFixed(1)} MiB`};
  return null;
}

async function loadModels() {
  try {
    const r = await fetch('/api/v1/models');
    if (!r.ok) return;
    const j = await r.json();
    for (const m of j.models || []) {
      const opt = document.createElement('option');
      opt.value = m.name;
      opt.textContent = m.name;
      opt.title = m.description || '';
      $('model').appendChild(opt);
    }
    const help = () => {
      const o = $('model').selectedOptions[0];
      $('model-help').textContent = o && o.value !== 'auto' ? o.title : j.auto || '';
    };
    $('model').addEventListener('change', help);
    help();
  } catch (_) { /* the page still works with auto */ }
}

function upload(body, fields) {
  return new Promise((resolve, reject) => {
    const form = new FormData();
    for (const [k, v] of Object.entries(fields)) form.append(k, v);
    form.append('file', body.blob, body.name);
    const xhr = new XMLHttpRequest();
    xhr.open('POST', '/api/v1/jobs');
    for (const [k, v] of Object.entries(authHeaders())) xhr.setRequestHeader(k, v);
    xhr.upload.onprogress = (e) => {
      if (e.lengthComputable) $('upload-progress').value = e.loaded / e.total;
    };
    xhr.onload = () => {
      if (xhr.status === 202 || xhr.status === 200) resolve(JSON.parse(xhr.responseText));
      else reject(new Error(errorText(xhr.status, xhr.responseText)));
    };
    xhr.onerror = () => reject(new Error('the upload failed (network error or the server ' +
                                         'closed the connection: is the file within its limit?)'));
    xhr.send(form);
  });
}

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

async function follow(id) {
  for (;;) {
    const r = await fetch(`/api/v1/jobs/${id}`, {headers: authHeaders()});
    const text = await r.text();
    if (!r.ok) throw new Error(errorText(r.status, text));
    const job = JSON.parse(text);
    const p = job.progress || {};
    $('job-state').textContent = `job ${job.id}: ${job.state}`;
    $('job-stage').textContent = (p.stage ? `${p.stage}` : '') +
        (p.eta_seconds ? `, about ${Math.ceil(p.eta_seconds)} s left` : '');
    $('job-progress').value = p.fraction || 0;
    if (job.state === 'succeeded') return job;
    if (job.state === 'failed' || job.state === 'cancelled')
      throw new Error(`the job ${job.state}: ${job.error || 'no reason given'}`);
    await sleep(700);
  }
}

async function showResult(job) {
  const links = job.links;
  $('open-viewer').href = withToken('/viewer/' + job.id);
  $('download').href = withToken(links.pack);
  $('report').href = withToken(links.report);
  const list = $('leaves');
  list.textContent = '';
  if (job.mode === 'leaf') {
    $('result-image').src = withToken(`/api/v1/packs/${job.id}/segmentation.png`);
    $('result-image').alt = 'segmentation: each leaf numbered';
    const r = await fetch(links.leaves, {headers: authHeaders()});
    if (r.ok) {
      for (const [i, leaf] of ((await r.json()).leaves || []).entries()) {
        const li = document.createElement('li');
        const a = document.createElement('a');
        a.href = withToken(`/viewer/${job.id}?select=${i}`);
        a.textContent = `leaf ${leaf.id}`;
        li.appendChild(a);
        li.appendChild(document.createTextNode(
            ` (${leaf.name}` + (leaf.area_mm2 ? `, ${Number(leaf.area_mm2).toFixed(0)} mm²` : '') +
            ')'));
        list.appendChild(li);
      }
    }
  } else {
    $('result-image').src = withToken(links.preview);
    $('result-image').alt = 'preview of the fitted material';
  }
  $('done').hidden = false;
  $('submit').disabled = false;
}

async function submit(event) {
  event.preventDefault();
  $('error').textContent = '';
  $('done').hidden = true;
  const what = picked();
  if (!what) return showError('choose a folder or an archive first');
  sessionStorage.setItem('matfit-token', token());
  $('submit').disabled = true;
  $('status').hidden = false;
  $('upload-progress').value = 0;
  $('job-progress').value = 0;
  $('job-state').textContent = 'uploading';
  $('job-stage').textContent = '';
  try {
    const body = what.kind === 'folder'
        ? {blob: ustar(Array.from($('folder').files)), name: 'dataset.tar'}
        : {blob: $('archive').files[0], name: $('archive').files[0].name};
    const fields = {mode: $('mode').value};
    if (fields.mode === 'fit') fields.model = $('model').value;
    const job = await upload(body, fields);
    $('upload-progress').value = 1;
    await showResult(await follow(job.id));
  } catch (e) {
    showError(String(e.message || e));
  }
}

function main() {
  $('token').value = sessionStorage.getItem('matfit-token') || '';
  const update = (which) => () => {
    if (which === 'folder' && $('folder').files.length) $('archive').value = '';
    if (which === 'archive' && $('archive').files.length) $('folder').value = '';
    const what = picked();
    $('picked').textContent = what ? what.label : '';
  };
  $('folder').addEventListener('change', update('folder'));
  $('archive').addEventListener('change', update('archive'));
  $('mode').addEventListener('change', () => {
    $('model-label').hidden = $('mode').value !== 'fit';
  });
  $('form').addEventListener('submit', submit);
  loadModels();
}

main();
