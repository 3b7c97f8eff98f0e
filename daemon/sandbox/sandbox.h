/* Running an untrusted program under bubblewrap (bwrap): its own user, pid,
 * network, IPC, UTS and cgroup namespaces, no network, no environment, a
 * file system of /usr read-only, a fresh /proc and a read-only /dev (no
 * writable /dev/shm), two small tmpfs (/tmp and the working folder /work)
 * and the files it is given, copied in, the rest of the root read-only;
 * resource limits; a wall clock after which the whole tree is killed;
 * its output read through pipes with byte limits. There is no fallback:
 * when bwrap cannot start, rd_sandbox_run fails and nothing runs.
 *
 * The process limit is set inside, by /usr/bin/prlimit (util-linux) as the
 * first process in the sandbox, so that it counts this sandbox alone; a
 * seccomp filter (seccomp_filter.h) refuses what a student has no use for.
 *
 * When the caller runs as root, the sandbox runs as the kernel uid and gid
 * of the spec (65534, nobody, by default): root is exempt from
 * RLIMIT_NPROC, so a fork bomb would not be stopped otherwise. Files are
 * opened by the caller and copied by bwrap, so that uid needs no access to
 * any of the caller's folders.
 *
 * Thread-safe: nothing is shared between runs. Ownership: the result's
 * buffers are malloc'ed by rd_sandbox_run and freed by
 * rd_sandbox_result_free. */
#ifndef RD_SANDBOX_H
#define RD_SANDBOX_H

#include <stdatomic.h>
#include <stddef.h>
#include <sys/types.h>

#include "rayd/error.h"

/* A file put into the sandbox: from a host path (opened by the caller) or
 * from memory. dest is absolute; its folders are created. */
typedef struct {
    const char *dest;
    const char *host_path; /* or NULL, and then data/len */
    const void *data;
    size_t len;
    int executable;
} rd_sandbox_file;

typedef struct {
    const char *bwrap;            /* the bwrap binary (absolute path) */
    const rd_sandbox_file *files; /* nfiles of them */
    size_t nfiles;
    const char *const *argv;          /* the program in the sandbox, NULL-terminated */
    double wall_ms;                   /* the whole run; then SIGKILL to every process */
    unsigned long cpu_s;              /* RLIMIT_CPU of each process */
    unsigned long long address_space; /* RLIMIT_AS of each process, bytes */
    unsigned long long file_size;     /* RLIMIT_FSIZE */
    unsigned long open_files;         /* RLIMIT_NOFILE */
    unsigned long processes;          /* RLIMIT_NPROC, counted in this sandbox alone */
    unsigned long long tmpfs_bytes;   /* size of /tmp and of /work, each */
    size_t output_max;                /* stdout + stderr bytes kept; more ends the run */
    size_t data_max;                  /* bytes kept from fd 3; more ends the run */
    uid_t uid;                        /* the kernel uid when the caller is root */
    gid_t gid;
    const atomic_int *cancel; /* optional: non-zero ends the run */
} rd_sandbox_spec;

typedef enum {
    RD_SANDBOX_EXITED,       /* the program exited; see status */
    RD_SANDBOX_SIGNALED,     /* it was killed by a signal (a crash, SIGXCPU) */
    RD_SANDBOX_TIMED_OUT,    /* the wall clock ran out */
    RD_SANDBOX_OUTPUT_LIMIT, /* it wrote more than output_max */
    RD_SANDBOX_DATA_LIMIT,   /* it wrote more than data_max to fd 3 */
    RD_SANDBOX_CANCELLED
} rd_sandbox_end;

typedef struct {
    rd_sandbox_end end;
    int status;   /* exit status, or the signal number */
    char *output; /* stdout and stderr as they came, NUL-terminated */
    size_t output_len;
    unsigned char *data; /* what the program wrote to fd 3 */
    size_t data_len;
    double ms;
} rd_sandbox_result;

/* Defaults for everything but bwrap, files and argv. */
rd_sandbox_spec rd_sandbox_spec_default(void);

/* The host memory one run may hold at most, as a budget reserves it: the
 * address space limit, the two tmpfs' sizes and the files copied in (bwrap
 * writes them to its own root). The limit is per process: several at once
 * (the compiler's, the evaluator's) may together hold more. Files that
 * cannot be read count 0. */
unsigned long long rd_sandbox_memory_bytes(const rd_sandbox_spec *spec);

/* Runs spec->argv in a new sandbox and waits for its end. RD_ERR_UNAVAILABLE when
 * the sandbox could not be set up (bwrap missing, user namespaces
 * refused: err says which); RD_ERR_NOMEM; else RD_OK with *out filled,
 * whatever the program did. */
rd_error_code rd_sandbox_run(const rd_sandbox_spec *spec, rd_sandbox_result *out, rd_error *err);

void rd_sandbox_result_free(rd_sandbox_result *r);

/* Whether a sandbox starts on this machine: runs /usr/bin/true in one.
 * RD_OK, or RD_ERR_UNAVAILABLE with the reason (bwrap's own message) in err. */
rd_error_code rd_sandbox_probe(const char *bwrap, rd_error *err);

#endif
