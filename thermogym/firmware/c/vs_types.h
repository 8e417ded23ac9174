/**
 * @file vs_types.h
 * @brief Number type and read-only-memory access shared by the sensor-module firmware.
 *
 * Part of the thermogym sensor-module firmware (thermogym/firmware/c). C99.
 *
 * - @c vs_real is the floating-point type of every computation; it is
 *   @c float (IEEE 754 binary32) unless @c VS_FLOAT is defined, e.g.
 *   @c -DVS_FLOAT=double on a host for a double-precision reference run.
 *   On the ATmega328P (avr-gcc) @c double is 32 bits as well.
 * - Constant tables (model matrices, test vectors) live in flash on AVR
 *   (@c PROGMEM, read with @c pgm_read_float) and in ordinary read-only
 *   memory elsewhere; @c VS_ROM marks them and vs_rom_read() reads one value.
 *
 * The observer's compensated state update needs IEEE rounding: never compile
 * these sources with @c -ffast-math (an @c #error says so).
 */
#ifndef VS_TYPES_H
#define VS_TYPES_H

#include <stdint.h>

#if defined(__FAST_MATH__)
#error "thermogym firmware: do not compile with -ffast-math (the compensated state update needs IEEE rounding)"
#endif

#ifndef VS_FLOAT
#define VS_FLOAT float
#endif

/** Floating-point type of the firmware (float32 by default). */
typedef VS_FLOAT vs_real;

#ifndef VS_SQRT
#include <math.h>
/** Square root in @c vs_real (sqrtf for float; define VS_SQRT for other types). */
#define VS_SQRT(x) ((vs_real)sqrt((double)(x)))
#endif

#if defined(__AVR__)
#include <avr/pgmspace.h>
/** Place a constant table in flash. */
#define VS_ROM PROGMEM
/* C99 has no static_assert: a negative array size fails the build instead. */
typedef char vs_real_is_32_bits_on_avr[(sizeof(vs_real) == 4) ? 1 : -1];
/**
 * @brief Read one @c vs_real from a table marked @c VS_ROM.
 * @param[in] p address of the value in flash
 * @return the value
 */
static inline vs_real vs_rom_read(const vs_real *p) { return (vs_real)pgm_read_float(p); }
#else
#define VS_ROM
/**
 * @brief Read one @c vs_real from a table marked @c VS_ROM (plain memory off AVR).
 * @param[in] p address of the value
 * @return the value
 */
static inline vs_real vs_rom_read(const vs_real *p) { return *p; }
#endif

/**
 * @brief Whether @p v is a finite number (not NaN, not infinite).
 *
 * Written without isfinite() so that it works for any @c vs_real and on
 * avr-libc: NaN compares unequal to itself and inf − inf is NaN.
 * @param[in] v value
 * @return 1 when finite, 0 otherwise
 */
static inline int vs_is_finite(vs_real v)
{
    volatile vs_real d = v - v; /* volatile: keep the test exact under optimisation */
    return (v == v) && (d == (vs_real)0);
}

#endif /* VS_TYPES_H */
