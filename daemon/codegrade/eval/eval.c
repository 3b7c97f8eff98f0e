/* rayd-eval: run inside the sandbox (daemon/sandbox), never outside it.
 * Compiles one student's file with the course's adapter into a shared
 * object, then calls its calcReflectedLight on every query, each batch in
 * a child process so that a crash, an exit or a stall costs one value and
 * not the grade; reports on fd 3 (code_frames.h).
 *
 *   rayd-eval KIND CLASS STUDENT_FILE COURSE_DIR QUERIES COMPILE_MS STALL_MS RUN_MS
 *
 * KIND is the adapter's RAYD_KIND (1 to 4), CLASS its RAYD_CLASS. A
 * student file ending in .cpp/.cc is compiled beside the adapter with the
 * class's declaration from COURSE_DIR/decl (g++ takes a .c for C++ too);
 * any other is included by the
 * adapter. STALL_MS bounds one call, RUN_MS them all. Exit status 0 whatever the student's code did; 2 on a bad
 * invocation or input; 3 when fd 3 cannot be written. */
#include <dlfcn.h>
#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "code_frames.h"

#define OUT_FD 3
#define SO_PATH "/tmp/student.so"
#define KEEP_BYTES (16 * 1024)       /* of the compiler's or the code's output */
#define OUTPUT_MAX (4 * 1024 * 1024) /* the code may print this much in all */
#define MAX_RESTARTS 16
#define MAX_QUERIES (8u * 1024 * 1024)

typedef struct {
    char keep[KEEP_BYTES];
    size_t kept;
    unsigned long long total;
} captured;

static double now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

static int write_all(int fd, const void *p, size_t n)
{
    const char *c = p;
    while (n) {
        ssize_t w = write(fd, c, n);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0)
            return -1;
        c += w;
        n -= (size_t)w;
    }
    return 0;
}

static void frame(uint32_t type, const void *head, size_t head_len, const void *body, size_t body_len)
{
    rd_frame_header h = {type, (uint32_t)(head_len + body_len)};
    if (write_all(OUT_FD, &h, sizeof h) || write_all(OUT_FD, head, head_len) || write_all(OUT_FD, body, body_len))
        exit(3);
}

static void note(const char *text) { frame(RD_FRAME_NOTE, text, strlen(text), "", 0); }

/* Reads what is there on fd into c; 0 at end of file. */
static int drain(int fd, captured *c)
{
    char buf[4096];
    ssize_t r = read(fd, buf, sizeof buf);
    if (r < 0)
        return errno == EINTR || errno == EAGAIN;
    if (r == 0)
        return 0;
    size_t take = (size_t)r < KEEP_BYTES - c->kept ? (size_t)r : KEEP_BYTES - c->kept;
    memcpy(c->keep + c->kept, buf, take);
    c->kept += take;
    c->total += (unsigned long long)r;
    return 1;
}

/* A child in its own process group with stdout and stderr on a pipe. */
static pid_t spawn(int *out_fd)
{
    int p[2];
    if (pipe(p))
        return -1;
    pid_t pid = fork();
    if (pid < 0) {
        close(p[0]);
        close(p[1]);
        return -1;
    }
    if (pid == 0) {
        setpgid(0, 0);
        dup2(p[1], 1);
        dup2(p[1], 2);
        close(p[0]);
        close(p[1]);
        close(OUT_FD);
        return 0;
    }
    setpgid(pid, pid);
    close(p[1]);
    *out_fd = p[0];
    return pid;
}

static void kill_tree(pid_t pid)
{
    kill(-pid, SIGKILL);
    kill(pid, SIGKILL);
}

static int ends_with(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && strcmp(s + a - b, suffix) == 0;
}

static void compiler_argv(const char *argv[32], char defs[4][512], int kind, const char *cls, const char *student,
                          const char *course)
{
    int cpp = ends_with(student, ".cpp") || ends_with(student, ".cc") || ends_with(student, ".c");
    int n = 0;
    snprintf(defs[0], sizeof defs[0], "-I%s", course);
    snprintf(defs[1], sizeof defs[1], cpp ? "-I%s/decl" : "-I%s", course);
    snprintf(defs[2], sizeof defs[2], cpp ? "-DRAYD_DECL_FILE=\"%s.h\"" : "-DRAYD_STUDENT_FILE=\"%s\"",
             cpp ? cls : student);
    snprintf(defs[3], sizeof defs[3], "-DRAYD_CLASS=%s", cls);
    static char kind_def[32], adapter[512];
    snprintf(kind_def, sizeof kind_def, "-DRAYD_KIND=%d", kind);
    snprintf(adapter, sizeof adapter, "%s/adapter.cpp", course);
    const char *fixed[] = {"g++",
                           "-std=c++17",
                           "-O2",
                           "-Wall",
                           "-fPIC",
                           "-shared",
                           "-fdiagnostics-color=never",
                           "-fmax-errors=20",
                           "-Wl,-z,defs",
                           defs[0],
                           defs[1],
                           defs[2],
                           defs[3],
                           kind_def,
                           adapter};
    for (size_t i = 0; i < sizeof fixed / sizeof *fixed; i++)
        argv[n++] = fixed[i];
    if (cpp)
        argv[n++] = student;
    argv[n++] = "-o";
    argv[n++] = SO_PATH;
    argv[n] = NULL;
}

