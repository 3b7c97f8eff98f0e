#include "json_text.h"

#include <stdlib.h>
#include <string.h>

char *rd_json_print(cJSON *root)
{
    char *text = root ? cJSON_Print(root) : NULL;
    cJSON_Delete(root);
    if (!text)
        return NULL;
    /* A copy, so free() matches whatever allocator cJSON was built with. */
    size_t n = strlen(text);
    char *copy = malloc(n + 2);
    if (copy) {
        memcpy(copy, text, n);
        copy[n] = '\n';
        copy[n + 1] = 0;
    }
    cJSON_free(text);
    return copy;
}

cJSON *rd_json_add(cJSON *parent, const char *key, cJSON *item, int *failed)
{
    if (!parent || !item || !(key ? cJSON_AddItemToObject(parent, key, item) : cJSON_AddItemToArray(parent, item))) {
        cJSON_Delete(item);
        *failed = 1;
        return NULL;
    }
    return item;
}

cJSON *rd_json_curve(const rd_curve_point *c, int n)
{
    cJSON *a = cJSON_CreateArray();
    for (int i = 0; a && i < n; i++) {
        double pt[3] = {c[i].ms, c[i].samples, c[i].error};
        cJSON *item = cJSON_CreateDoubleArray(pt, 3);
        if (!item || !cJSON_AddItemToArray(a, item)) {
            cJSON_Delete(item);
            cJSON_Delete(a);
            return NULL;
        }
    }
    return a;
}
