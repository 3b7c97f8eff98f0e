#!/bin/sh
# bench/run.sh: rays per second of `rayd render`, and wall time against POV-Ray 3.7
# rendering the same scenes (bench/NAME.pov), at 1920x1080 with 1 and 2 threads.
#
# Usage: sh bench/run.sh PATH/TO/rayd        (`make bench` runs sh bench/run.sh build/rayd)
#
# Each configuration (scene x threads) runs BENCH_RUNS times (default 3), rayd and
# povray taking turns, and the table shows the best (smallest time) of the runs:
# the machine is shared and noisy, and noise only ever adds time.
# Optional environment:
#   BENCH_RUNS=3            runs per configuration
#   BENCH_THREADS="1 2"     thread counts (speed-ups are against the first)
#   BENCH_SCENES="diffuse phong"   scenes/NAME.cfg with bench/NAME.pov
#   BENCH_KEEP=1            keep the rendered images and logs and print where
# Needs: POSIX sh, awk, GNU date (+%N), povray 3.7 (`sh deploy/deps.sh bench`).
set -eu

W=1920
H=1080
RUNS=${BENCH_RUNS:-3}
THREADS=${BENCH_THREADS:-1 2}
SCENES=${BENCH_SCENES:-diffuse phong}

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

# Work from the repository root, whatever the caller's directory.
ROOT=$(cd "$(dirname "$0")/.." && pwd)
cd "$ROOT"
for s in $SCENES; do
    [ -r "scenes/$s.cfg" ] || die "scenes/$s.cfg: missing"
    [ -r "bench/$s.pov" ] || die "bench/$s.pov: missing"
done

command -v povray >/dev/null 2>&1 ||
    die "povray not found: install Debian's povray (sh deploy/deps.sh bench does)"
case $(date +%N) in
    *[!0-9]*|'') die "date +%N gives no nanoseconds (GNU date needed)" ;;
esac
now() { date +%s.%N; }
ms_since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.3f", (b - a) * 1000 }'; }
is_num() { case $1 in ''|*[!0-9.eE+-]*) return 1 ;; *) return 0 ;; esac; }

# povray's I/O restrictions (/etc/povray/3.7/povray.conf) allow writing under
# /tmp, so the scratch directory is there whatever TMPDIR says.
WORK=$(mktemp -d /tmp/rayd-bench.XXXXXX)
if [ "${BENCH_KEEP:-0}" = 1 ]; then
    trap 'echo "bench: images and logs kept in $WORK" >&2' EXIT
else
    trap 'rm -rf "$WORK"' EXIT
fi
trap 'exit 130' INT
trap 'exit 143' TERM
RESULTS=$WORK/results

# One rayd run; sets r_wall r_ms r_rps r_line.
run_rayd() {  # scene threads
    out=$WORK/$1-t$2-rayd.png
    log=$WORK/$1-t$2-rayd.log
    t0=$(now)
    if ! "$RAYD" render "scenes/$1.cfg" -o "$out" --width $W --height $H --threads "$2" \
            >"$log" 2>&1; then
        die_log "$log" "rayd failed on scenes/$1.cfg with --threads $2"
    fi
    r_wall=$(ms_since "$t0")
    r_line=$(grep '^render: ' "$log" | tail -n 1) || true
    r_ms=$(printf '%s\n' "$r_line" | sed -n 's/.* time_ms=\([^ ]*\).*/\1/p')
    r_rps=$(printf '%s\n' "$r_line" | sed -n 's/.* rays_per_s=\([^ ]*\).*/\1/p')
    if ! is_num "$r_ms" || ! is_num "$r_rps"; then
        die_log "$log" "no 'render: ... time_ms=... rays_per_s=...' line from rayd on scenes/$1.cfg"
    fi
    case $r_line in
        *" threads=$2 "*) ;;
        *) echo "bench: warning: asked rayd for $2 threads, it reports: $r_line" >&2 ;;
    esac
}

