#define _GNU_SOURCE
#include "sandbox.h"

#include <errno.h>
#include <fcntl.h>
#include <grp.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "rayd/clock.h"
#include "seccomp_filter.h"
#include "strbuf.h"

/* Everything the child needs is made before fork: after it, in a threaded
 * daemon, only async-signal-safe calls are allowed. The child puts its
 * descriptors in place (0..4, then the files from FILE_FD on) after moving
 * every one above the last of those places, so that none can overwrite
 * another wherever the caller's open() put it: no descriptor needs to be
 * high, and a daemon under a small RLIMIT_NOFILE still starts sandboxes. */
enum { FILE_FD = 5, NSTD = 5, NTMPFS = 2, MAX_FILES = 64, MAX_ARGS = 512, STATUS_MAX = 4096 };

rd_sandbox_spec rd_sandbox_spec_default(void)
{
    rd_sandbox_spec s;
    memset(&s, 0, sizeof s);
    s.bwrap = "/usr/bin/bwrap";
    s.wall_ms = 20000;
    s.cpu_s = 20;
    s.address_space = 2ULL << 30;
    s.file_size = 16ULL << 20;
    s.open_files = 64;
    s.processes = 32;
    s.tmpfs_bytes = 64ULL << 20;
    s.output_max = 64 << 10;
    s.data_max = 64 << 20;
    s.uid = 65534;
    s.gid = 65534;
    return s;
}

void rd_sandbox_result_free(rd_sandbox_result *r)
{
    if (!r)
        return;
    free(r->output);
    free(r->data);
    memset(r, 0, sizeof *r);
}

typedef struct {
    const char *argv[MAX_ARGS];
    int argc;
    char numbers[MAX_FILES + 4][24]; /* the fd and size arguments */
    int nnum;
    char root_links[4][256]; /* the targets of /lib, /lib64, /bin, /sbin */
    char nproc[40];          /* prlimit's --nproc=N */
} args;

static int add(args *a, const char *s)
{
    if (a->argc >= MAX_ARGS - 1)
        return -1;
    a->argv[a->argc++] = s;
    a->argv[a->argc] = NULL;
    return 0;
}

static const char *num(args *a, unsigned long long v)
{
    snprintf(a->numbers[a->nnum], sizeof a->numbers[0], "%llu", v);
    return a->numbers[a->nnum++];
}

/* /lib, /lib64, /bin, /sbin as the host has them: a symlink into /usr
 * (merged /usr, Debian 12) or a folder, bound read-only. */
static int add_root_dir(args *a, const char *path, char *buf, size_t cap)
{
    struct stat st;
    if (lstat(path, &st) != 0)
        return 0;
    if (S_ISLNK(st.st_mode)) {
        ssize_t n = readlink(path, buf, cap - 1);
        if (n <= 0)
            return 0;
        buf[n] = 0;
        return add(a, "--symlink") || add(a, buf) || add(a, path);
    }
    return S_ISDIR(st.st_mode) ? add(a, "--ro-bind") || add(a, path) || add(a, path) : 0;
}

