#!/bin/sh
# deploy/nginx/rayd.conf as shipped, in front of two real daemons: nginx
# accepts it (nginx -t), passes health checks and renders through, refuses
# a body over its limit (which is the daemon's --max-body-bytes) itself,
# sets the forwarding headers the daemon's --trust-proxy believes, and
# still answers when one daemon is killed. Then the systemd unit as `make
# install` writes it: systemd-analyze verify has nothing to say about it.
# The three upstream servers become two daemons on ports of their own and
# one free port nobody listens on; `listen 80;` becomes a free port of
# 127.0.0.1. Everything runs as the current user inside a temporary folder.
# Usage (from the repository root): RAYD=build/rayd sh tests/integration/deploy_test.sh
set -u
RAYD=${RAYD:-build/rayd}
case $RAYD in /*) ;; *) RAYD=$(pwd)/$RAYD ;; esac
NGINX=${NGINX:-$(command -v nginx || echo /usr/sbin/nginx)}
T=$(mktemp -d)
pass=0
fail=0
ok() { pass=$((pass + 1)); }
bad() {
    fail=$((fail + 1))
    echo "FAIL: $*"
}
d1=""
d2=""
ngx=""
stop() { # pid: SIGTERM, then wait for it
    [ -n "$1" ] || return 0
    kill "$1" 2>/dev/null
    wait "$1" 2>/dev/null
}
cleanup() {
    stop "$ngx"
    stop "$d1"
    stop "$d2"
    rm -rf "$T"
}
trap cleanup EXIT
trap 'exit 1' INT TERM

free_port() {
    /usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}
wait_file() { # file: up to 10 s for it to be non-empty
    i=0
    while [ ! -s "$1" ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
    [ -s "$1" ]
}
# PNG signature, then IHDR width, height, bit depth 8 and colour type 2 (RGB).
png_is() {
    f=$1; w=$2; h=$3
    sig=$(od -An -tx1 -N8 "$f" | tr -d ' \n')
    ihdr=$(od -An -tx1 -j16 -N10 "$f" | tr -d ' \n')
    want=$(printf '%08x%08x0802' "$w" "$h")
    [ "$sig" = "89504e470d0a1a0a" ] && [ "$ihdr" = "$want" ]
}

# Two daemons. --data-dir only once the binary has it (the job store).
"$RAYD" serve --help >"$T/help" 2>&1
store_flags=""
grep -q -- '--data-dir' "$T/help" && store_flags=yes
start_daemon() { # n: starts daemon n, its pid in $started
    mkdir -p "$T/data$1"
    if [ -n "$store_flags" ]; then
        "$RAYD" serve --listen 127.0.0.1:0 --port-file "$T/port$1" --threads 1 --trust-proxy 127.0.0.1 \
            --data-dir "$T/data$1" 2>"$T/daemon$1.log" &
    else
        "$RAYD" serve --listen 127.0.0.1:0 --port-file "$T/port$1" --threads 1 --trust-proxy 127.0.0.1 \
            2>"$T/daemon$1.log" &
    fi
    started=$!
}
start_daemon 1
d1=$started
start_daemon 2
d2=$started
wait_file "$T/port1" && wait_file "$T/port2" && ok ||
    bad "the daemons did not start: $(cat "$T/daemon1.log" "$T/daemon2.log")"
p1=$(cat "$T/port1" 2>/dev/null)
p2=$(cat "$T/port2" 2>/dev/null)
p3=$(free_port)
listen=$(free_port)

# The shipped file, with the ports replaced; each replacement must hit
# exactly one line, or the file's form changed under the test.
mkdir "$T/conf.d"
conf=$T/conf.d/rayd.conf
sed -e "s/^\( *server \)127\.0\.0\.1:8081 /\1127.0.0.1:$p1 /" \
    -e "s/^\( *server \)127\.0\.0\.1:8082 /\1127.0.0.1:$p2 /" \
    -e "s/^\( *server \)127\.0\.0\.1:8083 /\1127.0.0.1:$p3 /" \
    -e "s/^\( *\)listen 80;\$/\1listen 127.0.0.1:$listen;/" deploy/nginx/rayd.conf >"$conf"
for want in "server 127.0.0.1:$p1 max_fails=3 fail_timeout=10s;" "server 127.0.0.1:$p2 max_fails=3 fail_timeout=10s;" \
    "server 127.0.0.1:$p3 max_fails=3 fail_timeout=10s;" "listen 127.0.0.1:$listen;"; do
    [ "$(grep -cxF "    $want" "$conf")" -eq 1 ] && ok || bad "deploy/nginx/rayd.conf: no line to become '$want'"
done
left=$(grep -v '^ *#' "$conf" | grep -n ':808[123]\|listen 80;')
[ -z "$left" ] && ok || bad "the copied conf still names a default port: $left"

# client_max_body_size is the daemon's default --max-body-bytes.
conf_limit=$(sed -n 's/^ *client_max_body_size \([0-9]*\);.*/\1/p' "$conf")
daemon_limit=$(sed -n 's/.*--max-body-bytes N .*(default \([0-9]*\);.*/\1/p' "$T/help")
[ -n "$conf_limit" ] && [ "$conf_limit" = "$daemon_limit" ] && ok ||
    bad "client_max_body_size ($conf_limit) is not the daemon's default --max-body-bytes ($daemon_limit)"