/* Waits for the compiler, reading its messages, for at most limit_ms. */
static int compile(int kind, const char *cls, const char *student, const char *course, double limit_ms)
{
    const char *argv[32];
    char defs[4][512];
    compiler_argv(argv, defs, kind, cls, student, course);
    double t0 = now_ms();
    int fd = -1;
    pid_t pid = spawn(&fd);
    if (pid == 0) {
        execvp(argv[0], (char *const *)argv);
        fprintf(stderr, "g++ could not start: %s\n", strerror(errno));
        _exit(127);
    }
    if (pid < 0) {
        note("the compiler could not be started (fork failed)");
        return -1;
    }
    static captured c;
    rd_frame_compile f = {RD_COMPILE_OK, 0, 0};
    for (int open = 1; open;) {
        double left = limit_ms - (now_ms() - t0);
        if (left <= 0) {
            f.result = RD_COMPILE_TIME_LIMIT;
            break;
        }
        struct pollfd p = {fd, POLLIN, 0};
        if (poll(&p, 1, (int)(left < 100 ? left + 1 : 100)) > 0)
            open = drain(fd, &c);
        if (c.total > OUTPUT_MAX) {
            f.result = RD_COMPILE_OUTPUT_LIMIT;
            break;
        }
    }
    kill_tree(pid);
    close(fd);
    int st = 0;
    waitpid(pid, &st, 0);
    if (f.result == RD_COMPILE_OK) {
        f.status = WIFEXITED(st) ? WEXITSTATUS(st) : WTERMSIG(st);
        if (!WIFEXITED(st) || WEXITSTATUS(st) != 0)
            f.result = RD_COMPILE_FAILED;
    }
    f.ms = now_ms() - t0;
    frame(RD_FRAME_COMPILE, &f, sizeof f, c.keep, c.kept);
    return f.result == RD_COMPILE_OK ? 0 : -1;
}

static rd_code_query *read_queries(const char *path, uint32_t *count)
{
    FILE *f = fopen(path, "rb");
    rd_queries_header h;
    if (!f || fread(&h, sizeof h, 1, f) != 1 || h.magic != RD_QUERIES_MAGIC || h.count > MAX_QUERIES) {
        if (f)
            fclose(f);
        return NULL;
    }
    rd_code_query *q = malloc((h.count ? h.count : 1) * sizeof *q);
    if (q && fread(q, sizeof *q, h.count, f) != h.count) {
        free(q);
        q = NULL;
    }
    fclose(f);
    *count = h.count;
    return q;
}

/* What the children share with the evaluator: how far they got. */
typedef struct {
    atomic_uint done;
    rd_frame_value v[];
} shared_values;

/* The child: loads the code and calls it from `from` on, recording each
 * value before starting the next. Exits 125 when the object cannot load. */
static void evaluate_from(const rd_code_query *q, uint32_t count, uint32_t from, shared_values *sv)
{
    void *so = dlopen(SO_PATH, RTLD_NOW | RTLD_LOCAL);
    void (*fn)(const rayd_code_material *, const rayd_code_hit *, const double *, const double *, double *) =
        so ? (void (*)(const rayd_code_material *, const rayd_code_hit *, const double *, const double *,
                       double *))dlsym(so, "rayd_code_reflected")
           : NULL;
    int (*abi)(void) = so ? (int (*)(void))dlsym(so, "rayd_code_abi") : NULL;
    if (!fn || !abi || abi() != RAYD_CODE_ABI) {
        fprintf(stderr, "rayd-eval: %s\n", so ? "the compiled code lacks the adapter" : dlerror());
        _exit(125);
    }
    for (uint32_t i = from; i < count; i++) {
        double out[3] = {0, 0, 0};
        fn(&q[i].m, &q[i].h, q[i].incoming, q[i].outgoing, out);
        sv->v[i] = (rd_frame_value){RD_VALUE_RETURNED, 0, {out[0], out[1], out[2]}};
        atomic_store(&sv->done, i + 1);
    }
    fflush(NULL);
    _exit(0);
}

typedef struct {
    int ended;    /* the child is gone (else it stalled or printed too much) */
    int status;   /* waitpid's */
    int too_much; /* output limit */
    int stalled;  /* no new value within the stall limit, or out of time */
} child_end;

