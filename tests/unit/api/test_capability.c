/* Ids that grant access (api/util/capability.h): their form, that they
 * do not repeat or follow one another, that equality reads every byte. */
#include <criterion/criterion.h>
#include <string.h>

#include "capability.h"

Test(capability, form_is_kind_and_32_hex_digits)
{
    char id[RD_CAP_MAX];
    cr_assert_eq(rd_cap_new(id, 'g', NULL), RD_OK);
    cr_assert_eq(strlen(id), 33);
    cr_assert_eq(id[0], 'g');
    cr_assert_eq(strspn(id + 1, "0123456789abcdef"), 32, "%s", id);
    cr_assert(rd_cap_valid(id, 'g'));
    cr_assert_not(rd_cap_valid(id, 0), "a kind letter is not a digit");
    cr_assert_eq(rd_cap_new(id, 0, NULL), RD_OK);
    cr_assert_eq(strlen(id), 32);
    cr_assert(rd_cap_valid(id, 0));
}

Test(capability, invalid_forms_are_refused)
{
    const char *bad[] = {"",
                         "g",
                         "0123456789abcdef",
                         "0123456789ABCDEF0123456789abcdef",
                         "0123456789abcdef0123456789abcde",
                         "0123456789abcdef0123456789abcdef0",
                         "0123456789abcdef0123456789abcde/",
                         "../23456789abcdef0123456789abcdef"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++)
        cr_assert_not(rd_cap_valid(bad[i], 0), "%s", bad[i]);
    cr_assert_not(rd_cap_valid(NULL, 0));
    cr_assert_eq(rd_cap_bucket("zz"), 0);
}

/* 4096 ids: no two alike, and no bit stuck: each of the 128 is set in
 * between a third and two thirds of them (a counter's low bits, or a
 * mix of a counter, would not leave the high ones so). */
Test(capability, ids_do_not_repeat_and_every_bit_varies)
{
    enum { N = 4096 };
    static char ids[N][RD_CAP_MAX];
    int ones[128] = {0};
    for (int i = 0; i < N; i++) {
        cr_assert_eq(rd_cap_new(ids[i], 0, NULL), RD_OK);
        for (int b = 0; b < 128; b++) {
            int digit = ids[i][b / 4] <= '9' ? ids[i][b / 4] - '0' : ids[i][b / 4] - 'a' + 10;
            ones[b] += digit >> (b % 4) & 1;
        }
        for (int k = 0; k < i; k++)
            cr_assert(!rd_cap_equal(ids[i], ids[k]), "id %d repeats id %d", i, k);
    }
    for (int b = 0; b < 128; b++)
        cr_assert(ones[b] > N / 3 && ones[b] < 2 * N / 3, "bit %d set in %d of %d", b, ones[b], N);
}

Test(capability, equal_compares_whole_ids)
{
    char a[RD_CAP_MAX], b[RD_CAP_MAX];
    rd_cap_new(a, 'g', NULL);
    memcpy(b, a, sizeof a);
    cr_assert(rd_cap_equal(a, b));
    b[32] ^= 1;
    cr_assert_not(rd_cap_equal(a, b), "the last digit counts");
    b[32] ^= 1;
    b[32] = 0;
    cr_assert_not(rd_cap_equal(a, b), "a prefix is not the id");
    cr_assert_not(rd_cap_equal(b, a));
    cr_assert_not(rd_cap_equal(a, ""));
    cr_assert(rd_cap_equal("", ""));
}

Test(capability, bucket_is_the_first_64_bits)
{
    cr_assert_eq(rd_cap_bucket("0123456789abcdef0123456789abcdef"), 0x0123456789abcdefULL);
    cr_assert_eq(rd_cap_bucket("gfedcba9876543210fedcba9876543210"), 0xfedcba9876543210ULL);
}
