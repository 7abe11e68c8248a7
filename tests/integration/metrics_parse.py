#!/usr/bin/python3
# Reads a Prometheus text exposition with prometheus_client's own parser (Debian's
# python3-prometheus-client), which raises on any line it cannot read, and prints every sample as
# JSON: {"name{label=\"value\",...}": value}, labels sorted.
import json
import sys

from prometheus_client.parser import text_string_to_metric_families

samples = {}
families = {}
for family in text_string_to_metric_families(open(sys.argv[1], encoding="utf-8").read()):
    families[family.name] = family.type
    for s in family.samples:
        labels = ",".join(f'{k}="{v}"' for k, v in sorted(s.labels.items()))
        samples[f"{s.name}{{{labels}}}" if labels else s.name] = s.value
print(json.dumps({"families": families, "samples": samples}))