static child_end watch(pid_t pid, int fd, shared_values *sv, double stall_ms, double deadline, captured *out)
{
    child_end e = {0, 0, 0, 0};
    unsigned last = atomic_load(&sv->done);
    double since = now_ms();
    for (int open = 1;;) {
        struct pollfd p = {fd, POLLIN, 0};
        if (open && poll(&p, 1, 50) > 0)
            open = drain(fd, out);
        else if (!open)
            usleep(5000);
        if (out->total > OUTPUT_MAX) {
            e.too_much = 1;
            break;
        }
        if (waitpid(pid, &e.status, WNOHANG) == pid) {
            e.ended = 1;
            break;
        }
        unsigned d = atomic_load(&sv->done);
        if (d != last) {
            last = d;
            since = now_ms();
        } else if (now_ms() - since > stall_ms || now_ms() > deadline) {
            e.stalled = 1;
            break;
        }
    }
    kill_tree(pid);
    if (!e.ended)
        waitpid(pid, NULL, 0);
    for (struct pollfd p = {fd, POLLIN, 0}; poll(&p, 1, 0) > 0 && drain(fd, out);)
        ;
    close(fd);
    return e;
}

/* Calls the code on every query, a fresh child after each crash or exit;
 * after a stall or too much output the rest is not run. */
static void evaluate(const rd_code_query *q, uint32_t count, double stall_ms, double run_ms)
{
    size_t bytes = sizeof(shared_values) + (size_t)(count ? count : 1) * sizeof(rd_frame_value);
    shared_values *sv = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
    if (sv == MAP_FAILED) {
        note("the evaluator is out of memory");
        return;
    }
    static captured out;
    double t0 = now_ms();
    rd_frame_values f = {count, 0, 0};
    rd_frame_output o = {0, 0, 0};
    for (uint32_t i = 0; i < count; i++)
        sv->v[i] = (rd_frame_value){RD_VALUE_NOT_RUN, 0, {0, 0, 0}};
    uint32_t from = 0;
    while (from < count) {
        atomic_store(&sv->done, from);
        int fd = -1;
        pid_t pid = spawn(&fd);
        if (pid == 0)
            evaluate_from(q, count, from, sv);
        if (pid < 0) {
            note("the evaluator could not start a process for the code (fork failed)");
            break;
        }
        child_end e = watch(pid, fd, sv, stall_ms, t0 + run_ms, &out);
        uint32_t done = atomic_load(&sv->done);
        if (done > count)
            done = count;
        if (e.ended && WIFEXITED(e.status) && WEXITSTATUS(e.status) == 125 && done == from) {
            note("the compiled code could not be loaded");
            break;
        }
        if (done == count)
            break;
        rd_frame_value *v = &sv->v[done];
        if (e.too_much) {
            o.limited = 1;
            break;
        }
        if (e.stalled) {
            v->status = RD_VALUE_TIMED_OUT;
            break;
        }
        v->status = WIFSIGNALED(e.status) ? RD_VALUE_CRASHED : RD_VALUE_EXITED;
        v->signal = WIFSIGNALED(e.status) ? WTERMSIG(e.status) : WEXITSTATUS(e.status);
        from = done + 1;
        if (++f.restarts > MAX_RESTARTS)
            break;
    }
    f.ms = now_ms() - t0;
    frame(RD_FRAME_VALUES, &f, sizeof f, sv->v, (size_t)count * sizeof(rd_frame_value));
    o.total = out.total;
    frame(RD_FRAME_OUTPUT, &o, sizeof o, out.keep, out.kept);
}

int main(int argc, char **argv)
{
    if (argc != 9) {
        fprintf(stderr, "usage: rayd-eval KIND CLASS STUDENT_FILE COURSE_DIR QUERIES COMPILE_MS STALL_MS RUN_MS\n");
        return 2;
    }
    int kind = atoi(argv[1]);
    double compile_ms = atof(argv[6]), stall_ms = atof(argv[7]), run_ms = atof(argv[8]);
    struct stat st;
    if (kind < 1 || kind > 4 || fstat(OUT_FD, &st) != 0 || compile_ms <= 0 || stall_ms <= 0 || run_ms <= 0) {
        fprintf(stderr, "rayd-eval: bad arguments, or no fd 3\n");
        return 2;
    }
    signal(SIGPIPE, SIG_IGN);
    /* The student's code runs as the same uid: a dumpable evaluator's
     * /proc/PID/mem could be opened and written by it (ptrace itself is
     * refused by the sandbox's seccomp filter). Its children inherit this
     * until they exec. */
    if (prctl(PR_SET_DUMPABLE, 0, 0, 0, 0) != 0) {
        fprintf(stderr, "rayd-eval: cannot make itself non-dumpable\n");
        return 2;
    }
    uint32_t count = 0;
    rd_code_query *q = read_queries(argv[5], &count);
    if (!q) {
        note("the queries could not be read");
        return 2;
    }
    if (compile(kind, argv[2], argv[3], argv[4], compile_ms) == 0)
        evaluate(q, count, stall_ms, run_ms);
    free(q);
    return 0;
}
