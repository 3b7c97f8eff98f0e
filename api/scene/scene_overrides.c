#include "scene_overrides.h"

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "scene_keys.h"
#include "value_parse.h"

const char *const rd_override_names[] = {"width", "height", "samples", "max_depth", "gamma", "seed", NULL};

static int override_index(const char *name)
{
    for (int i = 0; rd_override_names[i]; i++)
        if (strcmp(rd_override_names[i], name) == 0)
            return i;
    return -1;
}

rd_error_code rd_override_set(rd_scene_overrides *ov, const char *name, const char *value, const char *what,
                              rd_error *err)
{
    int i = override_index(name);
    const rd_key *k = i < 0 ? NULL : rd_key_find(RD_SEC_RENDER, name, strlen(name));
    if (!k)
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "%s: not a render setting that can be overridden", what);
    /* The value as the cfg reader would see it after "key =": one word. */
    rd_token t = {value, strlen(value), 0, 0, 0, 0};
    void *dst = (char *)&ov->values + k->offset;
    char range[64];
    if (k->type == RD_KT_INT) {
        long long x;
        if (rd_parse_int(&t, (long long)k->lo, (long long)k->hi, &x))
            return rd_error_set(err, RD_ERR_SYNTAX, 0, 0, "%s: expected an integer in %lld..%lld, got '%.40s'", what,
                                (long long)k->lo, (long long)k->hi, value);
        *(int *)dst = (int)x;
    } else if (k->type == RD_KT_SEED) {
        unsigned long long x;
        if (rd_parse_u64(&t, &x))
            return rd_error_set(err, RD_ERR_SYNTAX, 0, 0,
                                "%s: expected an integer in 0..18446744073709551615, got '%.40s'", what, value);
        *(uint64_t *)dst = x;
    } else {
        double x;
        rd_key_range_text(k, range, sizeof range);
        if (rd_parse_real(&t, &x) || !rd_key_in_range(k, x))
            return rd_error_set(err, RD_ERR_SYNTAX, 0, 0, "%s: expected a number%s, got '%.40s'", what, range, value);
        *(double *)dst = x;
    }
    ov->set |= 1u << i;
    return RD_OK;
}

int rd_override_given(const rd_scene_overrides *ov, const char *name)
{
    int i = override_index(name);
    return i >= 0 && (ov->set & 1u << i);
}

void rd_overrides_apply(const rd_scene_overrides *ov, rd_scene *s)
{
    for (int i = 0; rd_override_names[i]; i++) {
        if (!(ov->set & 1u << i))
            continue;
        const rd_key *k = rd_key_find(RD_SEC_RENDER, rd_override_names[i], strlen(rd_override_names[i]));
        size_t size = k->type == RD_KT_INT ? sizeof(int) : k->type == RD_KT_SEED ? sizeof(uint64_t) : sizeof(double);
        memcpy((char *)&s->render + k->offset, (const char *)&ov->values + k->offset, size);
    }
}