static int build_args(const rd_sandbox_spec *s, args *a)
{
    static const char *const fixed[] = {"--unshare-all",
                                        "--unshare-user",
                                        "--die-with-parent",
                                        "--new-session",
                                        "--clearenv",
                                        "--cap-drop",
                                        "ALL",
                                        "--ro-bind",
                                        "/usr",
                                        "/usr",
                                        "--proc",
                                        "/proc",
                                        "--dev",
                                        "/dev",
                                        "--hostname",
                                        "sandbox",
                                        "--setenv",
                                        "PATH",
                                        "/usr/bin",
                                        "--setenv",
                                        "TMPDIR",
                                        "/tmp",
                                        "--setenv",
                                        "LC_ALL",
                                        "C",
                                        "--setenv",
                                        "HOME",
                                        "/work",
                                        "--uid",
                                        "65534",
                                        "--gid",
                                        "65534",
                                        "--disable-userns",
                                        "--json-status-fd",
                                        "4"};
    memset(a, 0, sizeof *a);
    if (add(a, s->bwrap))
        return -1;
    for (size_t i = 0; i < sizeof fixed / sizeof *fixed; i++)
        if (add(a, fixed[i]))
            return -1;
    static const char *const dirs[] = {"/lib", "/lib64", "/bin", "/sbin"};
    for (int i = 0; i < 4; i++)
        if (add_root_dir(a, dirs[i], a->root_links[i], sizeof a->root_links[i]))
            return -1;
    const char *tmpfs[NTMPFS] = {"/tmp", "/work"};
    for (int i = 0; i < NTMPFS; i++)
        if (add(a, "--size") || add(a, num(a, s->tmpfs_bytes)) || add(a, "--tmpfs") || add(a, tmpfs[i]))
            return -1;
    for (size_t i = 0; i < s->nfiles; i++) {
        const char *perms = s->files[i].executable ? "0555" : "0444";
        if (add(a, "--perms") || add(a, perms) || add(a, "--ro-bind-data") || add(a, num(a, FILE_FD + i)) ||
            add(a, s->files[i].dest))
            return -1;
    }
    /* the filter's descriptor follows the files' (seccomp_filter.h) */
    if (add(a, "--seccomp") || add(a, num(a, FILE_FD + s->nfiles)))
        return -1;
    /* bwrap's root and its /dev (with /dev/shm) are tmpfs without a size:
     * host memory outside every limit. Read-only once set up, only /tmp
     * and /work, sized, can be written. */
    if (add(a, "--remount-ro") || add(a, "/dev") || add(a, "--remount-ro") || add(a, "/") || add(a, "--chdir") ||
        add(a, "/work"))
        return -1;
    /* RLIMIT_NPROC is counted per user namespace and uid, and a namespace's
     * ceiling in its parent is its creator's limit when it is made (Linux
     * 5.14, ucounts): bwrap makes the namespace under the caller's own
     * limit, and the first process inside sets the sandbox's before it
     * runs the program. So the count is this sandbox's alone, not one
     * shared with the daemon's threads and every other sandbox of the uid. */
    snprintf(a->nproc, sizeof a->nproc, "--nproc=%lu", s->processes);
    if (s->processes && (add(a, "/usr/bin/prlimit") || add(a, a->nproc) || add(a, "--")))
        return -1;
    for (const char *const *p = s->argv; *p; p++)
        if (add(a, *p))
            return -1;
    return 0;
}

/* A descriptor of the file's bytes, close-on-exec: the host file opened
 * here, or a memfd holding the data. */
static int file_fd(const rd_sandbox_file *f)
{
    int fd;
    if (f->host_path) {
        fd = open(f->host_path, O_RDONLY | O_CLOEXEC);
    } else {
        fd = memfd_create("rayd-sandbox", MFD_CLOEXEC);
        if (fd >= 0) {
            const char *p = f->data;
            size_t left = f->len;
            while (left) {
                ssize_t n = write(fd, p, left);
                if (n < 0 && errno == EINTR)
                    continue;
                if (n <= 0) {
                    close(fd);
                    return -1;
                }
                p += n;
                left -= (size_t)n;
            }
            if (lseek(fd, 0, SEEK_SET) != 0) {
                close(fd);
                return -1;
            }
        }
    }
    return fd;
}

/* Sets a limit of the spec (0: the caller's stays), or the caller's hard
 * limit where that is lower; -1 when refused, and then the sandbox does
 * not start (a service's system-call filter may refuse setrlimit: the
 * limits are not optional). */
static int limit(int resource, unsigned long long v)
{
    struct rlimit rl;
    if (!v)
        return 0;
    if (getrlimit(resource, &rl) != 0)
        return -1;
    if (rl.rlim_max == RLIM_INFINITY || (rlim_t)v < rl.rlim_max)
        rl.rlim_max = (rlim_t)v;
    rl.rlim_cur = rl.rlim_max;
    return setrlimit(resource, &rl);
}

/* In the child: src[i] becomes descriptor i, for i < n. Each is first
 * copied at or above n (F_DUPFD takes the lowest free one there), so that
 * no dup2 below n overwrites a source not yet in place; then everything
 * from n on is closed. Async-signal-safe; -1 when out of descriptors. */
static int place_fds(const int *src, int n)
{
    int moved[NSTD + MAX_FILES + 1];
    for (int i = 0; i < n; i++)
        if ((moved[i] = fcntl(src[i], F_DUPFD, n)) < 0)
            return -1;
    for (int i = 0; i < n; i++)
        if (dup2(moved[i], i) < 0)
            return -1;
    close_range((unsigned)n, ~0U, 0);
    return 0;
}

/* The child between fork and exec: descriptors into place (src: what
 * becomes 0, 1, 2, 3, 4 and then the files), the caller's uid dropped if it
 * is root, the limits, bwrap. */
static void child(const rd_sandbox_spec *s, const args *a, const int *src)
{
    setpgid(0, 0);
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, NULL);
    if (place_fds(src, NSTD + (int)s->nfiles + 1))
        _exit(127);
    if (geteuid() == 0) {
        if (setgroups(0, NULL) != 0 || setgid(s->gid) != 0 || setuid(s->uid) != 0)
            _exit(127);
    }
    struct rlimit no_core = {0, 0};
    if (limit(RLIMIT_CPU, s->cpu_s) || limit(RLIMIT_AS, s->address_space) || limit(RLIMIT_FSIZE, s->file_size) ||
        limit(RLIMIT_NOFILE, s->open_files) || setrlimit(RLIMIT_CORE, &no_core))
        _exit(127);
    char *const envp[] = {NULL};
    execve(s->bwrap, (char *const *)a->argv, envp);
    _exit(127);
}

