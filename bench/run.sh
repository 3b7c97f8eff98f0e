#!/bin/sh
# bench/run.sh: rays per second of `rayd render`, and wall time against POV-Ray 3.7
# rendering the same scenes, with 1 and 2 threads. Four tables (bench/README.md):
#
#  1. scenes/diffuse.cfg and phong.cfg at 1920x1080 against the hand-written
#     bench/NAME.pov;
#  2. large scenes generated at bench time (10,000 spheres; a 1,000,000-triangle
#     torus knot), at 960x540, against POV-Ray files made from the same cfg text
#     by bench/cfg2pov.py (checked first: diffuse.cfg through cfg2pov renders
#     like bench/diffuse.pov); load, BVH build and trace times apart;
#  3. the BVH of the 1M-triangle scene: build time, nodes, bytes, peak memory;
#  4. diffuse.cfg at 1920x1080, 1 thread: this rayd against rayd built from the
#     foundation commit (BENCH_BASE) in a temporary git worktree;
# and the service and sampling sections after them (bench/README.md):
#  5. http:     POST /v1/render requests/s and latency (wrk), rayd against
#               bench/bare_mhd.c, a libmicrohttpd server that only answers a
#               fixed PNG (the HTTP ceiling of this machine);
#  6. overload: 3x rayd's capacity at a fixed arrival rate (hey) against a
#               small --queue: status codes, latency, memory and open files;
#  7. mixed:    small sync renders while one large async job runs;
#  8. converge: `rayd converge` tables, SVG plots in build/bench-out/;
#  9. equal:    equal-time error against POV-Ray, each against its own
#               converged reference.
#
# Usage: sh bench/run.sh PATH/TO/rayd        (`make bench` runs sh bench/run.sh build/rayd)
#
# Each configuration (scene x threads) runs BENCH_RUNS times (default 3), rayd and
# povray taking turns, and the table shows the best (smallest time) of the runs:
# the machine is shared and noisy, and noise only ever adds time.
# Optional environment:
#   BENCH_RUNS=3            runs per configuration
#   BENCH_THREADS="1 2"     thread counts (speed-ups are against the first)
#   BENCH_SCENES="diffuse phong"   scenes/NAME.cfg with bench/NAME.pov (table 1)
#   BENCH_LARGE="spheres10k knot1m"  generated scenes of tables 2 and 3; "" skips them
#   BENCH_LARGE_SIZE=960x540         their image size
#   BENCH_BASE=8745562      the commit of table 4; "" skips it
#   BENCH_KEEP=1            keep the rendered images and logs and print where
#   BENCH_TIME=/usr/bin/time  GNU time, for peak memory (%M); "" reads VmHWM instead
#   BENCH_HTTP=1 BENCH_OVERLOAD=1 BENCH_MIXED=1 BENCH_CONVERGE=1 BENCH_EQUAL=1
#                           sections 5-9; 0 skips one
#   BENCH_ONLY="http converge"  run only these sections, by name: scenes (table 1),
#                           large (tables 2, 3), base (table 4), http, overload,
#                           mixed, converge, equal
#   BENCH_HTTP_SECS=10      length of each wrk run (section 5)
#   BENCH_HTTP_CONC="1 8 64"  its concurrencies
#   BENCH_OVERLOAD_SECS=10  length of the hey run (section 6)
#   BENCH_OUT=build/bench-out  where section 8 writes its SVG and CSV files
#   BENCH_EQ_SIZE=320x240 BENCH_EQ_THREADS=1 BENCH_EQ_REF_SAMPLES=512  section 9
# Needs: POSIX sh, awk, GNU date (+%N), povray 3.7 (`sh deploy/deps.sh bench`),
# python3 (scenes/gen.py, bench/cfg2pov.py, bench/pngdiff.py); table 4 also git,
# make and what building rayd needs (gcc, pkg-config, libpng, libcjson, zlib);
# sections 5-7 wrk, hey, curl, timeout (coreutils), and for bare_mhd cc,
# pkg-config and libmicrohttpd's headers.
set -eu

W=1920
H=1080
RUNS=${BENCH_RUNS:-3}
THREADS=${BENCH_THREADS:-1 2}
SCENES=${BENCH_SCENES:-diffuse phong}
LARGE=${BENCH_LARGE-spheres10k knot1m}
LARGE_SIZE=${BENCH_LARGE_SIZE:-960x540}
BASE=${BENCH_BASE-8745562}
GNU_TIME=${BENCH_TIME-/usr/bin/time}
# The generated scenes: gen.py arguments. 2 * 4000 * 125 = 1,000,000 triangles.
SPHERES_N=10000
KNOT_SEGS=4000
KNOT_SIDES=125
KNOT_TRIS=$((2 * KNOT_SEGS * KNOT_SIDES))

die() { echo "bench: $*" >&2; exit 1; }
# Ends the "running ..." progress line, shows a log, and stops.
die_log() {  # log message
    echo "FAILED" >&2
    tr '\r' '\n' <"$1" | tail -n 20 >&2
    die "$2"
}

