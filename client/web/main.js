// Wires the page together: the session (restored from localStorage or created), the live view,
// camera input, panels, stats, messages, the help overlay and keyboard shortcuts.

import {Api, SessionLostError} from './api.js';
import {CameraControl, isTyping} from './camera.js';
import {LightsPanel} from './lights.js';
import {ObjectsPanel} from './objects.js';
import {ObjectHandle} from './handle.js';
import {MaterialPanel, ModelPanel, SettingsPanel} from './panels.js';
import {ReadOnlyMode} from './readonly.js';
import {StatsPanel} from './stats.js';
import {TimelinePanel} from './timeline.js';
import {ViewHint, ViewOverlay} from './overlay.js';
import {LiveView} from './view.js';

const $ = (id) => document.getElementById(id);

const api = new Api();
let targets = ['final'];
let messageIsInfo = false;
let messageIsUnreachable = false;  // "cannot be reached": goes away by itself once it answers
let messageIsStream = false;       // the stream's problem (429, 503): goes once it shows again

// --- messages -----------------------------------------------------------------------------

function showMessage(text, {info = false, newSession = false, apiKey = false,
                             unreachable = false} = {}) {
  messageIsInfo = info;
  messageIsUnreachable = unreachable;
  messageIsStream = false;
  $('message').hidden = false;
  delete $('message').dataset.reason;
  $('message').classList.toggle('info', info);
  $('message-text').textContent = text;
  $('new-session').hidden = !newSession;
  $('api-key-label').hidden = !apiKey;
}

function hideMessage() {
  $('message').hidden = true;
}

function showInfo(text) {
  if (text) showMessage(text, {info: true});
  else if (messageIsInfo) hideMessage();
}

function showProblem(error) {
  if (error.stale) return;  // an answer about the previous session
  if (error instanceof SessionLostError) {
    sessionLost(error.message, error);
    return;
  }
  showMessage(error.message || String(error), {unreachable: error.status === 0});
}

// A page opened from a link whose token no longer opens the session (revoked or expired): the
// session itself may well be there; only its owner can give a new link.
function linkEnded(revoked) {
  view.stop();
  stats.stop();
  closeEvents();
  showMessage(`This link ${revoked ? 'was revoked' : 'no longer works (revoked or expired)'}: ` +
              "ask the session's owner for a new one.", {newSession: true});
  $('message').dataset.reason = 'link-revoked';
}

function sessionLost(text, error = null) {
  if (api.linked && error?.status === 401) {
    linkEnded(/revoked/i.test(error.problem?.detail || ''));
    return;
  }
  view.stop();
  stats.stop();
  closeEvents();
  showMessage(`${text}\nSettings, lights and the model of that session are gone with it.`,
              {newSession: true});
}

// --- parts ----------------------------------------------------------------------------------

const view = new LiveView(api, $('view'), $('stream'), $('view-status'));
// What the view feels like (perf.js), for the browser test and scripts/bench-page.sh.
window.myriadPerf = view.perf;
// The status line and stats strip on the view: "rendering" from the moment of a change (an edit
// sent, camera input) until a new frame shows; fps, latency, bandwidth and codec of the stream.
const overlay = new ViewOverlay($('view-state'), $('stats-strip'));
const hint = new ViewHint($('view-hint'));
view.onConnect = () => overlay.connect();
view.onFrame = (frame) => overlay.frame(frame);
view.onInput = () => {
  overlay.changed();
  hint.used();
};
api.onChange = () => {
  overlay.changed();
  lastOwnEdit = performance.now();
};
api.onChangeFailed = () => overlay.cancelChange();
view.onProblem = (error) => {
  showProblem(error);
  messageIsStream = !(error instanceof SessionLostError) && !$('message').hidden;
};
view.onRecovered = () => { if (messageIsStream) hideMessage(); };
// The page measured that video cannot hold its rate here and took the JPEG stream: said once.
view.onPathChange = (why) => {
  showInfo(`The view now uses the JPEG stream: ${why}.`);
  setTimeout(() => showInfo(null), 8000);
};

const camera = new CameraControl(api, $('view'), view);
camera.onProblem = showProblem;

