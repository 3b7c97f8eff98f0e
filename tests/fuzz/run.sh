#!/bin/sh
# Coverage-guided fuzzing of the scene readers with libFuzzer.
#
#   sh tests/fuzz/run.sh SECONDS [target...]      (from the repository root)
#
# Targets: cfg (tests/fuzz/fuzz_cfg.c) and json (tests/fuzz/fuzz_json.c);
# all of them when none is named. For each target, in turn (the machine has
# two cores and each libFuzzer process uses one), it
#   1. builds build/fuzz/fuzz_TARGET with clang, libFuzzer, ASan and UBSan,
#   2. replays every file in tests/fuzz/regressions/TARGET/ once: these are
#      inputs that once crashed, and any of them crashing again fails the run,
#   3. fuzzes for SECONDS, starting from build/fuzz/corpus/TARGET/ (kept
#      between runs, so coverage accumulates) seeded with scenes/*.TARGET and
#      the regressions that pass, with the dictionary tests/fuzz/TARGET.dict.
# stdout gets one line per target, "fuzz TARGET: N execs, M crashes" (M
# counts failing regressions and this run's crash, hang, leak or OOM; libFuzzer
# stops at the first), and a last line "fuzz: P passed, F failed"; details
# (coverage, the crash input, the stack, the log) go to stderr. The exit
# status is 0 only when every target ran clean, 1 when one crashed, 2 on a
# usage or build error.
#
# A crash leaves its input in build/fuzz/artifacts/TARGET/; reproduce it with
#   build/fuzz/fuzz_TARGET FILE
# and, once understood, copy it to tests/fuzz/regressions/TARGET/ so that
# every later run checks it.
#
# Flag lists ($LIB_FLAGS, $PKGS, ...) are split on white space on purpose.
# shellcheck disable=SC2086
set -u

usage() {
    echo "usage: sh tests/fuzz/run.sh SECONDS [cfg|json ...]" >&2
    exit 2
}
die() {
    echo "fuzz: $*" >&2
    exit 2
}

ALL_TARGETS="cfg json"

[ $# -ge 1 ] || usage
SECS=$1
shift
case $SECS in
'' | *[!0-9]*) usage ;;
esac
[ "$SECS" -gt 0 ] || usage
TARGETS=${*:-$ALL_TARGETS}
for t in $TARGETS; do
    case " $ALL_TARGETS " in
    *" $t "*) ;;
    *) die "unknown target '$t' (targets: $ALL_TARGETS)" ;;
    esac
done

# Paths below are relative to the repository root, as in the Makefile.
if [ ! -f api/cfg_parse.h ] || [ ! -f tests/fuzz/fuzz_cfg.c ]; then
    die "run me from the repository root: sh tests/fuzz/run.sh SECONDS"
fi

CC=clang
command -v "$CC" >/dev/null 2>&1 || die "clang not found (apt-get install clang libclang-rt-14-dev)"
PKGS="libpng libcjson zlib"
# The library headers come with the project's other build dependencies;
# deploy/deps.sh installs them as `make` would, and is quiet when they exist.
if ! pkg-config --exists $PKGS 2>/dev/null; then
    sh deploy/deps.sh || die "could not install the build dependencies (deploy/deps.sh)"
    pkg-config --exists $PKGS || die "pkg-config cannot find $PKGS"
fi

OUT=build/fuzz
OBJ=$OUT/obj
LOGS=$OUT/logs
mkdir -p "$OBJ" "$LOGS" || die "cannot create $OUT"

# The project's flags (Makefile) with -g -O1 and frame pointers for readable
# stacks. The library is compiled with fuzzer-no-link: coverage
# instrumentation without libFuzzer's main(), which only the targets link.
# -fno-sanitize-recover=all turns UBSan reports into crashes libFuzzer saves.
STD="-std=c11 -D_DEFAULT_SOURCE -D_POSIX_C_SOURCE=200809L -Icore -Iapi -Wall -Wextra -Werror"
PKG_CFLAGS=$(pkg-config --cflags $PKGS)
PKG_LIBS="$(pkg-config --libs $PKGS) -lm -lpthread"
COMMON="$STD $PKG_CFLAGS -g -O1 -fno-omit-frame-pointer -fno-sanitize-recover=all"
LIB_FLAGS="$COMMON -fsanitize=fuzzer-no-link,address,undefined"
TGT_FLAGS="$COMMON -fsanitize=fuzzer,address,undefined"

# Fail early and clearly when libFuzzer's runtime is missing, rather than in
# the middle of linking.
probe=$OUT/probe
printf '#include <stddef.h>\n#include <stdint.h>\nint LLVMFuzzerTestOneInput(const uint8_t *d, size_t n);\nint LLVMFuzzerTestOneInput(const uint8_t *d, size_t n) { (void)d; (void)n; return 0; }\n' >"$probe.c"
"$CC" -fsanitize=fuzzer,address,undefined "$probe.c" -o "$probe" >"$probe.log" 2>&1 ||
    die "clang cannot link -fsanitize=fuzzer (is libclang-rt-14-dev installed?): $(head -n 3 "$probe.log")"

# Objects are rebuilt when the flags change, their source changed, or any
# header in core/ or api/ changed: coarser than real dependencies, but plain
# sh and never stale.
stamp=$OBJ/flags
if [ "$(cat "$stamp" 2>/dev/null)" != "$CC $LIB_FLAGS | $TGT_FLAGS" ]; then
    rm -rf "$OBJ"
    mkdir -p "$OBJ"
    echo "$CC $LIB_FLAGS | $TGT_FLAGS" >"$stamp"
