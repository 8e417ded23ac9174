/**
 * @file rtd.h
 * @brief Pt1000 RTD conversion of the sensor module: AD7794 code → resistance → temperature.
 *
 * Paper 001_6d13a2cd04f5de5e.txt, section 2.1: each RTD is read in a 4-wire,
 * ratiometric set-up by an AD7794 (24-bit sigma-delta ADC, gain 2, 210 µA
 * excitation, 4.17 Hz). Assumptions (configurable through rtd_adc_config):
 *
 * - Ratiometric reference: the excitation current also flows through a
 *   precision reference resistor R_ref whose voltage is the ADC reference,
 *   V_ref = I·R_ref, and AIN = I·R_RTD, so the current cancels:
 *   R_RTD = (AIN / V_ref)·R_ref. Default R_ref = 5110 Ω (0.1 %, E96): with
 *   gain 2 the input range ends at R_ref/2 = 2555 Ω, above Pt1000 at 300 °C
 *   (2120.5 Ω).
 * - Transfer function, eq (1) of the paper, "Code = 2^N (AIN·GAIN/V_ref + 1)":
 *   this is the AD7794 datasheet's *bipolar* code with 2^N standing for
 *   2^(N−1) of the N = 24-bit converter (the literal 2^24 would put every
 *   positive input outside the 24-bit code range). Bipolar (default):
 *   R = (Code/2^(N−1) − 1)·R_ref/GAIN; unipolar: R = Code·R_ref/(2^N·GAIN).
 * - Resistance to temperature: DIN EN 60751 / IEC 60751 (Callendar-Van Dusen),
 *   eq (2): R(T) = R0(1 + A T + B T²) for T >= 0 °C, inverted exactly with the
 *   quadratic formula in its cancellation-free form; for T < 0 °C the standard
 *   adds C (T − 100) T³ and the inverse is 3 Newton steps from the quadratic
 *   root (error below 1e-6 K in exact arithmetic over −50..0 °C).
 *   A = 3.9083e-3 /°C, B = −5.775e-7 /°C², C = −4.183e-12 /°C⁴, R0 = 1000 Ω.
 * - Range: the module's −50..300 °C (paper Table 2); outside it the status
 *   says so (the computed value is still written). A code at full scale is an
 *   open circuit, a code at or below zero input a short circuit (NaN written).
 */
#ifndef RTD_H
#define RTD_H

#include <stdint.h>

#include "vs_types.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Callendar-Van Dusen coefficient A [1/°C] (DIN EN 60751). */
#define RTD_CVD_A ((vs_real)3.9083e-3)
/** Callendar-Van Dusen coefficient B [1/°C²] (DIN EN 60751). */
#define RTD_CVD_B ((vs_real)-5.775e-7)
/** Callendar-Van Dusen coefficient C [1/°C⁴], T < 0 °C only (DIN EN 60751). */
#define RTD_CVD_C ((vs_real)-4.183e-12)
/** Lower end of the module's measurement range [°C] (paper 001, Table 2). */
#define RTD_T_MIN ((vs_real)-50.0)
/** Upper end of the module's measurement range [°C] (paper 001, Table 2). */
#define RTD_T_MAX ((vs_real)300.0)

/** Outcome of an RTD conversion. */
typedef enum {
    RTD_OK = 0,           /**< converted, inside −50..300 °C */
    RTD_ERR_ARG = 1,      /**< a NULL pointer */
    RTD_ERR_NAN = 2,      /**< the input is NaN or infinite */
    RTD_BELOW_RANGE = 3,  /**< converted, but below RTD_T_MIN */
    RTD_ABOVE_RANGE = 4,  /**< converted, but above RTD_T_MAX */
    RTD_OPEN = 5,         /**< ADC code at full scale: open circuit (NaN written) */
    RTD_SHORT = 6,        /**< zero or negative input: short circuit (NaN written) */
    RTD_ERR_CONFIG = 7    /**< invalid converter configuration */
} rtd_status;

/** Converter set-up of one channel. */
typedef struct {
    uint8_t bits;     /**< converter resolution N [bit], 24 for the AD7794 */
    uint8_t bipolar;  /**< 1: bipolar coding (offset binary), 0: unipolar */
    vs_real gain;     /**< PGA gain [1], 2 in paper 001 */
    vs_real r_ref;    /**< reference resistor [Ω] */
    vs_real r0;       /**< RTD resistance at 0 °C [Ω], 1000 for Pt1000 */
} rtd_adc_config;

/**
 * @brief The set-up of paper 001: 24 bit, bipolar, gain 2, R_ref 5110 Ω, Pt1000.
 * @param[out] cfg configuration to fill
 * @return RTD_OK, or RTD_ERR_ARG for a NULL pointer
 */
rtd_status rtd_default_config(rtd_adc_config *cfg);

/**
 * @brief AD7794 code → RTD resistance (eq 1, ratiometric).
 * @param[in] cfg converter set-up
 * @param[in] code raw conversion result, 0 .. 2^N − 1
 * @param[out] r_ohm resistance [Ω] (NaN for an open or short circuit)
 * @return RTD_OK, RTD_OPEN, RTD_SHORT, RTD_ERR_CONFIG or RTD_ERR_ARG
 */
rtd_status rtd_code_to_resistance(const rtd_adc_config *cfg, uint32_t code, vs_real *r_ohm);

/**
 * @brief Resistance → temperature by the inverse Callendar-Van Dusen relation (eq 2).
 * @param[in] r_ohm RTD resistance [Ω]
 * @param[in] r0_ohm resistance at 0 °C [Ω]
 * @param[out] t_degc temperature [°C] (written also when out of range)
 * @return RTD_OK, RTD_BELOW_RANGE, RTD_ABOVE_RANGE, RTD_SHORT (r <= 0),
 *         RTD_ERR_NAN or RTD_ERR_ARG
 */
rtd_status rtd_resistance_to_temperature(vs_real r_ohm, vs_real r0_ohm, vs_real *t_degc);

/**
 * @brief AD7794 code → temperature: rtd_code_to_resistance() then
 *        rtd_resistance_to_temperature().
 * @param[in] cfg converter set-up
 * @param[in] code raw conversion result
 * @param[out] t_degc temperature [°C] (NaN for an open or short circuit)
 * @return the status of the failing stage, or of the temperature range check
 */
rtd_status rtd_code_to_temperature(const rtd_adc_config *cfg, uint32_t code, vs_real *t_degc);

/**
 * @brief Temperature → resistance by the Callendar-Van Dusen relation (eq 2).
 * @param[in] t_degc temperature [°C]
 * @param[in] r0_ohm resistance at 0 °C [Ω]
 * @return resistance [Ω]
 */
vs_real rtd_temperature_to_resistance(vs_real t_degc, vs_real r0_ohm);

#ifdef __cplusplus
}
#endif

#endif /* RTD_H */
