// Validates Kubernetes objects against the Kubernetes OpenAPI schemas, offline.
//
// Input (stdin): a JSON array of objects (apiVersion, kind, ...). Output (stdout): a JSON array with
// one entry per object, {"schema": NAME, "errors": [MESSAGE, ...]}, errors empty when valid.
// Exit 0 when the input was read (whatever the objects' verdicts), 2 on unusable input.
//
// The schemas are kubernetes-models' (npm, pinned by package-lock.json): the definitions of the
// upstream Kubernetes OpenAPI document (v1.33.0, with its enums) compiled by ajv into one validate
// function per definition, with types, formats (int32, int64, ...), required fields and enums.
// Those schemas, like the OpenAPI document, do not forbid undeclared fields, while the API server
// does: `kubectl apply` and `--dry-run=server` use strict field validation by default (1.27+), so
// a field the schema does not declare is an error ("unknown field"). This reproduces that without
// a second copy of the schemas: every object of the input is handed to the validator as a Proxy
// that records which of its fields the validator reads. A compiled `properties` schema reads each
// declared property (to check it or see that it is absent) and a map (`additionalProperties`)
// lists the object's keys, so a field that was neither read nor listed is one the schema does not
// declare. An object the validator never looked into at all is one whose schema constrains nothing
// (a free-form object) or that hangs under a field already reported; it is left alone.
import { existsSync, readFileSync } from "node:fs";
import { createRequire } from "node:module";
import { dirname, join } from "node:path";

const require = createRequire(import.meta.url);
const schemasDir = join(dirname(require.resolve("kubernetes-models/package.json")), "_schemas");

// apiVersion "apps/v1", kind "StatefulSet" -> IoK8sApiAppsV1StatefulSet; the core group ("v1")
// is Core; a dotted group (networking.k8s.io) is named by its first label.
function schemaName(apiVersion, kind) {
  const cap = (s) => s.charAt(0).toUpperCase() + s.slice(1);
  const [group, version] = apiVersion.includes("/") ? apiVersion.split("/") : ["core", apiVersion];
  return `IoK8sApi${cap(group.split(".")[0])}${cap(version)}${kind}`;
}

// The path of a field as the API server writes it: spec.template.spec.containers[0].ports[0].
function fieldPath(pointer) {
  let path = "";
  for (const token of pointer.split("/").slice(1)) {
    const part = token.replace(/~1/g, "/").replace(/~0/g, "~");
    path += /^\d+$/.test(part) ? `[${part}]` : (path ? "." : "") + part;
  }
  return path;
}

function track(value, path, records) {
  if (Array.isArray(value)) return value.map((v, i) => track(v, `${path}[${i}]`, records));
  if (value === null || typeof value !== "object") return value;
  const record = { path, keys: Object.keys(value), read: new Set(), listed: false };
  records.push(record);
  const target = {};
  for (const [key, child] of Object.entries(value)) {
    target[key] = track(child, path ? `${path}.${key}` : key, records);
  }
  return new Proxy(target, {
    get(t, key, receiver) {
      if (typeof key === "string") record.read.add(key);
      return Reflect.get(t, key, receiver);
    },
    has(t, key) {
      if (typeof key === "string") record.read.add(key);
      return Reflect.has(t, key);
    },
    ownKeys(t) {
      record.listed = true;
      return Reflect.ownKeys(t);
    },
  });
}

function describe(error) {
  const at = fieldPath(error.instancePath);
  const p = error.params || {};
  switch (error.keyword) {
    case "required":
      return `${at ? at + "." : ""}${p.missingProperty}: Required value`;
    case "type":
      return `${at}: Invalid value: must be of type ${p.type}`;
    case "enum":
      return `${at}: Unsupported value: supported values: ` +
        p.allowedValues.map((v) => JSON.stringify(v)).join(", ");
    case "format":
      return `${at}: Invalid value: must match format ${p.format}`;
    default:
      return `${at}: Invalid value: ${error.keyword} ${JSON.stringify(p)}`;
  }
}

async function validateObject(object) {
  if (object === null || typeof object !== "object" || Array.isArray(object)) {
    return { schema: null, errors: ["the document is not an object"] };
  }
  if (typeof object.apiVersion !== "string" || typeof object.kind !== "string") {
    return { schema: null, errors: ["apiVersion and kind: Required value"] };
  }
  const name = schemaName(object.apiVersion, object.kind);
  const file = join(schemasDir, `${name}.mjs`);
  if (!existsSync(file)) {
    const error = `no kind "${object.kind}" in "${object.apiVersion}" (no schema ${name})`;
    return { schema: name, errors: [error] };
  }
  const { validate } = await import(file);
  const records = [];
  const valid = validate(track(object, "", records));
  let errors = [];
  if (!valid) {
    // A oneOf/anyOf (int-or-string) reports each branch's type error and then itself: one message.
    const alternatives = new Map();
    for (const e of validate.errors) {
      if (e.keyword === "oneOf" || e.keyword === "anyOf") alternatives.set(e.instancePath, []);
    }
    for (const e of validate.errors) {
      const types = alternatives.get(e.instancePath);
      if (types && e.keyword === "type") types.push(e.params.type);
      else if (!types) errors.push(describe(e));
    }
    for (const [pointer, types] of alternatives) {
      errors.push(`${fieldPath(pointer)}: Invalid value: must be of type ${types.join(" or ")}`);
    }
  }
  for (const record of records) {
    if (record.listed || record.read.size === 0) continue;
    for (const key of record.keys) {
      if (!record.read.has(key)) {
        errors.push(`unknown field "${record.path ? record.path + "." : ""}${key}"`);
      }
    }
  }
  return { schema: name, errors };
}

let input;
try {
  input = JSON.parse(readFileSync(0, "utf8"));
  if (!Array.isArray(input)) throw new Error("not an array");
} catch (e) {
  console.error(`validate.mjs: stdin must be a JSON array of objects (${e.message})`);
  process.exit(2);
}
const results = [];
for (const object of input) results.push(await validateObject(object));
process.stdout.write(JSON.stringify(results) + "\n");
