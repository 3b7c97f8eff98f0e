#include "time_text.h"

#include <stdio.h>
#include <string.h>
#include <time.h>

void rd_time_text(long long ms, char *buf, size_t size)
{
    /* Floor division, so that a time before 1970 keeps 0..999 ms. */
    long long sec = ms >= 0 ? ms / 1000 : -((-ms + 999) / 1000);
    int milli = (int)(ms - sec * 1000);
    time_t t = (time_t)sec;
    struct tm tm;
    if (!gmtime_r(&t, &tm)) {
        snprintf(buf, size, "%s", "");
        return;
    }
    snprintf(buf, size, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday, tm.tm_hour,
             tm.tm_min, tm.tm_sec, milli);
}

/* Days from 1970-01-01 to y-m-d (proleptic Gregorian; Hinnant's
 * days_from_civil), so no time zone is involved. */
static long long days_from_civil(long long y, unsigned m, unsigned d)
{
    y -= m <= 2;
    long long era = (y >= 0 ? y : y - 399) / 400;
    unsigned yoe = (unsigned)(y - era * 400);
    unsigned doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
    unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    return era * 146097 + (long long)doe - 719468;
}

static int month_days(int y, int m)
{
    static const int days[] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
    int leap = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
    return days[m - 1] + (m == 2 && leap);
}

/* "Thh:mm", ":ss", ".mmm", "Z", each after the one before: *p moves past
 * what it read. 0 when what is there is none of them. */
static int clock_part(const char **p, int *h, int *mi, int *sec, int *milli)
{
    int k = 0;
    if (**p != 'T')
        return **p == 0;
    if (sscanf(*p, "T%2d:%2d%n", h, mi, &k) != 2 || k != 6)
        return 0;
    *p += k;
    if (**p == ':') {
        if (sscanf(*p, ":%2d%n", sec, &k) != 1 || k != 3)
            return 0;
        *p += k;
    }
    if (**p == '.') {
        if (sscanf(*p, ".%3d%n", milli, &k) != 1 || k != 4)
            return 0;
        *p += k;
    }
    if (**p == 'Z')
        (*p)++;
    return **p == 0;
}

long long rd_time_parse(const char *text)
{
    int y, mo, d, h = 0, mi = 0, sec = 0, milli = 0, n = 0;
    if (!text || sscanf(text, "%4d-%2d-%2d%n", &y, &mo, &d, &n) != 3 || n != 10 || text[4] != '-' || text[7] != '-')
        return -1;
    const char *p = text + n;
    if (!clock_part(&p, &h, &mi, &sec, &milli))
        return -1;
    if (y < 1970 || mo < 1 || mo > 12 || d < 1 || d > month_days(y, mo) || h > 23 || mi > 59 || sec > 60 || h < 0 ||
        mi < 0 || sec < 0 || milli < 0)
        return -1;
    return ((days_from_civil(y, (unsigned)mo, (unsigned)d) * 24 + h) * 60 + mi) * 60000LL + sec * 1000LL + milli;
}
