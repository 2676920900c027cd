#!/usr/bin/env bash
# the folders of src/ include each other only downward through the layers that CMakeLists.txt
# builds, bottom up: core math | params | model motion | engine | control analysis | sim |
# plan | batch | app | viz. Within a layer the folder graph has no cycle either. (The build
# enforces the layers through the include trees; this names the offending file and line.) Run
# from the root.
set -u
python3 - <<'PY'
import pathlib, re, sys
layers = [["core", "math"], ["params"], ["model", "motion"], ["engine"], ["control", "analysis"],
          ["sim"], ["plan"], ["batch"], ["app"], ["viz"]]
rank = {f: i for i, layer in enumerate(layers) for f in layer}
edges, bad = {}, []
for path in sorted(pathlib.Path("src").rglob("*")):
    if path.suffix not in (".h", ".cc"):
        continue
    here = path.parts[1]
    if here not in rank:
        bad.append(f"{path}: folder src/{here} is in no layer")
        continue
    for n, line in enumerate(path.read_text().splitlines(), 1):
        m = re.match(r'\s*#\s*include\s+"([a-z_]+)/', line)
        if not m or m.group(1) == here:
            continue
        there = m.group(1)
        if there not in rank:
            bad.append(f"{path}:{n}: includes unknown folder {there}/")
        elif rank[there] > rank[here]:
            bad.append(f"{path}:{n}: {here}/ includes {there}/, a layer above it")
        else:
            edges.setdefault(here, set()).add(there)
# a cycle among folders of the same layer
def reach(a, b, seen=()):
    return any(c == b or (c not in seen and reach(c, b, seen + (c,))) for c in edges.get(a, ()))
for a in edges:
    if reach(a, a):
        bad.append(f"folder cycle through src/{a}/")
for b in bad:
    print("FAIL:", b)
print(f"{len(bad)} problems in the folder graph:",
      {k: sorted(v) for k, v in sorted(edges.items())})
sys.exit(1 if bad else 0)
PY