[ $# -eq 1 ] || { echo "usage: sh bench/run.sh PATH/TO/rayd" >&2; exit 2; }
RAYD=$1
case $RAYD in
    */*) ;;
    *) RAYD=$(command -v "$RAYD" 2>/dev/null) || die "$1: not found" ;;
esac
if [ ! -f "$RAYD" ] || [ ! -x "$RAYD" ]; then
    die "$RAYD: not an executable file (build it with make)"
fi
case $RAYD in
    /*) ;;
    *) RAYD=$(cd "$(dirname "$RAYD")" && pwd)/$(basename "$RAYD") ;;
esac
case $RUNS in ''|*[!0-9]*|0) die "BENCH_RUNS must be a positive integer, got '$RUNS'" ;; esac
for t in $THREADS; do
    case $t in ''|*[!0-9]*|0) die "BENCH_THREADS must be positive integers, got '$t'" ;; esac
done
LW=${LARGE_SIZE%x*}
LH=${LARGE_SIZE#*x}
case $LW$LH in ''|*[!0-9]*) die "BENCH_LARGE_SIZE must be WxH, got '$LARGE_SIZE'" ;; esac
for s in $LARGE; do
    case $s in spheres10k|knot1m) ;; *) die "BENCH_LARGE: unknown scene '$s' (spheres10k, knot1m)" ;; esac
done
T1=${THREADS%% *}    # the first thread count: the baseline, and BVH figures

# Which sections run: BENCH_ONLY names them, else each one's own switch.
ONLY=${BENCH_ONLY-}
for s in $ONLY; do
    case $s in scenes|large|base|http|overload|mixed|converge|equal) ;;
    *) die "BENCH_ONLY: unknown section '$s' (scenes large base http overload mixed converge equal)" ;;
    esac
done
section_on() {  # name switch: 1 or 0
    if [ -n "$ONLY" ]; then
        case " $ONLY " in *" $1 "*) echo 1 ;; *) echo 0 ;; esac
    else
        case $2 in ''|0) echo 0 ;; *) echo 1 ;; esac
    fi
}
DO_SCENES=$(section_on scenes "$SCENES")
DO_LARGE=$(section_on large "$LARGE")
DO_BASE=$(section_on base "$BASE")
DO_HTTP=$(section_on http "${BENCH_HTTP:-1}")
DO_OVERLOAD=$(section_on overload "${BENCH_OVERLOAD:-1}")
DO_MIXED=$(section_on mixed "${BENCH_MIXED:-1}")
DO_CONVERGE=$(section_on converge "${BENCH_CONVERGE:-1}")
DO_EQUAL=$(section_on equal "${BENCH_EQUAL:-1}")
[ "$DO_LARGE" = 1 ] && [ -z "$LARGE" ] && LARGE="spheres10k knot1m"
[ "$DO_BASE" = 1 ] && [ -z "$BASE" ] && BASE=8745562
[ "$DO_LARGE" = 1 ] || LARGE=''
[ "$DO_BASE" = 1 ] || BASE=''
NEED_POVRAY=$DO_SCENES$DO_LARGE$DO_EQUAL
NEED_PYTHON=$DO_LARGE$DO_BASE$DO_EQUAL

HTTP_SECS=${BENCH_HTTP_SECS:-10}
HTTP_CONC=${BENCH_HTTP_CONC:-1 8 64}
OVL_SECS=${BENCH_OVERLOAD_SECS:-10}
EQ_SIZE=${BENCH_EQ_SIZE:-320x240}
EQ_THREADS=${BENCH_EQ_THREADS:-1}
EQ_REF=${BENCH_EQ_REF_SAMPLES:-512}
for v in "$HTTP_SECS" "$OVL_SECS" "$EQ_THREADS" "$EQ_REF" $HTTP_CONC; do
    case $v in ''|*[!0-9]*|0) die "BENCH_HTTP_SECS, BENCH_HTTP_CONC, BENCH_OVERLOAD_SECS, BENCH_EQ_THREADS and BENCH_EQ_REF_SAMPLES must be positive integers, got '$v'" ;; esac
done
EW=${EQ_SIZE%x*}
EH=${EQ_SIZE#*x}
case $EW$EH in ''|*[!0-9]*) die "BENCH_EQ_SIZE must be WxH, got '$EQ_SIZE'" ;; esac

# Work from the repository root, whatever the caller's directory.
ROOT=$(cd "$(dirname "$0")/.." && pwd)
cd "$ROOT"
for s in $SCENES; do
    [ -r "scenes/$s.cfg" ] || die "scenes/$s.cfg: missing"
    [ -r "bench/$s.pov" ] || die "bench/$s.pov: missing"
done

case $NEED_POVRAY in *1*)
    command -v povray >/dev/null 2>&1 ||
        die "povray not found: install Debian's povray (sh deploy/deps.sh bench does)" ;;
esac
need_tool() {  # tool why
    command -v "$1" >/dev/null 2>&1 ||
        die "$1 not found, needed by $2: install Debian's $1 (sh deploy/deps.sh bench does), or skip the section"
}
[ "$DO_HTTP" = 0 ] || { need_tool wrk "BENCH_HTTP"; need_tool cc "BENCH_HTTP (bench/bare_mhd.c)";
    need_tool pkg-config "BENCH_HTTP (bench/bare_mhd.c)"; }
[ "$DO_OVERLOAD" = 0 ] || { need_tool wrk "BENCH_OVERLOAD"; need_tool hey "BENCH_OVERLOAD"; }
case $DO_HTTP$DO_OVERLOAD$DO_MIXED in *1*) need_tool curl "BENCH_HTTP/OVERLOAD/MIXED"; need_tool timeout "BENCH_HTTP/OVERLOAD/MIXED" ;; esac
case $(date +%N) in
    *[!0-9]*|'') die "date +%N gives no nanoseconds (GNU date needed)" ;;
esac
PYTHON=/usr/bin/python3
[ -x "$PYTHON" ] || PYTHON=$(command -v python3 2>/dev/null) || PYTHON=
case $NEED_PYTHON in *1*)
    [ -n "$PYTHON" ] ||
        die "python3 not found (needed by scenes/gen.py and bench/*.py; BENCH_LARGE= BENCH_BASE= BENCH_EQUAL=0 skip them)" ;;
esac
if [ -n "$GNU_TIME" ] && ! "$GNU_TIME" -f %M -o /dev/null true >/dev/null 2>&1; then
    GNU_TIME=''    # not GNU time: peak memory from /proc/PID/status instead
fi
now() { date +%s.%N; }
ms_since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.3f", (b - a) * 1000 }'; }
is_num() { case $1 in ''|*[!0-9.eE+-]*) return 1 ;; *) return 0 ;; esac; }
loadavg() { cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo '?'; }

# povray's I/O restrictions (/etc/povray/3.7/povray.conf) allow writing under
# /tmp, so the scratch directory is there whatever TMPDIR says.
WORK=$(mktemp -d /tmp/rayd-bench.XXXXXX)
BASESRC=''    # the git worktree of table 4 while it exists
SRV_ALL=''    # the servers of sections 5-7 while they run (pids)
AUX_PID=''    # a load generator running in the background
cleanup() {
    if [ -n "$AUX_PID" ]; then
        kill -TERM "$AUX_PID" 2>/dev/null || true
        wait "$AUX_PID" 2>/dev/null || true
        AUX_PID=''
    fi
    for p in $SRV_ALL; do stop_server "$p"; done
    if [ -n "$BASESRC" ]; then
        git -C "$ROOT" worktree remove --force "$BASESRC" >/dev/null 2>&1 ||
            { rm -rf "$BASESRC"; git -C "$ROOT" worktree prune >/dev/null 2>&1 || true; }
        BASESRC=''
    fi
    if [ "${BENCH_KEEP:-0}" = 1 ]; then
        echo "bench: images and logs kept in $WORK" >&2
    else
        rm -rf "$WORK"
    fi
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
# A closed terminal or output pipe must still stop the servers of sections 5-7.
trap 'exit 129' HUP
trap 'exit 141' PIPE
RESULTS=$WORK/results

# Runs a command, its stdout and stderr into LOG; sets m_wall (ms), m_rc, and
# m_rss (peak resident kB, or nan) when WANT_RSS=1: from GNU time's %M, or,
# without it, VmHWM in /proc/PID/status read every 50 ms while it runs.
WANT_RSS=0
measure() {  # log command...
    m_log=$1
    shift
    m_rss=nan
    if [ "$WANT_RSS" = 1 ] && [ -n "$GNU_TIME" ]; then
        t0=$(now)
        if "$GNU_TIME" -f %M -o "$m_log.rss" "$@" >"$m_log" 2>&1; then m_rc=0; else m_rc=$?; fi
        m_wall=$(ms_since "$t0")
        m_rss=$(tail -n 1 "$m_log.rss" 2>/dev/null) || m_rss=nan
        is_num "$m_rss" || m_rss=nan
    elif [ "$WANT_RSS" = 1 ]; then
        t0=$(now)
        "$@" >"$m_log" 2>&1 &
        m_pid=$!
        while :; do
            st=$(awk '/^State:/ { s = $2 } /^VmHWM:/ { h = $2 } END { print s, h }' \
                "/proc/$m_pid/status" 2>/dev/null) || break
            case $st in ''|Z*|X*) break ;; esac
            case ${st#* } in ''|*[!0-9]*) ;; *) m_rss=${st#* } ;; esac
            sleep 0.05
        done
        if wait "$m_pid"; then m_rc=0; else m_rc=$?; fi
        m_wall=$(ms_since "$t0")
    else
        t0=$(now)
        if "$@" >"$m_log" 2>&1; then m_rc=0; else m_rc=$?; fi
        m_wall=$(ms_since "$t0")
    fi
}

# The value of KEY=... in rayd's statistics line.
stat_of() { printf '%s\n' "$1" | sed -n "s/.* $2=\([^ ]*\).*/\1/p"; }

# One rayd run; sets r_wall r_ms r_rps r_line r_prep r_rss r_out.
run_rayd() {  # cfg tag threads width height [more rayd options]
    r_cfg=$1 r_tag=$2 r_t=$3 r_w=$4 r_h=$5
    shift 5
    r_out=$WORK/$r_tag-t$r_t-rayd.png
    log=$WORK/$r_tag-t$r_t-rayd.log
    measure "$log" "$RAYD" render "$r_cfg" -o "$r_out" --width "$r_w" --height "$r_h" \
        --threads "$r_t" "$@"
    [ "$m_rc" = 0 ] || die_log "$log" "rayd failed on $r_cfg with --threads $r_t"
    r_wall=$m_wall
    r_rss=$m_rss
    r_line=$(grep '^render: ' "$log" | tail -n 1) || true
    r_ms=$(stat_of "$r_line" time_ms)
    r_rps=$(stat_of "$r_line" rays_per_s)
    r_prep=$(stat_of "$r_line" prepare_ms)
    if ! is_num "$r_ms" || ! is_num "$r_rps"; then
        die_log "$log" "no 'render: ... time_ms=... rays_per_s=...' line from rayd on $r_cfg"
    fi
    is_num "$r_prep" || r_prep=nan
    case $r_line in
        *" threads=$r_t "*) ;;
        *) echo "bench: warning: asked rayd for $r_t threads, it reports: $r_line" >&2 ;;
    esac
}

# POV-Ray's "Parse Time: ... (1.234 seconds)" and the like, in ms (nan if absent).
pov_ms() {  # stats label
    printf '%s\n' "$1" | sed -n "s/.*$2:.*(\([0-9.]*\) seconds).*/\1/p" | tail -n 1 |
        awk '{ s = $0 } END { if (s ~ /^[0-9.]+$/) printf "%.3f", s * 1000; else print "nan" }'
}

# One povray run; sets p_wall p_parse p_bound p_trace p_rays (camera rays +
# shadow ray tests) p_rss p_out.
run_povray() {  # pov tag threads width height
    p_out=$WORK/$2-t$3-povray.png
    log=$WORK/$2-t$3-povray.log
    # -D no display, -A no antialiasing, +Q9 default quality (shadows on),
    # File_Gamma=1.0 as rayd's gamma 1, -V -GR: less chatter (the log is only
    # read for the statistics), -P no pause. The "cannot open the user
    # configuration file ~/.povray/3.7/povray.conf" warning is harmless.
    measure "$log" povray "+I$1" "+O$p_out" +FN "+W$4" "+H$5" -D -A +Q9 "+WT$3" \
        File_Gamma=1.0 -V -GR -P
    [ "$m_rc" = 0 ] || die_log "$log" "povray failed on $1 with +WT$3"
    p_wall=$m_wall
    p_rss=$m_rss
    stats=$(tr '\r' '\n' <"$log")
    p_parse=$(pov_ms "$stats" 'Parse Time')
    p_bound=$(pov_ms "$stats" 'Bounding Time')
    p_trace=$(pov_ms "$stats" 'Trace Time')
    p_rays=$(printf '%s\n' "$stats" | awk '
        /^Rays:/ { r = $2 } /^Shadow Ray Tests:/ { s = $4 }
        END { if (r == "") print "nan"; else print r + s }')
}

# POV-Ray's fixed cost: start-up and shut-down of its front end, measured on
# an empty scene at 16x9; part of every povray wall time below.
povray_overhead() {
    printf '#version 3.7;\ncamera { location <0, 0, -5> look_at 0 }\n' >"$WORK/empty.pov"
    best=
    i=0
    while [ $i -lt "$RUNS" ]; do
        t0=$(now)
        povray "+I$WORK/empty.pov" -F +W16 +H9 -D -A +WT1 -V -GR -P \
            >"$WORK/empty.log" 2>&1 || { cat "$WORK/empty.log" >&2; die "povray cannot render an empty scene"; }
        w=$(ms_since "$t0")
        best=$(awk -v a="${best:-$w}" -v b="$w" 'BEGIN { print (b < a ? b : a) }')
        i=$((i + 1))
    done
    echo "$best"
}

# Smallest / largest of two numbers; "nan" and "" lose to any number.
min() { awk -v a="$1" -v b="$2" 'BEGIN { if (a !~ /^[0-9.eE+-]+$/) print b; else if (b !~ /^[0-9.eE+-]+$/) print a; else print (b + 0 < a + 0 ? b : a) }'; }
max() { awk -v a="$1" -v b="$2" 'BEGIN { if (a !~ /^[0-9.eE+-]+$/) print b; else if (b !~ /^[0-9.eE+-]+$/) print a; else print (b + 0 > a + 0 ? b : a) }'; }
sub_ms() { awk -v a="$1" -v b="$2" 'BEGIN { if (a ~ /^[0-9.eE+-]+$/ && b ~ /^[0-9.eE+-]+$/) printf "%.3f", a - b; else print "nan" }'; }
# rayd's camera + shadow + secondary rays from its statistics line.
rays_of() {
    printf '%s\n' "$1" | awk '{
        for (i = 1; i <= NF; i++) { split($i, kv, "=");
            if (kv[1] ~ /^(camera|shadow|secondary)_rays$/) n += kv[2] }
        print n + 0 }'
}
pngdiff() {  # a.png b.png: "pixels=N differ=D over1=M max=K" or "pngdiff failed"
    "$PYTHON" bench/pngdiff.py "$1" "$2" 2>&1 || echo "pngdiff failed"
}

