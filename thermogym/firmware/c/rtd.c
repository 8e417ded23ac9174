/**
 * @file rtd.c
 * @brief Pt1000 RTD conversion: AD7794 code → resistance → temperature (see rtd.h).
 */
#include "rtd.h"

rtd_status rtd_default_config(rtd_adc_config *cfg)
{
    if (cfg == 0) {
        return RTD_ERR_ARG;
    }
    cfg->bits = 24u;
    cfg->bipolar = 1u;
    cfg->gain = (vs_real)2.0;
    cfg->r_ref = (vs_real)5110.0;
    cfg->r0 = (vs_real)1000.0;
    return RTD_OK;
}

static vs_real rtd_nan(void)
{
    volatile vs_real zero = (vs_real)0;
    return zero / zero;
}

/* 2^k as vs_real for 0 <= k <= 31, exact */
static vs_real rtd_pow2(uint8_t k)
{
    return (vs_real)((uint32_t)1u << k);
}

rtd_status rtd_code_to_resistance(const rtd_adc_config *cfg, uint32_t code, vs_real *r_ohm)
{
    uint32_t full;
    vs_real lsb;
    if (cfg == 0 || r_ohm == 0) {
        return RTD_ERR_ARG;
    }
    if (cfg->bits < 2u || cfg->bits > 31u || !(cfg->gain > (vs_real)0) ||
        !(cfg->r_ref > (vs_real)0) || !vs_is_finite(cfg->gain) || !vs_is_finite(cfg->r_ref)) {
        *r_ohm = rtd_nan();
        return RTD_ERR_CONFIG;
    }
    full = ((uint32_t)1u << cfg->bits) - 1u;
    if (code >= full) { /* full scale: the excitation path is open */
        *r_ohm = rtd_nan();
        return RTD_OPEN;
    }
    if (cfg->bipolar) {
        /* eq (1), bipolar: Code = 2^(N−1) (AIN·GAIN/V_ref + 1), V_ref = I R_ref, AIN = I R
         * ⇒ R = (Code − 2^(N−1)) · R_ref / (GAIN 2^(N−1)); the difference is an exact integer */
        uint32_t mid = (uint32_t)1u << (cfg->bits - 1u);
        if (code <= mid) { /* zero or negative input: the RTD is shorted */
            *r_ohm = rtd_nan();
            return RTD_SHORT;
        }
        lsb = cfg->r_ref / (cfg->gain * rtd_pow2((uint8_t)(cfg->bits - 1u)));
        *r_ohm = (vs_real)(code - mid) * lsb;
    } else {
        /* unipolar: Code = 2^N AIN·GAIN/V_ref ⇒ R = Code · R_ref / (GAIN 2^N) */
        if (code == 0u) {
            *r_ohm = rtd_nan();
            return RTD_SHORT;
        }
        lsb = cfg->r_ref / (cfg->gain * rtd_pow2(cfg->bits));
        *r_ohm = (vs_real)code * lsb;
    }
    return RTD_OK;
}

rtd_status rtd_resistance_to_temperature(vs_real r_ohm, vs_real r0_ohm, vs_real *t_degc)
{
    vs_real x, disc, t;
    if (t_degc == 0) {
        return RTD_ERR_ARG;
    }
    if (!vs_is_finite(r_ohm) || !vs_is_finite(r0_ohm)) {
        *t_degc = rtd_nan();
        return RTD_ERR_NAN;
    }
    if (!(r0_ohm > (vs_real)0)) {
        *t_degc = rtd_nan();
        return RTD_ERR_CONFIG;
    }
    if (!(r_ohm > (vs_real)0)) {
        *t_degc = rtd_nan();
        return RTD_SHORT;
    }
    /* x = R/R0 − 1 = A T + B T² (+ C (T − 100) T³ below 0 °C)                 eq (2) */
    x = (r_ohm - r0_ohm) / r0_ohm;
    disc = RTD_CVD_A * RTD_CVD_A + (vs_real)4.0 * RTD_CVD_B * x;
    if (disc < (vs_real)0) { /* beyond the parabola's vertex (≈ 3383 °C) */
        *t_degc = -RTD_CVD_A / ((vs_real)2.0 * RTD_CVD_B);
        return RTD_ABOVE_RANGE;
    }
    /* root of B T² + A T − x = 0 without cancellation: T = 2x / (A + √(A² + 4 B x)) */
    t = (vs_real)2.0 * x / (RTD_CVD_A + VS_SQRT(disc));
    if (t < (vs_real)0) {
        /* Newton on f(T) = A T + B T² + C (T − 100) T³ − x, 3 fixed steps (deterministic
         * run time); the quadratic root is within 0.03 K at −50 °C, each step squares
         * the relative error */
        uint8_t i;
        for (i = 0u; i < 3u; ++i) {
            vs_real t2 = t * t;
            vs_real f = RTD_CVD_A * t + RTD_CVD_B * t2 + RTD_CVD_C * (t - (vs_real)100.0) * t2 * t - x;
            vs_real df = RTD_CVD_A + (vs_real)2.0 * RTD_CVD_B * t +
                         RTD_CVD_C * ((vs_real)4.0 * t2 * t - (vs_real)300.0 * t2);
            t -= f / df;
        }
    }
    *t_degc = t;
    if (t < RTD_T_MIN) {
        return RTD_BELOW_RANGE;
    }
    if (t > RTD_T_MAX) {
        return RTD_ABOVE_RANGE;
    }
    return RTD_OK;
}

rtd_status rtd_code_to_temperature(const rtd_adc_config *cfg, uint32_t code, vs_real *t_degc)
{
    vs_real r;
    rtd_status st;
    if (cfg == 0 || t_degc == 0) {
        return RTD_ERR_ARG;
    }
    st = rtd_code_to_resistance(cfg, code, &r);
    if (st != RTD_OK) {
        *t_degc = rtd_nan();
        return st;
    }
    return rtd_resistance_to_temperature(r, cfg->r0, t_degc);
}

vs_real rtd_temperature_to_resistance(vs_real t_degc, vs_real r0_ohm)
{
    vs_real t2 = t_degc * t_degc;
    vs_real x = RTD_CVD_A * t_degc + RTD_CVD_B * t2;
    if (t_degc < (vs_real)0) {
        x += RTD_CVD_C * (t_degc - (vs_real)100.0) * t2 * t_degc;
    }
    return r0_ohm * ((vs_real)1.0 + x);
}