limit=${conf_limit:-${daemon_limit:-16777216}}

# The top level nginx reads in /etc/nginx/nginx.conf, in the temporary folder.
user_line=""
[ "$(id -u)" -eq 0 ] && user_line="user $(id -un) $(id -gn);"
cat >"$T/nginx.conf" <<EOF
$user_line
daemon off;
worker_processes 1;
pid $T/nginx.pid;
error_log $T/error.log info;
events { worker_connections 256; }
http {
    access_log $T/access.log;
    client_body_temp_path $T/client_body;
    proxy_temp_path $T/proxy;
    fastcgi_temp_path $T/fastcgi;
    uwsgi_temp_path $T/uwsgi;
    scgi_temp_path $T/scgi;
    include $conf;
}
EOF
if [ ! -x "$NGINX" ]; then
    bad "no nginx at $NGINX (make deps installs Debian's nginx)"
    echo "deploy: $pass passed, $fail failed"
    exit 1
fi
"$NGINX" -t -p "$T" -e "$T/error.log" -c "$T/nginx.conf" >"$T/nginx-t" 2>&1 && ok || bad "nginx -t rejects the conf: $(cat "$T/nginx-t")"
grep -q '\[warn\]\|\[emerg\]' "$T/nginx-t" && bad "nginx -t warns: $(cat "$T/nginx-t")" || ok

# The file as shipped, not a byte changed (its ports, listen 80 included:
# nginx -t binds nothing), inside the smallest main file that includes it
# from http {} as /etc/nginx/nginx.conf includes conf.d/*.conf. It is a
# conf.d file, not a main one: nginx -t -c rayd.conf alone says "upstream"
# is not allowed there, which the file's first lines say.
mkdir "$T/shipped"
cat >"$T/shipped/nginx.conf" <<EOF
$user_line
worker_processes 1;
pid $T/shipped/nginx.pid;
error_log $T/shipped/error.log;
events { worker_connections 64; }
http {
    client_body_temp_path $T/shipped/client_body;
    proxy_temp_path $T/shipped/proxy;
    fastcgi_temp_path $T/shipped/fastcgi;
    uwsgi_temp_path $T/shipped/uwsgi;
    scgi_temp_path $T/shipped/scgi;
    access_log off;
    include $(pwd)/deploy/nginx/rayd.conf;
}
EOF
"$NGINX" -t -p "$T/shipped" -e "$T/shipped/error.log" -c "$T/shipped/nginx.conf" >"$T/nginx-t" 2>&1 && ok ||
    bad "nginx -t rejects deploy/nginx/rayd.conf as shipped: $(cat "$T/nginx-t")"
grep -q '\[warn\]\|\[emerg\]' "$T/nginx-t" && bad "nginx -t warns about the shipped file: $(cat "$T/nginx-t")" || ok

"$NGINX" -p "$T" -e "$T/error.log" -c "$T/nginx.conf" 2>"$T/nginx.stderr" &
ngx=$!
url="http://127.0.0.1:$listen"
i=0
until curl -s -o /dev/null "$url/healthz" || [ $i -ge 100 ]; do sleep 0.1; i=$((i + 1)); done

code=$(curl -s -o "$T/h" -w '%{http_code}' "$url/healthz")
[ "$code" = 200 ] && ok || bad "GET /healthz through nginx: HTTP $code $(head -c 200 "$T/h") $(cat "$T/error.log")"

hdr=$T/render.hdr
code=$(curl -s -o "$T/r.png" -D "$hdr" -w '%{http_code} %{content_type}' -H 'X-Forwarded-For: 203.0.113.9' \
    -H 'X-Request-Id: deploy-test-1' --data-binary @scenes/phong.cfg "$url/v1/render?width=32&height=24")
[ "$code" = "200 image/png" ] && png_is "$T/r.png" 32 24 && ok ||
    bad "POST /v1/render through nginx: $code $(head -c 300 "$T/r.png")"