# ---------------------------------------------------------------------------
# Servers of sections 5-7: `rayd serve` or bench/bare_mhd on 127.0.0.1, at a
# port the kernel picks (written to PORT_FILE), stopped by their pid.

PORT_FILE=$WORK/port
SRV_PORT=''
alive() {  # pid: running (not exited, not a zombie)?
    a_st=$(sed -n 's/^State:[[:space:]]*\([A-Z]\).*/\1/p' "/proc/$1/status" 2>/dev/null) || a_st=''
    case $a_st in ''|Z|X) return 1 ;; *) return 0 ;; esac
}
# Starts a server in the background; it must write PORT_FILE within 10 s.
start_server() {  # log command...
    s_log=$1
    shift
    rm -f "$PORT_FILE"
    "$@" >"$s_log" 2>&1 &
    SRV_PID=$!
    SRV_ALL="$SRV_ALL $SRV_PID"
    s_i=0
    while [ ! -s "$PORT_FILE" ]; do
        if ! alive "$SRV_PID"; then
            stop_server "$SRV_PID"
            die_log "$s_log" "the server exited at start: $*"
        fi
        [ $s_i -lt 200 ] || die_log "$s_log" "the server wrote no port file in 10 s: $*"
        sleep 0.05
        s_i=$((s_i + 1))
    done
    SRV_PORT=$(cat "$PORT_FILE")
    case $SRV_PORT in ''|*[!0-9]*) die "bad port '$SRV_PORT' from: $*" ;; esac
}
# Stops one server started above (by its pid): SIGTERM, up to 15 s to exit
# (rayd drains for --drain-ms), then SIGKILL; sets s_rc to its exit status.
stop_server() {  # pid
    s_pid=$1
    case " $SRV_ALL " in *" $s_pid "*) ;; *) return 0 ;; esac
    kill -TERM "$s_pid" 2>/dev/null || true
    s_i=0
    while alive "$s_pid" && [ $s_i -lt 300 ]; do
        sleep 0.05
        s_i=$((s_i + 1))
    done
    if alive "$s_pid"; then
        echo "bench: server $s_pid still running 15 s after SIGTERM: SIGKILL" >&2
        kill -KILL "$s_pid" 2>/dev/null || true
    fi
    if wait "$s_pid" 2>/dev/null; then s_rc=0; else s_rc=$?; fi
    # shellcheck disable=SC2086
    SRV_ALL=$(printf '%s\n' $SRV_ALL | grep -vx "$s_pid" | tr '\n' ' ') || SRV_ALL=''
}
# `rayd serve` for the bench: 127.0.0.1 only, short drain, logs in LOG.
start_rayd() {  # log [more serve options]
    r_log=$1
    shift
    start_server "$r_log" "$RAYD" serve --listen 127.0.0.1:0 --port-file "$PORT_FILE" \
        --scenes scenes --drain-ms 2000 "$@"
}
# The sum of a metric (all its labels, or one label value) from rayd's /metrics.
metric() {  # name [label value]
    curl -s --max-time 5 "http://127.0.0.1:$SRV_PORT/metrics" 2>/dev/null |
        awk -v n="$1" -v l="${2:-}" '
        ($1 == n || index($1, n "{") == 1) && (l == "" || index($1, "\"" l "\"") > 0) { s += $2; f = 1 }
        END { print f ? s : "nan" }'
}
# Waits up to 30 s until rayd has no job queued or running (after a load
# generator stops, the jobs of its abandoned requests are cancelled).
wait_idle() {
    w_i=0
    while [ $w_i -lt 150 ]; do
        [ "$(metric rayd_queue_depth)$(metric rayd_jobs_running)" = 00 ] && return 0
        sleep 0.2
        w_i=$((w_i + 1))
    done
    echo "bench: warning: rayd still has jobs queued or running 30 s after the load" >&2
}
# VmRSS (kB) and open file descriptors of a process: "RSS FDS".
rss_fds() {  # pid
    r_rss=$(sed -n 's/^VmRSS:[[:space:]]*\([0-9]*\).*/\1/p' "/proc/$1/status" 2>/dev/null) || r_rss=''
    # shellcheck disable=SC2012
    r_fds=$(ls "/proc/$1/fd" 2>/dev/null | wc -l) || r_fds=''
    echo "${r_rss:-nan} ${r_fds:-nan}"
}
# Nearest-rank percentile of the numbers in a file (one per line), or nan.
pct() {  # file p
    sort -g "$1" | awk -v p="$2" '{ a[NR] = $1 } END {
        if (NR == 0) { print "nan"; exit }
        i = int(p / 100 * NR); if (i < p / 100 * NR) i++; if (i < 1) i = 1; if (i > NR) i = NR
        print a[i] }'
}
# wrk's Lua script: POST the file named by WRK_BODY as text/plain, and at the
# end one line "WRK requests=... p50_us=..." for the script to read.
write_wrk_lua() {  # out.lua
    cat >"$1" <<'LUA'
local f = assert(io.open(os.getenv("WRK_BODY"), "rb"))
wrk.method = "POST"
wrk.body = f:read("*a")
f:close()
wrk.headers["Content-Type"] = "text/plain"

done = function(summary, latency, requests)
    local e = summary.errors
    io.write(string.format("WRK requests=%.0f duration_us=%.0f p50_us=%.0f p99_us=%.0f max_us=%.0f " ..
        "connect=%.0f read=%.0f write=%.0f status=%.0f timeout=%.0f\n",
        summary.requests, summary.duration, latency:percentile(50), latency:percentile(99), latency.max,
        e.connect, e.read, e.write, e.status, e.timeout))
end
LUA
}
# One bounded wrk run; sets w_rps w_p50 w_p99 (ms) w_err (failed requests:
# non-2xx answers, timeouts, socket errors) and w_n (requests).
run_wrk() {  # log lua body url connections seconds
    w_t=2
    [ "$5" -ge 2 ] || w_t=1    # wrk needs connections >= threads
    if ! WRK_BODY=$3 timeout -k 5 $(($6 + 60)) wrk "-t$w_t" "-c$5" "-d$6s" --latency --timeout 30s \
        -s "$2" "$4" >"$1" 2>&1; then
        die_log "$1" "wrk failed on $4"
    fi
    w_line=$(grep '^WRK ' "$1" | tail -n 1) || w_line=''
    [ -n "$w_line" ] || die_log "$1" "no WRK line from wrk's Lua script"
    w_n=$(stat_of " $w_line" requests)
    w_rps=$(awk -v n="$w_n" -v d="$(stat_of " $w_line" duration_us)" 'BEGIN { printf "%.1f", (d > 0 ? n / d * 1e6 : 0) }')
    w_p50=$(awk -v x="$(stat_of " $w_line" p50_us)" 'BEGIN { printf "%.2f", x / 1000 }')
    w_p99=$(awk -v x="$(stat_of " $w_line" p99_us)" 'BEGIN { printf "%.2f", x / 1000 }')
    w_err=$(printf '%s\n' "$w_line" | awk '{ for (i = 1; i <= NF; i++) { split($i, kv, "=");
        if (kv[1] ~ /^(connect|read|write|status|timeout)$/) n += kv[2] } print n + 0 }')
}

cpus=$(getconf _NPROCESSORS_ONLN 2>/dev/null || echo '?')
pvver=''
case $NEED_POVRAY in *1*)
    pvver=$(povray --version 2>&1 | sed -n 's/^\(POV-Ray [0-9][^ ]*\).*/\1/p' | head -n 1) ;;
esac
echo "rayd bench: ${W}x${H}, 1 sample per pixel, best of $RUNS runs per configuration"
echo "  rayd:   $RAYD"
case $NEED_POVRAY in *1*)
    echo "  povray: ${pvver:-povray} ($(command -v povray)), -A -D +Q9, same scenes in bench/*.pov" ;;
esac
echo "  host:   $cpus CPUs, load average $(loadavg) at start, $(date -u '+%Y-%m-%d %H:%M UTC')"
[ -z "$ONLY" ] || echo "  only:   $ONLY (BENCH_ONLY)"
rev=$(git rev-parse --short HEAD 2>/dev/null) || rev=''
[ -z "$rev" ] || echo "  commit: $rev$(git diff --quiet HEAD 2>/dev/null || echo ' (with local changes)')"
for t in $THREADS; do
    [ "$cpus" = '?' ] || [ "$t" -le "$cpus" ] ||
        echo "  warning: $t threads on $cpus CPUs: the threads share cores" >&2
done
case $NEED_POVRAY in *1*)
    overhead=$(povray_overhead)
    printf "  povray start-up + shut-down (empty scene): %.0f ms, included in its wall times\n" "$overhead" ;;
esac

# ---------------------------------------------------------------------------
# Table 1: the assignment scenes at 1920x1080 against bench/NAME.pov.

if [ "$DO_SCENES" = 1 ]; then
echo
: >"$RESULTS"
for s in $SCENES; do
    for t in $THREADS; do
        printf '  running %-8s threads=%s ... ' "$s" "$t" >&2
        bw='' bms='' brps='' pw='' ptr='' prays='' line=''
        i=0
        while [ $i -lt "$RUNS" ]; do
            run_rayd "scenes/$s.cfg" "$s" "$t" $W $H
            run_povray "bench/$s.pov" "$s" "$t" $W $H
            bw=$(min "$bw" "$r_wall")
            bms=$(min "$bms" "$r_ms")
            brps=$(max "$brps" "$r_rps")
            pw=$(min "$pw" "$p_wall")
            ptr=$(min "$ptr" "$p_trace")
            prays=$p_rays
            line=$r_line
            i=$((i + 1))
        done
        echo "done" >&2
        echo "$s $t $bw $bms $brps $pw ${ptr:-nan} $prays $(rays_of "$line")" >>"$RESULTS"
    done
