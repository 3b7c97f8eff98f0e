#!/bin/sh
# Coverage-guided fuzzing of every reader of untrusted bytes with libFuzzer.
#
#   sh tests/fuzz/run.sh SECONDS [target...]      (from the repository root)
#
# Targets (tests/fuzz/fuzz_TARGET.c; all of them when none is named):
#   cfg, json    the scene readers
#   obj          the OBJ mesh reader, alone and through a scene's [mesh]
#   png          the PNG decoder and the grade upload decoder
#   grade_file   the .grade assignment file reader
#   roster       the roster reader (--roster's CSV)
#   form         POST /v1/grade multipart forms, through the real daemon
#   query        POST /v1/render query parameters, through the real daemon
#   archive      the upload archive reader (zip, tar, tar.gz)
#   frames       the code grader's reading of its sandbox's frames and the
#                compiler's messages
#   walk         the ray walks against their definition (tests/oracles/)
# SECONDS is per target. For each target, in turn (the machine has two
# cores and each libFuzzer process uses one), it
#   1. builds build/fuzz/fuzz_TARGET with clang, libFuzzer, ASan and UBSan
#      (form and query also link the daemon's objects and libmicrohttpd),
#   2. replays every file in tests/fuzz/regressions/TARGET/ once: these are
#      inputs that once crashed, and any of them crashing again fails the run,
#   3. fuzzes for SECONDS, starting from build/fuzz/corpus/TARGET/ (kept
#      between runs, so coverage accumulates) seeded with
#      tests/fuzz/seeds/TARGET/*, scenes/*.TARGET and the regressions that
#      pass, with the dictionary tests/fuzz/TARGET.dict when there is one.
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
    echo "usage: sh tests/fuzz/run.sh SECONDS [$(echo $ALL_TARGETS | sed 's/ /|/g') ...]" >&2
    exit 2
}
die() {
    echo "fuzz: $*" >&2
    exit 2
}

ALL_TARGETS="cfg json obj png grade_file roster form query archive frames walk"
# The targets that run the daemon in-process.
HTTP_TARGETS="form query"
# The targets that take some of the daemon's objects: the code grader's.
CODE_TARGETS="frames"

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
if [ ! -f api/scene/cfg_parse.h ] || [ ! -f tests/fuzz/fuzz_cfg.c ]; then
    die "run me from the repository root: sh tests/fuzz/run.sh SECONDS"
fi

CC=clang
command -v "$CC" >/dev/null 2>&1 || die "clang not found (apt-get install clang libclang-rt-14-dev)"
need_daemon=0
for t in $TARGETS; do
    case " $HTTP_TARGETS $CODE_TARGETS " in
    *" $t "*) need_daemon=1 ;;
    esac
done
# The Makefile's own package list: one place says what rayd links.
PKGS=$(make --no-print-directory -s print-pkgs) || die "make print-pkgs failed"
# The library headers come with the project's other build dependencies;
# deploy/deps.sh installs them as `make` would, and is quiet when they exist.
if ! pkg-config --exists $PKGS 2>/dev/null; then
    sh deploy/deps.sh || die "could not install the build dependencies (deploy/deps.sh)"
    pkg-config --exists $PKGS || die "pkg-config cannot find $PKGS"
fi

OUT=${FUZZ_OUT:-build/fuzz}
OBJ=$OUT/obj
LOGS=$OUT/logs
mkdir -p "$OBJ" "$LOGS" || die "cannot create $OUT"

# The project's flags (Makefile) with -g -O1 and frame pointers for readable
# stacks. The library is compiled with fuzzer-no-link: coverage
# instrumentation without libFuzzer's main(), which only the targets link.
# -fno-sanitize-recover=all turns UBSan reports into crashes libFuzzer saves.
# Every folder's include path at once, from the Makefile (the main build
# checks the layering; this one only compiles).
INCLUDES=$(make --no-print-directory -s print-includes) || die "make print-includes failed"
# -ffp-contract=off as in the Makefile: clang would fuse a*b+c in the
# functions compiled for AVX-512 (FMA) and change the bits a walk returns.
STD="-std=c11 -ffp-contract=off -D_DEFAULT_SOURCE -D_POSIX_C_SOURCE=200809L $INCLUDES -Wall -Wextra -Werror"
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
# header under core/ or api/ changed: coarser than real dependencies, but
# plain sh and never stale.
LIB_HEADERS=$(find core api -name '*.h')
DAEMON_HEADERS=$(find daemon -name '*.h')
stamp=$OBJ/flags
if [ "$(cat "$stamp" 2>/dev/null)" != "$CC $LIB_FLAGS | $TGT_FLAGS" ]; then
    rm -rf "$OBJ"
    mkdir -p "$OBJ"
    echo "$CC $LIB_FLAGS | $TGT_FLAGS" >"$stamp"
