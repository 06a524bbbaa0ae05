/* Obstacles the SPH particles cannot enter: spheres, axis-aligned boxes, turned boxes and meshes
 * (signed distance fields over a turned box), still or carried from where they are to where
 * move_obstacles puts them over one step. */
#include "internal_fluid.h"
#include <stdio.h>
#include <stdlib.h>

static double quat_length(const float q[4])
{
    return sqrt((double)q[0] * q[0] + (double)q[1] * q[1] + (double)q[2] * q[2] +
                (double)q[3] * q[3]);
}

/* The axes of a turned box in the world, x, y and z (the columns of q's rotation matrix, q
 * normalised); the world's own for the other types. */
static void axes_of(const hbk_fluid_obstacle_t *o, float ax[9])
{
    static const float world[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    if (o->type < 2) {
        memcpy(ax, world, sizeof world);
        return;
    }
    const double n = quat_length(o->rotation);
    const double w = o->rotation[0] / n, x = o->rotation[1] / n, y = o->rotation[2] / n,
                 z = o->rotation[3] / n;
    const double m[9] = {1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y),
                         2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x),
                         2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)};
    for (int i = 0; i < 9; ++i) ax[i] = (float)m[i];
}

/* 0 if o is an obstacle the step can take; else non-zero, and (if what is not NULL) the
 * field and its allowed range in what (96 bytes). Also used by hbk_fluid_load_state. */
int hbk_fluid_obstacle_problem(const hbk_fluid_obstacle_t *o, char *what)
{
    if (o->type < 0 || o->type > 3) {
        if (what)
            snprintf(what, 96, "type = %d: must be 0 (sphere), 1 (box), 2 (turned box) or 3 "
                     "(mesh)", o->type);
        return 1;
    }
    for (int a = 0; a < 3; ++a) {
        if (!(fabsf(o->center[a]) <= 1e6f)) {
            if (what)
                snprintf(what, 96, "center[%d] = %g: must be a finite number in [-1e6, 1e6] m",
                         a, (double)o->center[a]);
            return 1;
        }
        if (!(o->extent[a] >= 0.0f && o->extent[a] <= 1e6f) && (o->type != 0 || a == 0)) {
            if (what)
                snprintf(what, 96, "extent[%d] = %g: must be in [0, 1e6] m", a,
                         (double)o->extent[a]);
            return 1;
        }
        if (o->type == 3 && !(o->extent[a] > 0.0f)) {
            if (what)
                snprintf(what, 96, "extent[%d] = %g: must be in (0, 1e6] m for a mesh", a,
                         (double)o->extent[a]);
            return 1;
        }
    }
    if (o->type >= 2) {
        const double n = quat_length(o->rotation);
        if (!(fabs(n - 1.0) <= 1e-3)) {
            if (what)
                snprintf(what, 96, "rotation: length %.6g, must be a unit quaternion (w, x, y, "
                         "z), length 1 +- 1e-3", n);
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
    hbk_fluid_fields_free(h); /* a new list: its meshes' fields come next */
    return HBK_OK;
}

void hbk_fluid_fields_free(hbk_fluid_t *h)
{
    for (int i = 0; i < HBK_FLUID_MAX_OBSTACLES; ++i) {
        free(h->obs_field[i]);
        free(h->obs_field_to[i]);
        h->obs_field[i] = h->obs_field_to[i] = NULL;
        h->obs_shape_speed[i] = 0.0f;
        memset(h->obs_dims[i], 0, sizeof h->obs_dims[i]);
    }
}

hbk_result_t hbk_fluid_field_check(hbk_fluid_t *h, const int32_t dims[3], const float *distance,
                                   size_t *n)
{
    if (!dims || !distance)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "%s: must not be NULL",
                        dims ? "distance" : "dims");
    *n = 1;
    for (int a = 0; a < 3; ++a) {
        if (dims[a] < 2 || dims[a] > HBK_FLUID_FIELD_MAX_DIM)
            return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "dims[%d] = %d: must be in [2, %d]",
                            a, dims[a], HBK_FLUID_FIELD_MAX_DIM);
        *n *= (size_t)dims[a];
    }
    for (size_t i = 0; i < *n; ++i)
        if (!(fabsf(distance[i]) <= 1e6f))
            return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                            "distance[%zu] = %g: must be a finite number in [-1e6, 1e6] m", i,
                            (double)distance[i]);
    return HBK_OK;
}

hbk_result_t hbk_fluid_shape_check(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                                   const int32_t dims[3], const float *distance,
                                   size_t *points)
{
    char what[96];
    *points = 0;
    if (hbk_fluid_obstacle_problem(shape, what))
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "shape.%s", what);
    return shape->type == 3 ? hbk_fluid_field_check(h, dims, distance, points) : HBK_OK;
}

