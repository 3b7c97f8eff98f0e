/* The system calls a sandboxed program may not make, as a seccomp filter
 * that bwrap installs (--seccomp FD) after its own setup and before it
 * runs the program. Everything else is allowed: the compiler (g++,
 * cc1plus, as, ld, collect2) and the evaluator need a wide, ordinary set,
 * and these are the ones that reach kernel surface a student has no use
 * for or that could stop or read another process:
 *
 *   ptrace, process_vm_readv/writev, pidfd_getfd, kcmp (another process's
 *   memory and descriptors); perf_event_open; io_uring_setup/enter/
 *   register; bpf; userfaultfd; keyctl, add_key, request_key; kexec_load,
 *   kexec_file_load, module loading, reboot, swapon/off, acct; the mount
 *   family (mount, umount2, pivot_root, open_tree, move_mount, fsopen,
 *   fsconfig, fsmount, fspick, mount_setattr), chroot; unshare, setns and
 *   clone with a namespace flag; socket() of any family but AF_UNIX
 *   (AF_NETLINK, AF_VSOCK, AF_PACKET, AF_INET...: the sandbox has no
 *   network, and vsock is not isolated by a network namespace); a stop
 *   signal (SIGSTOP, SIGTSTP, SIGTTIN, SIGTTOU) sent by kill, tkill,
 *   tgkill, rt_(tg)sigqueueinfo or pidfd_send_signal (a stopped evaluator
 *   enforces no time limit).
 *
 * They fail with EPERM; clone3 and the io_uring calls with ENOSYS, so
 * that glibc falls back to clone (whose flags the filter can read) and a
 * library to ordinary reads. A call of another architecture's ABI (i386
 * int 0x80 on x86-64) kills the process. */
#ifndef RD_SECCOMP_FILTER_H
#define RD_SECCOMP_FILTER_H

#include "rayd/error.h"

/* A memfd holding the filter as BPF, positioned at its start, close-on-
 * exec; the caller closes it. -1 with err set (RD_ERR_UNAVAILABLE) when libseccomp
 * cannot build it. */
int rd_seccomp_filter_fd(rd_error *err);

#endif