const viewSize = () => ({width: $('view').clientWidth, height: $('view').clientHeight});
// The size of the frame shown, from the stream's own metadata (the same on every path).
const frameSize = () => view.frameSize();
const lights = new LightsPanel(api, {
  onProblem: showProblem, onInfo: showInfo, getCamera: () => camera.camera,
  getViewSize: viewSize, getFrameSize: frameSize, overlay: $('markers-overlay'),
});
camera.onChange = () => {
  lights.drawOverlay();
  handle.place();
};
camera.onClick = (x, y) => lights.pick(x, y);
new ResizeObserver(() => {
  lights.drawOverlay();
  handle.place();
}).observe($('view'));

const materials = new MaterialPanel(api, {onProblem: showProblem});
const settings = new SettingsPanel(api, {
  onProblem: showProblem,
  onChange: () => {},
});
const stats = new StatsPanel(api, $('stats-graph'), $('stats-table'), {
  onProblem: showProblem,
  onStats: (s) => settings.showShadowCost(s.frame),
  onRecovered: () => { if (messageIsUnreachable) hideMessage(); },
});

const model = new ModelPanel(api, {
  onProblem: showProblem,
  onInfo: showInfo,
  // A new model replaced meshes and materials and reset the camera; lights may have come too.
  onLoaded: (state) => {
    model.show(state);
    camera.setModelBounds(state.model.bounds);
    lights.setModelBounds(state.model.bounds);
    camera.dropPending();
    camera.setFromServer(state.camera);
    materials.refresh();
    lights.changed(state.lights.count);
    objects.refresh();
  },
  onCamera: (cam) => {
    camera.dropPending();
    camera.setFromServer(cam);
  },
});
// The outliner: objects and assets; a model added becomes one more object (and its materials).
const objects = new ObjectsPanel(api, {
  onProblem: showProblem,
  onInfo: showInfo,
  onAssetsChanged: () => materials.refresh(),
  onCount: (count) => hint.setObjects(count),
  onSelected: (object) => handle.show(object),
  onAnimationsChanged: () => timeline.refresh(),
});
// The selected object's move and turn handles on the view; the scene clock's timeline.
const handle = new ObjectHandle(api, $('object-handle'), {
  getCamera: () => camera.camera, getViewSize: viewSize,
  onAnswer: (object) => objects.replace(object), onProblem: showProblem,
});
const timeline = new TimelinePanel(api, {onProblem: showProblem});
// A model file, a .zip, several files or a folder dropped on the view is added to the scene as a
// new object at the view's centre; with Shift it replaces the scene, as the Model panel's pick.
model.acceptDrops($('view'), (files, paths, event) =>
    event.shiftKey ? model.upload(files, paths) : objects.addModel(files, paths));

// --- the session ----------------------------------------------------------------------------

// Every page of a session (the owner's tabs and its viewers' pages) keeps its controls in sync
// through GET .../events (Server-Sent Events of the session's version): on each new version it
// reloads the session's state into the panels. A page's own edits also come back as versions: it
// waits until it has been quiet for OWN_EDIT_QUIET_MS (a drag sends many), then syncs once.
const OWN_EDIT_QUIET_MS = 400;
let events = null;         // the EventSource of this session, or null
let eventsEnded = false;   // the session or the link ended: no new EventSource
let seenVersion = null;    // the version the controls show
let lastOwnEdit = -Infinity;
let syncRunning = false;
let syncQueued = false;
let syncTimer = 0;
const readOnly = new ReadOnlyMode($('panels'), $('view-only-note'));

async function syncControls() {
  const session = api.session;
  if (!session) return;
  let state;
  try {
    state = await api.get(api.sessionPath());
  } catch (e) {
    showProblem(e);
    return;
  }
  if (api.session !== session) return;
  settings.show(state.settings);
  camera.setFromServer(state.camera);
  model.show(state);
  if (state.lights.count !== lights.total) lights.changed(state.lights.count);
  else lights.showPage(lights.offset || 0).then(() => lights.refreshSelected());
  materials.refresh();
  objects.refresh();
  readOnly.apply();
}

function scheduleSync() {
  clearTimeout(syncTimer);
  const wait = lastOwnEdit + OWN_EDIT_QUIET_MS - performance.now();
  if (wait > 0) {
    syncTimer = setTimeout(scheduleSync, wait);
    return;
  }
  if (syncRunning) {
    syncQueued = true;
    return;
  }
  syncRunning = true;
  syncControls().finally(() => {
    syncRunning = false;
    if (syncQueued) {
      syncQueued = false;
      scheduleSync();
    }
  });
}