/* A checked copy of a mesh obstacle's field, in *out (its point count in *n). */
static hbk_result_t field_copy(hbk_fluid_t *h, int32_t index, const int32_t dims[3],
                               const float *distance, float **out, size_t *n)
{
    if (index < 0 || index >= h->n_obs)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "index = %d: must be in [0, %d)",
                        index, h->n_obs);
    if (h->obs[index].type != 3)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "index = %d: obstacle %d is of type %d, must be 3 (mesh)", index, index,
                        h->obs[index].type);
    hbk_result_t r = hbk_fluid_field_check(h, dims, distance, n);
    if (r) return r;
    *out = malloc(*n * sizeof **out);
    if (!*out) return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "distance: out of memory");
    memcpy(*out, distance, *n * sizeof **out);
    return HBK_OK;
}

/* Mesh obstacle index's field (checked and copied): at once (blend 0, or no field of these
 * dims to change from, a change under way dropped), or as its shape at the end of the next
 * step (blend 1), with the fastest its surface moves by the change. */
static hbk_result_t put_field(hbk_fluid_t *h, int32_t index, const int32_t dims[3],
                              const float *distance, int blend)
{
    float *f = NULL;
    size_t n = 0;
    hbk_result_t r = field_copy(h, index, dims, distance, &f, &n);
    if (r) return r;
    free(h->obs_field_to[index]);
    h->obs_field_to[index] = NULL;
    h->obs_shape_speed[index] = 0.0f;
    if (!blend || !h->obs_field[index] ||
        memcmp(dims, h->obs_dims[index], sizeof h->obs_dims[index])) {
        free(h->obs_field[index]);
        h->obs_field[index] = f;
        memcpy(h->obs_dims[index], dims, sizeof h->obs_dims[index]);
        return HBK_OK;
    }
    float most = 0.0f; /* the largest change of a distance over the step */
    for (size_t i = 0; i < n; ++i) {
        const float d = fabsf(f[i] - h->obs_field[index][i]);
        most = d > most ? d : most;
    }
    h->obs_field_to[index] = f;
    h->obs_shape_speed[index] = most / h->p.dt;
    return HBK_OK;
}

hbk_result_t hbk_fluid_set_obstacle_field(hbk_fluid_t *h, int32_t index, const int32_t dims[3],
                                          const float *distance)
{
    HBK_FLUID_ENTER(h);
    return put_field(h, index, dims, distance, 0);
}

hbk_result_t hbk_fluid_move_obstacle_field(hbk_fluid_t *h, int32_t index, const int32_t dims[3],
                                           const float *distance)
{
    HBK_FLUID_ENTER(h);
    return put_field(h, index, dims, distance, 1);
}

hbk_result_t hbk_fluid_fields_ready(hbk_fluid_t *h, const char *what)
{
    for (int32_t i = 0; i < h->n_obs; ++i)
        if (h->obs[i].type == 3 && !h->obs_field[i])
            return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                            "%s: obstacle %d is a mesh without its field "
                            "(hbk_fluid_set_obstacle_field)", what, i);
    return HBK_OK;
}

/* The cell of a field over the box [-e, e] holding l: the offset of its lower corner, its
 * eight corners' offsets from there, the fractions t and the grid steps per metre; 0 where l
 * lies outside the box (outside the mesh). */
static int field_cell(const int32_t dims[3], const float e[3], const float l[3], size_t *at,
                      size_t off[8], float t[3], float scale[3])
{
    int32_t i[3];
    for (int a = 0; a < 3; ++a) {
        if (!(fabsf(l[a]) < e[a])) return 0;
        scale[a] = (float)(dims[a] - 1) / (2.0f * e[a]); /* grid steps per metre */
        const float g = (l[a] + e[a]) * scale[a];
        int32_t k = (int32_t)g;
        k = k < 0 ? 0 : k > dims[a] - 2 ? dims[a] - 2 : k;
        i[a] = k;
        t[a] = g - (float)k;
    }
    const size_t sx = 1, sy = (size_t)dims[0], sz = sy * (size_t)dims[1];
    *at = (size_t)i[0] + sy * (size_t)i[1] + sz * (size_t)i[2];
    const size_t o[8] = {0, sx, sy, sx + sy, sz, sx + sz, sy + sz, sx + sy + sz};
    memcpy(off, o, sizeof o);
    return 1;
}