done

echo "Rays per second and wall time, rayd against POV-Ray 3.7 (bench/NAME.pov), ${W}x${H}:"
awk -v runs="$RUNS" '
function f(x, fmt) { return (x == "nan" || x == "") ? "n/a" : sprintf(fmt, x) }
function r(a, b) { return (a == "nan" || b == "nan" || b + 0 == 0) ? "n/a" : sprintf("%.2f", a / b) }
{
    n++; S[n] = $1; T[n] = $2; RW[n] = $3; RMS[n] = $4; RRPS[n] = $5
    PW[n] = $6; PT[n] = $7; PR[n] = $8; RR[n] = $9
}
END {
    printf "%-8s %3s | %9s %9s %7s | %9s %9s %7s | %6s %6s\n", "", "", \
        "rayd", "rayd", "rayd", "povray", "povray", "povray", "ratio", "ratio"
    printf "%-8s %3s | %9s %9s %7s | %9s %9s %7s | %6s %6s\n", "scene", "thr", \
        "wall ms", "render ms", "Mrays/s", "wall ms", "trace ms", "Mrays/s", "wall", "render"
    print "---------------------------------------------------------------------------------------"
    for (i = 1; i <= n; i++) {
        pm = (PT[i] == "nan" || PR[i] == "nan") ? "nan" : PR[i] / PT[i] / 1000
        printf "%-8s %3s | %9s %9s %7s | %9s %9s %7s | %6s %6s\n", S[i], T[i], \
            f(RW[i], "%.1f"), f(RMS[i], "%.1f"), f(RRPS[i] / 1e6, "%.2f"), \
            f(PW[i], "%.1f"), f(PT[i], "%.1f"), f(pm, "%.2f"), r(RW[i], PW[i]), r(RMS[i], PT[i])
    }
    print ""
    print "ratio = rayd time / povray time, < 1 means rayd is faster. wall: whole processes"
    print "(start, parse, render, PNG, exit); render: rayd time_ms / povray Trace Time."
    print "Mrays/s: (camera + shadow + secondary rays) / render time; for povray its Rays"
    printf "plus Shadow Ray Tests over its Trace Time. Best of %d runs each.\n", runs
    sp = 0
    for (i = 1; i <= n; i++) {
        for (j = 1; j <= n; j++) if (S[j] == S[i] && j < i) break
        if (j < i) continue            # first row of this scene is the baseline
        for (k = i + 1; k <= n; k++) {
            if (S[k] != S[i]) continue
            if (!sp++) print ""
            printf "speed-up %s/%s threads, %-8s rayd %sx wall, %sx render;  povray %sx wall, %sx trace\n", \
                T[k], T[i], S[i], r(RW[i], RW[k]), r(RMS[i], RMS[k]), r(PW[i], PW[k]), r(PT[i], PT[k])
        }
    }
    print ""
    for (i = 1; i <= n; i++) {
        if (seen[S[i]]++) continue
        printf "rays per frame, %-8s rayd %s, povray %s%s\n", S[i], RR[i], PR[i], \
            (RR[i] == PR[i]) ? " (same work)" : " (differ: see bench/README.md)"
    }
}' "$RESULTS"
fi

# ---------------------------------------------------------------------------
# Tables 2 and 3: large generated scenes, POV-Ray files from bench/cfg2pov.py.

if [ -n "$LARGE" ]; then
    GEN=$WORK/gen
    mkdir -p "$GEN"
    echo
    echo "== Large scenes at ${LW}x${LH}, generated now; load average $(loadavg)"
    printf '  generating scenes ... ' >&2
    t0=$(now)
    for s in $LARGE; do
        case $s in
        spheres10k)
            "$PYTHON" scenes/gen.py spheres "$GEN/spheres10k.cfg" $SPHERES_N >"$GEN/gen.log" 2>&1 ||
                die_log "$GEN/gen.log" "scenes/gen.py spheres failed"
            n=$(grep -c '^\[sphere\]' "$GEN/spheres10k.cfg") || n=0
            [ "$n" = $SPHERES_N ] || die "spheres10k.cfg has $n spheres, not $SPHERES_N"
            ;;
        knot1m)
            "$PYTHON" scenes/gen.py knot "$GEN/knot1m.obj" $KNOT_SEGS $KNOT_SIDES >"$GEN/gen.log" 2>&1 ||
                die_log "$GEN/gen.log" "scenes/gen.py knot failed"
            n=$(grep -c '^f ' "$GEN/knot1m.obj") || n=0
            [ "$n" = $KNOT_TRIS ] || die "knot1m.obj has $n triangles, not $KNOT_TRIS"
            # scenes/mesh.cfg as it is, only pointing at the big knot.
            sed 's|^file = generated/knot\.obj$|file = knot1m.obj|' scenes/mesh.cfg >"$GEN/knot1m.cfg"
            grep -q '^file = knot1m\.obj$' "$GEN/knot1m.cfg" ||
                die "scenes/mesh.cfg has no 'file = generated/knot.obj' line to point at knot1m.obj"
            ;;
        esac
        "$PYTHON" bench/cfg2pov.py "$GEN/$s.cfg" "$GEN/$s.pov" --width "$LW" --height "$LH" \
            >"$GEN/cfg2pov-$s.log" 2>&1 || die_log "$GEN/cfg2pov-$s.log" "bench/cfg2pov.py failed on $s"
    done
    echo "done ($(awk -v a="$(ms_since "$t0")" 'BEGIN { printf "%.0f", a / 1000 }') s)" >&2
    for s in $LARGE; do
        case $s in
        spheres10k) echo "  spheres10k: scenes/gen.py spheres $SPHERES_N: $SPHERES_N Phong spheres on a Lambert plane, 1 point + 1 directional light" ;;
        knot1m) echo "  knot1m:     scenes/mesh.cfg with scenes/gen.py knot $KNOT_SEGS $KNOT_SIDES: $KNOT_TRIS triangles (checked), Cook-Torrance gold on a Lambert plane, 2 point lights" ;;
        esac
    done

    # The converter against the hand-written files: both through POV-Ray.
    for s in diffuse phong; do
        printf '  checking bench/cfg2pov.py on %s.cfg ... ' "$s" >&2
        "$PYTHON" bench/cfg2pov.py "scenes/$s.cfg" "$GEN/$s.pov" --width "$LW" --height "$LH" \
            >"$GEN/cfg2pov-$s.log" 2>&1 || die_log "$GEN/cfg2pov-$s.log" "bench/cfg2pov.py failed on scenes/$s.cfg"
        run_povray "bench/$s.pov" "check-$s-hand" "$T1" "$LW" "$LH"
        hand=$p_out
        run_povray "$GEN/$s.pov" "check-$s-cfg2pov" "$T1" "$LW" "$LH"
        conv=$p_out
        run_rayd "scenes/$s.cfg" "check-$s" "$T1" "$LW" "$LH"
        echo "done" >&2
        echo "  cfg2pov check, scenes/$s.cfg at ${LW}x${LH}:"
        echo "    POV-Ray on bench/$s.pov vs on cfg2pov's file: $(pngdiff "$hand" "$conv")"
        echo "    rayd vs POV-Ray on cfg2pov's file:    $(pngdiff "$r_out" "$conv")"
    done
    echo

    # Every rayd and povray run here is timed under GNU time for its peak memory.
    WANT_RSS=1
    LRES=$WORK/large
    : >"$LRES"
    for s in $LARGE; do
        extra=''
        # 1,000,000 triangles + the floor plane is one over rayd's default limit.
        [ "$s" = knot1m ] && extra='--max-objects 2000000'
        for t in $THREADS; do
            printf '  running %-10s threads=%s ... ' "$s" "$t" >&2
            bw='' bother='' bprep='' brend='' bbvh='' rrss='' pw='' ppar='' pbnd='' ptr='' prss=''
            i=0
            while [ $i -lt "$RUNS" ]; do
                # shellcheck disable=SC2086
                run_rayd "$GEN/$s.cfg" "$s" "$t" "$LW" "$LH" $extra
                run_povray "$GEN/$s.pov" "$s" "$t" "$LW" "$LH"
                bw=$(min "$bw" "$r_wall")
                bother=$(min "$bother" "$(sub_ms "$r_wall" "$r_ms")")
                bprep=$(min "$bprep" "$r_prep")
                brend=$(min "$brend" "$(sub_ms "$r_ms" "$r_prep")")
                bbvh=$(min "$bbvh" "$(stat_of "$r_line" bvh_build_ms)")
                rrss=$(max "$rrss" "$r_rss")
                pw=$(min "$pw" "$p_wall")
                ppar=$(min "$ppar" "$p_parse")
                pbnd=$(min "$pbnd" "$p_bound")
                ptr=$(min "$ptr" "$p_trace")
                prss=$(max "$prss" "$p_rss")
                i=$((i + 1))
            done
            echo "done" >&2
            [ "$t" = "$T1" ] && diff1=$(pngdiff "$r_out" "$p_out")
            echo "$s $t $bw $bother $bprep $brend $(rays_of "$r_line") $pw $ppar $pbnd $ptr $p_rays" \
                "$bbvh $(stat_of "$r_line" bvh_nodes) $(stat_of "$r_line" primitives)" \
                "$(stat_of "$r_line" world_bytes) ${rrss:-nan} ${prss:-nan} $diff1" >>"$LRES"
        done
    done
    WANT_RSS=0

    echo "Large scenes: load (rayd) / parse (povray), BVH build, and rendering apart, ${LW}x${LH}:"
    awk -v runs="$RUNS" '
    function f(x, fmt) { return (x == "nan" || x == "") ? "n/a" : sprintf(fmt, x) }
    function r(a, b) { return (a == "nan" || b == "nan" || b + 0 == 0) ? "n/a" : sprintf("%.2f", a / b) }
    function m(rays, ms) { return (rays == "nan" || ms == "nan" || ms + 0 == 0) ? "nan" : rays / ms / 1000 }
    {
        n++; S[n] = $1; T[n] = $2; RW[n] = $3; RO[n] = $4; RP[n] = $5; RR[n] = $6; RN[n] = $7
        PW[n] = $8; PP[n] = $9; PB[n] = $10; PT[n] = $11; PN[n] = $12
        D[n] = ""; for (k = 19; k <= NF; k++) D[n] = D[n] " " $k
    }
    END {
        fmt = "%-10s %3s | %8s %8s %8s %9s %7s | %8s %8s %8s %9s %7s | %6s %6s\n"
        printf fmt, "", "", "rayd", "rayd", "rayd", "rayd", "rayd", \
            "povray", "povray", "povray", "povray", "povray", "ratio", "ratio"
        printf fmt, "scene", "thr", "wall ms", "load ms", "prep ms", "render ms", "Mrays/s", \
            "wall ms", "parse ms", "bound ms", "trace ms", "Mrays/s", "wall", "render"
        print "------------------------------------------------------------------------------------------------------------------"
        for (i = 1; i <= n; i++)
            printf fmt, S[i], T[i], f(RW[i], "%.1f"), f(RO[i], "%.1f"), f(RP[i], "%.1f"), \
                f(RR[i], "%.1f"), f(m(RN[i], RR[i]), "%.2f"), f(PW[i], "%.1f"), f(PP[i], "%.1f"), \
                f(PB[i], "%.1f"), f(PT[i], "%.1f"), f(m(PN[i], PT[i]), "%.2f"), \
                r(RW[i], PW[i]), r(RR[i], PT[i])
        print ""
        print "rayd: load = wall - time_ms (start, cfg + OBJ parse, PNG, exit); prep = prepare_ms"
        print "(camera, lights, BVH build); render = time_ms - prepare_ms. povray: parse = Parse"
        print "Time (reading the scene, for a mesh2 also building its own triangle tree); bound ="
        print "Bounding Time (the tree over the objects); trace = Trace Time. ratio render = rayd"
        print "render / povray trace; < 1 means rayd is faster. Mrays/s over render / trace time."
        printf "Best of %d runs, each column on its own.\n", runs
        sp = 0
        for (i = 1; i <= n; i++) {
            for (j = 1; j < i; j++) if (S[j] == S[i]) break
            if (j < i) continue
            for (k = i + 1; k <= n; k++) {
                if (S[k] != S[i]) continue
                if (!sp++) print ""
                printf "speed-up %s/%s threads, %-10s rayd %sx render;  povray %sx trace\n", \
                    T[k], T[i], S[i], r(RR[i], RR[k]), r(PT[i], PT[k])
            }
        }
        print ""
        for (i = 1; i <= n; i++) {
            if (seen[S[i]]++) continue
            printf "rays per frame, %-10s rayd %s, povray %s%s\n", S[i], RN[i], PN[i], \
                (RN[i] == PN[i]) ? " (same work)" : " (differ: see bench/README.md)"
        }
        for (i = 1; i <= n; i++) {
            if (seen2[S[i]]++) continue
            printf "images, %-10s rayd vs povray:%s%s\n", S[i], D[i], \
                (S[i] == "knot1m") ? "  (Cook-Torrance is approximated as Phong in POV-Ray)" : ""
        }
    }' "$LRES"

    # Table 3: the BVH of the 1M-triangle scene, from its first-thread-count runs.
    if grep -q "^knot1m $T1 " "$LRES"; then
        echo
        echo "BVH build of knot1m ($KNOT_TRIS triangles + 1 plane), rayd --threads $T1, best of $RUNS:"
        grep "^knot1m $T1 " "$LRES" | awk -v src="${GNU_TIME:+GNU time %M}" '
        function mib(kb) { return kb / 1024 }
        {
            bvh = $13; nodes = $14; prims = $15; bytes = $16; rss = $17; prss = $18
            printf "  bvh_build_ms     %12.1f   (prepare_ms %.1f)\n", bvh, $5
            printf "  bvh_nodes        %12d\n", nodes
            printf "  primitives       %12d\n", prims
            printf "  world_bytes      %12d   (%.1f MiB)\n", bytes, bytes / 1048576
            printf "  bytes/triangle   %12.1f   (world_bytes / primitives)\n", bytes / prims
            if (rss == "nan")
                print  "  peak RSS                  n/a   (not measured)"
            else
                printf "  peak RSS         %9d kB   (%.1f MiB, largest of the runs, %s; povray: %s)\n", \
                    rss, mib(rss), (src == "" ? "VmHWM sampled every 50 ms" : src), \
                    (prss == "nan" ? "n/a" : sprintf("%.1f MiB", mib(prss)))
        }'
    fi
