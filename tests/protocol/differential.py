#!/usr/bin/env python3
"""Differential check of Myriad's own JSON Schema validator (protocol/validate.cpp) against
python3-jsonschema (Draft 2020-12). Runs the exporter, which prints bodies with the C++ verdicts,
and fails unless python3-jsonschema gives the same verdict for every one, and, for a rejected body,
reports an error at the JSON Pointer the C++ validator named (its parent object for "is required"
and "is not a member", which jsonschema reports on the object).

Usage: differential.py EXPORTER SCHEMA_DIR
"""
import glob
import json
import os
import subprocess
import sys
import time

import jsonschema


def load_schemas(schema_dir):
    schemas = {}
    for path in sorted(glob.glob(os.path.join(schema_dir, "*.schema.json"))):
        with open(path, encoding="utf-8") as f:
            schemas[os.path.basename(path)[: -len(".schema.json")]] = json.load(f)
    return schemas


def make_validators(schemas):
    """One Draft202012Validator per schema, resolving $ref within the bundle by $id."""
    cls = jsonschema.Draft202012Validator
    for schema in schemas.values():
        cls.check_schema(schema)
    try:  # jsonschema >= 4.18
        from referencing import Registry, Resource

        registry = Registry().with_resources(
            [(s["$id"], Resource.from_contents(s)) for s in schemas.values()])
        return {name: cls(s, registry=registry) for name, s in schemas.items()}
    except ImportError:  # Debian 12's 4.10
        store = {s["$id"]: s for s in schemas.values()}
        return {name: cls(s, resolver=jsonschema.RefResolver.from_schema(s, store=store))
                for name, s in schemas.items()}


def pointer(path):
    return "".join("/" + str(p).replace("~", "~0").replace("/", "~1") for p in path)


def main():
    exporter, schema_dir = sys.argv[1], sys.argv[2]
    validators = make_validators(load_schemas(schema_dir))
    cases = json.loads(subprocess.run([exporter], check=True, capture_output=True, text=True).stdout)
    start = time.monotonic()
    disagreements = []
    rejected = 0
    for case in cases:
        errors = list(validators[case["schema"]].iter_errors(case["body"]))
        py_valid = not errors
        if py_valid != case["valid"]:
            disagreements.append((case, "python says " + ("valid" if py_valid else
                                  "invalid: " + "; ".join(e.message for e in errors[:3]))))
            continue
        if py_valid:
            continue
        rejected += 1
        where = case["pointer"]
        if "is required" in case["message"] or "is not a member" in case["message"]:
            where = where[: where.rfind("/")]
        py_pointers = {pointer(e.absolute_path) for e in errors}
        if where not in py_pointers:
            disagreements.append((case, "python reports errors at %s, not at %r" %
                                  (sorted(py_pointers), where)))
    for case, why in disagreements[:20]:
        body = json.dumps(case["body"])
        print("DISAGREE %s %s: C++ says %s; %s" % (case["schema"], body[:300],
              case.get("pointer", "valid") + " " + case.get("message", ""), why))
    print("protocol-differential: %d bodies (%d rejected by both, %d accepted by both), "
          "%d disagreements, jsonschema %.2f s" % (len(cases), rejected,
          len(cases) - rejected - len(disagreements), len(disagreements), time.monotonic() - start))
    return 1 if disagreements else 0


if __name__ == "__main__":
    sys.exit(main())
