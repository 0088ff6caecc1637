// The HTTP API (protocol/CONTRACT.md) as a few functions: requests with the session's bearer
// token, RFC 9457 problem bodies turned into one readable sentence, and the session kept in
// localStorage so that a reload continues where it was.

const STORAGE_KEY = 'myriad.session';

// A failed request: `message` is the readable sentence shown to the user.
export class ApiError extends Error {
  constructor(status, problem, message) {
    super(message);
    this.status = status;
    this.problem = problem;
  }
  get typeName() {
    return problemTypeName(this.problem);
  }
}

// The session is gone (expired, deleted, or the server restarted): only a new one helps.
export class SessionLostError extends ApiError {}

function problemTypeName(problem) {
  const type = problem && typeof problem.type === 'string' ? problem.type : '';
  return type.slice(type.lastIndexOf('/') + 1);
}

// "Width must be at most 4096 (parameter width; 400 invalid-parameter)".
export function problemMessage(status, problem, fallback) {
  if (!problem || typeof problem !== 'object') {
    return `${fallback || 'The request failed'} (${status})`;
  }
  const text = problem.detail || problem.title || fallback || 'The request failed';
  const where = [];
  if (problem.parameter) where.push(`parameter ${problem.parameter}`);
  if (problem.pointer) where.push(`at ${problem.pointer}`);
  if (problem.limit) where.push(`limit ${problem.limit}`);
  const name = problemTypeName(problem);
  where.push(name ? `${status} ${name}` : String(status));
  return `${text} (${where.join('; ')})`;
}

async function errorFromResponse(response) {
  const text = await response.text().catch(() => '');
  let problem = null;
  try {
    problem = JSON.parse(text);
  } catch {
    // Not JSON (a proxy's page, a truncated body): show the start of the text instead.
  }
  const fallback = text && !problem ? text.slice(0, 200) : response.statusText;
  return new ApiError(response.status, problem, problemMessage(response.status, problem, fallback));
}

function loadStoredSession() {
  try {
    const value = JSON.parse(localStorage.getItem(STORAGE_KEY) || 'null');
    if (value && typeof value.id === 'string' && typeof value.token === 'string') return value;
  } catch {
    // A corrupt entry is the same as none.
  }
  return null;
}

// A session named by the page's address: /#session=ID&token=TOKEN (a link from "Share" or
// `myriad session share`: a viewer token; `myriad open`: the owner's). null when there is none.
function linkedSession() {
  const params = new URLSearchParams(location.hash.slice(1));
  const id = params.get('session');
  const token = params.get('token');
  return id && token ? {id, token} : null;
}

export class Api {
  constructor() {
    // A linked session is this page's only: it does not replace the one kept in localStorage.
    this.linked = linkedSession();
    this.session = this.linked || loadStoredSession();  // {id, token} or null
    this.apiKey = '';                    // only for creating a session with --api-key
    this.onChange = () => {};            // a request that changes the session is on its way
    this.onChangeFailed = () => {};      // ... and was refused (nothing will change)
  }

  get hasSession() {
    return this.session !== null;
  }

  sessionPath(sub = '') {
    return `/v1/sessions/${encodeURIComponent(this.session.id)}${sub}`;
  }

  // One request. `path` starting with "/v1/sessions/" carries the session token. Returns the
  // parsed JSON, null for 204, or the Response itself when `raw` is set; with `tagged`,
  // {body, etag}: the JSON and the session version it shows (ETag). `ifMatch`: an ETag the edit
  // is conditional on (412 precondition-failed when the session moved on; reference.md
  // "Conditional edits").
  async request(method, path, {json, body, contentType, query, signal, raw = false, auth = true,
                               headers: extra = {}, ifMatch, tagged = false} = {}) {
    const headers = {...extra};
    if (ifMatch) headers['If-Match'] = ifMatch;
    let payload = body;
    if (json !== undefined) {
      payload = JSON.stringify(json);
      headers['Content-Type'] = 'application/json';
    } else if (contentType) {
      headers['Content-Type'] = contentType;
    }
    const sessionRoute = path.startsWith('/v1/sessions/');
    const session = this.session;  // a new session may start while this request is out
    if (auth && sessionRoute && session) headers.Authorization = `Bearer ${session.token}`;
    const url = query ? `${path}?${new URLSearchParams(query)}` : path;
    if (sessionRoute && method !== 'GET' && !path.endsWith('/tokens')) this.onChange();

    let response;
    try {
      response = await fetch(url, {method, headers, body: payload, signal, cache: 'no-store'});
    } catch (e) {
      throw new ApiError(0, null, `The server cannot be reached (${e.message}).`);
    }
    if (!response.ok) {
      if (sessionRoute && method !== 'GET' && !path.endsWith('/tokens')) this.onChangeFailed();
      let error = await errorFromResponse(response);
      if (sessionRoute && await this.isSessionLost(error, session)) {
        error = new SessionLostError(error.status, error.problem,
                                     `The session is gone: ${error.message}`);
      }
      // About a session that is no longer the page's: nobody needs to hear of it.
      error.stale = session !== this.session;
      throw error;
    }
    if (raw) return response;
    const parsed = response.status === 204 ? null : await response.json();
    return tagged ? {body: parsed, etag: response.headers.get('ETag')} : parsed;
  }