typedef struct {
    int fd;
    rd_strbuf buf;
    size_t max;
    int over, eof;
} stream;

/* Reads what is there; 1 when the stream passed its limit. */
static int drain(stream *st)
{
    char chunk[16384];
    for (;;) {
        ssize_t n = read(st->fd, chunk, sizeof chunk);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0)
            return 0; /* EAGAIN */
        if (n == 0) {
            st->eof = 1;
            return 0;
        }
        size_t keep = st->buf.len < st->max ? st->max - st->buf.len : 0;
        if ((size_t)n > keep) {
            rd_strbuf_append(&st->buf, chunk, keep);
            st->over = 1;
            return 1;
        }
        rd_strbuf_append(&st->buf, chunk, (size_t)n);
    }
}

static int started(const rd_strbuf *status) { return status->text && strstr(status->text, "\"child-pid\""); }

/* Waits for bwrap and the pipes, ending the run early on the wall clock,
 * a limit or a cancel. */
static void watch(const rd_sandbox_spec *s, pid_t pid, stream st[3], rd_sandbox_result *out)
{
    double t0 = rd_wall_ms();
    int wstatus = 0, reaped = 0, killed = 0;
    double reaped_at = 0;
    for (;;) {
        double now = rd_wall_ms();
        if (!killed) {
            rd_sandbox_end why = RD_SANDBOX_EXITED;
            if (now - t0 > s->wall_ms)
                why = RD_SANDBOX_TIMED_OUT;
            else if (st[0].over)
                why = RD_SANDBOX_OUTPUT_LIMIT;
            else if (st[1].over)
                why = RD_SANDBOX_DATA_LIMIT;
            else if (s->cancel && atomic_load(s->cancel))
                why = RD_SANDBOX_CANCELLED;
            if (why != RD_SANDBOX_EXITED && !reaped) {
                kill(-pid, SIGKILL);
                kill(pid, SIGKILL);
                out->end = why;
                killed = 1;
            }
        }
        if (!reaped && waitpid(pid, &wstatus, WNOHANG) == pid) {
            reaped = 1;
            reaped_at = now;
        }
        int open = !st[0].eof || !st[1].eof || !st[2].eof;
        /* Once bwrap has gone, its namespace has too: the pipes close at
         * once; a moment's grace is all they get. */
        if (reaped && (!open || now - reaped_at > 200))
            break;
        struct pollfd p[3];
        int np = 0, idx[3];
        for (int i = 0; i < 3; i++)
            if (!st[i].eof) {
                p[np].fd = st[i].fd;
                p[np].events = POLLIN;
                idx[np++] = i;
            }
        int wait = reaped ? 20 : 50;
        if (np) {
            if (poll(p, (nfds_t)np, wait) > 0)
                for (int k = 0; k < np; k++)
                    if (p[k].revents)
                        drain(&st[idx[k]]);
        } else {
            usleep(wait * 1000);
        }
    }
    out->ms = rd_wall_ms() - t0;
    if (!killed) {
        out->end = RD_SANDBOX_EXITED;
        if (WIFEXITED(wstatus)) {
            out->status = WEXITSTATUS(wstatus);
            /* bwrap passes on a program killed by signal N as 128 + N. */
            if (out->status > 128 && out->status < 128 + 65) {
                out->end = RD_SANDBOX_SIGNALED;
                out->status -= 128;
            }
        } else if (WIFSIGNALED(wstatus)) {
            out->end = RD_SANDBOX_SIGNALED;
            out->status = WTERMSIG(wstatus);
        }
    }
}

static void close_all(int *fds, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (fds[i] >= 0)
            close(fds[i]);
}

