/* The workspace: scratch buffers by role, kept between renders (see internal_caustics.h). */
#include "internal_caustics.h"
#include <stdlib.h>
#include <string.h>

void *hbk_cs_get(hbk_caustics_workspace_t *ws, int slot, size_t bytes, int zero)
{
    if (!bytes) bytes = 1;
    if (bytes > ws->cap[slot]) {
        free(ws->p[slot]);
        ws->cap[slot] = 0;
        if (!(ws->p[slot] = malloc(bytes))) return NULL;
        ws->cap[slot] = bytes;
    }
    if (zero) memset(ws->p[slot], 0, bytes);
    return ws->p[slot];
}

void hbk_cs_release(hbk_caustics_workspace_t *ws)
{
    for (int k = 0; k < CS_COUNT; ++k) free(ws->p[k]);
    memset(ws, 0, sizeof *ws);
}

hbk_result_t hbk_caustics_workspace_create(hbk_caustics_workspace_t **out, hbk_message_t *msg)
{
    hbk_message_clear(msg);
    if (!out) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "out: must not be NULL");
    *out = calloc(1, sizeof **out);
    return *out ? HBK_OK : hbk_fail(msg, HBK_ERR_OUT_OF_MEMORY, "workspace: out of memory");
}

void hbk_caustics_workspace_destroy(hbk_caustics_workspace_t *ws)
{
    if (!ws) return;
    hbk_cs_release(ws);
    free(ws);
}

size_t hbk_caustics_workspace_bytes(const hbk_caustics_workspace_t *ws)
{
    size_t n = 0;
    for (int k = 0; ws && k < CS_COUNT; ++k) n += ws->cap[k];
    return n;
}
