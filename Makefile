# rayd: `make` builds build/rayd; `make test` runs every suite; `make run`
# starts the service; `make bench` measures. Each installs what it needs.

CC      ?= gcc
ifeq ($(origin CC),default)
CC := gcc
endif
BUILD   ?= build
SAN     ?=
PKGS    := libpng libcjson zlib libmicrohttpd OpenEXR sqlite3 libpq libarchive libseccomp
TESTPKG := criterion libcurl

SANFLAGS := -fsanitize=address,undefined
OPT      := -O2
LDFLAGS  :=
ifneq ($(SAN),)
OPT      := -O1 $(SANFLAGS) -fno-omit-frame-pointer -fno-sanitize-recover=all
LDFLAGS  := $(SANFLAGS)
endif
# The renderer's identity for cached grading references: any change to
# core/ makes new references.
CORE_FILES := $(sort $(shell find core -name '*.[ch]'))
CORE_HASH := $(shell cat $(CORE_FILES) 2>/dev/null | sha1sum | cut -c1-12)
CPPFLAGS := -D_DEFAULT_SOURCE -D_POSIX_C_SOURCE=200809L
# -ffp-contract=off: a*b+c is never fused into one rounding. clang fuses by
# default where the target has FMA (AVX-512 code), and the same arithmetic
# must give the same bits in every function, under gcc and clang alike
# (a packet's rays against the same rays alone, core/geometry/packet.c).
CFLAGS   := -std=c11 -ffp-contract=off -Wall -Wextra -Werror -Wshadow -Wstrict-prototypes -g $(OPT) -MMD -MP
PKG_CFLAGS = $(shell pkg-config --cflags $(PKGS))
PKG_LIBS   = $(shell pkg-config --libs $(PKGS)) -lm -lpthread

# What each folder may include (the README's map): its own headers, the
# public core/include/rayd/ ones and those of the folders below it. A
# folder's include path is exactly that, so an upward include does not
# compile.
INC_core_base     := -Icore/include
INC_core_geometry := $(INC_core_base) -Icore/geometry
INC_core_shading  := $(INC_core_geometry) -Icore/shading
INC_core_render   := $(INC_core_shading) -Icore/render
INC_api_util      := -Icore/include -Iapi/util
INC_api_image     := $(INC_api_util) -Iapi/image
INC_api_scene     := $(INC_api_util) -Iapi/scene
INC_api_assets    := $(INC_api_scene) -Iapi/image -Iapi/assets
INC_api_grading   := $(INC_api_assets) -Iapi/grading
# -iquote: its archive.h is "archive.h", and <archive.h> stays libarchive's.
INC_api_archive   := $(INC_api_util) -iquote api/archive
INC_daemon_errors := $(INC_api_grading) -Idaemon/errors
INC_daemon_store  := $(INC_api_util) -Idaemon/store
INC_daemon_jobs   := $(INC_api_grading) -Idaemon/jobs
INC_daemon_log    := $(INC_api_util) -Idaemon/log
INC_daemon_sandbox := $(INC_api_util) -Idaemon/sandbox
INC_daemon_codegrade := $(INC_api_grading) -Idaemon/sandbox -Idaemon/codegrade -Idaemon/codegrade/course
INC_daemon_farm   := $(INC_daemon_jobs) -Idaemon/store -Idaemon/errors -Idaemon/log -Idaemon/farm
INC_daemon_grading := $(INC_daemon_jobs) -Idaemon/store -Idaemon/errors -Idaemon/log -Idaemon/sandbox \
                      -Idaemon/codegrade -Idaemon/codegrade/course -Idaemon/grading
INC_daemon_http   := $(INC_daemon_farm) -iquote api/archive -Idaemon/sandbox -Idaemon/codegrade \
                     -Idaemon/codegrade/course -Idaemon/grading -Idaemon/http
INC_daemon_cli    := $(INC_daemon_http) -Idaemon/cli
INC_daemon        := $(INC_daemon_cli)
# Tests are white-box: every folder, and tests/ for support/ and oracles/.
INC_ALL           := $(INC_core_render) $(filter-out -Icore/include,$(INC_daemon)) -iquote api/archive -Itests
inc_for = $(if $(filter tests/% bench/%,$1),$(INC_ALL),$(INC_$(subst /,_,$(patsubst %/,%,$(dir $1)))))

