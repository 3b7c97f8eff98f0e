#!/bin/sh
# make install and make uninstall, and an installed rayd used from another
# folder: it finds its scenes and assignments in its compiled-in data
# folder (serve, render, grade), a staged install (DESTDIR) holds every
# file under the prefix, messages about a missing folder name it, and
# uninstall leaves nothing behind.
# Usage (from the repository root): sh tests/integration/install_test.sh
set -u
root=$(pwd)
T=$(mktemp -d)
pass=0
fail=0
ok() { pass=$((pass + 1)); }
bad() {
    fail=$((fail + 1))
    echo "FAIL: $*"
}
daemon=""
cleanup() {
    [ -n "$daemon" ] && kill "$daemon" 2>/dev/null
    rm -rf "$T"
}
trap cleanup EXIT

prefix="$T/prefix"
make --no-print-directory -s install PREFIX="$prefix" >"$T/make.log" 2>&1 || bad "make install PREFIX=$prefix: $(tail -5 "$T/make.log")"
rayd="$prefix/bin/rayd"
for f in bin/rayd share/man/man1/rayd.1 lib/systemd/system/rayd@.service share/doc/rayd/LICENSE \
    share/rayd/scenes/phong.cfg share/rayd/scenes/assignments/phong.cfg share/rayd/scenes/generated/knot.obj \
    libexec/rayd/rayd-eval share/rayd/course/Material.h share/rayd/course/skeleton/PhongMaterial.h; do
    [ -f "$prefix/$f" ] && ok || bad "make install did not install $f"
done

# From a folder that has no scenes in it.
mkdir "$T/elsewhere"
cd "$T/elsewhere" || exit 1
"$rayd" --version | grep -Eq '^rayd [0-9]' && ok || bad "the installed rayd --version: $("$rayd" --version)"
"$rayd" render "$prefix/share/rayd/scenes/assignments/phong.cfg" -o phong.png 2>err && [ -s phong.png ] && ok ||
    bad "the installed rayd renders: $(cat err)"
"$rayd" render "$prefix/share/rayd/scenes/mesh.cfg" -o mesh.png --width 64 --height 48 2>err && ok ||
    bad "a bundled scene's mesh resolves beside it: $(cat err)"
"$rayd" grade --assignment phong --image phong.png >grade.out 2>err
rc=$?
[ "$rc" -eq 0 ] && grep -q '"pass":[[:space:]]*true' grade.out && ok ||
    bad "the installed rayd grades against its own assignments (exit $rc): $(cat err)"
"$rayd" grade --assignment phong --code "$root/tests/codegrade/students/phong_ok.h" --json >code.out 2>err
rc=$?
[ "$rc" -eq 0 ] && grep -q '"pass":[[:space:]]*true' code.out && ok ||
    bad "the installed rayd grades code with its own course and evaluator (exit $rc): $(cat err) $(head -c 300 code.out)"

# Without --data-dir the store goes to the user's state folder, not ./var
# of the folder the daemon starts in.
XDG_STATE_HOME="$T/state" "$rayd" serve --listen 127.0.0.1:0 --port-file "$T/port" 2>"$T/serve.log" &
daemon=$!
i=0
while [ ! -s "$T/port" ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
port=$(cat "$T/port" 2>/dev/null)
url="http://127.0.0.1:$port"
curl -sf "$url/v1/scenes" | grep -q '"phong.cfg"' && ok || bad "the installed daemon lists its bundled scenes"
curl -sf "$url/v1/assignments" | grep -q '"phong"' && ok || bad "the installed daemon lists its assignments"
code=$(curl -s -o grade.json -w '%{http_code}' -F assignment=phong -F image=@phong.png "$url/v1/grade")
[ "$code" = 200 ] && grep -q '"pass":true' grade.json && ok || bad "the installed daemon grades (HTTP $code): $(head -c 300 grade.json)"
grep -q "$prefix/share/rayd/scenes" "$T/serve.log" && ok || bad "the start-up line names the data folders: $(cat "$T/serve.log")"
kill "$daemon"
wait "$daemon" && ok || bad "the installed daemon stops on SIGTERM with 0"
daemon=""
[ -f "$T/state/rayd/rayd.sqlite3" ] && [ ! -e var ] && ok ||
    bad "the installed daemon's store is not in \$XDG_STATE_HOME/rayd: $(ls "$T/state/rayd" . 2>&1 | tr '\n' ' ')"
grep -q "jobs stored in sqlite in $T/state/rayd " "$T/serve.log" && ok ||
    bad "the start-up line does not say where the store is: $(cat "$T/serve.log")"

# Under systemd's StateDirectory= (STATE_DIRECTORY, which wins), and with
# neither variable (~/.local/state/rayd).
for how in "STATE_DIRECTORY=$T/lib/rayd/8080" "XDG_STATE_HOME= HOME=$T/home"; do
    rm -f "$T/port"
    # shellcheck disable=SC2086
    env XDG_STATE_HOME="$T/state2" $how "$rayd" serve --listen 127.0.0.1:0 --port-file "$T/port" 2>"$T/serve2.log" &
    daemon=$!
    i=0
    while [ ! -s "$T/port" ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
    kill "$daemon"
    wait "$daemon"
    daemon=""
    case $how in STATE*) want=$T/lib/rayd/8080 ;; *) want=$T/home/.local/state/rayd ;; esac
    [ -f "$want/rayd.sqlite3" ] && [ ! -e var ] && [ ! -e "$T/state2" ] && ok ||
        bad "with $how the store is not in $want: $(cat "$T/serve2.log")"
