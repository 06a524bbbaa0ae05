/* Obstacles the SPH particles cannot enter: spheres and axis-aligned boxes, still or carried
 * from where they are to where move_obstacles puts them over one step. */
#include "internal_fluid.h"
#include <stdio.h>

/* 0 if o is an obstacle the step can take; else non-zero, and (if what is not NULL) the
 * field and its allowed range in what (96 bytes). Also used by hbk_fluid_load_state. */
int hbk_fluid_obstacle_problem(const hbk_fluid_obstacle_t *o, char *what)
{
    if (o->type != 0 && o->type != 1) {
        if (what) snprintf(what, 96, "type = %d: must be 0 (sphere) or 1 (box)", o->type);
        return 1;
    }
    for (int a = 0; a < 3; ++a) {
        if (!(fabsf(o->center[a]) <= 1e6f)) {
            if (what)
                snprintf(what, 96, "center[%d] = %g: must be a finite number in [-1e6, 1e6] m",
                         a, (double)o->center[a]);
            return 1;
        }
        if (!(o->extent[a] >= 0.0f && o->extent[a] <= 1e6f) && (o->type == 1 || a == 0)) {
            if (what)
                snprintf(what, 96, "extent[%d] = %g: must be in [0, 1e6] m", a,
                         (double)o->extent[a]);
            return 1;
        }
    }
    return 0;
}

static hbk_result_t check_list(hbk_fluid_t *h, const hbk_fluid_obstacle_t *obs, int32_t count,
                               const char *name)
{
    if (count < 0 || count > HBK_FLUID_MAX_OBSTACLES)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "count = %d: must be in [0, %d]", count,
                        HBK_FLUID_MAX_OBSTACLES);
    if (count && !obs)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "%s: must not be NULL", name);
    for (int32_t i = 0; i < count; ++i) {
        char what[96];
        if (hbk_fluid_obstacle_problem(&obs[i], what))
            return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "%s[%d].%s", name, i, what);
    }
    return HBK_OK;
}

hbk_result_t hbk_fluid_set_obstacles(hbk_fluid_t *h, const hbk_fluid_obstacle_t *obs, int32_t count)
{
    HBK_FLUID_ENTER(h);
    hbk_result_t r = check_list(h, obs, count, "obs");
    if (r) return r;
    if (count) memcpy(h->obs, obs, (size_t)count * sizeof *obs);
    h->n_obs = count;
    h->obs_moving = 0;
    return HBK_OK;
}

hbk_result_t hbk_fluid_move_obstacles(hbk_fluid_t *h, const hbk_fluid_obstacle_t *to, int32_t count)
{
    HBK_FLUID_ENTER(h);
    if (count != h->n_obs)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "count = %d: must be the obstacle count %d (set_obstacles changes the "
                        "list)", count, h->n_obs);
    hbk_result_t r = check_list(h, to, count, "to");
    if (r) return r;
    for (int32_t i = 0; i < count; ++i)
        if (to[i].type != h->obs[i].type)
            return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                            "to[%d].type = %d: must be obstacle %d's type %d", i, to[i].type, i,
                            h->obs[i].type);
    if (count) memcpy(h->obs_to, to, (size_t)count * sizeof *to);
    h->obs_moving = 1;
    return HBK_OK;
}

void hbk_fluid_obstacles_at(hbk_fluid_t *h, double t)
{
    const double dt = h->p.dt;
    float fastest = 0.0f;
    for (int32_t i = 0; i < h->n_obs; ++i) {
        const hbk_fluid_obstacle_t *a = &h->obs[i];
        hbk_fluid_obstacle_t *now = &h->obs_now[i];
        float *rate = h->obs_rate[i];
        *now = *a;
        memset(rate, 0, 6 * sizeof *rate);
        if (!h->obs_moving) continue; /* still: collide meets them exactly as they are */
        const hbk_fluid_obstacle_t *b = &h->obs_to[i];
        float c2 = 0.0f, e = 0.0f;
        for (int k = 0; k < 3; ++k) {
            const double dc = (double)b->center[k] - a->center[k];
            const double de = (double)b->extent[k] - a->extent[k];
            /* the end of the step lands exactly on `to` */
            now->center[k] = t >= 1.0 ? b->center[k] : (float)(a->center[k] + dc * t);
            now->extent[k] = t >= 1.0 ? b->extent[k] : (float)(a->extent[k] + de * t);
            rate[k] = (float)(dc / dt);
            rate[3 + k] = (float)(de / dt);
            c2 += rate[k] * rate[k];
            const float g = fabsf(rate[3 + k]);
            e = g > e ? g : e;
        }
        const float s = sqrtf(c2) + e; /* no point of its surface moves faster */
        fastest = s > fastest ? s : fastest;
    }
    h->obs_speed = fastest;
}

void hbk_fluid_obstacles_moved(hbk_fluid_t *h)
{
    if (!h->obs_moving) return;
    memcpy(h->obs, h->obs_to, (size_t)h->n_obs * sizeof *h->obs);
    h->obs_moving = 0;
}

int hbk_fluid_in_obstacle(const hbk_fluid_t *h, const float x[3])
{
    const float m = 0.5f * h->p.particle_spacing; /* as collide keeps particles out */
    for (int32_t o = 0; o < h->n_obs; ++o) {
        const hbk_fluid_obstacle_t *ob = &h->obs[o];
        const float q[3] = {x[0] - ob->center[0], x[1] - ob->center[1], x[2] - ob->center[2]};
        if (ob->type == 0) {
            const float R = ob->extent[0] + m;
            if (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] < R * R) return 1;
        } else if (fabsf(q[0]) < ob->extent[0] + m && fabsf(q[1]) < ob->extent[1] + m &&
                   fabsf(q[2]) < ob->extent[2] + m) {
            return 1;
        }
    }
    return 0;
}