int hbk_fluid_field_contact(const hbk_fluid_t *h, int32_t o, const float e[3], const float l[3],
                            float m, int moving, float *push, float nl[3], float *grow)
{
    const float *f = h->obs_field[o];
    float t[3], scale[3];
    size_t at, off[8];
    if (!field_cell(h->obs_dims[o], e, l, &at, off, t, scale)) return 0;
    float c[8], dc[8] = {0};
    const float *to = moving ? h->obs_field_to[o] : NULL;
    for (int k = 0; k < 8; ++k) {
        c[k] = f[at + off[k]];
        if (to) { /* a change of shape under way: the field obs_t of the way to the new one */
            dc[k] = to[at + off[k]] - c[k];
            c[k] += h->obs_t * dc[k];
        }
    }
    const float c000 = c[0], c100 = c[1], c010 = c[2], c110 = c[3], c001 = c[4], c101 = c[5],
                c011 = c[6], c111 = c[7];
    /* trilinear, and its exact gradient within the cell */
    const float x0 = c000 + t[0] * (c100 - c000), x1 = c010 + t[0] * (c110 - c010),
                x2 = c001 + t[0] * (c101 - c001), x3 = c011 + t[0] * (c111 - c011);
    const float y0 = x0 + t[1] * (x1 - x0), y1 = x2 + t[1] * (x3 - x2);
    const float d = y0 + t[2] * (y1 - y0);
    if (d >= m) return 0;
    const float dx0 = (c100 - c000) + t[1] * ((c110 - c010) - (c100 - c000));
    const float dx1 = (c101 - c001) + t[1] * ((c111 - c011) - (c101 - c001));
    float gr[3] = {(dx0 + t[2] * (dx1 - dx0)) * scale[0], (x1 - x0 + t[2] * (x3 - x2 - x1 + x0)) *
                                                            scale[1],
                   (y1 - y0) * scale[2]};
    const float len = sqrtf(gr[0] * gr[0] + gr[1] * gr[1] + gr[2] * gr[2]);
    if (!(len > 1e-6f)) return 0; /* a flat spot (the middle of a thick part): no way out */
    for (int a = 0; a < 3; ++a) nl[a] = gr[a] / len;
    *push = (m - d) / (len > 1.0f ? 1.0f : len); /* a distance field: |gradient| near 1 */
    *grow = 0.0f;
    if (to) { /* the surface moves out where the distances fall: -(d d / d t) / |gradient| */
        const float r0 = dc[0] + t[0] * (dc[1] - dc[0]), r1 = dc[2] + t[0] * (dc[3] - dc[2]),
                    r2 = dc[4] + t[0] * (dc[5] - dc[4]), r3 = dc[6] + t[0] * (dc[7] - dc[6]);
        const float s0 = r0 + t[1] * (r1 - r0), s1 = r2 + t[1] * (r3 - r2);
        *grow = -(s0 + t[2] * (s1 - s0)) / ((float)h->p.dt * len);
    }
    return 1;
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

/* The turn from a to b, the shorter way: its axis times its angle (rad), and the rotation
 * `t` (0..1) of the way (w, x, y, z). Both given as unit quaternions (within 1e-3). */
static void turn(const float a[4], const float b[4], double t, double axis_angle[3],
                 float at[4])
{
    double qa[4], qb[4], d = 0.0;
    const double na = quat_length(a), nb = quat_length(b);
    for (int k = 0; k < 4; ++k) { qa[k] = a[k] / na; qb[k] = b[k] / nb; d += qa[k] * qb[k]; }
    if (d < 0.0) for (int k = 0; k < 4; ++k) qb[k] = -qb[k]; /* q and -q: the same rotation */
    /* r = qb conj(qa), the turn in world axes; its w = |qa . qb| >= 0, so angle in [0, pi] */
    const double rw = qb[0] * qa[0] + qb[1] * qa[1] + qb[2] * qa[2] + qb[3] * qa[3];
    const double rv[3] = {-qb[0] * qa[1] + qa[0] * qb[1] - (qb[2] * qa[3] - qb[3] * qa[2]),
                          -qb[0] * qa[2] + qa[0] * qb[2] - (qb[3] * qa[1] - qb[1] * qa[3]),
                          -qb[0] * qa[3] + qa[0] * qb[3] - (qb[1] * qa[2] - qb[2] * qa[1])};
    const double s = sqrt(rv[0] * rv[0] + rv[1] * rv[1] + rv[2] * rv[2]);
    const double angle = 2.0 * atan2(s, rw);
    double u[3] = {0.0, 0.0, 0.0};
    if (s > 0.0) for (int k = 0; k < 3; ++k) u[k] = rv[k] / s;
    for (int k = 0; k < 3; ++k) axis_angle[k] = u[k] * angle;
    /* (cos(angle t / 2), u sin(angle t / 2)) qa */
    const double cw = cos(0.5 * angle * t), sw = sin(0.5 * angle * t);
    const double p[4] = {cw, u[0] * sw, u[1] * sw, u[2] * sw};
    const double out[4] = {p[0] * qa[0] - p[1] * qa[1] - p[2] * qa[2] - p[3] * qa[3],
                           p[0] * qa[1] + p[1] * qa[0] + p[2] * qa[3] - p[3] * qa[2],
                           p[0] * qa[2] - p[1] * qa[3] + p[2] * qa[0] + p[3] * qa[1],
                           p[0] * qa[3] + p[1] * qa[2] - p[2] * qa[1] + p[3] * qa[0]};
    for (int k = 0; k < 4; ++k) at[k] = (float)out[k];
}

void hbk_fluid_obstacles_at(hbk_fluid_t *h, double t)
{
    const double dt = h->p.dt;
    float fastest = 0.0f;
    h->obs_t = (float)t;
    for (int32_t i = 0; i < h->n_obs; ++i) {
        const hbk_fluid_obstacle_t *a = &h->obs[i];
        hbk_fluid_obstacle_t *now = &h->obs_now[i];
        float *rate = h->obs_rate[i];
        *now = *a;
        memset(rate, 0, 9 * sizeof *rate);
        const float shape = h->obs_field_to[i] ? h->obs_shape_speed[i] : 0.0f;
        fastest = shape > fastest ? shape : fastest;
        if (!h->obs_moving) { /* still: collide meets them exactly as they are */
            axes_of(now, h->obs_axes[i]);
            continue;
        }
        const hbk_fluid_obstacle_t *b = &h->obs_to[i];
        float c2 = 0.0f, e = 0.0f, r2 = 0.0f;
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
            const float r = fmaxf(a->extent[k], b->extent[k]);
            r2 += r * r;
        }
        float s = sqrtf(c2) + e; /* no point of its surface moves faster */
        if (a->type >= 2) {
            double w[3];
            turn(a->rotation, b->rotation, t, w, now->rotation);
            if (t >= 1.0) memcpy(now->rotation, b->rotation, sizeof now->rotation);
            float w2 = 0.0f;
            for (int k = 0; k < 3; ++k) {
                rate[6 + k] = (float)(w[k] / dt);
                w2 += rate[6 + k] * rate[6 + k];
            }
            s += sqrtf(w2) * sqrtf(r2); /* a corner, turning */
        }
        axes_of(now, h->obs_axes[i]);
        s += shape;
        fastest = s > fastest ? s : fastest;
    }
    h->obs_speed = fastest;
}

