#include "log.h"

#include <fcntl.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

struct rd_log {
    char *path; /* NULL: stderr */
    int json;
    pthread_mutex_t mu; /* one line at a time, and none during a reopen */
};

static rd_error_code put_on_stderr(const char *path, rd_error *err)
{
    int fd = open(path, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0640);
    if (fd < 0)
        return rd_error_set(err, RD_ERR_IO, 0, 0, "cannot open the log file %s", path);
    int ok = dup2(fd, STDERR_FILENO) >= 0;
    close(fd);
    return ok ? RD_OK : rd_error_set(err, RD_ERR_IO, 0, 0, "cannot write the log to %s", path);
}

rd_log *rd_log_open(const char *path, int json, rd_error *err)
{
    rd_log *log = calloc(1, sizeof *log);
    if (!log || (path && !(log->path = strdup(path)))) {
        free(log);
        rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
        return NULL;
    }
    log->json = json;
    pthread_mutex_init(&log->mu, NULL);
    if (path && put_on_stderr(path, err)) {
        rd_log_free(log);
        return NULL;
    }
    return log;
}

rd_error_code rd_log_reopen(rd_log *log, rd_error *err)
{
    if (!log || !log->path)
        return RD_OK;
    pthread_mutex_lock(&log->mu);
    rd_error_code rc = put_on_stderr(log->path, err);
    pthread_mutex_unlock(&log->mu);
    return rc;
}

void rd_log_free(rd_log *log)
{
    if (!log)
        return;
    pthread_mutex_destroy(&log->mu);
    free(log->path);
    free(log);
}

int rd_log_is_json(const rd_log *log) { return log && log->json; }

void rd_log_time(char *buf, size_t size)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    struct tm tm;
    gmtime_r(&ts.tv_sec, &tm);
    snprintf(buf, size, "%04d-%02d-%02dT%02d:%02d:%02d.%03ldZ", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday,
             tm.tm_hour, tm.tm_min, tm.tm_sec, ts.tv_nsec / 1000000);
}

void rd_log_line(rd_log *log, const char *line)
{
    size_t n = strlen(line);
    char *buf = malloc(n + 2);
    if (log)
        pthread_mutex_lock(&log->mu);
    if (buf) {
        memcpy(buf, line, n);
        buf[n] = '\n';
        ssize_t w = write(STDERR_FILENO, buf, n + 1);
        (void)w; /* a log that cannot be written has nowhere to say so */
        free(buf);
    }
    if (log)
        pthread_mutex_unlock(&log->mu);
}

/* " key=value" for each field, strings as they are, the rest as JSON. */
static void append_fields(char *buf, size_t size, const cJSON *fields)
{
    size_t n = strlen(buf);
    for (const cJSON *f = fields ? fields->child : NULL; f && n + 1 < size; f = f->next) {
        char *v = cJSON_IsString(f) ? NULL : cJSON_PrintUnformatted(f);
        n += (size_t)snprintf(buf + n, size - n, " %s=%s", f->string, v ? v : f->valuestring);
        free(v);
        if (n >= size)
            n = size - 1;
    }
}

static char *json_line(const char *level, const char *msg, cJSON *fields)
{
    char when[40];
    rd_log_time(when, sizeof when);
    cJSON *o = cJSON_CreateObject();
    cJSON_AddItemToObject(o, "time", cJSON_CreateString(when));
    cJSON_AddItemToObject(o, "level", cJSON_CreateString(level));
    cJSON_AddItemToObject(o, "msg", cJSON_CreateString(msg));
    while (o && fields && fields->child) {
        cJSON *f = cJSON_DetachItemViaPointer(fields, fields->child);
        cJSON_AddItemToObject(o, f->string, f);
    }
    char *t = o ? cJSON_PrintUnformatted(o) : NULL;
    cJSON_Delete(o);
    return t;
}

void rd_log_event(rd_log *log, const char *level, const char *msg, cJSON *fields)
{
    char line[4096];
    if (rd_log_is_json(log)) {
        char *t = json_line(level, msg, fields);
        snprintf(line, sizeof line, "%s", t ? t : msg);
        free(t);
    } else {
        int plain = strcmp(level, "info") == 0;
        snprintf(line, sizeof line, "rayd serve: %s%s%s", plain ? "" : level, plain ? "" : ": ", msg);
        append_fields(line, sizeof line, fields);
    }
    cJSON_Delete(fields);
    rd_log_line(log, line);
}

void rd_log_msg(rd_log *log, const char *level, const char *fmt, ...)
{
    char msg[2048];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    rd_log_event(log, level, msg, NULL);
}