function closeEvents() {
  eventsEnded = true;
  clearTimeout(syncTimer);
  events?.close();
  events = null;
}

function openEvents() {
  events?.close();
  events = null;
  eventsEnded = false;
  seenVersion = null;
  const session = api.session;
  if (!session) return;
  const source = new EventSource(
      `${api.sessionPath('/events')}?token=${encodeURIComponent(session.token)}`);
  events = source;
  source.addEventListener('version', (e) => {
    if (events !== source) return;
    const data = JSON.parse(e.data);
    readOnly.set(data.role === 'viewer');
    if (seenVersion !== null && data.version !== seenVersion) scheduleSync();
    seenVersion = data.version;
  });
  source.addEventListener('end', (e) => {
    source.close();
    if (events !== source) return;
    events = null;
    let reason = '';
    try {
      reason = JSON.parse(e.data).reason;
    } catch {
      // no reason given
    }
    // A session deleted or expired is said by the view's stream and the next request (with
    // the server's own words and status); a revoked or expired link is said here.
    eventsEnded = true;
    if (readOnly.on && (reason === 'revoked' || reason === 'expired')) linkEnded(reason === 'revoked');
  });
  // Refused (429, 401) or the server went away for good: try again later, once.
  source.addEventListener('error', () => {
    if (events !== source || source.readyState !== EventSource.CLOSED) return;
    events = null;
    setTimeout(() => {
      if (!events && !eventsEnded && api.session === session) openEvents();
    }, 5000);
  });
}

function startSession(state) {
  hideMessage();
  $('session-label').textContent = api.linked ? `${api.session.id} (shared link)` : api.session.id;
  $('session-label').title = `session ${api.session.id}` +
      (api.linked ? ': opened from a link; a view-only link watches but cannot change it' : '');
  model.show(state);
  camera.setModelBounds(state.model.bounds);
  lights.setModelBounds(state.model.bounds);
  camera.setFromServer(state.camera);
  settings.show(state.settings);
  materials.refresh();
  lights.changed(state.lights.count);
  objects.refresh();
  model.refreshLibrary();
  view.restart();
  stats.start();
  readOnly.set(false);
  openEvents();
}

async function newSession() {
  if ($('api-key').value) api.apiKey = $('api-key').value;
  api.forgetSession();
  closeEvents();
  try {
    startSession(await api.createSession());
  } catch (e) {
    if (e.status === 401) {
      showMessage(`${e.message}\nThis server needs an API key to create a session.`,
                  {newSession: true, apiKey: true});
    } else {
      showMessage(e.message, {newSession: true});
    }
  }
}

async function boot() {
  try {
    const info = await api.get('/v1/info');
    targets = info.targets || targets;
    $('target').replaceChildren(...targets.map((t, i) => {
      const option = document.createElement('option');
      option.value = t;
      option.textContent = i < 10 ? `${t} (${(i + 1) % 10})` : t;
      return option;
    }));
    settings.setTechniques(info.techniques || []);
    settings.setDevice(info.device);
    if (info.limits?.maxResolution) view.maxResolution = info.limits.maxResolution;
    view.isCpu = info.device?.isCpu === true;
    view.restoreLearnt(info.device?.name || '');
  } catch (e) {
    showMessage(`${e.message}\nReload the page once the server runs.`);
    return;
  }
  if (!api.hasSession) {
    await newSession();
    return;
  }
  try {
    startSession(await api.get(api.sessionPath()));
  } catch (e) {
    if (e instanceof SessionLostError) sessionLost(`The saved session ${api.session.id} is gone.`);
    else showMessage(e.message, {newSession: true});
  }
}

// --- actions --------------------------------------------------------------------------------

async function screenshot() {
  if (!api.hasSession) return;
  const {width, height} = view.fullSize();
  const target = view.target;
  try {
    const response = await api.request('GET', api.sessionPath('/frame'), {
      raw: true, query: {target, format: 'png', width, height}});
    const url = URL.createObjectURL(await response.blob());
    const link = document.createElement('a');
    link.href = url;
    link.download = `myriad-${target}-${width}x${height}.png`;
    document.body.append(link);
    link.click();
    link.remove();
    setTimeout(() => URL.revokeObjectURL(url), 10000);
  } catch (e) {
    showProblem(e);
  }
}