void hbk_fluid_obstacles_moved(hbk_fluid_t *h)
{
    for (int32_t i = 0; i < h->n_obs; ++i)
        if (h->obs_field_to[i]) { /* the change of shape made */
            free(h->obs_field[i]);
            h->obs_field[i] = h->obs_field_to[i];
            h->obs_field_to[i] = NULL;
            h->obs_shape_speed[i] = 0.0f;
        }
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
        } else {
            float ax[9], l[3], push, nl[3], grow;
            axes_of(ob, ax); /* (a box's: the world's, which give q exactly) */
            for (int k = 0; k < 3; ++k)
                l[k] = ax[3 * k] * q[0] + ax[3 * k + 1] * q[1] + ax[3 * k + 2] * q[2];
            if (ob->type == 3) { /* (its field is set: fill_box checks) */
                if (hbk_fluid_field_contact(h, o, ob->extent, l, m, 0, &push, nl, &grow))
                    return 1;
            } else if (fabsf(l[0]) < ob->extent[0] + m && fabsf(l[1]) < ob->extent[1] + m &&
                       fabsf(l[2]) < ob->extent[2] + m) {
                return 1;
            }
        }
    }
    return 0;
}

void hbk_fluid_shape_bounds(const hbk_fluid_obstacle_t *o, float lo[3], float hi[3])
{
    float ax[9];
    axes_of(o, ax);
    for (int a = 0; a < 3; ++a) {
        /* a box's reach along world axis a: the sum of its axes' components times extents */
        float r = o->type == 0 ? o->extent[0] : 0.0f;
        for (int k = 0; o->type != 0 && k < 3; ++k) r += fabsf(ax[3 * k + a]) * o->extent[k];
        lo[a] = o->center[a] - r;
        hi[a] = o->center[a] + r;
    }
}

