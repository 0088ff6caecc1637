// GET /v1/openapi.json against the OpenAPI 3.1 specification and against the server itself:
//
//  1. the served document is valid OpenAPI 3.1 (@seriousme/openapi-schema-validator: the
//     official 3.1 schema, unresolvable $refs included);
//  2. its component schemas are valid JSON Schema 2020-12 under Ajv's strict mode (the OpenAPI
//     schema checks a Schema Object only for being an object), every $ref resolves, and every
//     example of protocol/examples still passes its schema after the $ref rewriting;
//  3. its enumerations are what GET /v1/info serves (targets, techniques, formats), and live
//     answers (info, health, a problem) pass their schemas;
//  4. its operations are exactly the endpoints of protocol/reference.md's headings, and the server
//     routes each operation (method + path) to that very template: every operation is requested
//     once and GET /metrics, which counts responses by the template the server matched, must show
//     each template and no other. (That the server has no route beyond the document is checked
//     when it starts: HttpServer::bind refuses a route table that differs from
//     protocol/operations.cpp.)
//
// Usage: node openapi_test.mjs SERVER_BINARY PROTOCOL_DIR

import fs from 'node:fs';
import path from 'node:path';
import {Validator} from '@seriousme/openapi-schema-validator';
import Ajv2020Module from 'ajv/dist/2020.js';
import {startServer} from '../browser/server_process.mjs';

const Ajv2020 = Ajv2020Module.default ?? Ajv2020Module;
const METHODS = ['get', 'put', 'post', 'delete', 'options', 'head', 'patch', 'trace'];

const failures = [];
function check(ok, what) {
  if (!ok) failures.push(what);
  return ok;
}
function sameSet(a, b) {
  const sa = new Set(a);
  const sb = new Set(b);
  return sa.size === sb.size && [...sa].every((x) => sb.has(x));
}
function difference(a, b) {
  const sb = new Set(b);
  return [...new Set(a)].filter((x) => !sb.has(x));
}

// "#/components/schemas/vec3" -> "urn:myriad:vec3", ".../settings/$defs/x" -> "urn:myriad:settings#/$defs/x"
const PREFIX = '#/components/schemas/';
function standaloneRef(ref) {
  if (!ref.startsWith(PREFIX)) throw new Error(`a $ref outside the components: ${ref}`);
  const rest = ref.slice(PREFIX.length);
  const slash = rest.indexOf('/');
  return slash < 0 ? `urn:myriad:${rest}` : `urn:myriad:${rest.slice(0, slash)}#${rest.slice(slash)}`;
}
function withStandaloneRefs(node) {
  if (Array.isArray(node)) return node.map(withStandaloneRefs);
  if (node === null || typeof node !== 'object') return node;
  const out = {};
  for (const [key, value] of Object.entries(node)) {
    out[key] = key === '$ref' && typeof value === 'string' ? standaloneRef(value) : withStandaloneRefs(value);
  }
  return out;
}

// Every "$ref" string in the document, with where it is.
function* refs(node, where = '#') {
  if (Array.isArray(node)) {
    for (let i = 0; i < node.length; ++i) yield* refs(node[i], `${where}/${i}`);
  } else if (node !== null && typeof node === 'object') {
    for (const [key, value] of Object.entries(node)) {
      if (key === '$ref' && typeof value === 'string') yield [where, value];
      else yield* refs(value, `${where}/${key}`);
    }
  }
}
function resolvePointer(doc, ref) {
  let node = doc;
  for (const token of ref.slice(2).split('/')) {
    const key = token.replaceAll('~1', '/').replaceAll('~0', '~');
    if (node === null || typeof node !== 'object' || !(key in node)) return undefined;
    node = node[key];
  }
  return node;
}

// The endpoints of reference.md: "### GET, PATCH, DELETE /v1/sessions/{id}/lights/{lid}" and
// "### GET / and GET /web/{file}" headings.
function referenceEndpoints(markdown) {
  const endpoints = [];
  for (const line of markdown.split('\n')) {
    if (!line.startsWith('### ')) continue;
    const verbs = '(?:GET|POST|PUT|PATCH|DELETE)';
    for (const m of line.matchAll(new RegExp(`(${verbs}(?:, ${verbs})*) (/\\S*)`, 'g'))) {
      for (const method of m[1].split(', ')) endpoints.push(`${method} ${m[2]}`);
    }
  }
  return endpoints;
}

