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
#     foundation commit (BENCH_BASE) in a temporary git worktree.
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
# Needs: POSIX sh, awk, GNU date (+%N), povray 3.7 (`sh deploy/deps.sh bench`),
# python3 (scenes/gen.py, bench/cfg2pov.py, bench/pngdiff.py); table 4 also git,
# make and what building rayd needs (gcc, pkg-config, libpng, libcjson, zlib).
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
PYTHON=/usr/bin/python3
[ -x "$PYTHON" ] || PYTHON=$(command -v python3 2>/dev/null) || PYTHON=
if [ -n "$LARGE$BASE" ] && [ -z "$PYTHON" ]; then
    die "python3 not found (needed by scenes/gen.py and bench/*.py; BENCH_LARGE= BENCH_BASE= skip them)"
fi
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
cleanup() {
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

cpus=$(getconf _NPROCESSORS_ONLN 2>/dev/null || echo '?')
pvver=$(povray --version 2>&1 | sed -n 's/^\(POV-Ray [0-9][^ ]*\).*/\1/p' | head -n 1)
echo "rayd bench: ${W}x${H}, 1 sample per pixel, best of $RUNS runs per configuration"
echo "  rayd:   $RAYD"
echo "  povray: ${pvver:-povray} ($(command -v povray)), -A -D +Q9, same scenes in bench/*.pov"
echo "  host:   $cpus CPUs, load average $(loadavg) at start, $(date -u '+%Y-%m-%d %H:%M UTC')"
rev=$(git rev-parse --short HEAD 2>/dev/null) || rev=''
[ -z "$rev" ] || echo "  commit: $rev$(git diff --quiet HEAD 2>/dev/null || echo ' (with local changes)')"
for t in $THREADS; do
    [ "$cpus" = '?' ] || [ "$t" -le "$cpus" ] ||
        echo "  warning: $t threads on $cpus CPUs: the threads share cores" >&2
done
overhead=$(povray_overhead)
printf "  povray start-up + shut-down (empty scene): %.0f ms, included in its wall times\n" "$overhead"
echo

# ---------------------------------------------------------------------------
# Table 1: the assignment scenes at 1920x1080 against bench/NAME.pov.

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

echo
echo "load average at end: $(loadavg)"