int hbk_fluid_in_shape(const hbk_fluid_obstacle_t *o, const int32_t dims[3], const float *f,
                       const float x[3])
{
    float ax[9];
    axes_of(o, ax);
    return hbk_fluid_in_shape_ax(o, ax, dims, f, x);
}

void hbk_fluid_shape_axes(const hbk_fluid_obstacle_t *o, float ax[9]) { axes_of(o, ax); }

/* x in the shape's own frame (its centre, its axes ax): *q from the centre in the world, l
 * along the axes. */
static void to_local(const hbk_fluid_obstacle_t *o, const float ax[9], const float x[3],
                     float q[3], float l[3])
{
    for (int a = 0; a < 3; ++a) q[a] = x[a] - o->center[a];
    for (int k = 0; k < 3; ++k) l[k] = ax[3 * k] * q[0] + ax[3 * k + 1] * q[1] + ax[3 * k + 2] * q[2];
}

/* A mesh's field (dims points over its box [-e, e]) at l, trilinear, into *v, and its gradient
 * per metre within the cell into g if set (as hbk_fluid_field_contact's); 0 outside the box. */
static int field_at(const int32_t dims[3], const float e[3], const float *f, const float l[3],
                    float *v, float g[3])
{
    float t[3], scale[3];
    size_t at, off[8];
    if (!field_cell(dims, e, l, &at, off, t, scale)) return 0;
    float c[8];
    for (int k = 0; k < 8; ++k) c[k] = f[at + off[k]];
    const float x0 = c[0] + t[0] * (c[1] - c[0]), x1 = c[2] + t[0] * (c[3] - c[2]),
                x2 = c[4] + t[0] * (c[5] - c[4]), x3 = c[6] + t[0] * (c[7] - c[6]);
    const float y0 = x0 + t[1] * (x1 - x0), y1 = x2 + t[1] * (x3 - x2);
    *v = y0 + t[2] * (y1 - y0);
    if (g) {
        const float dx0 = (c[1] - c[0]) + t[1] * ((c[3] - c[2]) - (c[1] - c[0]));
        const float dx1 = (c[5] - c[4]) + t[1] * ((c[7] - c[6]) - (c[5] - c[4]));
        g[0] = (dx0 + t[2] * (dx1 - dx0)) * scale[0];
        g[1] = (x1 - x0 + t[2] * (x3 - x2 - x1 + x0)) * scale[1];
        g[2] = (y1 - y0) * scale[2];
    }
    return 1;
}

int hbk_fluid_in_shape_ax(const hbk_fluid_obstacle_t *o, const float ax[9],
                          const int32_t dims[3], const float *f, const float x[3])
{
    float q[3], l[3], v;
    to_local(o, ax, x, q, l);
    if (o->type == 0)
        return q[0] * q[0] + q[1] * q[1] + q[2] * q[2] < o->extent[0] * o->extent[0];
    if (o->type != 3)
        return fabsf(l[0]) < o->extent[0] && fabsf(l[1]) < o->extent[1] &&
               fabsf(l[2]) < o->extent[2];
    return field_at(dims, o->extent, f, l, &v, NULL) && v < 0.0f;
}

int hbk_fluid_shape_distance(const hbk_fluid_obstacle_t *o, const float ax[9],
                             const int32_t dims[3], const float *f, const float x[3], float *d,
                             float n[3])
{
    float q[3], l[3], nl[3] = {0, 0, 0};
    to_local(o, ax, x, q, l);
    if (o->type == 0) {
        const float r = sqrtf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
        if (!(r > 0.0f)) return 0; /* the centre: every way is out */
        for (int a = 0; a < 3; ++a) n[a] = q[a] / r;
        *d = r - o->extent[0];
        return 1;
    }
    if (o->type != 3) { /* inside: the nearest face's (the first of equals) */
        int m = 0;
        for (int k = 1; k < 3; ++k)
            m = fabsf(l[k]) - o->extent[k] > fabsf(l[m]) - o->extent[m] ? k : m;
        *d = fabsf(l[m]) - o->extent[m];
        nl[m] = l[m] < 0.0f ? -1.0f : 1.0f;
    } else {
        float v;
        if (!field_at(dims, o->extent, f, l, &v, nl)) return 0;
        const float len = sqrtf(nl[0] * nl[0] + nl[1] * nl[1] + nl[2] * nl[2]);
        if (!(len > 1e-6f)) return 0; /* a flat spot: no way out */
        for (int a = 0; a < 3; ++a) nl[a] /= len;
        *d = v / (len > 1.0f ? 1.0f : len);
    }
    for (int a = 0; a < 3; ++a) n[a] = ax[a] * nl[0] + ax[3 + a] * nl[1] + ax[6 + a] * nl[2];
    return 1;
}