  // 401: the token no longer fits. 403: the token of another session, or a viewer's token asked
  // to change something (the session is still there). 404: either the session or something
  // inside it (a light id) is missing. Asking for the session itself tells which.
  async isSessionLost(error, session) {
    if (error.status === 401) return true;
    if ((error.status !== 404 && error.status !== 403) || !session) return false;
    try {
      const r = await fetch(`/v1/sessions/${encodeURIComponent(session.id)}`, {
        headers: {Authorization: `Bearer ${session.token}`}, cache: 'no-store'});
      return r.status === 404 || r.status === 401 || r.status === 403;
    } catch {
      return false;
    }
  }

  get(path, options) { return this.request('GET', path, options); }
  // `end`: the last change of an interaction (a drag or a slider released), X-Myriad-Interaction.
  // A PATCH over the resource as the page showed it: read again with the session's ETag, kept
  // by `unchanged(current)` or not sent ({conflict: current}), and conditional on that ETag
  // (If-Match), so nothing lands between the read and the write unseen; a 412 from an unrelated
  // edit reads again (three tries). {updated}: the PATCH's answer.
  async patchIfUnchanged(path, json, unchanged, {headers = {}} = {}) {
    for (let attempt = 1; ; ++attempt) {
      const {body: current, etag} = await this.request('GET', path, {tagged: true});
      if (!unchanged(current)) return {conflict: current};
      try {
        return {updated: await this.request('PATCH', path, {json, ifMatch: etag, headers})};
      } catch (e) {
        if (e.status !== 412 || attempt === 3) throw e;
      }
    }
  }

  patch(path, json, end = false) {
    return this.request('PATCH', path, {json, headers: end ? {'X-Myriad-Interaction': 'end'} : {}});
  }
  put(path, json) { return this.request('PUT', path, {json}); }
  post(path, json) { return this.request('POST', path, {json}); }
  delete(path) { return this.request('DELETE', path); }

  // POST /v1/sessions, with the API key when the server asks for one.
  async createSession() {
    const headers = {'Content-Type': 'application/json'};
    if (this.apiKey) headers.Authorization = `Bearer ${this.apiKey}`;
    let response;
    try {
      response = await fetch('/v1/sessions', {method: 'POST', headers, body: '{}'});
    } catch (e) {
      throw new ApiError(0, null, `The server cannot be reached (${e.message}).`);
    }
    if (!response.ok) throw await errorFromResponse(response);
    const created = await response.json();
    this.session = {id: created.id, token: created.token};
    localStorage.setItem(STORAGE_KEY, JSON.stringify(this.session));
    this.leaveLink();
    return created.session;
  }

  forgetSession() {
    this.session = null;
    if (this.linked) this.leaveLink();
    else localStorage.removeItem(STORAGE_KEY);
  }

  // The page no longer shows the linked session: drop the link from the address.
  leaveLink() {
    this.linked = null;
    if (location.hash) history.replaceState(null, '', location.pathname + location.search);
  }

  // POST .../tokens: a view-only token; returns the page link that opens the session with it.
  async share() {
    const created = await this.post(this.sessionPath('/tokens'), {role: 'viewer'});
    return {link: new URL(created.link, location.href).href, expiresInSeconds: created.expiresInSeconds};
  }
}