function documentEndpoints(doc) {
  const endpoints = [];
  for (const [route, item] of Object.entries(doc.paths)) {
    for (const method of METHODS) {
      if (item[method]) endpoints.push(`${method.toUpperCase()} ${route}`);
    }
  }
  return endpoints;
}

// A path of `route` that names no existing session, light or material, so that no request of
// the probe changes anything but the counters.
function concretePath(route) {
  return route
      .replace('{id}', 's-0000000000000000')
      .replace('{mid}', '0')
      .replace('{lid}', '0')
      .replace('{file}', 'no-such-file.js');
}

async function probeRoutes(url, doc) {
  const statuses = [];
  for (const endpoint of documentEndpoints(doc)) {
    const [method, route] = endpoint.split(' ');
    let target = url + concretePath(route);
    if (route === '/v1/frame') target += '?width=8&height=8';  // a real frame: keep it small
    const init = {method};
    if (['POST', 'PUT', 'PATCH'].includes(method)) {
      init.headers = {'Content-Type': 'application/json'};
      init.body = '{}';
    }
    const reply = await fetch(target, init);
    await reply.arrayBuffer();
    statuses.push(`${endpoint} -> ${reply.status}`);
    check(reply.status !== 405, `${endpoint}: the server answered 405 (it has the path, not the method)`);
  }
  const metrics = await (await fetch(`${url}/metrics`)).text();
  const counted = new Set();
  for (const m of metrics.matchAll(/^myriad_http_requests_total\{route="([^"]*)",status="\d+"\} \d+/gm)) {
    counted.add(m[1]);
  }
  counted.delete('unmatched');  // the label of a path no route has: the 404 probe above
  const documented = Object.keys(doc.paths);
  const notRouted = difference(documented, counted);
  const unknown = difference(counted, documented);
  check(notRouted.length === 0,
        `the server routed no request to ${notRouted.join(', ')} (answers: ${statuses.join('; ')})`);
  check(unknown.length === 0, `requests were counted under templates the document lacks: ${unknown.join(', ')}`);
}

