/* A fault-injecting allocator for build/unit-tests (after SQLite's
 * src/test_malloc.c): "fail the k-th allocation from now", so that a test
 * can walk every out-of-memory path of an operation.
 *
 * How it hooks in: the unit-test binary is linked with
 * -Wl,--wrap=malloc,--wrap=calloc,--wrap=realloc,--wrap=free,
 * --wrap=aligned_alloc,--wrap=strdup,--wrap=strndup (Makefile), so every
 * call to those from an object linked into it (core/, api/, daemon/jobs/,
 * the tests) goes to the __wrap_* functions here, which call the real
 * allocator (glibc's, or the sanitizers' under ASan) through __real_*.
 * strdup and strndup are wrapped themselves because glibc's allocate
 * inside libc, where --wrap does not reach.
 *
 * What is and is not failed, decided: --wrap only renames references in
 * the objects being linked, so shared libraries keep calling the real
 * allocator: libc's own internals, libpng and zlib (png_read.c's and
 * png_write.c's buffers are the project's and are failed; libpng's
 * structures are not), libcurl and Criterion are never failed, and their
 * allocations are not counted. The exception is cJSON, which takes
 * allocation hooks: rd_fault_route_cjson() sends its allocations through
 * the wrappers, so its failures are injected too (cJSON then returns NULL,
 * which the code must report as RD_ERR_NOMEM). Call it before the first
 * cJSON allocation of the process (Criterion runs every test in a process
 * of its own).
 *
 * Counting is process-wide, on every thread (atomics): the code under test
 * may allocate on render threads, and the libraries that run threads of
 * their own (Criterion) are not wrapped. With one operation running at a
 * time, "the k-th allocation from now" is the k-th of that operation.
 *
 * Unarmed, the wrappers only count and pass through. With RD_FAULT_TRACE
 * set in the environment, the first failure injected after each
 * rd_fault_arm prints a backtrace on stderr (addr2line -e build/unit-tests
 * turns its offsets into lines), to find which allocation a test names. */
#ifndef RD_TEST_FAULT_ALLOC_H
#define RD_TEST_FAULT_ALLOC_H

/* Fails the k-th allocation from now (k >= 1) and, when persist is set,
 * every allocation after it too (a lasting shortage); the others succeed.
 * A failed allocation returns NULL with errno ENOMEM. Resets the count of
 * injected failures. */
void rd_fault_arm(long k, int persist);

/* Stops failing. Counters keep their values. */
void rd_fault_disarm(void);

/* Allocation calls made so far in the process (malloc, calloc, realloc,
 * aligned_alloc, strdup, strndup through the wrappers; failed ones
 * included). */
long rd_fault_calls(void);

/* Failures injected since the last rd_fault_arm. */
long rd_fault_injected(void);

/* Blocks allocated through the wrappers and not yet freed through them:
 * equal before and after an operation and its cleanup when nothing leaked. */
long rd_fault_live(void);

/* Routes cJSON's allocations through the wrappers (cJSON_InitHooks). */
void rd_fault_route_cjson(void);

#endif