done
"$rayd" serve --help | tr -s ' \n' '  ' | grep -q -- "--data-dir DIR .*(default \$STATE_DIRECTORY under systemd, else" && ok ||
    bad "serve --help does not give the store's default: $("$rayd" serve --help | grep -A2 -- --data-dir)"

# The man page says what --help says.
man=$prefix/share/man/man1/rayd.1
for want in '^\.TH RAYD' 'rayd serve' 'RAYD_THREADS' '\\-\\-assignments' 'limit'; do
    grep -q -- "$want" "$man" && ok || bad "the man page lacks $want"
done
if command -v man >/dev/null 2>&1; then
    MANWIDTH=100 man -l "$man" 2>/dev/null | grep -q -- "--memory-budget" && ok || bad "man -l rayd.1 does not show serve's flags"
fi
# grade --code's own help, the code grader's files, every exit status, and
# a SEE ALSO that names installed files, each of them there.
for want in '^\.SS "rayd grade --code"' 'usage: rayd grade --assignment NAME --code FILE' \
    "$prefix/share/rayd/course/" "$prefix/libexec/rayd/rayd.*eval" '^\.B 4$' 'the sandbox cannot start here' \
    "$prefix/share/doc/rayd/" 'XDG_STATE_HOME'; do
    grep -q -- "$want" "$man" && ok || bad "the man page lacks $want"
done
grep -q "docs/ of the source" "$man" && bad "the man page points to the source's docs/, which is not installed" || ok
see_also=$(sed -n '/^\.SH "SEE ALSO"/,$p' "$man")
for f in README.md "$root"/docs/*.md openapi.json scene.schema.json; do
    f=${f##*/}
    [ -f "$prefix/share/doc/rayd/$f" ] && ok || bad "make install did not install share/doc/rayd/$f"
    printf '%s' "$see_also" | sed 's/\\-/-/g' | grep -qF "$f" && ok || bad "SEE ALSO does not name $f"
done
grep -q "ExecStart=$prefix/bin/rayd serve" "$prefix/lib/systemd/system/rayd@.service" && ok ||
    bad "the unit runs the installed binary"
if command -v systemd-analyze >/dev/null 2>&1; then
    systemd-analyze verify --man=no "$prefix/lib/systemd/system/rayd@.service" >"$T/verify" 2>&1 && ok ||
        bad "systemd-analyze verify rejects the unit: $(cat "$T/verify")"
fi
# Code grading under the unit's own RestrictNamespaces=, SystemCallFilter=,
# RestrictAddressFamilies= and ProtectHostname= (build/unit-filter installs
# their seccomp equivalent, its @groups expanded by systemd-analyze): the
# sandbox starts and a correct file passes. With the old unit
# (RestrictNamespaces=yes, ~@privileged) this was exit 3.
make --no-print-directory -s -C "$root" build/unit-filter >"$T/uf.log" 2>&1 || bad "build/unit-filter: $(cat "$T/uf.log")"
"$root/build/unit-filter" "$prefix/lib/systemd/system/rayd@.service" "$rayd" grade --assignment phong \
    --code "$root/tests/codegrade/students/phong_ok.h" --json >"$T/unit_grade.json" 2>"$T/unit_grade.err"
rc=$?
[ "$rc" -eq 0 ] && grep -Eq "\"pass\":[[:space:]]*true" "$T/unit_grade.json" && ok ||
    bad "rayd grade --code under the unit's restrictions (exit $rc): $(cat "$T/unit_grade.err")"

