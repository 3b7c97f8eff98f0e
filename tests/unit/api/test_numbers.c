/* Numbers as the readers take them (api/scene/value_parse.h): rd_parse_real
 * reads the short decimals of meshes without strtod, and must give strtod's
 * double to the bit for every text, on both sides of where that shortcut
 * stops (15 significant digits, powers of ten beyond ±22). */
#include <criterion/criterion.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "support/rng.h"
#include "value_parse.h"

static void same_as_strtod(const char *text)
{
    rd_token t = {text, strlen(text), 0, 0, 0, 0};
    double got = 12345;
    int rc = rd_parse_real(&t, &got);
    double want = strtod(text, NULL);
    cr_assert_eq(rc, 0, "'%s' was refused (%d)", text, rc);
    cr_assert(memcmp(&got, &want, sizeof got) == 0, "'%s': %.17g, strtod %.17g", text, got, want);
}

Test(numbers, hand_picked_texts_read_as_strtod_reads_them)
{
    const char *texts[] = {"0",
                           "-0",
                           "+0",
                           "0.0",
                           "-0.0e5",
                           "1",
                           "-1",
                           "1.",
                           ".5",
                           "-.5",
                           "0.1",
                           "0.3",
                           "3.14159",
                           "1e22",
                           "1e23",
                           "1e-22",
                           "1e-23",
                           "123456789012345",
                           "1234567890123456",
                           "9007199254740993",
                           "0.000000000000000000001",
                           "00000123.4500000",
                           "1.7976931348623157e308",
                           "4.9e-324",
                           "2.2250738585072014e-308",
                           "1E5",
                           "1e+05",
                           "-2.5E-3",
                           "0.1e-22",
                           "123456789012345e-22",
                           "123456789012345e22",
                           "5e-1"};
    for (size_t i = 0; i < sizeof texts / sizeof texts[0]; i++)
        same_as_strtod(texts[i]);
}

/* Random decimals: 1 to 20 digits, a point anywhere or none, leading and
 * trailing zeros, exponents from -40 to 40 or none. */
Test(numbers, random_decimals_read_as_strtod_reads_them)
{
    test_rng r = {2024};
    for (int k = 0; k < 200000; k++) {
        char buf[96];
        size_t n = 0;
        if (rng_int(&r, 3) == 0)
            buf[n++] = rng_int(&r, 2) ? '-' : '+';
        int digits = 1 + rng_int(&r, 20), point = rng_int(&r, digits + 2) - 1;
        for (int i = 0; i < digits; i++) {
            if (i == point)
                buf[n++] = '.';
            int zero = rng_int(&r, 4) == 0;
            buf[n++] = zero ? '0' : (char)('0' + rng_int(&r, 10));
        }
        if (point == digits)
            buf[n++] = '.';
        if (rng_int(&r, 2)) {
            buf[n++] = rng_int(&r, 2) ? 'e' : 'E';
            n += (size_t)snprintf(buf + n, sizeof buf - n, "%d", rng_int(&r, 81) - 40);
        }
        buf[n] = 0;
        same_as_strtod(buf);
    }
}

Test(numbers, what_is_no_decimal_stays_refused)
{
    const char *texts[] = {"", "-", ".", "e5", "1e", "1e+", "1.2.3", "1x", "--1", "0x10", "1 ", "nan", "inf"};
    for (size_t i = 0; i < sizeof texts / sizeof texts[0]; i++) {
        rd_token t = {texts[i], strlen(texts[i]), 0, 0, 0, 0};
        double v;
        cr_assert_neq(rd_parse_real(&t, &v), 0, "'%s' was read as %g", texts[i], v);
    }
}
