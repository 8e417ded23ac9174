/**
 * @file vs_observer.h
 * @brief Virtual-sensor observer: internal temperatures from surface temperatures.
 *
 * The steady-state Kalman observer of an identified linear model (paper
 * 001_6d13a2cd04f5de5e.txt, abstract and section 3.3: the model is written into
 * the firmware of the sensor module so that it computes the spindle's internal
 * temperatures from its surface temperatures). The model and its gains come
 * from the generated header vs_model.h (`thermogym firmware export`), which
 * fixes every buffer size at compile time: no dynamic memory, no recursion.
 *
 * One step per sample (k), in the scaled coordinates of vs_model.h:
 * @code
 *   ν      = z − Cz x − Dz u                 innovation of the measured channels
 *   ŷ      = Ch x + Dh u + F ν               hidden estimate ŷ[k|k]
 *   x⁺     = x + (M x + B u + G ν),  M = A − I
 * @endcode
 * The state is kept as an unevaluated sum x_hi + x_lo and the increment is
 * added with Knuth's TwoSum: with thermal time constants of hours sampled
 * every second, A ≈ I − 1e-4 and a plain float32 update x⁺ = A x stalls up
 * to (τ/Δt)·eps·|x| ≈ 0.1 K away from the true fixed point; the increment
 * form with the compensated sum keeps the float32 result within 1e-4 K of a
 * double-precision run over a day (measured by the host test).
 *
 * Invalid input (NaN, infinite or outside the channel's range in vs_model.h)
 * is rejected: the state does not move, the last valid estimate is returned
 * and the status names the problem.
 */
#ifndef VS_OBSERVER_H
#define VS_OBSERVER_H

#include <stdint.h>

#include "vs_model.h"
#include "vs_types.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Outcome of an observer call (the Python twin uses the same codes). */
typedef enum {
    VS_OK = 0,            /**< sample used */
    VS_ERR_ARG = 1,       /**< a NULL pointer */
    VS_ERR_NAN = 2,       /**< a channel is NaN or infinite: estimate held */
    VS_ERR_RANGE = 3,     /**< a channel is out of range: estimate held */
    VS_ERR_NOT_READY = 4, /**< vs_init() was not called */
    VS_ERR_NO_RESET = 5   /**< the model has no rest state (integrating mode) */
} vs_status;

/** One observer instance; all buffers sized at compile time by vs_model.h. */
typedef struct {
    vs_real x_hi[VS_N_X];   /**< state estimate x̂[k|k−1], leading part (scaled units) */
    vs_real x_lo[VS_N_X];   /**< state estimate, compensation part (TwoSum error) */
    vs_real y[VS_N_Y];      /**< last valid hidden estimate [units of vs_model.h, e.g. °C] */
    vs_real us[VS_N_U];     /**< scratch: scaled exogenous inputs */
#if VS_N_Z > 0
    vs_real nu[VS_N_Z];     /**< scratch: innovation (scaled units) */
#endif
    vs_real d[VS_N_X];      /**< scratch: state increment */
    uint16_t magic;         /**< set by vs_init() */
    uint16_t n_rejected;    /**< samples rejected since the last valid one (saturates) */
    uint8_t bad_channel;    /**< first bad channel of the last rejected sample (u: 0.., z: VS_N_U..) */
    uint8_t last_status;    /**< vs_status of the last call */
} vs_observer;

/**
 * @brief Initialise an instance: state at the model's operating point (offsets
 *        of vs_model.h), estimate at the output offsets.
 * @param[out] o instance
 * @return VS_OK or VS_ERR_ARG
 */
vs_status vs_init(vs_observer *o);

/**
 * @brief Start at the observer's equilibrium for constant readings (u, z): a
 *        machine at rest. The state is unchanged when a reading is invalid.
 * @param[in,out] o instance (after vs_init())
 * @param[in] u exogenous channels [VS_N_U], physical units (e.g. rpm, °C)
 * @param[in] z measured channels [VS_N_Z], physical units (NULL when VS_N_Z is 0)
 * @return VS_OK, VS_ERR_NAN, VS_ERR_RANGE, VS_ERR_NO_RESET, VS_ERR_NOT_READY or VS_ERR_ARG
 */
vs_status vs_reset(vs_observer *o, const vs_real u[], const vs_real z[]);

/**
 * @brief Use one sample: write the hidden estimate ŷ[k|k], advance to k + 1.
 * @param[in,out] o instance (after vs_init())
 * @param[in] u exogenous channels [VS_N_U] at sample k, physical units
 * @param[in] z measured channels [VS_N_Z] at sample k, physical units (NULL when VS_N_Z is 0)
 * @param[out] y hidden estimates [VS_N_Y], physical units; on a rejected sample the
 *             last valid estimate
 * @return VS_OK, VS_ERR_NAN or VS_ERR_RANGE (estimate held), VS_ERR_NOT_READY or VS_ERR_ARG
 */
vs_status vs_step(vs_observer *o, const vs_real u[], const vs_real z[], vs_real y[]);

#ifdef __cplusplus
}
#endif

#endif /* VS_OBSERVER_H */
