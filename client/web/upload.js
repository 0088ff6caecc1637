// Model uploads as the page sends them (PUT .../model and POST .../assets take the same bodies):
// one file, several, a folder or a drop; and what the page does with a refusal it can act on (an
// upload of several models asks which one in a dialog, then names it with ?entry=; the server's
// words about files an upload lacks get the page's own advice).

const $ = (id) => document.getElementById(id);

// Model files the server reads (an upload's candidates for ?entry=); the companions (.bin, .mtl,
// images) are not among them.
const MODEL_EXTENSIONS = /\.(gltf|glb|obj|fbx|dae|ply|stl|3ds|blend|x3d|off|lwo|ms3d|ase|ac|x|md2|md3|md5mesh|smd|b3d|q3o|ter|3mf|irr|irrmesh|dxf|cob|raw|nff|xgl|zgl|hmp|mdl|ogex)$/i;

// The model files to choose among when the server refused an upload for holding several (its
// detail names them, at most five, "..." after): the named ones, else the upload's own paths
// that look like models. [] for any other refusal.
export function entryChoices(error, paths = []) {
  const detail = error?.problem?.detail || '';
  if (!/several|model files/.test(detail) || !/entry parameter/.test(detail)) return [];
  const listed = [...detail.matchAll(/'([^']+)'/g)].map((m) => m[1]).slice(1);  // [0]: the upload
  if (listed.length > 1 && !/\.\.\.\)/.test(detail)) return listed;
  const own = paths.filter((p) => MODEL_EXTENSIONS.test(p));
  return own.length > 1 ? own : listed;
}

// The server's words for an upload the page can do something about, with what to do in the
// page's terms (the problem's type and status stay, for whoever branches on them).
export function uploadProblem(error) {
  const detail = error?.problem?.detail || '';
  let advice = '';
  if (/cannot carry/.test(detail)) {
    advice = 'Pick the model together with the files it refers to: select them all in Upload, ' +
             'choose their folder in Folder, or drop the folder on the view.';
  } else if (/none of its \d+ files is a model/.test(detail)) {
    advice = 'None of the chosen files is a model: choose a .glb, .gltf, .obj, .fbx or another ' +
             'format the server reads.';
  } else if (/is missing|upload lacks/.test(detail)) {
    advice = 'A file the model refers to was not chosen: choose the model\'s whole folder in Folder.';
  }
  if (!advice) return error;
  const out = new Error(`${error.message}\n${advice}`);
  Object.assign(out, {status: error.status, problem: error.problem, stale: error.stale});
  return out;
}

// The dialog that asks which of an upload's models to load: the chosen path, or '' (cancelled).
export function chooseEntry(choices) {
  const dialog = $('entry-dialog');
  const list = $('entry-choices');
  list.querySelectorAll('label').forEach((l) => l.remove());
  choices.forEach((path, i) => {
    const label = document.createElement('label');
    const radio = document.createElement('input');
    radio.type = 'radio';
    radio.name = 'entry';
    radio.value = path;
    radio.checked = i === 0;
    label.append(radio, path);
    list.append(label);
  });
  $('entry-text').textContent = `The upload holds ${choices.length} models. Load this one:`;
  return new Promise((resolve) => {
    dialog.addEventListener('close', () => {
      const picked = list.querySelector('input[name="entry"]:checked');
      resolve(dialog.returnValue === 'load' && picked ? picked.value : '');
    }, {once: true});
    dialog.returnValue = '';
    dialog.showModal();
  });
}

// "spider.obj (12 KiB)", "3 files (80 KiB)": what an upload sends, for progress messages.
export function describeFiles(files) {
  const total = files.reduce((sum, f) => sum + f.size, 0);
  return `${files.length === 1 ? files[0].name : `${files.length} files`} (${(total / 1024).toFixed(0)} KiB)`;
}

// The request options that send a model: one file goes as itself (a .zip as an archive); several
// (a multi-file pick, a folder, a drop) as multipart/form-data, each under the path the model
// uses for it, so the server finds the model among them and resolves its .bin, .mtl and images.
// Every path is relative to the folder picked or dropped (its own name dropped), as the model's
// own references are. PUT .../model and POST .../assets take the same bodies.
export function modelUpload(files, paths = files.map(relativePath), query) {
  if (files.length === 1) {
    const zip = files[0].name.toLowerCase().endsWith('.zip');
    return {body: files[0], query: {filename: files[0].name, ...query},
            contentType: zip ? 'application/zip' : 'application/octet-stream'};
  }
  const form = new FormData();
  files.forEach((file, i) => form.append('files', file, paths[i]));
  return {body: form, query};  // fetch sets the multipart boundary
}

// A picked file's path inside the picked folder (without the folder's own name), else its name.
export function relativePath(file) {
  const path = file.webkitRelativePath || '';
  const slash = path.indexOf('/');
  return slash >= 0 ? path.slice(slash + 1) : file.name;
}

// Every file under a dropped FileSystemEntry, with its path from the drop.
export async function collectFiles(entry, prefix, out) {
  if (entry.isFile) {
    out.push({file: await new Promise((ok, fail) => entry.file(ok, fail)), path: prefix + entry.name});
    return;
  }
  const reader = entry.createReader();
  for (;;) {
    const batch = await new Promise((ok, fail) => reader.readEntries(ok, fail));
    if (!batch.length) return;
    for (const child of batch) await collectFiles(child, `${prefix}${entry.name}/`, out);
  }
}
