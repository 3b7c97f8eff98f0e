#!/bin/sh
# make run as the README gives it: PORT=N picks the port, RAYD_LISTEN the
# address (the Makefile passes no --listen then, so the variable is not
# overruled), PORT wins over RAYD_LISTEN, and a port in use is a message
# that names the way out. Each daemon runs in its own session, stopped by
# its group's id; ports are picked free by the test.
# Usage (from the repository root): RUN_MAKEFLAGS="CC=gcc BUILD=build" sh tests/integration/make_run_test.sh
set -u
T=$(mktemp -d)
pass=0
fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }
group=""
stop() {
    [ -n "$group" ] && kill -TERM -- "-$group" 2>/dev/null
    i=0
    while [ -n "$group" ] && kill -0 -- "-$group" 2>/dev/null && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
    group=""
}
trap 'stop; rm -rf "$T"' EXIT

free_port() {
    /usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}

# start LOG ENV... make ARGS...: make run in a session of its own, its
# store in the test's folder (RAYD_DATA_DIR), not the tree's var/ that a
# developer's own make run keeps.
start() {
    log=$1; shift
    setsid env RAYD_DATA_DIR="$T/var" "$@" >"$log" 2>&1 &
    group=$!
}

# up PORT: /healthz answers on 127.0.0.1:PORT within 30 s.
up() {
    i=0
    while [ $i -lt 300 ]; do
        curl -sf "http://127.0.0.1:$1/healthz" >/dev/null 2>&1 && return 0
        kill -0 "$group" 2>/dev/null || return 1
        sleep 0.1
        i=$((i + 1))
    done
    return 1
}

# shellcheck disable=SC2086
p=$(free_port)
start "$T/port.log" make --no-print-directory run ${RUN_MAKEFLAGS:-} PORT="$p"
up "$p" && ok || bad "make run PORT=$p does not serve there: $(tail -5 "$T/port.log")"
stop

q=$(free_port)
# shellcheck disable=SC2086
start "$T/listen.log" RAYD_LISTEN="127.0.0.1:$q" make --no-print-directory run ${RUN_MAKEFLAGS:-}
up "$q" && ok || bad "RAYD_LISTEN=127.0.0.1:$q make run does not serve there: $(tail -5 "$T/listen.log")"
stop

p=$(free_port)
q=$(free_port)
# shellcheck disable=SC2086
start "$T/both.log" RAYD_LISTEN="127.0.0.1:$q" make --no-print-directory run ${RUN_MAKEFLAGS:-} PORT="$p"
up "$p" && ok || bad "PORT=$p does not win over RAYD_LISTEN: $(tail -5 "$T/both.log")"
stop

# A port in use: exit 3 and a message that names the way out.
p=$(free_port)
/usr/bin/python3 -c 'import socket, sys, time
s = socket.socket(); s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
s.bind(("127.0.0.1", int(sys.argv[1]))); s.listen(1); open(sys.argv[2], "w").close(); time.sleep(60)' "$p" "$T/held" &
holder=$!
i=0
while [ ! -e "$T/held" ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
# shellcheck disable=SC2086
RAYD_DATA_DIR="$T/var" make --no-print-directory run ${RUN_MAKEFLAGS:-} PORT="$p" >"$T/busy.log" 2>&1
rc=$?
kill "$holder" 2>/dev/null
wait "$holder" 2>/dev/null
[ "$rc" -ne 0 ] && grep -q "cannot listen on 127.0.0.1 port $p: Address already in use (--listen or RAYD_LISTEN picks another)" "$T/busy.log" && ok ||
    bad "a busy port (make exit $rc): $(tail -3 "$T/busy.log")"

echo "make run: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