grep -qi '^X-Request-Id: deploy-test-1' "$hdr" && ok || bad "the client's X-Request-Id is not the daemon's: $(cat "$hdr")"
grep -q 'deploy-test-1' "$T/daemon1.log" "$T/daemon2.log" && ok || bad "no daemon logged the request id deploy-test-1"
# nginx sets X-Forwarded-For to the address it saw: the client cannot name
# another one, and the daemon (trusting 127.0.0.1) logs the client.
grep 'deploy-test-1' "$T/daemon1.log" "$T/daemon2.log" | grep -q '203\.0\.113\.9' &&
    bad "a client's own X-Forwarded-For reached the daemon: $(grep 'deploy-test-1' "$T"/daemon*.log)" || ok
curl -s -o /dev/null -D "$hdr" "$url/healthz"
grep -Eqi '^X-Request-Id: [0-9a-f]{32}' "$hdr" && ok || bad "a request without X-Request-Id does not get nginx's: $(cat "$hdr")"

# One byte over client_max_body_size: nginx answers 413 itself, from the
# Content-Length, and no daemon sees the request.
head -c $((limit + 1)) /dev/zero >"$T/big"
code=$(curl -s -o "$T/big.out" -w '%{http_code}' -H 'Content-Type: text/plain' --data-binary @"$T/big" \
    "$url/v1/render?width=32&height=24")
[ "$code" = 413 ] && grep -q nginx "$T/big.out" && ok ||
    bad "a body of $((limit + 1)) bytes through nginx: HTTP $code $(head -c 200 "$T/big.out")"
rm -f "$T/big"

# A daemon killed outright: nginx passes requests on to the one left (the
# third server was never up), GETs and, since connecting failed, POSTs.
kill -KILL "$d1"
wait "$d1" 2>/dev/null
d1=""
n=0
for i in 1 2 3 4 5 6; do
    code=$(curl -s -o /dev/null -w '%{http_code}' "$url/healthz")
    [ "$code" = 200 ] && n=$((n + 1))
done
[ "$n" -eq 6 ] && ok || bad "with one daemon killed, $n of 6 GET /healthz through nginx answered 200: $(tail -5 "$T/error.log")"
code=$(curl -s -o "$T/r2.png" -w '%{http_code} %{content_type}' --data-binary @scenes/phong.cfg \
    "$url/v1/render?width=32&height=24")
[ "$code" = "200 image/png" ] && png_is "$T/r2.png" 32 24 && ok ||
    bad "POST /v1/render with one daemon killed: $code $(head -c 300 "$T/r2.png")"
grep -q 'connect() failed' "$T/error.log" && ok || bad "nginx never met a daemon that was down: $(tail -5 "$T/error.log")"

stop "$ngx"
ngx=""
stop "$d2" && ok || bad "the daemon left did not stop on SIGTERM with 0"
d2=""

# The unit `make install` writes, for this binary.
unit_dir=$T/unit
mkdir "$unit_dir"
unit=$unit_dir/rayd@.service
sed "s|@BINDIR@|$(dirname "$RAYD")|g" deploy/systemd/rayd@.service.in >"$unit"
for want in 'EnvironmentFile=-/etc/rayd/rayd.env' 'StateDirectory=rayd/%i' 'DynamicUser=yes' 'ProtectSystem=strict' \
    'ProtectHome=yes' 'PrivateTmp=yes' 'NoNewPrivileges=yes' 'RestrictAddressFamilies=AF_INET AF_INET6 AF_UNIX AF_NETLINK' \
    'SystemCallFilter=@system-service @mount sethostname seccomp' 'CapabilityBoundingSet=' 'Restart=on-failure' 'LockPersonality=yes' \
    'RestrictRealtime=yes' 'ProtectKernelTunables=yes' 'ProtectKernelModules=yes' 'ProtectControlGroups=yes'; do
    grep -qxF "$want" "$unit" && ok || bad "the unit lacks $want"
done
for want in 'MemoryMax=' 'TasksMax=' 'LimitNOFILE='; do
    grep -q "^$want." "$unit" && ok || bad "the unit sets no $want"
done
grep -q '^ExecStart=.* --data-dir \${STATE_DIRECTORY}' "$unit" && ok || bad "the unit's --data-dir is not its StateDirectory"
if command -v systemd-analyze >/dev/null 2>&1; then
    # verify exits 0 on an unknown or malformed setting: its output must be empty.
    systemd-analyze verify --man=no "$unit" >"$T/verify" 2>&1 && [ ! -s "$T/verify" ] && ok ||
        bad "systemd-analyze verify: $(cat "$T/verify")"
fi

echo "deploy: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
