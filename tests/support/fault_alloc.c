/* The fault-injecting allocator (fault_alloc.h). */
#include "fault_alloc.h"

#include <cJSON.h>
#include <errno.h>
#include <execinfo.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

void *__real_malloc(size_t n);
void *__real_calloc(size_t m, size_t n);
void *__real_realloc(void *p, size_t n);
void __real_free(void *p);
void *__real_aligned_alloc(size_t align, size_t n);
char *__real_strdup(const char *s);
char *__real_strndup(const char *s, size_t n);

void *__wrap_malloc(size_t n);
void *__wrap_calloc(size_t m, size_t n);
void *__wrap_realloc(void *p, size_t n);
void __wrap_free(void *p);
void *__wrap_aligned_alloc(size_t align, size_t n);
char *__wrap_strdup(const char *s);
char *__wrap_strndup(const char *s, size_t n);

static atomic_int armed; /* 0: pass through */
static atomic_int persist;
static atomic_long countdown; /* allocations left before the failing one, that one included */
static atomic_long injected;
static atomic_long calls;
static atomic_long live;

void rd_fault_arm(long k, int persist_after)
{
    atomic_store(&armed, 0);
    atomic_store(&injected, 0);
    atomic_store(&persist, persist_after);
    atomic_store(&countdown, k);
    atomic_store(&armed, 1);
}

void rd_fault_disarm(void) { atomic_store(&armed, 0); }

long rd_fault_calls(void) { return atomic_load(&calls); }

long rd_fault_injected(void) { return atomic_load(&injected); }

long rd_fault_live(void) { return atomic_load(&live); }

/* Counts one allocation call; 1 when it is to fail. */
static int should_fail(void)
{
    atomic_fetch_add_explicit(&calls, 1, memory_order_relaxed);
    if (!atomic_load_explicit(&armed, memory_order_acquire))
        return 0;
    long left = atomic_fetch_sub(&countdown, 1);
    if (left == 1 || (left < 1 && atomic_load(&persist))) {
        /* RD_FAULT_TRACE=1: where the first failure of each arming strikes. */
        if (atomic_fetch_add(&injected, 1) == 0 && getenv("RD_FAULT_TRACE")) {
            void *frames[16];
            backtrace_symbols_fd(frames, backtrace(frames, 16), STDERR_FILENO);
            write(STDERR_FILENO, "--\n", 3);
        }
        errno = ENOMEM;
        return 1;
    }
    return 0;
}

static void *counted(void *p)
{
    if (p)
        atomic_fetch_add_explicit(&live, 1, memory_order_relaxed);
    return p;
}

void *__wrap_malloc(size_t n) { return should_fail() ? NULL : counted(__real_malloc(n)); }

void *__wrap_calloc(size_t m, size_t n) { return should_fail() ? NULL : counted(__real_calloc(m, n)); }

void *__wrap_aligned_alloc(size_t align, size_t n)
{
    return should_fail() ? NULL : counted(__real_aligned_alloc(align, n));
}

char *__wrap_strdup(const char *s) { return should_fail() ? NULL : counted(__real_strdup(s)); }

char *__wrap_strndup(const char *s, size_t n) { return should_fail() ? NULL : counted(__real_strndup(s, n)); }

void *__wrap_realloc(void *p, size_t n)
{
    if (!p)
        return __wrap_malloc(n);
    if (n == 0) {
        /* glibc frees p and returns NULL. */
        atomic_fetch_sub_explicit(&live, 1, memory_order_relaxed);
        return counted(__real_realloc(p, n));
    }
    /* A failed realloc leaves p as it was. */
    return should_fail() ? NULL : __real_realloc(p, n);
}

void __wrap_free(void *p)
{
    if (p)
        atomic_fetch_sub_explicit(&live, 1, memory_order_relaxed);
    __real_free(p);
}

static void *cjson_malloc(size_t n) { return __wrap_malloc(n); }

static void cjson_free(void *p) { __wrap_free(p); }

void rd_fault_route_cjson(void)
{
    cJSON_Hooks h = {cjson_malloc, cjson_free};
    cJSON_InitHooks(&h);
}
