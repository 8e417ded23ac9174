/**
 * @file vs_observer.c
 * @brief Steady-state Kalman observer step (see vs_observer.h).
 */
#define VS_MODEL_IMPLEMENTATION
#include "vs_observer.h"

#define VS_MAGIC 0x5653u /* "VS" */

#define RD(p) vs_rom_read(p)

/* Validate every channel, first the exogenous then the measured ones. */
static vs_status vs_check(vs_observer *o, const vs_real u[], const vs_real z[])
{
    uint8_t j;
    for (j = 0u; j < (uint8_t)VS_N_U; ++j) {
        if (!vs_is_finite(u[j])) {
            o->bad_channel = j;
            return VS_ERR_NAN;
        }
        if (u[j] < RD(&vs_u_lo[j]) || u[j] > RD(&vs_u_hi[j])) {
            o->bad_channel = j;
            return VS_ERR_RANGE;
        }
    }
#if VS_N_Z > 0
    for (j = 0u; j < (uint8_t)VS_N_Z; ++j) {
        if (!vs_is_finite(z[j])) {
            o->bad_channel = (uint8_t)(VS_N_U + j);
            return VS_ERR_NAN;
        }
        if (z[j] < RD(&vs_z_lo[j]) || z[j] > RD(&vs_z_hi[j])) {
            o->bad_channel = (uint8_t)(VS_N_U + j);
            return VS_ERR_RANGE;
        }
    }
#else
    (void)z;
#endif
    return VS_OK;
}

static vs_status vs_reject(vs_observer *o, vs_status st, vs_real y[])
{
    uint8_t i;
    if (y != 0) {
        for (i = 0u; i < (uint8_t)VS_N_Y; ++i) {
            y[i] = o->y[i];
        }
    }
    if (o->n_rejected < 0xFFFFu) {
        ++o->n_rejected;
    }
    o->last_status = (uint8_t)st;
    return st;
}

/* Scaled inputs us = (u − u_off)/u_scale and innovation ν = zs − Cz x − Dz us. */
static void vs_scale_and_innovate(vs_observer *o, const vs_real u[], const vs_real z[])
{
    uint8_t i, j;
    for (j = 0u; j < (uint8_t)VS_N_U; ++j) {
        o->us[j] = (u[j] - RD(&vs_u_off[j])) * RD(&vs_u_iscale[j]);
    }
#if VS_N_Z > 0
    for (i = 0u; i < (uint8_t)VS_N_Z; ++i) {
        vs_real s = (z[i] - RD(&vs_z_off[i])) * RD(&vs_z_iscale[i]);
        for (j = 0u; j < (uint8_t)VS_N_X; ++j) {
            s -= RD(&vs_Cz[i * VS_N_X + j]) * o->x_hi[j];
        }
#if VS_HAS_DZ
        for (j = 0u; j < (uint8_t)VS_N_U; ++j) {
            s -= RD(&vs_Dz[i * VS_N_U + j]) * o->us[j];
        }
#endif
        o->nu[i] = s; /* ν = z − Cz x − Dz u */
    }
#else
    (void)z;
    (void)i;
#endif
}

/* Hidden estimate ŷ = Ch x + Dh u + F ν, back to physical units. */
static void vs_output(vs_observer *o, vs_real y[])
{
    uint8_t i, j;
    for (i = 0u; i < (uint8_t)VS_N_Y; ++i) {
        vs_real s = (vs_real)0;
        for (j = 0u; j < (uint8_t)VS_N_X; ++j) {
            s += RD(&vs_Ch[i * VS_N_X + j]) * o->x_hi[j];
        }
#if VS_HAS_DH
        for (j = 0u; j < (uint8_t)VS_N_U; ++j) {
            s += RD(&vs_Dh[i * VS_N_U + j]) * o->us[j];
        }
#endif
#if VS_N_Z > 0
        for (j = 0u; j < (uint8_t)VS_N_Z; ++j) {
            s += RD(&vs_F[i * VS_N_Z + j]) * o->nu[j];
        }
#endif
        o->y[i] = RD(&vs_y_off[i]) + RD(&vs_y_scale[i]) * s;
        if (y != 0) {
            y[i] = o->y[i];
        }
    }
}

vs_status vs_init(vs_observer *o)
{
    uint8_t i;
    if (o == 0) {
        return VS_ERR_ARG;
    }
    for (i = 0u; i < (uint8_t)VS_N_X; ++i) {
        o->x_hi[i] = (vs_real)0;
        o->x_lo[i] = (vs_real)0;
        o->d[i] = (vs_real)0;
    }
    for (i = 0u; i < (uint8_t)VS_N_Y; ++i) {
        o->y[i] = RD(&vs_y_off[i]);
    }
    for (i = 0u; i < (uint8_t)VS_N_U; ++i) {
        o->us[i] = (vs_real)0;
    }
#if VS_N_Z > 0
    for (i = 0u; i < (uint8_t)VS_N_Z; ++i) {
        o->nu[i] = (vs_real)0;
    }
#endif
    o->magic = VS_MAGIC;
    o->n_rejected = 0u;
    o->bad_channel = 0xFFu;
    o->last_status = (uint8_t)VS_OK;
    return VS_OK;
}