fi

# ---------------------------------------------------------------------------
# Table 4: this rayd against rayd built from the foundation commit.

if [ -n "$BASE" ]; then
    echo
    echo "== Leave out what a scene does not need: this rayd vs rayd at $BASE; load average $(loadavg)"
    base_bin=''
    if ! git -C "$ROOT" rev-parse --verify --quiet "$BASE^{commit}" >/dev/null 2>&1; then
        echo "  skipped: $BASE is not a commit of $ROOT"
    else
        printf '  building rayd at %s in a git worktree ... ' "$BASE" >&2
        BASESRC=$WORK/base-src
        if git -C "$ROOT" worktree add --detach "$BASESRC" "$BASE" >"$WORK/base-build.log" 2>&1 &&
            env -u MAKEFLAGS -u MFLAGS -u MAKELEVEL make -C "$BASESRC" -j2 BUILD=build build/rayd \
                >>"$WORK/base-build.log" 2>&1 &&
            cp "$BASESRC/build/rayd" "$WORK/rayd-base"; then
            base_bin=$WORK/rayd-base
            echo "done" >&2
        else
            echo "FAILED" >&2
        fi
        git -C "$ROOT" worktree remove --force "$BASESRC" >>"$WORK/base-build.log" 2>&1 ||
            { rm -rf "$BASESRC"; git -C "$ROOT" worktree prune >/dev/null 2>&1 || true; }
        BASESRC=''
        if [ -z "$base_bin" ]; then
            echo "  skipped: building rayd at $BASE failed:"
            tail -n 10 "$WORK/base-build.log" | sed 's/^/    /'
        fi
    fi
    if [ -n "$base_bin" ]; then
        printf '  running diffuse   threads=1 (%s, this rayd) ... ' "$BASE" >&2
        cur_rayd=$RAYD
        bb_ms='' bb_w='' bc_ms='' bc_w=''
        i=0
        while [ $i -lt "$RUNS" ]; do
            RAYD=$base_bin
            run_rayd scenes/diffuse.cfg base 1 $W $H
            base_png=$r_out
            bb_ms=$(min "$bb_ms" "$r_ms")
            bb_w=$(min "$bb_w" "$r_wall")
            RAYD=$cur_rayd
            run_rayd scenes/diffuse.cfg current 1 $W $H
            cur_png=$r_out
            bc_ms=$(min "$bc_ms" "$r_ms")
            bc_w=$(min "$bc_w" "$r_wall")
            i=$((i + 1))
        done
        echo "done" >&2
        echo "scenes/diffuse.cfg, ${W}x${H}, --threads 1, best of $RUNS; render = time_ms, wall = whole process:"
        awk -v base="$BASE" -v cur="${rev:-current}" -v bm="$bb_ms" -v bw="$bb_w" -v cm="$bc_ms" -v cw="$bc_w" '
        BEGIN {
            printf "  %-30s %10s %10s\n", "", "render ms", "wall ms"
            printf "  %-30s %10.1f %10.1f\n", "rayd at " base " (foundation)", bm, bw
            printf "  %-30s %10.1f %10.1f\n", "this rayd (" cur ")", cm, cw
            printf "  %-30s %10.2f %10.2f   (this / foundation; < 1 means this rayd is faster)\n", \
                "ratio", cm / bm, cw / bw
        }'
        echo "  images, foundation vs this rayd: $(pngdiff "$base_png" "$cur_png")"
    fi
fi

# ---------------------------------------------------------------------------
# Section 5: HTTP. wrk against rayd's POST /v1/render and against bare_mhd,
# which answers the same PNG bytes with the same libmicrohttpd flags and does
# nothing else: the HTTP ceiling of this machine.

