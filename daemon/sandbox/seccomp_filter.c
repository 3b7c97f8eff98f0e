#define _GNU_SOURCE
#include "seccomp_filter.h"

#include <errno.h>
#include <sched.h>
#include <seccomp.h>
#include <signal.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <unistd.h>

/* Refused with EPERM, by name: a name this libseccomp or architecture
 * does not know is skipped (the call does not exist here). */
static const char *const refused[] = {
    "ptrace",
    "process_vm_readv",
    "process_vm_writev",
    "pidfd_getfd",
    "kcmp",
    "perf_event_open",
    "bpf",
    "userfaultfd",
    "keyctl",
    "add_key",
    "request_key",
    "kexec_load",
    "kexec_file_load",
    "init_module",
    "finit_module",
    "delete_module",
    "reboot",
    "swapon",
    "swapoff",
    "acct",
    "mount",
    "umount2",
    "pivot_root",
    "open_tree",
    "move_mount",
    "fsopen",
    "fsconfig",
    "fsmount",
    "fspick",
    "mount_setattr",
    "chroot",
    "unshare",
    "setns",
    "lookup_dcookie",
    "quotactl",
    "open_by_handle_at",
    "syslog",
    "iopl",
    "ioperm",
};

/* Refused with ENOSYS, so that callers fall back to an older call. */
static const char *const absent[] = {"clone3", "io_uring_setup", "io_uring_enter", "io_uring_register"};

static const unsigned long ns_flags[] = {CLONE_NEWUSER, CLONE_NEWNS,  CLONE_NEWPID,   CLONE_NEWNET,
                                         CLONE_NEWIPC,  CLONE_NEWUTS, CLONE_NEWCGROUP};

static int refuse_names(scmp_filter_ctx ctx, const char *const *names, size_t n, int errnum)
{
    for (size_t i = 0; i < n; i++) {
        int nr = seccomp_syscall_resolve_name(names[i]);
        if (nr != __NR_SCMP_ERROR && seccomp_rule_add(ctx, SCMP_ACT_ERRNO(errnum), nr, 0) != 0)
            return -1;
    }
    return 0;
}

/* A stop signal sent to any process: the student's code runs as the
 * evaluator's uid, and a stopped evaluator no longer enforces its per-call
 * and total time limits (the grade would hold its slot until the outer
 * wall clock). Its default action stops, whatever the target. */
static int refuse_stops(scmp_filter_ctx ctx)
{
    static const int stops[] = {SIGSTOP, SIGTSTP, SIGTTIN, SIGTTOU};
    static const struct {
        const char *name;
        unsigned arg; /* the signal's argument */
    } senders[] = {{"kill", 1},
                   {"tkill", 1},
                   {"tgkill", 2},
                   {"rt_sigqueueinfo", 1},
                   {"rt_tgsigqueueinfo", 2},
                   {"pidfd_send_signal", 1}};
    for (size_t i = 0; i < sizeof senders / sizeof *senders; i++) {
        int nr = seccomp_syscall_resolve_name(senders[i].name);
        for (size_t k = 0; nr != __NR_SCMP_ERROR && k < sizeof stops / sizeof *stops; k++) {
            struct scmp_arg_cmp sig = {senders[i].arg, SCMP_CMP_EQ, (scmp_datum_t)stops[k], 0};
            if (seccomp_rule_add_array(ctx, SCMP_ACT_ERRNO(EPERM), nr, 1, &sig) != 0)
                return -1;
        }
    }
    return 0;
}

/* clone with any namespace flag, and socket() of a family but AF_UNIX. */
static int refuse_args(scmp_filter_ctx ctx)
{
    for (size_t i = 0; i < sizeof ns_flags / sizeof *ns_flags; i++)
        if (seccomp_rule_add(ctx, SCMP_ACT_ERRNO(EPERM), SCMP_SYS(clone), 1,
                             SCMP_A0(SCMP_CMP_MASKED_EQ, ns_flags[i], ns_flags[i])) != 0)
            return -1;
    return seccomp_rule_add(ctx, SCMP_ACT_ERRNO(EPERM), SCMP_SYS(socket), 1, SCMP_A0(SCMP_CMP_NE, AF_UNIX, 0));
}

int rd_seccomp_filter_fd(rd_error *err)
{
    scmp_filter_ctx ctx = seccomp_init(SCMP_ACT_ALLOW);
    int fd = -1;
    if (ctx && seccomp_attr_set(ctx, SCMP_FLTATR_ACT_BADARCH, SCMP_ACT_KILL_PROCESS) == 0 &&
        refuse_names(ctx, refused, sizeof refused / sizeof *refused, EPERM) == 0 &&
        refuse_names(ctx, absent, sizeof absent / sizeof *absent, ENOSYS) == 0 && refuse_args(ctx) == 0 &&
        refuse_stops(ctx) == 0)
        fd = memfd_create("rayd-seccomp", MFD_CLOEXEC);
    if (fd >= 0 && (seccomp_export_bpf(ctx, fd) != 0 || lseek(fd, 0, SEEK_SET) != 0)) {
        close(fd);
        fd = -1;
    }
    seccomp_release(ctx);
    if (fd < 0)
        rd_error_set(err, RD_ERR_UNAVAILABLE, 0, 0, "the sandbox's seccomp filter cannot be built (libseccomp): %s",
                     strerror(errno));
    return fd;
}