# A staged install: every file under DESTDIR/PREFIX, nothing else; the
# binary looks in PREFIX, and says so when it is not there yet.
cd "$root" || exit 1
stage="$T/stage"
make --no-print-directory -s install DESTDIR="$stage" PREFIX=/opt/rayd-test >"$T/make2.log" 2>&1 || bad "make install DESTDIR: $(tail -5 "$T/make2.log")"
outside=$(find "$stage" -type f | grep -cv "^$stage/opt/rayd-test/")
[ "$outside" -eq 0 ] && ok || bad "$outside staged files lie outside DESTDIR/PREFIX"
cd "$T/elsewhere" || exit 1
staged="$stage/opt/rayd-test/bin/rayd"
"$staged" serve --listen 127.0.0.1:0 2>err
rc=$?
[ "$rc" -eq 3 ] && grep -q "/opt/rayd-test/share/rayd/scenes" err && ok ||
    bad "a missing data folder is named at start (exit $rc): $(cat err)"
"$staged" grade --assignment phong --image phong.png 2>err >/dev/null
grep -q "/opt/rayd-test/share/rayd/scenes/assignments" err && ok || bad "rayd grade names the folder it searched: $(cat err)"
"$staged" grade --assignment phong --image phong.png --assignments "$stage/opt/rayd-test/share/rayd/scenes/assignments" \
    >/dev/null 2>err && ok || bad "--assignments overrides the data folder: $(cat err)"

# Completion, generated from the installed binary: every command of its
# --help, each command's flags (grade's --code ones and the limits too).
comp=$prefix/share/bash-completion/completions/rayd
[ -f "$comp" ] && [ -f "$prefix/share/zsh/site-functions/_rayd" ] && ok || bad "make install did not install the completion"
complete_words() { # words...: what bash completes for the last one
    bash -c '. "$1"; shift; COMP_WORDS=("$@"); COMP_CWORD=$(($# - 1)); _rayd; printf "%s\n" "${COMPREPLY[@]}"' _ "$comp" "$@"
}
for c in $("$rayd" --help | sed -n '/^Commands:/,/^$/s/^  \([a-z][a-z-]*\) .*/\1/p'); do
    complete_words rayd "" | grep -qx "$c" && ok || bad "bash completion lacks the command $c"
done
complete_words rayd rend | grep -qx render && ok || bad "bash: rayd rend<TAB>: $(complete_words rayd rend)"
complete_words rayd render --gam | grep -qx -- --gamma && ok || bad "bash: render --gam<TAB>"
complete_words rayd grade --code-e | grep -qx -- --code-eval && ok || bad "bash: grade --code-e<TAB>"
complete_words rayd serve --instructor | grep -qx -- --instructor-tokens && ok || bad "bash: serve --instructor<TAB>"
complete_words rayd converge --limit-obj | grep -qx -- --limit-objects && ok || bad "bash: converge --limit-obj<TAB>"
complete_words rayd serve --limit | grep -qx -- --limit && bad "bash completes the help's --limit-... placeholder" || ok
# zsh: _rayd under stand-ins for compsys's compadd and _files, which print
# what they are given (compadd's own matching against PREFIX is zsh's).
zcomp=$prefix/share/zsh/site-functions/_rayd
zsh_words() { # CURRENT words...: what _rayd offers
    zsh -fc 'compadd() { if [[ $1 == -a ]]; then print -l -- ${(P)2}; else [[ $1 == -- ]] && shift; print -l -- "$@"; fi }
        _files() { print FILES }
        f=$1 CURRENT=$2; shift 2; words=("$@"); PREFIX=${words[CURRENT]}
        source "$f"' _ "$zcomp" "$@"
}
if command -v zsh >/dev/null 2>&1; then
    zsh -n "$zcomp" && ok || bad "_rayd is not zsh"
    zsh_words 2 rayd re | grep -qx render && ok || bad "zsh: rayd re<TAB>: $(zsh_words 2 rayd re 2>&1 | head -3)"
    zsh_words 3 rayd render --gam | grep -qx -- --gamma && ok || bad "zsh: render --gam<TAB>"
    zsh_words 3 rayd grade --code-e | grep -qx -- --code-eval && ok || bad "zsh: grade --code-e<TAB>"
    zsh_words 3 rayd render sc | grep -qx FILES && ok || bad "zsh: a file argument does not complete files"
else
    bad "no zsh to check _rayd with (make deps installs it)"
fi

# uninstall leaves nothing.
cd "$root" || exit 1
make --no-print-directory -s uninstall PREFIX="$prefix" >/dev/null 2>&1
left=$(find "$prefix" -type f | wc -l)
[ "$left" -eq 0 ] && ok || bad "make uninstall left $left files: $(find "$prefix" -type f | head -3)"

echo "install: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