async function main() {
  const [serverBinary, protocolDir] = process.argv.slice(2);
  if (!serverBinary || !protocolDir) {
    console.error('usage: node openapi_test.mjs SERVER_BINARY PROTOCOL_DIR');
    return 2;
  }
  const server = await startServer(serverBinary,
                                    ['--port', '0', '--host', '127.0.0.1', '--lights', '8', '--max-resolution', '256']);
  try {
    const reply = await fetch(`${server.url}/v1/openapi.json`);
    check(reply.status === 200, `GET /v1/openapi.json: status ${reply.status}`);
    check((reply.headers.get('content-type') ?? '').startsWith('application/json'),
          `GET /v1/openapi.json: Content-Type ${reply.headers.get('content-type')}`);
    const doc = await reply.json();
    check(doc.openapi === '3.1.0', `openapi is ${doc.openapi}, not 3.1.0`);

    // 1. The OpenAPI 3.1 schema.
    const validator = new Validator();
    const result = await validator.validate(doc);
    check(result.valid && validator.version === '3.1',
          `not a valid OpenAPI 3.1 document: ${JSON.stringify(result.errors, null, 1)}`);

    // 2. The schemas, strictly; every $ref; the examples.
    for (const [where, ref] of refs(doc)) {
      check(ref.startsWith('#/') && resolvePointer(doc, ref) !== undefined, `${where}: $ref ${ref} resolves to nothing`);
    }
    // Strict, but a `type` list is JSON Schema 2020-12 (an object's semantic class is an integer
    // or a name: ["integer", "string"]); Ajv's strict mode only discourages it.
    const ajv = new Ajv2020({strict: true, allowUnionTypes: true, allErrors: true});
    const schemas = doc.components.schemas;
    for (const [name, schema] of Object.entries(schemas)) {
      check(!('$id' in schema) && !('$schema' in schema), `components/schemas/${name} keeps $id or $schema`);
      ajv.addSchema({...withStandaloneRefs(schema), $id: `urn:myriad:${name}`});
    }
    for (const name of Object.keys(schemas)) {
      try {
        ajv.getSchema(`urn:myriad:${name}`);
      } catch (e) {
        check(false, `components/schemas/${name} does not compile strictly: ${e.message}`);
      }
    }
    const examplesDir = path.join(protocolDir, 'examples');
    const examples = fs.readdirSync(examplesDir).filter((f) => f.endsWith('.json'));
    check(examples.length > 0, `no examples in ${examplesDir}`);
    for (const file of examples) {
      const name = file.replace(/\.json$/, '');
      const validate = ajv.getSchema(`urn:myriad:${name}`);
      if (!check(validate !== undefined, `examples/${file} has no component schema ${name}`)) continue;
      const example = JSON.parse(fs.readFileSync(path.join(examplesDir, file), 'utf8'));
      check(validate(example), `examples/${file} fails components/schemas/${name}: ${ajv.errorsText(validate.errors)}`);
    }
    // Newer schemas carry their examples inline: each passes its component schema too.
    let inlineExamples = 0;
    for (const [name, schema] of Object.entries(schemas)) {
      const validate = ajv.getSchema(`urn:myriad:${name}`);
      for (const example of schema.examples ?? []) {
        inlineExamples++;
        check(validate(example), `components/schemas/${name} "examples" fails it: ${ajv.errorsText(validate.errors)}`);
      }
    }
    const schemaFiles = fs.readdirSync(path.join(protocolDir, 'schemas')).map((f) => f.replace(/\.schema\.json$/, ''));
    const missing = schemaFiles.filter((n) => n !== 'defs' && !(n in schemas));
    check(missing.length === 0, `schemas missing from the components: ${missing.join(', ')}`);

    // 3. Live answers and enumerations.
    const info = await (await fetch(`${server.url}/v1/info`)).json();
    const health = await (await fetch(`${server.url}/v1/health`)).json();
    const notFound = await (await fetch(`${server.url}/v1/no-such-route`)).json();
    for (const [name, body] of [['info', info], ['health', health], ['problem', notFound]]) {
      const validate = ajv.getSchema(`urn:myriad:${name}`);
      check(validate(body), `a live ${name} body fails its component schema: ${ajv.errorsText(validate.errors)}`);
    }
    check(sameSet(schemas.target.enum ?? [], info.targets), `target enum ${schemas.target.enum} != /v1/info targets ${info.targets}`);
    check(sameSet(schemas.technique.enum, info.techniques), `technique enum ${schemas.technique.enum} != /v1/info techniques ${info.techniques}`);
    check(sameSet(schemas.format.enum, info.formats), `format enum ${schemas.format.enum} != /v1/info formats ${info.formats}`);

    // 4. reference.md and the server's routing.
    const reference = referenceEndpoints(fs.readFileSync(path.join(protocolDir, 'reference.md'), 'utf8'));
    const documented = documentEndpoints(doc);
    check(reference.length > 0, 'no endpoint headings found in reference.md');
    const undocumented = difference(reference, documented);
    const unreferenced = difference(documented, reference);
    check(undocumented.length === 0, `in reference.md, not in the document: ${undocumented.join(', ')}`);
    check(unreferenced.length === 0, `in the document, not in reference.md: ${unreferenced.join(', ')}`);
    await probeRoutes(server.url, doc);

    console.log(`openapi: ${documented.length} operations on ${Object.keys(doc.paths).length} paths, ` +
                `${Object.keys(schemas).length} component schemas, ${examples.length + inlineExamples} examples, ` +
                `${reference.length} reference endpoints`);
  } finally {
    const status = await server.stop();
    check(status === 0, `the server exited with ${status}:\n${server.log()}`);
  }
  for (const failure of failures) console.error(`FAILED: ${failure}`);
  console.log(failures.length === 0 ? 'openapi: all checks passed' : `openapi: ${failures.length} checks failed`);
  return failures.length === 0 ? 0 : 1;
}

process.exitCode = await main().catch((e) => {
  console.error(e);
  return 1;
});