vs_status vs_reset(vs_observer *o, const vs_real u[], const vs_real z[])
{
    vs_status st;
    if (o == 0 || u == 0 || (VS_N_Z > 0 && z == 0)) {
        return VS_ERR_ARG;
    }
    if (o->magic != VS_MAGIC) {
        return VS_ERR_NOT_READY;
    }
#if VS_HAS_RESET
    st = vs_check(o, u, z);
    if (st != VS_OK) {
        return vs_reject(o, st, 0);
    }
    {
        uint8_t i, j;
        vs_real zs;
        for (j = 0u; j < (uint8_t)VS_N_U; ++j) {
            o->us[j] = (u[j] - RD(&vs_u_off[j])) * RD(&vs_u_iscale[j]);
        }
        /* x = N [u; z]: the observer's fixed point for constant readings */
        for (i = 0u; i < (uint8_t)VS_N_X; ++i) {
            vs_real s = (vs_real)0;
            for (j = 0u; j < (uint8_t)VS_N_U; ++j) {
                s += RD(&vs_Nu[i * VS_N_U + j]) * o->us[j];
            }
#if VS_N_Z > 0
            for (j = 0u; j < (uint8_t)VS_N_Z; ++j) {
                zs = (z[j] - RD(&vs_z_off[j])) * RD(&vs_z_iscale[j]);
                s += RD(&vs_Nz[i * VS_N_Z + j]) * zs;
            }
#else
            (void)zs;
#endif
            o->x_hi[i] = s;
            o->x_lo[i] = (vs_real)0;
        }
    }
    vs_scale_and_innovate(o, u, z);
    vs_output(o, 0);
    o->n_rejected = 0u;
    o->last_status = (uint8_t)VS_OK;
    return VS_OK;
#else
    (void)st;
    o->last_status = (uint8_t)VS_ERR_NO_RESET;
    return VS_ERR_NO_RESET;
#endif
}

vs_status vs_step(vs_observer *o, const vs_real u[], const vs_real z[], vs_real y[])
{
    uint8_t i, j;
    vs_status st;
    if (o == 0 || u == 0 || y == 0 || (VS_N_Z > 0 && z == 0)) {
        return VS_ERR_ARG;
    }
    if (o->magic != VS_MAGIC) {
        return VS_ERR_NOT_READY;
    }
    st = vs_check(o, u, z);
    if (st != VS_OK) {
        return vs_reject(o, st, y);
    }
    vs_scale_and_innovate(o, u, z);
    vs_output(o, y);
    /* increment d = (A − I) x + B u + G ν */
    for (i = 0u; i < (uint8_t)VS_N_X; ++i) {
        vs_real s = (vs_real)0;
        for (j = 0u; j < (uint8_t)VS_N_X; ++j) {
#if defined(VS_NAIVE_UPDATE) /* benchmark peer only: the textbook x⁺ = A x + B u + G ν */
            s += (RD(&vs_M[i * VS_N_X + j]) + (vs_real)(i == j)) * o->x_hi[j];
#else
            s += RD(&vs_M[i * VS_N_X + j]) * o->x_hi[j];
#endif
        }
        for (j = 0u; j < (uint8_t)VS_N_U; ++j) {
            s += RD(&vs_B[i * VS_N_U + j]) * o->us[j];
        }
#if VS_N_Z > 0
        for (j = 0u; j < (uint8_t)VS_N_Z; ++j) {
            s += RD(&vs_G[i * VS_N_Z + j]) * o->nu[j];
        }
#endif
        o->d[i] = s;
    }
    /* x⁺ = x + d, compensated: TwoSum(x_hi, d + x_lo) keeps the rounding error in x_lo */
    for (i = 0u; i < (uint8_t)VS_N_X; ++i) {
#if defined(VS_NAIVE_UPDATE)
        o->x_hi[i] = o->d[i];
#elif defined(VS_NO_COMPENSATION) /* benchmark peer only: the plain float update */
        o->x_hi[i] += o->d[i];
#else
        vs_real a = o->x_hi[i];
        vs_real b = o->d[i] + o->x_lo[i];
        vs_real s = a + b;
        vs_real bb = s - a;
        vs_real e = (a - (s - bb)) + (b - bb);
        o->x_hi[i] = s;
        o->x_lo[i] = e;
#endif
    }
    o->n_rejected = 0u;
    o->last_status = (uint8_t)VS_OK;
    return VS_OK;
}