// The clipboard API needs a secure context (https or localhost); elsewhere the text is shown.
async function copyText(text, what) {
  try {
    await navigator.clipboard.writeText(text);
    showInfo(`Copied the camera as ${what}.`);
    setTimeout(() => showInfo(null), 2000);
  } catch {
    showMessage(`Copy this (${what}):\n${text}`, {info: true});
  }
}

function setTarget(target) {
  $('target').value = target;
  view.setTarget(target);
}

function setCameraMode(mode) {
  $('camera-mode').value = mode;
  camera.setMode(mode);
  $('view-status').textContent = `${mode} camera`;
}

// The help is a modal <dialog>: the page behind it is inert and focus stays inside until it
// closes (Escape, its button, a click beside it); focus then returns where it was.
function toggleHelp(show = !$('help').open) {
  if (show && !$('help').open) $('help').showModal();
  else if (!show && $('help').open) $('help').close();
}

// Share: a view-only link (a viewer token) to this session, copied where the browser allows.
async function share() {
  if (!api.hasSession) return;
  try {
    const {link, expiresInSeconds} = await api.share();
    const minutes = Math.round(expiresInSeconds / 60);
    try {
      await navigator.clipboard.writeText(link);
      showMessage(`Copied a view-only link (works for ${minutes} min):\n${link}`, {info: true});
    } catch {
      showMessage(`A view-only link (works for ${minutes} min):\n${link}`, {info: true});
    }
    $('message-text').dataset.link = link;
  } catch (e) {
    showProblem(e);
  }
}

// Revoke: every view-only link of the session stops working (DELETE .../tokens); the pages
// opened with them say so.
async function revokeLinks() {
  if (!api.hasSession) return;
  const button = $('revoke');
  button.disabled = true;
  try {
    await api.delete(api.sessionPath('/tokens'));
    showInfo('Every view-only link to this session was revoked; Share makes a new one.');
  } catch (e) {
    showProblem(e);
  } finally {
    button.disabled = false;
  }
}

$('share').addEventListener('click', share);
$('new-session').addEventListener('click', newSession);
$('api-key-label').addEventListener('submit', (e) => {
  e.preventDefault();
  newSession();
});
$('message-close').addEventListener('click', hideMessage);
$('target').addEventListener('change', (e) => view.setTarget(e.target.value));
$('camera-mode').addEventListener('change', (e) => setCameraMode(e.target.value));
$('frame-model').addEventListener('click', () => camera.frameModel());
$('screenshot').addEventListener('click', screenshot);
$('copy-camera-json').addEventListener('click', () => camera.camera && copyText(camera.asJson(), 'JSON'));
$('copy-camera-curl').addEventListener('click', () => camera.camera && copyText(camera.asCurl(), 'a curl command'));
$('help-button').addEventListener('click', () => toggleHelp(true));
$('help-close').addEventListener('click', () => toggleHelp(false));
$('help').addEventListener('click', (e) => { if (e.target === $('help')) toggleHelp(false); });
$('revoke').addEventListener('click', revokeLinks);

window.addEventListener('keydown', (e) => {
  if (isTyping(e) || e.ctrlKey || e.metaKey || e.altKey) return;
  if (e.key === '?') {
    toggleHelp();
  } else if ($('help').open || !api.hasSession) {
    return;
  } else if (e.code === 'KeyF') {
    camera.frameModel();
  } else if (e.code === 'KeyC') {
    setCameraMode(camera.mode === 'orbit' ? 'fly' : 'orbit');
  } else if (e.code === 'KeyM') {
    settings.toggleMarkers();
  } else if (e.code === 'KeyP') {
    screenshot();
  } else if (/^Digit[0-9]$/.test(e.code)) {
    const index = (Number(e.code.slice(5)) + 9) % 10;  // 1 -> 0, ..., 0 -> 9
    if (index < targets.length) setTarget(targets[index]);
  } else {
    return;
  }
  e.preventDefault();
});

boot();
