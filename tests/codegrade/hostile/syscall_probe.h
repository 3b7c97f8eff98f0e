// Hostile PhongMaterial: tries each system call the sandbox's seccomp filter refuses (daemon/sandbox/
// seccomp_filter.h), stopping the evaluator and opening its /proc/PID/mem. Correct Phong when every one was
// refused (EPERM or ENOSYS; the mem file any way) and an AF_UNIX socket still opens; (100, 100, 100) otherwise.
// Prints what it saw.
#ifndef PHONGMATERIAL_H
#define PHONGMATERIAL_H

#include "Material.h"
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <linux/perf_event.h>
#include <sched.h>
#include <signal.h>
#include <sys/ptrace.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <sys/uio.h>
#include <unistd.h>

class PhongMaterial : public Material
{
  public:
    Real shininess; // n of cos^n
    vec3 ks;        // specular reflectance
    vec3 kd;        // diffuse reflectance

    PhongMaterial() : shininess(1), ks(0), kd(0) {}

    static bool refused(const char *what, long r)
    {
        bool no = r < 0 && (errno == EPERM || errno == ENOSYS);
        printf("%-24s %s\n", what, r >= 0 ? "allowed" : strerror(errno));
        if (r > 2)
            close((int)r);
        return no;
    }

    static bool probe()
    {
        perf_event_attr pe;
        memset(&pe, 0, sizeof pe);
        pe.type = PERF_TYPE_SOFTWARE;
        pe.size = sizeof pe;
        pe.config = PERF_COUNT_SW_CPU_CLOCK;
        pe.exclude_kernel = 1;
        char buf[16], params[128] = {0};
        iovec local = {buf, sizeof buf}, remote = {buf, sizeof buf};
        bool all = refused("perf_event_open", syscall(SYS_perf_event_open, &pe, 0, -1, -1, 0));
        all &= refused("io_uring_setup", syscall(SYS_io_uring_setup, 4, params));
        all &= refused("io_uring_enter", syscall(SYS_io_uring_enter, -1, 0, 0, 0, 0, 0));
        all &= refused("io_uring_register", syscall(SYS_io_uring_register, -1, 0, 0, 0));
        all &= refused("keyctl", syscall(SYS_keyctl, 0 /* KEYCTL_GET_KEYRING_ID */, -3, 0));
        all &= refused("add_key", syscall(SYS_add_key, "user", "k", "x", 1, -3));
        all &= refused("request_key", syscall(SYS_request_key, "user", "k", 0, -3));
        all &= refused("ptrace", ptrace(PTRACE_PEEKDATA, getppid(), 0, 0));
        all &= refused("process_vm_readv", syscall(SYS_process_vm_readv, getpid(), &local, 1, &remote, 1, 0));
        all &= refused("process_vm_writev", syscall(SYS_process_vm_writev, getpid(), &local, 1, &remote, 1, 0));
        all &= refused("bpf", syscall(SYS_bpf, 5 /* BPF_PROG_LOAD */, 0, 0));
        all &= refused("userfaultfd", syscall(SYS_userfaultfd, 0));
        all &= refused("kexec_load", syscall(SYS_kexec_load, 0, 0, 0, 0));
        all &= refused("mount", syscall(SYS_mount, "none", "/tmp", "tmpfs", 0, 0));
        all &= refused("umount2", syscall(SYS_umount2, "/tmp", 0));
        all &= refused("unshare", syscall(SYS_unshare, CLONE_NEWNS));
        all &= refused("socket(AF_NETLINK)", socket(AF_NETLINK, SOCK_RAW, 0));
        all &= refused("socket(AF_VSOCK)", socket(40 /* AF_VSOCK */, SOCK_STREAM, 0));
        all &= refused("socket(AF_PACKET)", socket(17 /* AF_PACKET */, SOCK_RAW, 0));
        all &= refused("socket(AF_INET)", socket(AF_INET, SOCK_STREAM, 0));
        /* stopping the evaluator: if it stops, it is let go at once */
        long stop = kill(getppid(), SIGSTOP);
        if (stop == 0)
            kill(getppid(), SIGCONT);
        all &= refused("kill(evaluator, SIGSTOP)", stop);
        char mem[64];
        snprintf(mem, sizeof mem, "/proc/%d/mem", (int)getppid());
        int fd = open(mem, O_RDWR);
        printf("%-24s %s\n", "evaluator's mem", fd >= 0 ? "opened" : strerror(errno));
        all &= fd < 0;
        int unix_fd = socket(AF_UNIX, SOCK_STREAM, 0);
        printf("%-24s %s\n", "socket(AF_UNIX)", unix_fd >= 0 ? "allowed" : strerror(errno));
        all &= unix_fd >= 0;
        if (fd >= 0)
            close(fd);
        if (unix_fd >= 0)
            close(unix_fd);
        fflush(stdout);
        return all;
    }

    virtual vec3 calcReflectedLight(const HitRecord &record, const vec3 &incomingDir, const vec3 &outgoingDir)
    {
        static int state = 0; // 0 not probed, 1 everything refused, 2 something went through
        if (!state)
            state = probe() ? 1 : 2;
        if (state == 2)
            return vec3(100, 100, 100);
        Real cosAlpha = -dot(record.normal, incomingDir);
        if (cosAlpha <= 0)
            return vec3(0, 0, 0);
        vec3 R = reflect(incomingDir, record.normal);
        return kd * cosAlpha + ks * pow(std::max(dot(R, outgoingDir), 0.0), shininess);
    }
};

#endif