# One povray run; sets p_wall p_trace p_rays (camera rays + shadow ray tests).
run_povray() {  # scene threads
    out=$WORK/$1-t$2-povray.png
    log=$WORK/$1-t$2-povray.log
    # -D no display, -A no antialiasing, +Q9 default quality (shadows on),
    # File_Gamma=1.0 as rayd's gamma 1, -V -GR: less chatter (the log is only
    # read for the statistics), -P no pause. The "cannot open the user
    # configuration file ~/.povray/3.7/povray.conf" warning is harmless.
    t0=$(now)
    if ! povray "+Ibench/$1.pov" "+O$out" +FN +W$W +H$H -D -A +Q9 "+WT$2" \
            File_Gamma=1.0 -V -GR -P >"$log" 2>&1; then
        die_log "$log" "povray failed on bench/$1.pov with +WT$2"
    fi
    p_wall=$(ms_since "$t0")
    stats=$(tr '\r' '\n' <"$log")
    p_trace=$(printf '%s\n' "$stats" |
        sed -n 's/.*Trace Time:.*(\([0-9.]*\) seconds).*/\1/p' | tail -n 1)
    p_trace=$(awk -v s="${p_trace:-x}" 'BEGIN { if (s ~ /^[0-9.]+$/) printf "%.3f", s * 1000; else print "nan" }')
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

min() { awk -v a="$1" -v b="$2" 'BEGIN { print (b + 0 < a + 0 ? b : a) }'; }
max() { awk -v a="$1" -v b="$2" 'BEGIN { print (b + 0 > a + 0 ? b : a) }'; }

cpus=$(getconf _NPROCESSORS_ONLN 2>/dev/null || echo '?')
load=$(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo '?')
pvver=$(povray --version 2>&1 | sed -n 's/^\(POV-Ray [0-9][^ ]*\).*/\1/p' | head -n 1)
echo "rayd bench: ${W}x${H}, 1 sample per pixel, best of $RUNS runs per configuration"
echo "  rayd:   $RAYD"
echo "  povray: ${pvver:-povray} ($(command -v povray)), -A -D +Q9, same scenes in bench/*.pov"
echo "  host:   $cpus CPUs, load average $load at start, $(date -u '+%Y-%m-%d %H:%M UTC')"
rev=$(git rev-parse --short HEAD 2>/dev/null) || rev=''
[ -z "$rev" ] || echo "  commit: $rev$(git diff --quiet HEAD 2>/dev/null || echo ' (with local changes)')"
for t in $THREADS; do
    [ "$cpus" = '?' ] || [ "$t" -le "$cpus" ] ||
        echo "  warning: $t threads on $cpus CPUs: the threads share cores" >&2
done
overhead=$(povray_overhead)
printf "  povray start-up + shut-down (empty scene): %.0f ms, included in its wall times\n" "$overhead"
echo

: >"$RESULTS"
for s in $SCENES; do
    for t in $THREADS; do
        printf '  running %-8s threads=%s ... ' "$s" "$t" >&2
        bw='' bms='' brps='' pw='' ptr='' prays='' line=''
        i=0
        while [ $i -lt "$RUNS" ]; do
            run_rayd "$s" "$t"
            run_povray "$s" "$t"
            bw=$(min "${bw:-$r_wall}" "$r_wall")
            bms=$(min "${bms:-$r_ms}" "$r_ms")
            brps=$(max "${brps:-$r_rps}" "$r_rps")
            pw=$(min "${pw:-$p_wall}" "$p_wall")
            if [ "$p_trace" != nan ]; then ptr=$(min "${ptr:-$p_trace}" "$p_trace"); fi
            prays=$p_rays
            line=$r_line
            i=$((i + 1))
        done
        echo "done" >&2
        rrays=$(printf '%s\n' "$line" | awk '{
            for (i = 1; i <= NF; i++) { split($i, kv, "=");
                if (kv[1] ~ /^(camera|shadow|secondary)_rays$/) n += kv[2] }
            print n + 0 }')
        echo "$s $t $bw $bms $brps $pw ${ptr:-nan} $prays $rrays" >>"$RESULTS"
    done
done

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