rd_error_code rd_sandbox_run(const rd_sandbox_spec *s, rd_sandbox_result *out, rd_error *err)
{
    memset(out, 0, sizeof *out);
    if (s->nfiles > MAX_FILES)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "a sandbox takes at most %d files", MAX_FILES);
    args *a = malloc(sizeof *a);
    if (!a)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    if (build_args(s, a)) {
        free(a);
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "too many sandbox arguments");
    }
    /* src: what the child's 0..4, its files and the filter become */
    int src[NSTD + MAX_FILES + 1], *fds = src + NSTD, pipes[3][2] = {{-1, -1}, {-1, -1}, {-1, -1}};
    size_t nf = 0;
    rd_error_code rc = RD_OK;
    for (; nf < s->nfiles; nf++) {
        fds[nf] = file_fd(&s->files[nf]);
        if (fds[nf] < 0) {
            rc = rd_error_set(err, RD_ERR_UNAVAILABLE, 0, 0, "cannot open %s for the sandbox: %s",
                              s->files[nf].host_path ? s->files[nf].host_path : s->files[nf].dest, strerror(errno));
            break;
        }
    }
    int filter = rc ? -1 : rd_seccomp_filter_fd(err);
    if (filter < 0 && !rc)
        rc = RD_ERR_UNAVAILABLE;
    fds[nf] = filter;
    int devnull = rc ? -1 : open("/dev/null", O_RDONLY | O_CLOEXEC);
    for (int i = 0; i < 3 && !rc; i++)
        if (pipe2(pipes[i], O_CLOEXEC) != 0)
            rc = rd_error_set(err, RD_ERR_UNAVAILABLE, 0, 0, "cannot make a pipe: %s", strerror(errno));
    if (!rc && devnull < 0)
        rc = rd_error_set(err, RD_ERR_UNAVAILABLE, 0, 0, "cannot open /dev/null");
    pid_t pid = -1;
    if (!rc) {
        int std[NSTD] = {devnull, pipes[0][1], pipes[0][1], pipes[1][1], pipes[2][1]};
        memcpy(src, std, sizeof std);
        pid = fork();
        if (pid == 0)
            child(s, a, src);
        if (pid < 0)
            rc = rd_error_set(err, RD_ERR_UNAVAILABLE, 0, 0, "cannot start the sandbox: %s", strerror(errno));
    }
    close_all(fds, nf);
    if (filter >= 0)
        close(filter);
    if (devnull >= 0)
        close(devnull);
    for (int i = 0; i < 3; i++) {
        if (pipes[i][1] >= 0)
            close(pipes[i][1]);
    }
    free(a);
    if (rc) {
        for (int i = 0; i < 3; i++)
            if (pipes[i][0] >= 0)
                close(pipes[i][0]);
        return rc;
    }
    stream st[3] = {{pipes[0][0], {0}, s->output_max, 0, 0},
                    {pipes[1][0], {0}, s->data_max, 0, 0},
                    {pipes[2][0], {0}, STATUS_MAX, 0, 0}};
    for (int i = 0; i < 3; i++)
        fcntl(st[i].fd, F_SETFL, O_NONBLOCK);
    watch(s, pid, st, out);
    for (int i = 0; i < 3; i++)
        close(st[i].fd);
    int ok = started(&st[2].buf) || out->end != RD_SANDBOX_EXITED;
    out->output = rd_strbuf_take(&st[0].buf, &out->output_len);
    out->data = (unsigned char *)rd_strbuf_take(&st[1].buf, &out->data_len);
    rd_strbuf_free(&st[2].buf);
    if (!out->output || !out->data) {
        rd_sandbox_result_free(out);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    if (!ok) {
        /* bwrap stopped before it started the program: its own message. */
        rd_error_set(err, RD_ERR_UNAVAILABLE, 0, 0, "the sandbox (bubblewrap) cannot start here: %.300s",
                     out->output_len ? out->output : "bwrap failed without a message");
        rd_sandbox_result_free(out);
        return RD_ERR_UNAVAILABLE;
    }
    return RD_OK;
}

unsigned long long rd_sandbox_memory_bytes(const rd_sandbox_spec *s)
{
    unsigned long long n = s->address_space + NTMPFS * s->tmpfs_bytes;
    for (size_t i = 0; i < s->nfiles; i++) {
        struct stat st;
        if (!s->files[i].host_path)
            n += s->files[i].len;
        else if (stat(s->files[i].host_path, &st) == 0)
            n += (unsigned long long)st.st_size;
    }
    return n;
}

rd_error_code rd_sandbox_probe(const char *bwrap, rd_error *err)
{
    rd_sandbox_spec s = rd_sandbox_spec_default();
    static const char *const argv[] = {"/usr/bin/true", NULL};
    s.bwrap = bwrap;
    s.argv = argv;
    s.wall_ms = 10000;
    if (access(bwrap, X_OK) != 0)
        return rd_error_set(err, RD_ERR_UNAVAILABLE, 0, 0,
                            "the sandbox needs bubblewrap, and %s is not there (apt-get install bubblewrap)", bwrap);
    rd_sandbox_result r;
    rd_error_code rc = rd_sandbox_run(&s, &r, err);
    if (rc)
        return rc;
    int ok = r.end == RD_SANDBOX_EXITED && r.status == 0;
    if (!ok)
        rd_error_set(err, RD_ERR_UNAVAILABLE, 0, 0, "a test program in the sandbox failed: %.300s", r.output);
    rd_sandbox_result_free(&r);
    return ok ? RD_OK : RD_ERR_UNAVAILABLE;
}
