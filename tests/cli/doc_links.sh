#!/usr/bin/env bash
# The documentation's relative links resolve: every [text](target) and ![image](target) in
# README.md, CONTRIBUTING.md, CHANGELOG.md and docs/*.md names a file or folder of the tree, and
# a #fragment names a heading of its target (GitHub's anchors). The README stays a front door:
# under 300 lines. Links in fenced code blocks and web links are not checked.
#   bash tests/cli/doc_links.sh [ignored]    (run by ctest as cli.doc_links)
set -u
root=$(cd "$(dirname "$0")/../.." && pwd)
cd "$root" || exit 1

fails=0
lines=$(wc -l <README.md)
if [ "$lines" -ge 300 ]; then
  echo "FAIL: README.md has $lines lines (a front door stays under 300; move details to docs/)"
  fails=1
fi

python3 - README.md CONTRIBUTING.md CHANGELOG.md docs/*.md <<'PY' || fails=1
import os, re, sys

def anchors(path):
    # GitHub's heading ids: lowercase, punctuation dropped, spaces to hyphens, repeats numbered
    seen, out, fenced = {}, set(), False
    for line in open(path, encoding="utf-8"):
        if line.startswith("```"):
            fenced = not fenced
        m = None if fenced else re.match(r"#{1,6} +(.*?) *#* *$", line)
        if not m:
            continue
        text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", m.group(1))
        slug = re.sub(r"[^\w\- ]", "", text.lower()).replace(" ", "-")
        n = seen.get(slug, 0)
        seen[slug] = n + 1
        out.add(slug if n == 0 else f"{slug}-{n}")
    return out

bad = 0
for doc in sys.argv[1:]:
    if not os.path.exists(doc):
        continue
    fenced = False
    for number, line in enumerate(open(doc, encoding="utf-8"), 1):
        if line.startswith("```"):
            fenced = not fenced
        if fenced:
            continue
        text = re.sub(r"`[^`]*`", "", line)
        for target in re.findall(r"\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)", text):
            if re.match(r"[a-z]+:", target):
                continue
            path, _, fragment = target.partition("#")
            file = os.path.normpath(os.path.join(os.path.dirname(doc), path)) if path else doc
            if not os.path.exists(file):
                print(f"FAIL: {doc}:{number}: {target}: no such file")
                bad += 1
            elif fragment and file.endswith(".md") and fragment not in anchors(file):
                print(f"FAIL: {doc}:{number}: {target}: no heading '#{fragment}' in {file}")
                bad += 1
sys.exit(1 if bad else 0)
PY

[ "$fails" -eq 0 ] && echo "doc links: all resolve; README.md $lines lines"
exit "$fails"
