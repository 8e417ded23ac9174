/**
 * @file avr_probe.c
 * @brief Minimal ATmega328P program whose size is the observer's footprint.
 *
 * One observer instance and one RTD configuration as static objects, one call of
 * each entry point on inputs the compiler cannot predict (volatile), nothing else:
 * `avr-size` of this program gives the flash (.text + .data) and static RAM
 * (.data + .bss) the virtual sensor adds to a firmware, C runtime included.
 */
#include <stdint.h>

#include "rtd.h"
#include "vs_observer.h"

static vs_observer obs;
static rtd_adc_config cfg;
volatile vs_real probe_in;
volatile uint32_t probe_code;
volatile vs_real probe_out;

int main(void)
{
    vs_real u[VS_N_U], z[VS_N_Z + 1], y[VS_N_Y], t;
    uint8_t j;
    rtd_default_config(&cfg);
    vs_init(&obs);
    for (j = 0; j < VS_N_U; ++j) {
        u[j] = probe_in;
    }
    z[0] = probe_in;
#if VS_N_Z > 0
    for (j = 0; j < VS_N_Z; ++j) {
        z[j] = probe_in;
    }
#endif
    vs_reset(&obs, u, z);
    for (;;) {
        for (j = 0; j < VS_N_U; ++j) {
            u[j] = probe_in;
        }
#if VS_N_Z > 0
        for (j = 0; j < VS_N_Z; ++j) {
            z[j] = probe_in;
        }
#endif
        (void)rtd_code_to_temperature(&cfg, probe_code, &t);
        (void)vs_step(&obs, u, z, y);
        probe_out = y[0] + t;
    }
}
