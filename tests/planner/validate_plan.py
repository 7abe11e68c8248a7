"""Validates plan JSON files against docs/plan.schema.json; run by /usr/bin/python3 (Debian's jsonschema)."""
import json
import sys

import jsonschema

schema_path, *plans = sys.argv[1:]
with open(schema_path) as f:
    schema = json.load(f)
jsonschema.Draft202012Validator.check_schema(schema)
validator = jsonschema.Draft202012Validator(schema)
failed = False
for path in plans:
    with open(path) as f:
        plan = json.load(f)
    for error in validator.iter_errors(plan):
        failed = True
        print(f"{path}: {'/'.join(map(str, error.absolute_path)) or '(root)'}: {error.message}")
sys.exit(1 if failed else 0)