fi
stale() { # obj src [more headers...]
    [ ! -f "$1" ] || [ -n "$(find "$2" $LIB_HEADERS ${3:-} -newer "$1" 2>/dev/null | head -n 1)" ]
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
for src in $(find core api -name '*.c' | sort); do
    obj=$OBJ/${src%.c}.o
    LIB_OBJS="$LIB_OBJS $obj"
    if stale "$obj" "$src"; then
        compile "$src" "$obj" $LIB_FLAGS
    fi
done
# The daemon without its main(), and the web page it serves (generated as
# the Makefile does), only for the targets that start it.
DAEMON_OBJS=""
if [ "$need_daemon" -eq 1 ]; then
    # Not the sandbox's evaluator either: a program of its own, with its main().
    for src in $(find daemon -name '*.c' -not -path 'daemon/codegrade/eval/*' | sort); do
        [ "$src" = daemon/main.c ] && continue
        obj=$OBJ/${src%.c}.o
        DAEMON_OBJS="$DAEMON_OBJS $obj"
        if stale "$obj" "$src" "$DAEMON_HEADERS"; then
            compile "$src" "$obj" $LIB_FLAGS
        fi
    done
    # The embedded files (the web page, the OpenAPI document) are generated
    # by the Makefile's own rules, into this build's folder.
    for gen in web_page openapi migrations; do
        make --no-print-directory -s BUILD="$OBJ" "$OBJ/gen/$gen.c" || die "could not generate $OBJ/gen/$gen.c"
        if stale "$OBJ/gen/$gen.o" "$OBJ/gen/$gen.c" ""; then
            compile "$OBJ/gen/$gen.c" "$OBJ/gen/$gen.o" $LIB_FLAGS
        fi
        DAEMON_OBJS="$DAEMON_OBJS $OBJ/gen/$gen.o"
    done
fi
for src in tests/fuzz/*.c tests/oracles/walk_oracle.c; do
    obj=$OBJ/${src%.c}.o
    if stale "$obj" "$src" "tests/fuzz/*.h $DAEMON_HEADERS"; then
        compile "$src" "$obj" $TGT_FLAGS
    fi
done
reap
[ "$build_failed" -eq 0 ] || die "build failed (see the compiler messages above)"
for t in $TARGETS; do
    extra=""
    case " $HTTP_TARGETS " in
    *" $t "*) extra="$OBJ/tests/fuzz/fuzz_http.o $DAEMON_OBJS" ;;
    esac
    case " $CODE_TARGETS " in
    *" $t "*) extra="$OBJ/daemon/codegrade/code_read.o $OBJ/daemon/codegrade/code_diag.o" ;;
    esac
    [ "$t" = walk ] && extra="$OBJ/tests/oracles/walk_oracle.o"
    "$CC" $TGT_FLAGS -o "$OUT/fuzz_$t" "$OBJ/tests/fuzz/fuzz_$t.o" "$OBJ/tests/fuzz/fuzz_check.o" $extra \
        $LIB_OBJS $PKG_LIBS || die "linking $OUT/fuzz_$t failed"
done

# Stacks for UBSan reports too (ASan prints them by default); keep whatever
# the caller set as well.
UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
export UBSAN_OPTIONS

# The same limits for replaying and fuzzing: a regression that only hangs
# must fail the same way it was found.
limits() { # target
    case $1 in
    # Decoding is bounded by the pixel limit (1 Mpx in the harness, a few
    # MB); one allocation above 256 MB is an allocation bomb, a crash.
    png) echo "-timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=256 -max_len=65536" ;;
    # Reading is bounded by the harness's byte limits (4 MB in all); one
    # allocation above 256 MB, the reader's or libarchive's, is a bomb.
    archive) echo "-timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=256 -max_len=65536" ;;
    # The harness aborts after 8 s without an answer, before libFuzzer's
    # own timeout. No per-input leak check: the daemon keeps memory between
    # requests (caches, kept jobs) and its threads allocate while an input
    # runs, so libFuzzer would turn the check off after the first input.
    form) echo "-timeout=20 -rss_limit_mb=2048 -max_len=65536 -detect_leaks=0" ;;
    # A query string of a few KB already holds hundreds of parameters.
    query) echo "-timeout=20 -rss_limit_mb=2048 -max_len=4096 -detect_leaks=0" ;;
    *) echo "-timeout=10 -rss_limit_mb=2048 -max_len=65536" ;;
    esac
}

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
    LIMITS=$(limits "$t")
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

    # 2. Seeds: small valid inputs (and a few known-bad ones) that reach
    # each reader's main paths; for the scene formats also the example
    # scenes, which cover every material.
    for f in tests/fuzz/seeds/"$t"/* scenes/*."$t"; do
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
