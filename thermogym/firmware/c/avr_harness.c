/**
 * @file avr_harness.c
 * @brief ATmega328P test program for simavr: test vectors in flash, results over the UART.
 *
 * Runs the observer over the vectors of vs_vectors.h (written by
 * `thermogym firmware export --vectors`) and the RTD conversion over a set of
 * codes, compares with the Python reference and prints one line per test:
 *
 *   TGVS observer n=8 m=3 q=0 p=5 steps=200 max_err_udegC=12 status_mismatch=0
 *        cycles_max=40000 cycles_mean=39000 f_cpu=16000000
 *   TGVS rtd codes=64 max_err_udegC=30 status_mismatch=0 cycles_max=9000
 *   TGVS done
 *
 * Cycles are counted by Timer1 at the CPU clock (prescaler 1) with an overflow
 * interrupt; the interrupt's own ~60 cycles per 65536 are included. The
 * program ends with interrupts off and the CPU asleep, which stops simavr.
 *
 * With -DVS_TIMING_ONLY there are no vector tables (for a model that leaves no
 * flash for them): 16 steps on synthetic valid inputs are timed, errors are not
 * measured (max_err_udegC=0) and the RTD test is left out (codes=0).
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdint.h>

#include "rtd.h"
#include "vs_observer.h"
#ifdef VS_TIMING_ONLY
#define VSV_T 16
#define RTV_N 0
#else
#include "vs_vectors.h"
#endif

#ifndef F_CPU
#define F_CPU 16000000UL
#endif

static volatile uint16_t overflows;
ISR(TIMER1_OVF_vect) { ++overflows; }

static vs_observer obs;
static rtd_adc_config cfg;

static void uart_init(void)
{
    UBRR0H = 0;
    UBRR0L = (uint8_t)(F_CPU / 16UL / 38400UL - 1UL);
    UCSR0B = (uint8_t)(1u << TXEN0);
    UCSR0C = (uint8_t)((1u << UCSZ01) | (1u << UCSZ00));
}

static void uart_putc(char c)
{
    while (!(UCSR0A & (1u << UDRE0))) {
    }
    UDR0 = (uint8_t)c;
}

static void uart_puts(const char *s)
{
    while (*s) {
        uart_putc(*s++);
    }
}

static void uart_putu(uint32_t v)
{
    char buf[11];
    uint8_t i = 0u;
    do {
        buf[i++] = (char)('0' + (v % 10u));
        v /= 10u;
    } while (v && i < sizeof buf);
    while (i) {
        uart_putc(buf[--i]);
    }
}

static void timer_start(void)
{
    TCCR1A = 0;
    TCCR1B = 0;
    TCNT1 = 0;
    overflows = 0;
    TIFR1 = (uint8_t)(1u << TOV1);
    TCCR1B = (uint8_t)(1u << CS10); /* clock / 1 */
}

static uint32_t timer_stop(void)
{
    uint16_t t = TCNT1;
    TCCR1B = 0;
    if (TIFR1 & (1u << TOV1)) { /* an overflow not yet serviced */
        TIFR1 = (uint8_t)(1u << TOV1);
        ++overflows;
    }
    return ((uint32_t)overflows << 16) | t;
}

#ifndef VS_TIMING_ONLY
/* |a − b| in micro-degrees, saturating */
static uint32_t err_u(vs_real a, vs_real b)
{
    vs_real e = a - b;
    if (e < 0) {
        e = -e;
    }
    if (!(e < (vs_real)4000.0)) {
        return 0xFFFFFFFFUL;
    }
    return (uint32_t)(e * (vs_real)1e6 + (vs_real)0.5);
}
#endif