if [ "$DO_HTTP" = 1 ]; then
    HT=$WORK/http
    mkdir -p "$HT"
    echo
    echo "== HTTP: POST /v1/render of scenes/phong.cfg, wrk ${HTTP_SECS} s per run, rayd against bare libmicrohttpd; load average $(loadavg)"
    printf '  building bench/bare_mhd.c ... ' >&2
    # shellcheck disable=SC2046
    cc -O2 bench/bare_mhd.c $(pkg-config --cflags --libs libmicrohttpd) -o "$WORK/bare_mhd" \
        >"$HT/cc.log" 2>&1 || die_log "$HT/cc.log" "cannot build bench/bare_mhd.c"
    echo "done" >&2
    write_wrk_lua "$HT/post.lua"
    hmax=1
    for c in $HTTP_CONC; do [ "$c" -le "$hmax" ] || hmax=$c; done
    hq=$((hmax * 2))
    [ "$hq" -ge 64 ] || hq=64
    start_rayd "$HT/rayd.log" --queue "$hq"
    rayd_pid=$SRV_PID
    rayd_port=$SRV_PORT
    : >"$HT/results"
    for size in 64x64 640x480; do
        sw=${size%x*}
        sh_=${size#*x}
        png=$HT/phong-$size.png
        url_q="/v1/render?width=$sw&height=$sh_"
        # bare_mhd answers the PNG rayd makes for this very request.
        "$RAYD" render scenes/phong.cfg -o "$png" --width "$sw" --height "$sh_" >"$HT/render-$size.log" 2>&1 ||
            die_log "$HT/render-$size.log" "rayd render failed on scenes/phong.cfg at $size"
        hdr=$(curl -s --max-time 60 -D - -o "$HT/answer-$size.png" -H 'Content-Type: text/plain' \
            --data-binary @scenes/phong.cfg "http://127.0.0.1:$rayd_port$url_q" | tr -d '\r') || hdr=''
        cmp -s "$png" "$HT/answer-$size.png" ||
            die "rayd serve's answer to POST $url_q is not the bytes of rayd render's PNG"
        rms=$(printf '%s\n' "$hdr" | sed -n 's/^X-Rayd-Render-Ms: *//p')
        echo "  $size: $(wc -c <"$png" | tr -d ' ')-byte PNG (the same bytes from rayd serve and rayd render), rendered in ${rms:-?} ms by rayd serve"
        start_server "$HT/bare-$size.log" "$WORK/bare_mhd" "$png" "$PORT_FILE" 2
        bare_pid=$SRV_PID
        bare_port=$SRV_PORT
        for c in $HTTP_CONC; do
            printf '  running wrk %-7s -c %-3s rayd, bare_mhd ... ' "$size" "$c" >&2
            run_wrk "$HT/wrk-rayd-$size-$c.log" "$HT/post.lua" "$ROOT/scenes/phong.cfg" \
                "http://127.0.0.1:$rayd_port$url_q" "$c" "$HTTP_SECS"
            r="$w_rps $w_p50 $w_p99 $w_err"
            SRV_PORT=$rayd_port
            wait_idle
            run_wrk "$HT/wrk-bare-$size-$c.log" "$HT/post.lua" "$ROOT/scenes/phong.cfg" \
                "http://127.0.0.1:$bare_port$url_q" "$c" "$HTTP_SECS"
            echo "$size $c $r $w_rps $w_p50 $w_p99 $w_err" >>"$HT/results"
            echo "done" >&2
        done
        stop_server "$bare_pid"
        SRV_PORT=$rayd_port
    done
    stop_server "$rayd_pid"
    [ "$s_rc" = 0 ] || echo "  warning: rayd serve exited with status $s_rc on SIGTERM (expected 0)"
    echo "rayd serve --threads $cpus (default) --queue $hq against bench/bare_mhd (same MHD flags, a fixed PNG),"
    echo "wrk -t2 -cN -d${HTTP_SECS}s --latency (-t1 for N = 1), POST scenes/phong.cfg ?width=W&height=H:"
    awk '
    function f(x, fmt) { return (x == "nan" || x == "") ? "n/a" : sprintf(fmt, x) }
    BEGIN {
        fmt = "%-8s %4s | %9s %8s %8s %6s | %9s %8s %8s %6s | %9s\n"
        printf fmt, "", "", "rayd", "rayd", "rayd", "rayd", "bare", "bare", "bare", "bare", "rayd/bare"
        printf fmt, "size", "conc", "req/s", "p50 ms", "p99 ms", "failed", "req/s", "p50 ms", "p99 ms", "failed", "req/s"
        print "-------------------------------------------------------------------------------------------"
    }
    {
        printf fmt, $1, $2, f($3, "%.1f"), f($4, "%.2f"), f($5, "%.2f"), $6, \
            f($7, "%.1f"), f($8, "%.2f"), f($9, "%.2f"), $10, ($7 > 0 ? sprintf("%.3g", $3 / $7) : "n/a")
        bad += $6 + $10
    }
    END {
        print ""
        print "req/s: answers per second over the run (wrk); p50/p99: wrk latency percentiles of the"
        print "answered requests; failed: non-2xx answers, timeouts (30 s) and socket errors (should be 0)."
        print "rayd/bare: the share of the machine'"'"'s HTTP ceiling that rayd reaches. wrk, rayd and bare_mhd"
        print "share the same 2 cores. Compare rayd'"'"'s p50 at conc 1 with its render time above: the"
        print "difference is what HTTP, parsing and PNG encoding add to a request."
        if (bad) print "WARNING: some requests failed: see the wrk logs (BENCH_KEEP=1)."
    }' "$HT/results"
fi

# ---------------------------------------------------------------------------
# Section 6: overload. rayd's capacity for the 640x480 phong render (wrk,
# closed loop), then 3x that rate at a fixed arrival rate (hey) against a
# small --queue: only 200 and 503 may come back, the accepted requests keep
# a bounded latency, and memory and open files come back to where they were.

if [ "$DO_OVERLOAD" = 1 ]; then
    OV=$WORK/overload
    mkdir -p "$OV"
    OVQ=4           # rayd --queue
    OVC=32          # hey workers: each sends at rate/OVC, so a worker waits
                    # on its own request for at most 8/3 of its period (below)
    echo
    echo "== Overload: 3x capacity at a fixed arrival rate (hey -z ${OVL_SECS}s), rayd --queue $OVQ, POST scenes/phong.cfg 640x480; load average $(loadavg)"
    write_wrk_lua "$OV/post.lua"
    start_rayd "$OV/rayd.log" --queue "$OVQ"
    ov_pid=$SRV_PID
    url="http://127.0.0.1:$SRV_PORT/v1/render?width=640&height=480"
    fresh=$(rss_fds "$ov_pid")
    i=0
    while [ $i -lt 3 ]; do    # warm-up
        code=$(curl -s --max-time 60 -o /dev/null -w '%{http_code}' -H 'Content-Type: text/plain' \
            --data-binary @scenes/phong.cfg "$url") || code=000
        [ "$code" = 200 ] || die "warm-up POST $url answered $code"
        i=$((i + 1))
    done
    # Capacity: 3 clients in a closed loop keep both render threads busy and
    # stay under the queue limit (4 jobs queued or running).
    printf '  measuring capacity (wrk -c3 -d5s) ... ' >&2
    run_wrk "$OV/capacity.log" "$OV/post.lua" "$ROOT/scenes/phong.cfg" "$url" 3 5
    echo "done" >&2
    cap=$w_rps
    [ "$w_err" = 0 ] || echo "  warning: $w_err of the capacity run's requests failed (see $OV/capacity.log)"
    wait_idle
    sleep 1
    base=$(rss_fds "$ov_pid")
    rate=$(awk -v c="$cap" 'BEGIN { printf "%.1f", 3 * c }')
    q=$(awk -v r="$rate" -v c=$OVC 'BEGIN { printf "%.4f", r / c }')
    log0=$(wc -l <"$OV/rayd.log")
    printf '  running hey -z %ss -q %s -c %s (%s req/s) ... ' "$OVL_SECS" "$q" "$OVC" "$rate" >&2
    timeout -k 5 $((OVL_SECS + 60)) hey -z "${OVL_SECS}s" -q "$q" -c "$OVC" -t 30 -m POST \
        -T text/plain -D scenes/phong.cfg -o csv "$url" >"$OV/hey.csv" 2>"$OV/hey.err" &
    AUX_PID=$!
    peak_rss=${base% *}
    peak_fds=${base#* }
    while alive "$AUX_PID"; do
        now_=$(rss_fds "$ov_pid")
        peak_rss=$(max "$peak_rss" "${now_% *}")
        peak_fds=$(max "$peak_fds" "${now_#* }")
        sleep 0.2
    done
    if wait "$AUX_PID"; then hey_rc=0; else hey_rc=$?; fi
    AUX_PID=''
    t_end=$(now)
    [ "$hey_rc" = 0 ] || die_log "$OV/hey.err" "hey failed (status $hey_rc)"
    # rayd's own log, one line per request: what it answered to the load.
    served=$(tail -n +"$((log0 + 1))" "$OV/rayd.log" | awk '$2 == "POST" && $3 ~ /^\/v1\/render/ { n[$4]++; t++ }
        END { for (c in n) printf "%s:%d ", c, n[c]; printf "total:%d", t + 0 }')
    echo "done" >&2
    # After the load: the same figures 1, 2, 3 and 5 s later.
    after=''
    for t in 1 2 3 5; do
        while [ "$(awk -v a="$t_end" -v b="$(now)" -v t="$t" 'BEGIN { print (b - a >= t) }')" = 0 ]; do
            sleep 0.05
        done
        after="$after $t:$(rss_fds "$ov_pid" | tr ' ' ',')"
    done
    wait_idle
    # hey's CSV: response-time,DNS+dialup,DNS,Request-write,Response-delay,Response-read,status-code,offset
    awk -F, 'NR > 1 && NF >= 8 && $7 == 200 { print $1 * 1000 }' "$OV/hey.csv" >"$OV/lat200"
    awk -F, 'NR > 1 && NF >= 8 { print $1 * 1000 }' "$OV/hey.csv" >"$OV/latall"
    awk -F, 'NR > 1 && NF >= 8 && $7 == 503 { print $1 * 1000 }' "$OV/hey.csv" >"$OV/lat503"
    codes=$(awk -F, 'NR > 1 && NF >= 8 { n[$7]++ } END { for (c in n) printf "%s:%d ", c, n[c] }' "$OV/hey.csv" |
        tr ' ' '\n' | sort | tr '\n' ' ')
    n_all=$(wc -l <"$OV/latall" | tr -d ' ')
    odd=$(awk -F, 'NR > 1 && NF >= 8 && $7 != 200 && $7 != 503' "$OV/hey.csv" | wc -l | tr -d ' ')
    # hey's offsets: when each request started; the last one ends the run.
    sent_rate=$(awk -F, 'NR > 1 && NF >= 8 { n++; if ($8 > t) t = $8 } END { printf "%.1f", (t > 0 ? n / t : 0) }' "$OV/hey.csv")
    stop_server "$ov_pid"
    echo "capacity: $cap req/s (wrk -t2 -c3 -d5s, closed loop; rayd --threads $cpus --queue $OVQ)"
    echo "offered:  $rate req/s = 3x capacity for ${OVL_SECS} s: hey -q $q -c $OVC (hey's rate is q x c); sent and answered $n_all ($sent_rate req/s)"
    echo "status codes (hey): ${codes:-none}$([ "$odd" = 0 ] && echo '(only 200 and 503: as required)' || echo "(WARNING: $odd answers other than 200 and 503)")"
    echo "rayd's log over the run (POST /v1/render by status): $served$([ "${served##*total:}" = "$n_all" ] && echo " (= hey's count)" || echo " (hey counted $n_all answers: the difference failed client-side)")"
    [ -s "$OV/hey.err" ] && echo "hey's stderr: $(head -c 300 "$OV/hey.err" | tr '\n' ' ')"
    awk -v a="$(pct "$OV/lat200" 50)" -v b="$(pct "$OV/lat200" 99)" -v c="$(pct "$OV/latall" 50)" \
        -v d="$(pct "$OV/latall" 99)" -v e="$(pct "$OV/lat503" 50)" -v f="$(pct "$OV/lat503" 99)" '
    function f_(x) { return x == "nan" ? "n/a" : sprintf("%.1f", x) }
    BEGIN {
        printf "latency ms     %8s %8s\n", "p50", "p99"
        printf "  200 (accepted) %6s %8s\n", f_(a), f_(b)
        printf "  503 (refused)  %6s %8s\n", f_(e), f_(f)
        printf "  all            %6s %8s\n", f_(c), f_(d)
    }'
    echo "rayd's memory and open files (VmRSS kB, ls /proc/PID/fd | wc -l):"
    printf '  %-26s %10s %6s\n' "" "VmRSS kB" "fds"
    printf '  %-26s %10s %6s\n' "fresh (just started)" "${fresh% *}" "${fresh#* }"
    printf '  %-26s %10s %6s\n' "before (after warm-up)" "${base% *}" "${base#* }"
    printf '  %-26s %10s %6s\n' "peak during the load" "$peak_rss" "$peak_fds"
    ok=''
    for a in $after; do
        t=${a%%:*}
        v=${a#*:}
        printf '  %-26s %10s %6s\n' "${t} s after the load" "${v%,*}" "${v#*,}"
        # Back: same open files, resident memory within 10% (or 2 MiB) of before.
        if [ -z "$ok" ] && [ "${v#*,}" = "${base#* }" ] &&
            [ "$(awk -v r="${v%,*}" -v b="${base% *}" 'BEGIN { t = b * 0.10; if (t < 2048) t = 2048; print (r <= b + t) }')" = 1 ]; then
            ok=$t
        fi
    done
    if [ -n "$ok" ]; then
        echo "  back to the baseline ${ok} s after the load (open files equal, VmRSS within 10% or 2 MiB)"
    else
        echo "  NOT back to the baseline 5 s after the load (open files equal, VmRSS within 10% or 2 MiB)"
    fi
fi

# ---------------------------------------------------------------------------
# Section 7: a small job's latency while a large one runs. 20 sequential
# 64x64 sync renders alone, then the same while one async 640x480 job of
# scenes/area_light.cfg at 64 samples per pixel is queued before them.

if [ "$DO_MIXED" = 1 ]; then
    MX=$WORK/mixed
    mkdir -p "$MX"
    MXN=20
    echo
    echo "== Small renders behind a large job: $MXN sequential 64x64 POST /v1/render (phong.cfg), alone and after one async area_light.cfg 640x480 at 64 spp; load average $(loadavg)"
    start_rayd "$MX/rayd.log" --queue 64
    mx_pid=$SRV_PID
    base_url="http://127.0.0.1:$SRV_PORT"
    small() {  # out-file: appends "code seconds" of one 64x64 sync render
        s_out=$(curl -s --max-time 120 -o /dev/null -w '%{http_code} %{time_total}' -H 'Content-Type: text/plain' \
            --data-binary @scenes/phong.cfg "$base_url/v1/render?width=64&height=64") || s_out="000 nan"
        echo "$s_out" >>"$1"
    }
    job_field() {  # id field: a string or number field of GET /v1/jobs/ID
        curl -s --max-time 10 "$base_url/v1/jobs/$1" |
            sed -n "s/.*\"$2\":\"\{0,1\}\([^\",}]*\).*/\1/p"
    }
    printf '  running %d small renders alone ... ' $MXN >&2
    : >"$MX/warm"
    small "$MX/warm"
    small "$MX/warm"
    : >"$MX/alone"
    i=0
    while [ $i -lt $MXN ]; do small "$MX/alone"; i=$((i + 1)); done
    echo "done" >&2
    printf '  running %d small renders behind the large job ... ' $MXN >&2
    code=$(curl -s --max-time 30 -o "$MX/job.json" -w '%{http_code}' -H 'Content-Type: text/plain' \
        --data-binary @scenes/area_light.cfg "$base_url/v1/jobs?width=640&height=480&samples=64") || code=000
    [ "$code" = 202 ] || die "POST /v1/jobs of area_light.cfg answered $code: $(head -c 300 "$MX/job.json")"
    id=$(sed -n 's/.*"id":"\([^"]*\)".*/\1/p' "$MX/job.json")
    [ -n "$id" ] || die "no job id in $(head -c 300 "$MX/job.json")"
    t0=$(now)
    : >"$MX/behind"
    : >"$MX/state"
    i=0
    while [ $i -lt $MXN ]; do
        # The large job's state as each small render is sent.
        echo "$(ms_since "$t0") $(job_field "$id" status)" >>"$MX/state"
        small "$MX/behind"
        i=$((i + 1))
    done
    # The large job: until it ends (bounded), then its own times.
    i=0
    st=$(job_field "$id" status)
    while [ $i -lt 600 ]; do
        case $st in done|failed|cancelled) break ;; esac
        sleep 0.2
        i=$((i + 1))
        st=$(job_field "$id" status)
    done
    big_done=$(ms_since "$t0")
    case $st in
        done|failed|cancelled) ;;
        *) curl -s --max-time 10 -X DELETE -o /dev/null "$base_url/v1/jobs/$id" || true ;;
    esac
    big_el=$(job_field "$id" elapsed_ms)
    big_q=$(job_field "$id" queued_ms)
    echo "done" >&2
    stop_server "$mx_pid"
    for f in alone behind; do
        awk '$1 == 200 { print $2 * 1000 }' "$MX/$f" >"$MX/$f.ms"
    done
    bad=$(cat "$MX/alone" "$MX/behind" | awk '$1 != 200' | wc -l | tr -d ' ')
    overlap=$(awk '$2 == "queued" || $2 == "running" { n++ } END { print n + 0 }' "$MX/state")
    first=$(head -n 1 "$MX/behind.ms")
    awk -v n=$MXN -v a50="$(pct "$MX/alone.ms" 50)" -v a99="$(pct "$MX/alone.ms" 99)" \
        -v b50="$(pct "$MX/behind.ms" 50)" -v b99="$(pct "$MX/behind.ms" 99)" -v first="$first" '
    function f_(x) { return (x == "nan" || x == "") ? "n/a" : sprintf("%.1f", x) }
    BEGIN {
        printf "64x64 sync render, ms        %8s %8s %10s\n", "p50", "p99", "first"
        printf "  alone                      %8s %8s\n", f_(a50), f_(a99)
        printf "  behind the large job       %8s %8s %10s\n", f_(b50), f_(b99), f_(first)
        printf "(p99 of %d = the largest; curl time_total, connection to last byte)\n", n
    }'
    awk -v st="$st" -v el="$big_el" -v q="$big_q" -v seen="$big_done" 'BEGIN {
        printf "large job (area_light.cfg 640x480, 64 spp, async): %s; elapsed_ms %s, queued_ms %s; seen ended %.0f ms after it was posted\n",
            st, (el == "" ? "?" : sprintf("%.0f", el)), (q == "" ? "?" : sprintf("%.1f", q)), seen }'
    echo "small renders sent while the large job was queued or running: $overlap of $MXN"
    [ "$bad" = 0 ] || echo "WARNING: $bad small renders did not answer 200"
fi

# ---------------------------------------------------------------------------
# Section 8: convergence. `rayd converge` on the soft-shadow scene and on the
# anti-aliasing scene: estimated and true error against samples per pixel,
# with its SVG plots and CSV tables kept in BENCH_OUT.

if [ "$DO_CONVERGE" = 1 ]; then
    OUT=${BENCH_OUT:-$ROOT/build/bench-out}
    mkdir -p "$OUT" || die "cannot make $OUT"
    CV_W=160
    CV_H=120
    CV_MAX=64
    CV_REF=1024
    echo
    echo "== Convergence: rayd converge, ${CV_W}x${CV_H}, 1 to $CV_MAX samples per pixel, reference $CV_REF samples; load average $(loadavg)"
    for s in area_light phong; do
        printf '  running rayd converge scenes/%s.cfg ... ' "$s" >&2
        log=$WORK/converge-$s.log
        if ! "$RAYD" converge "scenes/$s.cfg" --width $CV_W --height $CV_H --max-samples $CV_MAX \
            --reference-samples $CV_REF --svg "$OUT/converge-$s.svg" --csv "$OUT/converge-$s.csv" \
            >"$log" 2>"$log.err"; then
            cat "$log" >>"$log.err"
            die_log "$log.err" "rayd converge failed on scenes/$s.cfg"
        fi
        echo "done" >&2
        grep '^reference' "$log.err" | sed 's/^/# /' || true
        cat "$log"
        echo
    done
    echo "estimate: rayd's own error estimate; true: RMSE against the reference (1 = 255 levels);"
    echo "est/true near 1 means the estimate can be trusted; slopes near -0.5 are plain Monte Carlo,"
    echo "steeper is stratification paying off. Plots (error against time) and tables:"
    for s in area_light phong; do
        echo "  $OUT/converge-$s.svg  $OUT/converge-$s.csv"
    done
fi

# ---------------------------------------------------------------------------
# Section 9: equal time against POV-Ray. Each renderer renders a converged
# reference of its own, then a moderate and a high quality image whose time
# and RMSE against its own reference are measured; rayd then gets POV-Ray's
# render time as --time-budget-ms, uniform and adaptive.

# One POV-Ray render at the equal-time size; sets p_wall p_trace (ms), p_cam
# (camera rays: Rays, as these scenes have no reflections) and p_shadow.
run_pov_eq() {  # pov out.png threads [antialiasing options...]
    pe_pov=$1
    pe_out=$2
    pe_t=$3
    shift 3
    pe_log=${pe_out%.png}.log
    measure "$pe_log" povray "+I$pe_pov" "+O$pe_out" +FN "+W$EW" "+H$EH" -D "$@" +Q9 "+WT$pe_t" \
        File_Gamma=1.0 -V -GR -P
    [ "$m_rc" = 0 ] || die_log "$pe_log" "povray failed on $pe_pov"
    p_wall=$m_wall
    stats=$(tr '\r' '\n' <"$pe_log")
    p_trace=$(pov_ms "$stats" 'Trace Time')
    p_cam=$(printf '%s\n' "$stats" | awk '/^Rays:/ { r = $2 } END { print r == "" ? "nan" : r }')
    p_shadow=$(printf '%s\n' "$stats" | awk '/^Shadow Ray Tests:/ { s = $4 } END { print s == "" ? 0 : s }')
}
rmse_of() {  # a.png b.png: the RMSE, 1 = 255 levels, or nan
    "$PYTHON" bench/pngdiff.py --rmse "$1" "$2" 2>/dev/null | sed -n 's/^rmse=\([^ ]*\).*/\1/p' | grep . || echo nan
}

if [ "$DO_EQUAL" = 1 ]; then
    EQ=$WORK/equal
    mkdir -p "$EQ"
    EQP=$((EW * EH))
    # POV-Ray's settings per quality: bench/cfg2pov.py's area-light options
    # (points per side, adaptive level), and antialiasing on its command line.
    pov_area() {
        case $1 in
            REF) echo "--area-size 9" ;;
            moderate) echo "--area-size 5 --area-adaptive 1" ;;
            high) echo "--area-size 9 --area-adaptive 2" ;;
            higher) echo "--area-size 9 --area-adaptive 2" ;;
        esac
    }
    pov_aa() {
        case $1 in
            REF) echo "+AM1 +A0.0 +R9 +J" ;;
            moderate) echo "+AM1 +A0.3 +R3 +J" ;;
            high) echo "+AM1 +A0.1 +R3 +J" ;;
            higher) echo "+AM1 +A0.0 +R4 +J" ;;
        esac
    }
    PV_REF_AA=$(pov_aa REF)
    RD_FIXED=4
    echo
    echo "== Equal time against POV-Ray: RMSE against each renderer's own reference, ${EW}x${EH}, $EQ_THREADS thread(s); load average $(loadavg)"
    : >"$EQ/results"
    : >"$EQ/refs"
    for s in area_light phong; do
        printf '  rendering the references of %s ... ' "$s" >&2
        # cfg2pov: one .pov per quality (only the area light's grid differs).
        for lvl in REF moderate high higher; do
            # shellcheck disable=SC2046
            "$PYTHON" bench/cfg2pov.py "scenes/$s.cfg" "$EQ/$s-$lvl.pov" --width "$EW" --height "$EH" $(pov_area $lvl) \
                >"$EQ/cfg2pov-$s-$lvl.log" 2>&1 || die_log "$EQ/cfg2pov-$s-$lvl.log" "bench/cfg2pov.py failed on scenes/$s.cfg"
        done
        run_rayd "scenes/$s.cfg" "eq-$s-ref" "$cpus" "$EW" "$EH" --samples "$EQ_REF"
        rref=$r_out
        rref_est=$(stat_of "$r_line" error_estimate)
        rref_ms=$r_ms
        # shellcheck disable=SC2086
        run_pov_eq "$EQ/$s-REF.pov" "$EQ/$s-pov-ref.png" "$cpus" $PV_REF_AA
        pref=$EQ/$s-pov-ref.png
        pref_ms=$p_trace
        pref_spp=$(awk -v r="$p_cam" -v n=$EQP 'BEGIN { printf "%.1f", r / n }')
        echo "done" >&2
        cmp_=$("$PYTHON" bench/pngdiff.py --rmse "$rref" "$pref" 2>&1) || cmp_="pngdiff failed"
        echo "$s|$rref_est|$rref_ms|$pref_ms|$pref_spp|$cmp_" >>"$EQ/refs"
        for lvl in moderate high higher; do
            printf '  running %s %s: povray x%d, rayd at its time ... ' "$s" "$lvl" "$RUNS" >&2
            aa=$(pov_aa $lvl)
            area=$(pov_area $lvl)
            pw='' pt='' i=0
            while [ $i -lt "$RUNS" ]; do
                # shellcheck disable=SC2086
                run_pov_eq "$EQ/$s-$lvl.pov" "$EQ/$s-pov-$lvl.png" "$EQ_THREADS" $aa
                pw=$(min "$pw" "$p_wall")
                pt=$(min "$pt" "$p_trace")
                i=$((i + 1))
            done
            case $s in
                area_light) pset="area_light $(echo "$area" | awk '{ n = $2; a = ($4 == "" ? "" : " adaptive " $4); print n "x" n a " jitter" }'); $aa" ;;
                *) pset=$aa ;;
            esac
            e=$(rmse_of "$EQ/$s-pov-$lvl.png" "$pref")
            echo "$s|povray|$lvl|$pset|$pw|$pt|$(awk -v r="$p_cam" -v n=$EQP 'BEGIN { printf "%.2f", r / n }')|$(awk -v r="$p_cam" -v h="$p_shadow" -v n=$EQP 'BEGIN { printf "%.1f", (r + h) / n }')|$e" >>"$EQ/results"
            budget=$(awk -v t="$pt" 'BEGIN { b = int(t + 0.5); print (b < 1 ? 1 : b) }')
            for ad in '' --adaptive; do
                # shellcheck disable=SC2086
                run_rayd "scenes/$s.cfg" "eq-$s-$lvl$ad" "$EQ_THREADS" "$EW" "$EH" --samples 65536 \
                    --time-budget-ms "$budget" $ad
                e=$(rmse_of "$r_out" "$rref")
                echo "$s|rayd|$lvl|--time-budget-ms $budget${ad:+ $ad}|$r_wall|$r_ms|$(stat_of "$r_line" samples)|$(awk -v r="$(rays_of "$r_line")" -v n=$EQP 'BEGIN { printf "%.1f", r / n }')|$e" >>"$EQ/results"
            done
            echo "done" >&2
        done
        printf '  running %s: rayd --samples %d x%d ... ' "$s" $RD_FIXED "$RUNS" >&2
        rw='' rm_='' i=0
        while [ $i -lt "$RUNS" ]; do
            run_rayd "scenes/$s.cfg" "eq-$s-fixed" "$EQ_THREADS" "$EW" "$EH" --samples $RD_FIXED
            rw=$(min "$rw" "$r_wall")
            rm_=$(min "$rm_" "$r_ms")
            i=$((i + 1))
        done
        e=$(rmse_of "$r_out" "$rref")
        echo "$s|rayd|fixed|--samples $RD_FIXED|$rw|$rm_|$RD_FIXED|$(awk -v r="$(rays_of "$r_line")" -v n=$EQP 'BEGIN { printf "%.1f", r / n }')|$e" >>"$EQ/results"
        echo "done" >&2
    done
    echo "references (each renderer's own), ${EW}x${EH}, $cpus threads:"
    awk -F'|' -v ref="$EQ_REF" -v pa="$PV_REF_AA" '{
        printf "  %-10s rayd --samples %s: %.0f ms, its own error estimate %s\n", $1, ref, $3, $2
        printf "  %-10s povray %s%s: trace %.0f ms, %s camera rays per pixel\n", "", \
            ($1 == "area_light" ? "area_light 9x9 jitter (every point), " : ""), pa, $4, $5
        printf "  %-10s rayd reference vs povray reference: %s\n", "", $6
    }' "$EQ/refs"
    echo
    echo "Equal time: povray at three qualities, rayd given povray's render time (--time-budget-ms), $EQ_THREADS thread(s) each:"
    awk -F'|' '
    function f(x, fmt) { return (x == "nan" || x == "") ? "n/a" : sprintf(fmt, x) }
    {
        n++; for (k = 1; k <= 9; k++) R[n, k] = $k
        if ($2 == "povray") P[$1, $3] = $9
    }
    END {
        fmt = "%-10s %-6s %-8s %-42s %8s %9s %7s %8s %9s %7s\n"
        printf fmt, "scene", "", "quality", "settings", "wall ms", "render ms", "spp", "rays/px", "RMSE", "/povray"
        print "-----------------------------------------------------------------------------------------------------------------------"
        for (i = 1; i <= n; i++) {
            pe = P[R[i, 1], R[i, 3]]
            ratio = (R[i, 2] == "rayd" && pe != "" && pe != "nan" && pe + 0 > 0 && R[i, 9] != "nan") ? \
                sprintf("%.2f", R[i, 9] / pe) : ""
            printf fmt, R[i, 1], R[i, 2], R[i, 3], R[i, 4], f(R[i, 5], "%.0f"), f(R[i, 6], "%.0f"), \
                f(R[i, 7], "%.2f"), f(R[i, 8], "%.1f"), f(R[i, 9], "%.5f"), ratio
        }
        print ""
        print "RMSE: against the renderer'"'"'s own reference, 1 = 255 levels. render ms: rayd time_ms, povray"
        print "Trace Time. A rayd row under a povray quality ran with --samples 65536 --time-budget-ms set"
        print "to that povray row'"'"'s render ms (its best of the runs; povray'"'"'s wall time adds its ~0.7 s"
        print "front end). spp: camera rays per pixel (rayd: samples, fractional when adaptive). rays/px:"
        print "camera + shadow rays per pixel. /povray: rayd'"'"'s RMSE over povray'"'"'s at the same time; below"
        print "1 rayd is closer to its reference. povray rows: best time of the runs; rayd budget rows: one run."
    }' "$EQ/results"
fi

echo
echo "load average at end: $(loadavg)"