CORE_SRC   := $(sort $(wildcard core/*/*.c))
API_SRC    := $(sort $(wildcard api/*/*.c))
DAEMON_SRC := $(sort $(wildcard daemon/*.c daemon/*/*.c))
# tests/support/unit_filter.c is a program of its own (build/unit-filter).
TEST_SRC   := $(sort $(filter-out tests/support/unit_filter.c,$(wildcard tests/unit/*/*.c tests/integration/*.c \
                  tests/calibration/*.c tests/oracles/*.c tests/support/*.c tests/stability/test_stability.c))) \
              tests/stability/cases.c

LIB_OBJ    := $(patsubst %.c,$(BUILD)/%.o,$(CORE_SRC) $(API_SRC))
DAEMON_OBJ := $(patsubst %.c,$(BUILD)/%.o,$(DAEMON_SRC)) $(BUILD)/gen/web_page.o $(BUILD)/gen/openapi.o \
              $(BUILD)/gen/migrations.o
TEST_OBJ   := $(patsubst %.c,$(BUILD)/%.o,$(TEST_SRC))
# The job queue's objects: tests/unit/daemon drives it without HTTP.
JOBS_OBJ   := $(patsubst %.c,$(BUILD)/%.o,$(wildcard daemon/jobs/*.c))
# The job store's, with its migrations: tests/unit/daemon drives it too.
STORE_OBJ  := $(patsubst %.c,$(BUILD)/%.o,$(wildcard daemon/store/*.c)) $(BUILD)/gen/migrations.o
# The sandbox's and the code grader's: tests/unit/daemon runs programs in
# the one and reads compiler messages with the other.
SANDBOX_OBJ := $(patsubst %.c,$(BUILD)/%.o,$(wildcard daemon/sandbox/*.c) $(wildcard daemon/codegrade/*.c))
# The error map: tests/unit/daemon checks every code's answer.
ERRORS_OBJ := $(patsubst %.c,$(BUILD)/%.o,$(wildcard daemon/errors/*.c))

# The first rule: `make` alone builds build/rayd.
all: deps
	@$(MAKE) --no-print-directory $(BUILD)/rayd

# Large inputs are generated, not kept in git.
GENERATED := scenes/generated/knot.obj

scenes: $(GENERATED)

# The OpenAPI linters over docs/openapi.json (tests/openapi-lint/run.sh).
openapi-lint: deps
	@sh tests/openapi-lint/run.sh

.PHONY: openapi-lint all deps test check run install uninstall install-test bench bench-quick clean scenes fuzz stability tsan fault print-includes print-pkgs format-check farm


scenes/generated/knot.obj: scenes/gen.py
	@mkdir -p scenes/generated
	/usr/bin/python3 scenes/gen.py knot $@ 800 64


deps:
	@sh deploy/deps.sh

$(BUILD)/%.o: %.c
	@mkdir -p $(dir $@)
	@echo "  CC  $<  ($(CC)$(if $(SAN), +sanitizers))"
	@$(CC) $(CPPFLAGS) $(call inc_for,$<) $(PKG_CFLAGS) $(CFLAGS) -c $< -o $@

# The web page is served from the binary: no files, no CDN.
$(BUILD)/gen/web_page.c: daemon/http/web/index.html daemon/embed.py
	@mkdir -p $(dir $@)
	@/usr/bin/python3 daemon/embed.py $< rd_web_index_html > $@

$(BUILD)/gen/web_page.o: $(BUILD)/gen/web_page.c
	@$(CC) $(CFLAGS) -c $< -o $@

# So is the OpenAPI description (GET /openapi.json).
$(BUILD)/gen/openapi.c: docs/openapi.json daemon/embed.py
	@mkdir -p $(dir $@)
	@/usr/bin/python3 daemon/embed.py $< rd_openapi_json > $@

$(BUILD)/gen/openapi.o: $(BUILD)/gen/openapi.c
	@$(CC) $(CFLAGS) -c $< -o $@

# And the store's schema: deploy/sql/NNN_*.sql, applied in order at open.
MIGRATIONS := $(sort $(wildcard deploy/sql/*.sql))
$(BUILD)/gen/migrations.c: $(MIGRATIONS) daemon/store/embed_sql.py daemon/embed.py
	@mkdir -p $(dir $@)
	@/usr/bin/python3 daemon/store/embed_sql.py $(MIGRATIONS) > $@

$(BUILD)/gen/migrations.o: $(BUILD)/gen/migrations.c daemon/store/migrations.h
	@$(CC) $(INC_daemon_store) $(CFLAGS) -c $< -o $@

# The version: a release tarball's VERSION file, else `git describe` of a
# v* tag, else (a clone without tags) the release below and the commit. The
# stamp changes only with the string, so a new commit rebuilds one object.
RELEASE := 0.1.0
VERSION := $(shell cat VERSION 2>/dev/null || git describe --tags --match 'v[0-9]*' --dirty 2>/dev/null || \
	{ h=$$(git rev-parse --short HEAD 2>/dev/null) && echo "$(RELEASE)-g$$h"; } || echo $(RELEASE))
VERSION := $(patsubst v%,%,$(VERSION))
$(BUILD)/gen/version.stamp: FORCE
	@mkdir -p $(dir $@)
	@echo '$(VERSION)' | cmp -s - $@ || echo '$(VERSION)' > $@
FORCE:

$(BUILD)/api/util/version.o: CPPFLAGS += -DRD_VERSION=\"$(VERSION)\" -DRD_DATA_DIR=\"$(CURDIR)\" \
    -DRD_COURSE_DIR=\"$(CURDIR)/daemon/codegrade/course\" -DRD_EVAL_PATH=\"$(abspath $(BUILD))/rayd-eval\"
$(BUILD)/api/util/version.o: $(BUILD)/gen/version.stamp

$(BUILD)/api/grading/reference.o: CPPFLAGS += -DRD_CORE_HASH=\"$(CORE_HASH)\"
$(BUILD)/api/grading/reference.o: $(CORE_FILES)

$(BUILD)/librayd.a: $(LIB_OBJ)
	@rm -f $@
	@ar rcs $@ $^

# The code grader's evaluator runs in the sandbox under its limits
# (RLIMIT_AS among them), so it is built without sanitizers whatever SAN
# says: their shadow memory would not fit. It takes only the frames'
# header and libc.
EVAL_SRC := daemon/codegrade/eval/eval.c
EVAL_CFLAGS := $(filter-out -MMD -MP $(OPT),$(CFLAGS)) -O2
$(BUILD)/rayd-eval: $(EVAL_SRC) daemon/codegrade/code_frames.h daemon/codegrade/course/rayd_code.h
	@mkdir -p $(dir $@)
	@echo "  CC  $<  ($(CC))"
	@$(CC) $(CPPFLAGS) -Idaemon/codegrade -Idaemon/codegrade/course $(EVAL_CFLAGS) $< -o $@ -ldl

# The systemd unit's namespace and system-call restrictions for one
# program, on machines where PID 1 is not systemd (tests/integration/
# install_test.sh runs `rayd grade --code` under the shipped unit's).
$(BUILD)/unit-filter: tests/support/unit_filter.c
	@mkdir -p $(dir $@)
	@echo "  CC  $<  ($(CC))"
	@$(CC) $(CPPFLAGS) $(EVAL_CFLAGS) $(shell pkg-config --cflags libseccomp) $< -o $@ \
	    $(shell pkg-config --libs libseccomp)

$(BUILD)/rayd: $(DAEMON_OBJ) $(BUILD)/librayd.a $(BUILD)/rayd-eval
	@echo "  LD  $@"
	@$(CC) $(LDFLAGS) -o $@ $(DAEMON_OBJ) $(BUILD)/librayd.a $(PKG_LIBS)

# The unit tests' allocations go through tests/support/fault_alloc.c, which
# can fail the k-th one (the oom suite).
FAULT_WRAP := -Wl,--wrap=malloc,--wrap=calloc,--wrap=realloc,--wrap=free,--wrap=aligned_alloc,--wrap=strdup,--wrap=strndup

$(BUILD)/unit-tests: $(TEST_OBJ) $(JOBS_OBJ) $(STORE_OBJ) $(SANDBOX_OBJ) $(ERRORS_OBJ) $(BUILD)/librayd.a
	@echo "  LD  $@"
	@$(CC) $(LDFLAGS) $(FAULT_WRAP) -o $@ $(TEST_OBJ) $(JOBS_OBJ) $(STORE_OBJ) $(SANDBOX_OBJ) $(ERRORS_OBJ) $(BUILD)/librayd.a $(PKG_LIBS) $(shell pkg-config --libs $(TESTPKG))

# One build and run of the unit suite with the current CC/SAN/BUILD.
check: $(BUILD)/rayd $(BUILD)/unit-tests $(GENERATED)
	RAYD=$(BUILD)/rayd LSAN_OPTIONS=suppressions=$(CURDIR)/tests/lsan.supp $(BUILD)/unit-tests --jobs 2
	RAYD=$(BUILD)/rayd sh tests/integration/cli_test.sh
	RUN_MAKEFLAGS="CC=$(CC) BUILD=$(BUILD)$(if $(SAN), SAN=$(SAN))" sh tests/integration/make_run_test.sh
	RAYD=$(BUILD)/rayd sh tests/integration/grade_cli_test.sh
	RAYD=$(BUILD)/rayd /usr/bin/python3 tests/integration/docs_commands_test.py
	RAYD=$(BUILD)/rayd sh tests/integration/formats_test.sh
	RAYD=$(BUILD)/rayd /usr/bin/python3 tests/integration/schema_test.py
	RAYD=$(BUILD)/rayd /usr/bin/python3 tests/integration/grade_parity_test.py
	RAYD=$(BUILD)/rayd /usr/bin/python3 tests/integration/serve_test.py
	RAYD=$(BUILD)/rayd /usr/bin/python3 tests/integration/metrics_test.py
	RAYD=$(BUILD)/rayd /usr/bin/python3 tests/integration/openapi_test.py
	RAYD=$(BUILD)/rayd /usr/bin/python3 tests/integration/client_test.py
	RAYD=$(BUILD)/rayd sh tests/integration/deploy_test.sh
	RAYD=$(BUILD)/rayd $(if $(SAN),RAYD_TEST_SLOW=3) RAYD_TEST_STORE=sqlite /usr/bin/python3 tests/integration/store_test.py
	RAYD=$(BUILD)/rayd $(if $(SAN),RAYD_TEST_SLOW=3) RAYD_TEST_STORE=postgresql /usr/bin/python3 tests/integration/store_test.py
	RAYD=$(BUILD)/rayd /usr/bin/python3 tests/integration/grade_batch_test.py
	RAYD=$(BUILD)/rayd RAYD_TEST_STORE=sqlite /usr/bin/python3 tests/integration/term_test.py
	RAYD=$(BUILD)/rayd RAYD_TEST_STORE=postgresql /usr/bin/python3 tests/integration/term_test.py
	RAYD=$(BUILD)/rayd RAYD_TEST_STORE=sqlite /usr/bin/python3 tests/integration/batch_manage_test.py
	RAYD=$(BUILD)/rayd RAYD_TEST_STORE=postgresql /usr/bin/python3 tests/integration/batch_manage_test.py
	RAYD=$(BUILD)/rayd /usr/bin/python3 tests/integration/access_test.py
	RAYD=$(BUILD)/rayd /usr/bin/python3 tests/integration/store_faults_test.py
	RAYD=$(BUILD)/rayd $(if $(SAN),RAYD_TEST_SLOW=3) /usr/bin/python3 tests/integration/same_bytes_test.py
	RAYD=$(BUILD)/rayd $(if $(SAN),RAYD_TEST_SLOW=3) /usr/bin/python3 tests/integration/cpu_test.py
	RAYD=$(BUILD)/rayd /usr/bin/python3 tests/integration/code_grade_test.py

# Three daemons on one PostgreSQL behind nginx (tests/integration/farm_test.py):
# once, against the plain build.
farm: $(BUILD)/rayd $(GENERATED)
	@RAYD=$(BUILD)/rayd /usr/bin/python3 tests/integration/farm_test.py

# The C sources' format and the OpenAPI document's linters, then gcc plain,
# then clang with AddressSanitizer and UndefinedBehaviorSanitizer,
# then the web page in headless Chromium, the fault test against the plain
# daemon and under ThreadSanitizer, then a short fuzzing smoke of every
# reader.
test: deps
	@$(MAKE) --no-print-directory format-check
	@sh tests/openapi-lint/run.sh
	@$(MAKE) --no-print-directory check CC=gcc BUILD=build
	@$(MAKE) --no-print-directory check CC=clang SAN=1 BUILD=build/clang-san
	@$(MAKE) --no-print-directory farm
	@$(MAKE) --no-print-directory install-test
	@sh tests/integration/tree_clean_test.sh
	@RAYD=build/rayd sh tests/browser/run.sh
	@$(MAKE) --no-print-directory fault
	@$(MAKE) --no-print-directory tsan
	@sh tests/fuzz/run.sh $(FUZZ_SMOKE_SECONDS)

# The C sources as .clang-format writes them (clang-format -i $(FORMATTED)
# fixes a file).
FORMATTED = $(shell git ls-files '*.c' '*.h' 2>/dev/null | grep -v '^tests/fuzz/\(regressions\|seeds\)/')
format-check:
	@$(if $(FORMATTED),clang-format --dry-run -Werror $(FORMATTED),echo "format-check: not a git checkout, nothing checked")

# Hostile clients against one daemon while a probe renders (tests/fault/).
FAULT_SECONDS ?= 40
fault: $(BUILD)/rayd
	@RAYD=$(BUILD)/rayd FAULT_SECONDS=$(FAULT_SECONDS) /usr/bin/python3 tests/fault/fault_test.py

# The daemon under ThreadSanitizer through the same fault run: any race
# report makes it exit 66, which fails the run's SIGTERM check.
TSAN_SECONDS ?= 30
tsan: deps
	@$(MAKE) --no-print-directory CC=clang SAN=1 SANFLAGS=-fsanitize=thread BUILD=build/clang-tsan build/clang-tsan/rayd
	@TSAN_OPTIONS="exitcode=66 $(TSAN_OPTIONS)" RAYD=build/clang-tsan/rayd FAULT_SECONDS=$(TSAN_SECONDS) \
	    /usr/bin/python3 tests/fault/fault_test.py

FUZZ_SMOKE_SECONDS ?= 15
FUZZ_SECONDS ?= 300

# The numerical-stability report: every extreme case, its property, the
# measured worst error, pass or fail, written to build/stability.md
# (docs/stability.md is a copy from one machine; tracked files stay as
# they are).
stability: deps
	@$(MAKE) --no-print-directory $(BUILD)/librayd.a
	@$(CC) $(CPPFLAGS) $(INC_ALL) $(PKG_CFLAGS) $(filter-out -O% -g -MMD -MP,$(CFLAGS)) -O2 \
	    tests/stability/report.c tests/stability/cases.c tests/support/load.c $(BUILD)/librayd.a $(PKG_LIBS) \
	    -o $(BUILD)/stability-report
	@$(BUILD)/stability-report --threads 2 --out $(BUILD)/stability.md

# Coverage-guided fuzzing (libFuzzer) of every reader (tests/fuzz/README.md).
fuzz: deps
	@sh tests/fuzz/run.sh $(FUZZ_SECONDS)

# Starts the service on 127.0.0.1:8080 with the bundled scenes; Ctrl-C stops
# it. make run PORT=8081 takes another port; RAYD_LISTEN=HOST:PORT make run
# another address, which the daemon reads itself (a --listen here would win
# over it). PORT, when given, wins over RAYD_LISTEN.
PORT_GIVEN := $(filter command line environment,$(origin PORT))
run: all $(GENERATED)
	$(BUILD)/rayd serve $(if $(PORT_GIVEN)$(if $(RAYD_LISTEN),,1),--listen 127.0.0.1:$(or $(PORT),8080)) --scenes scenes

# make install [PREFIX=/usr/local] [DESTDIR=]: the binary (its data folder
# compiled in as $(PREFIX)/share/rayd), the scenes and assignments, the man
# page (help2man, from the commands' own --help), the docs, bash and zsh
# completion (docs/completion/gen.sh; where bash-completion and Debian's zsh
# look under /usr/local and /usr), the systemd unit, the licence. make
# uninstall removes exactly those.
PREFIX  ?= /usr/local
BINDIR   = $(PREFIX)/bin
DATADIR  = $(PREFIX)/share/rayd
LIBEXECDIR = $(PREFIX)/libexec/rayd
MANDIR   = $(PREFIX)/share/man/man1
DOCDIR   = $(PREFIX)/share/doc/rayd
UNITDIR  = $(PREFIX)/lib/systemd/system
BASHCOMPDIR = $(PREFIX)/share/bash-completion/completions
ZSHCOMPDIR  = $(PREFIX)/share/zsh/site-functions
INSTALL_BUILD := $(BUILD)/install
# The documentation the man page's SEE ALSO names, installed beside README.md.
DOCS := $(sort $(wildcard docs/*.md)) docs/openapi.json docs/scene.schema.json

$(INSTALL_BUILD)/prefix.stamp: FORCE
	@mkdir -p $(dir $@)
	@echo '$(DATADIR)' | cmp -s - $@ || echo '$(DATADIR)' > $@

$(INSTALL_BUILD)/version.o: api/util/version.c $(INSTALL_BUILD)/prefix.stamp $(BUILD)/gen/version.stamp
	@$(CC) $(CPPFLAGS) $(INC_api_util) -DRD_VERSION=\"$(VERSION)\" -DRD_DATA_DIR=\"$(DATADIR)\" -DRD_INSTALLED=1 \
	    -DRD_EVAL_PATH=\"$(LIBEXECDIR)/rayd-eval\" $(filter-out -MMD -MP,$(CFLAGS)) -c $< -o $@

# The installed binary differs from build/rayd only in its data folder.
$(INSTALL_BUILD)/rayd: $(DAEMON_OBJ) $(BUILD)/librayd.a $(INSTALL_BUILD)/version.o
	@echo "  LD  $@"
	@$(CC) $(LDFLAGS) -o $@ $(DAEMON_OBJ) $(INSTALL_BUILD)/version.o $(BUILD)/librayd.a $(PKG_LIBS)

$(INSTALL_BUILD)/rayd.1: $(INSTALL_BUILD)/rayd docs/man/commands.sh docs/man/rayd.h2m $(INSTALL_BUILD)/prefix.stamp
	@sh docs/man/commands.sh $(INSTALL_BUILD)/rayd | \
	    sed -e 's|@DATADIR@|$(DATADIR)|g' -e 's|@LIBEXECDIR@|$(LIBEXECDIR)|g' -e 's|@DOCDIR@|$(DOCDIR)|g' \
	    > $(INSTALL_BUILD)/rayd.h2m
	@help2man --no-info --no-discard-stderr --section 1 --include $(INSTALL_BUILD)/rayd.h2m \
	    --output $@ $(INSTALL_BUILD)/rayd

# Shell completion, from the installed binary's own --help and limits.
$(INSTALL_BUILD)/rayd.bash: $(INSTALL_BUILD)/rayd docs/completion/gen.sh
	@sh docs/completion/gen.sh $(INSTALL_BUILD)/rayd bash > $@
$(INSTALL_BUILD)/_rayd: $(INSTALL_BUILD)/rayd docs/completion/gen.sh
	@sh docs/completion/gen.sh $(INSTALL_BUILD)/rayd zsh > $@

$(INSTALL_BUILD)/rayd@.service: deploy/systemd/rayd@.service.in $(INSTALL_BUILD)/prefix.stamp
	@sed 's|@BINDIR@|$(BINDIR)|g' $< > $@

install: deps $(GENERATED)
	@$(MAKE) --no-print-directory $(INSTALL_BUILD)/rayd $(INSTALL_BUILD)/rayd.1 $(INSTALL_BUILD)/rayd@.service \
	    $(INSTALL_BUILD)/rayd.bash $(INSTALL_BUILD)/_rayd $(BUILD)/rayd-eval
	install -d $(DESTDIR)$(BINDIR) $(DESTDIR)$(DATADIR) $(DESTDIR)$(MANDIR) $(DESTDIR)$(DOCDIR) $(DESTDIR)$(UNITDIR) \
	    $(DESTDIR)$(BASHCOMPDIR) $(DESTDIR)$(ZSHCOMPDIR)
	install -m 0644 $(INSTALL_BUILD)/rayd.bash $(DESTDIR)$(BASHCOMPDIR)/rayd
	install -m 0644 $(INSTALL_BUILD)/_rayd $(DESTDIR)$(ZSHCOMPDIR)/_rayd
	install -m 0755 $(INSTALL_BUILD)/rayd $(DESTDIR)$(BINDIR)/rayd
	install -D -m 0755 $(BUILD)/rayd-eval $(DESTDIR)$(LIBEXECDIR)/rayd-eval
	cd daemon/codegrade/course && find . -type f | while read -r f; do \
	    install -D -m 0644 "$$f" "$(DESTDIR)$(DATADIR)/course/$$f" || exit 1; done
	install -m 0644 $(INSTALL_BUILD)/rayd.1 $(DESTDIR)$(MANDIR)/rayd.1
	install -m 0644 $(INSTALL_BUILD)/rayd@.service $(DESTDIR)$(UNITDIR)/rayd@.service
	install -m 0644 LICENSE README.md $(DOCS) $(DESTDIR)$(DOCDIR)/
	find scenes -type f ! -name '*.py' | while read -r f; do \
	    install -D -m 0644 "$$f" "$(DESTDIR)$(DATADIR)/$$f" || exit 1; done

uninstall:
	rm -f $(DESTDIR)$(BINDIR)/rayd $(DESTDIR)$(MANDIR)/rayd.1 $(DESTDIR)$(UNITDIR)/rayd@.service \
	    $(DESTDIR)$(BASHCOMPDIR)/rayd $(DESTDIR)$(ZSHCOMPDIR)/_rayd
	rm -rf $(DESTDIR)$(LIBEXECDIR)
	rm -rf $(DESTDIR)$(DATADIR) $(DESTDIR)$(DOCDIR)

# Installs into temporary folders and runs the installed rayd from another.
install-test: deps
	@sh tests/integration/install_test.sh

# The benchmark driver (bench/rayd_bench, Python's standard library):
# every section, results in build/bench/results.json, tables printed;
# BENCH_ARGS passes options (e.g. "--only http --runs 5"). bench-quick
# checks the driver itself with small sizes in a minute or two.
bench: all
	@sh deploy/deps.sh bench
	@$(MAKE) --no-print-directory $(BUILD)/bench/embree_trace
	@PYTHONPATH=bench /usr/bin/python3 -m rayd_bench --rayd $(BUILD)/rayd $(BENCH_ARGS)

bench-quick: all
	@sh deploy/deps.sh bench
	@$(MAKE) --no-print-directory $(BUILD)/bench/embree_trace
	@PYTHONPATH=bench /usr/bin/python3 -m rayd_bench --rayd $(BUILD)/rayd --quick \
	    --results build/bench/results-quick.json $(BENCH_ARGS)

# The embree and primitives sections' harness: rayd's scene loading
# (librayd.a) and Embree 3, whose Debian package has no pkg-config file.
EMBREE_LIBS = $(shell pkg-config --libs embree3 2>/dev/null || echo -lembree3)
$(BUILD)/bench/embree_trace: bench/embree_trace.c $(BUILD)/librayd.a
	@mkdir -p $(dir $@)
	@echo "  LD  $@"
	@$(CC) $(CPPFLAGS) $(call inc_for,$<) $(PKG_CFLAGS) $(CFLAGS) $< $(BUILD)/librayd.a $(PKG_LIBS) $(EMBREE_LIBS) -o $@

# The store section's harness: tile claims and results through
# daemon/store's API alone (the store's objects and librayd.a).
$(BUILD)/bench/store_claims: bench/store_claims.c $(STORE_OBJ) $(BUILD)/librayd.a
	@mkdir -p $(dir $@)
	@echo "  LD  $@"
	@$(CC) $(CPPFLAGS) $(call inc_for,$<) $(PKG_CFLAGS) $(CFLAGS) $< $(STORE_OBJ) $(BUILD)/librayd.a $(PKG_LIBS) -o $@

# The include path of every folder at once, for builds outside this file
# (tests/fuzz/run.sh).
print-includes:
	@echo $(INC_ALL)

print-pkgs:
	@echo $(PKGS)

clean:
	rm -rf build out scenes/generated

-include $(shell find build -name '*.d' 2>/dev/null)