int main(void)
{
    vs_real u[VS_N_U], z[VS_N_Z + 1], y[VS_N_Y], t;
    uint32_t cyc, cyc_max = 0, worst = 0, e;
    uint32_t cyc_sum_lo = 0, cyc_sum_hi = 0;
    uint16_t k, mism = 0;
    uint8_t j;
    int st;

    uart_init();
    TIMSK1 = (uint8_t)(1u << TOIE1);
    sei();

    vs_init(&obs);
#ifdef VS_TIMING_ONLY
    for (j = 0; j < VS_N_U; ++j) {
        u[j] = (vs_real)(20 + j);
    }
    for (j = 0; j < VS_N_Z + 1; ++j) {
        z[j] = (vs_real)(25 + j);
    }
#else
    for (j = 0; j < VS_N_U; ++j) {
        u[j] = vs_rom_read(&vsv_reset_u[j]);
    }
#if VS_N_Z > 0
    for (j = 0; j < VS_N_Z; ++j) {
        z[j] = vs_rom_read(&vsv_reset_z[j]);
    }
#endif
#endif
    vs_reset(&obs, u, z);
    for (k = 0; k < VSV_T; ++k) {
#ifdef VS_TIMING_ONLY
        u[0] += (vs_real)1; /* synthetic, always valid */
#else
        for (j = 0; j < VS_N_U; ++j) {
            u[j] = vs_rom_read(&vsv_u[(uint32_t)k * VS_N_U + j]);
        }
#if VS_N_Z > 0
        for (j = 0; j < VS_N_Z; ++j) {
            z[j] = vs_rom_read(&vsv_z[(uint32_t)k * VS_N_Z + j]);
        }
#endif
#endif
        timer_start();
        st = (int)vs_step(&obs, u, z, y);
        cyc = timer_stop();
        if (cyc > cyc_max) {
            cyc_max = cyc;
        }
        cyc_sum_lo += cyc;
        if (cyc_sum_lo < cyc) {
            ++cyc_sum_hi;
        }
#ifdef VS_TIMING_ONLY
        if (st != (int)VS_OK) {
            ++mism;
        }
        (void)e;
#else
        if ((uint8_t)st != pgm_read_byte(&vsv_status[k])) {
            ++mism;
        }
        for (j = 0; j < VS_N_Y; ++j) {
            e = err_u(y[j], vs_rom_read(&vsv_y[(uint32_t)k * VS_N_Y + j]));
            if (e > worst) {
                worst = e;
            }
        }
#endif
    }
    uart_puts("TGVS observer n=");
    uart_putu(VS_N_X);
    uart_puts(" m=");
    uart_putu(VS_N_U);
    uart_puts(" q=");
    uart_putu(VS_N_Z);
    uart_puts(" p=");
    uart_putu(VS_N_Y);
    uart_puts(" steps=");
    uart_putu(VSV_T);
    uart_puts(" max_err_udegC=");
    uart_putu(worst);
    uart_puts(" status_mismatch=");
    uart_putu(mism);
    uart_puts(" cycles_max=");
    uart_putu(cyc_max);
    uart_puts(" cycles_mean=");
    uart_putu(cyc_sum_hi ? 0xFFFFFFFFUL : cyc_sum_lo / VSV_T);
    uart_puts(" f_cpu=");
    uart_putu(F_CPU);
    uart_puts("\r\n");

    rtd_default_config(&cfg);
    worst = 0;
    mism = 0;
    cyc_max = 0;
    (void)t;
#if RTV_N > 0
    for (k = 0; k < RTV_N; ++k) {
        timer_start();
        st = (int)rtd_code_to_temperature(&cfg, pgm_read_dword(&rtv_code[k]), &t);
        cyc = timer_stop();
        if (cyc > cyc_max) {
            cyc_max = cyc;
        }
        if ((uint8_t)st != pgm_read_byte(&rtv_status[k])) {
            ++mism;
        }
        if (st == RTD_OK) {
            e = err_u(t, vs_rom_read(&rtv_t[k]));
            if (e > worst) {
                worst = e;
            }
        }
    }
#endif
    uart_puts("TGVS rtd codes=");
    uart_putu(RTV_N);
    uart_puts(" max_err_udegC=");
    uart_putu(worst);
    uart_puts(" status_mismatch=");
    uart_putu(mism);
    uart_puts(" cycles_max=");
    uart_putu(cyc_max);
    uart_puts("\r\nTGVS done\r\n");
    while (!(UCSR0A & (1u << TXC0))) {
    }
    cli();
    set_sleep_mode(SLEEP_MODE_PWR_DOWN);
    sleep_enable();
    sleep_cpu();
    for (;;) {
    }
}