fi
stale() { # obj src [more headers...]
    [ ! -f "$1" ] || [ -n "$(find "$2" core/*.h api/*.h ${3:-} -newer "$1" 2>/dev/null | head -n 1)" ]
}

# Two compilers at a time: the machine has two cores.
pids=""
build_failed=0
reap() {
    for p in $pids; do
        wait "$p" || build_failed=1
    done
    pids=""
}
compile() { # src obj flags...
    c_src=$1 c_obj=$2
    shift 2
    mkdir -p "$(dirname "$c_obj")"
    "$CC" "$@" -c "$c_src" -o "$c_obj" &
    pids="$pids $!"
    [ "$(echo $pids | wc -w)" -lt 2 ] || reap
}

LIB_OBJS=""
for src in core/*.c api/*.c; do
    obj=$OBJ/${src%.c}.o
    LIB_OBJS="$LIB_OBJS $obj"
    if stale "$obj" "$src"; then
        compile "$src" "$obj" $LIB_FLAGS
    fi
done
for src in tests/fuzz/*.c; do
    obj=$OBJ/${src%.c}.o
    if stale "$obj" "$src" "tests/fuzz/*.h"; then
        compile "$src" "$obj" $TGT_FLAGS
    fi
done
reap
[ "$build_failed" -eq 0 ] || die "build failed (see the compiler messages above)"
for t in $TARGETS; do
    "$CC" $TGT_FLAGS -o "$OUT/fuzz_$t" "$OBJ/tests/fuzz/fuzz_$t.o" "$OBJ/tests/fuzz/fuzz_check.o" \
        $LIB_OBJS $PKG_LIBS || die "linking $OUT/fuzz_$t failed"
done

# Stacks for UBSan reports too (ASan prints them by default); keep whatever
# the caller set as well.
UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
export UBSAN_OPTIONS

# The same limits for replaying and fuzzing: a regression that only hangs
# must fail the same way it was found.
LIMITS="-timeout=10 -rss_limit_mb=2048 -max_len=65536"

# Where in a log the crash is: the sanitizer's summary and the first frames
# in this repository's code (clang records absolute source paths), which
# skips the libc, sanitizer and libFuzzer frames around them.
show_crash() { # log
    grep -E '^(==[0-9]+==ERROR|SUMMARY|fuzz property failed|.*runtime error)' "$1" | head -n 4 >&2
    grep -E '^ +#[0-9]+ ' "$1" | grep -F " $PWD/" | head -n 8 >&2
}

passed=0
failed=0
for t in $TARGETS; do
    bin=$OUT/fuzz_$t
    corpus=$OUT/corpus/$t
    artifacts=$OUT/artifacts/$t
    regress=tests/fuzz/regressions/$t
    log=$LOGS/$t.log
    mkdir -p "$corpus" "$artifacts"
    crashes=0

    # 1. Regressions, one process each so that every failing file is named.
    # Only those that pass go into the corpus: libFuzzer stops at the first
    # crash while loading its corpus, which would hide everything else.
    for f in "$regress"/*; do
        [ -f "$f" ] || continue
        rlog=$LOGS/$t-regression-$(basename "$f").log
        if "$bin" $LIMITS "$f" >"$rlog" 2>&1; then
            cp "$f" "$corpus/regression-$(basename "$f")"
        else
            crashes=$((crashes + 1))
            echo "fuzz $t: regression $f fails (log: $rlog)" >&2
            show_crash "$rlog"
        fi
    done

    # 2. Seeds: the example scenes are small, valid and cover every
    # material, which is where most of the parser's paths start.
    for f in scenes/*."$t"; do
        [ -f "$f" ] && cp "$f" "$corpus/seed-$(basename "$f")"
    done

    # 3. Fuzzing. Artifacts newer than the stamp are this run's crashes.
    dict=tests/fuzz/$t.dict
    dict_arg=""
    [ -f "$dict" ] && dict_arg="-dict=$dict"
    : >"$artifacts/.stamp"
    "$bin" $LIMITS -max_total_time="$SECS" $dict_arg -print_final_stats=1 \
        -artifact_prefix="$artifacts/" "$corpus" >"$log" 2>&1
    status=$?
    found=$(find "$artifacts" -type f ! -name .stamp -newer "$artifacts/.stamp" | wc -l)
    # A non-zero exit without an artifact (say, libFuzzer itself failing)
    # still counts: nothing may pass unnoticed.
    [ "$status" -ne 0 ] && [ "$found" -eq 0 ] && found=1
    crashes=$((crashes + found))

    execs=$(sed -n 's/^stat::number_of_executed_units: *\([0-9]*\).*/\1/p' "$log" | tail -n 1)
    [ -n "$execs" ] || execs=$(sed -n 's/^#\([0-9][0-9]*\).*/\1/p' "$log" | tail -n 1)
    [ -n "$execs" ] || execs=0
    cov=$(grep -E '^#[0-9]+.*cov: ' "$log" | tail -n 1 | sed 's/.*\(cov: [0-9]* ft: [0-9]* corp: [^ ]*\).*/\1/')
    echo "fuzz $t: ${cov:-no coverage reported}; log: $log" >&2
    if [ "$found" -gt 0 ]; then
        echo "fuzz $t: fuzzing crashed (exit $status); input:" >&2
        find "$artifacts" -type f ! -name .stamp -newer "$artifacts/.stamp" >&2
        show_crash "$log"
    fi

    echo "fuzz $t: $execs execs, $crashes crashes"
    if [ "$crashes" -eq 0 ]; then
        passed=$((passed + 1))
    else
        failed=$((failed + 1))
    fi
done

echo "fuzz: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
