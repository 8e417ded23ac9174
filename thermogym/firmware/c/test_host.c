/**
 * @file test_host.c
 * @brief Host test: the C observer and RTD conversion against the Python reference.
 *
 * Usage: test_host OBSERVER_VECTORS [RTD_VECTORS]
 *
 * The vector files are written by `thermogym firmware export --vectors` (little-endian
 * binary, see thermogym/firmware/export.py). The observer file holds the rest-state
 * readings and, per sample, the inputs, measurements, the Python observer's estimate
 * (double precision) and its status; the RTD file holds ADC codes with the Python
 * reference temperature (root search on DIN EN 60751) and status. Exit status 0 when
 * every estimate is within the file's tolerance and every status agrees.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rtd.h"
#include "vs_observer.h"

static int read_exact(FILE *f, void *buf, size_t n)
{
    return fread(buf, 1, n, f) == n;
}

static int read_doubles(FILE *f, double *buf, size_t n)
{
    return n == 0 || fread(buf, sizeof(double), n, f) == n;
}

static int test_observer(const char *path)
{
    FILE *f = fopen(path, "rb");
    char magic[8];
    int32_t dims[5]; /* T, n, m, q, p */
    double tol, reset_u[VS_N_U + 1], reset_z[VS_N_Z + 1];
    double u[VS_N_U + 1], z[VS_N_Z + 1], yref[VS_N_Y], status;
    vs_real uf[VS_N_U + 1], zf[VS_N_Z + 1], y[VS_N_Y];
    vs_observer obs;
    double max_err = 0.0, err;
    long worst_k = -1, mismatches = 0, rejected = 0, k;
    int j, st;
    if (f == NULL) {
        fprintf(stderr, "observer: cannot open %s\n", path);
        return 1;
    }
    if (!read_exact(f, magic, 8) || memcmp(magic, "TGVSOBS1", 8) != 0 ||
        !read_exact(f, dims, sizeof dims) || !read_doubles(f, &tol, 1)) {
        fprintf(stderr, "observer: %s is not a thermogym observer vector file\n", path);
        fclose(f);
        return 1;
    }
    if (dims[1] != VS_N_X || dims[2] != VS_N_U || dims[3] != VS_N_Z || dims[4] != VS_N_Y) {
        fprintf(stderr,
                "observer: vectors are for n=%d m=%d q=%d p=%d, vs_model.h has n=%d m=%d q=%d p=%d\n",
                (int)dims[1], (int)dims[2], (int)dims[3], (int)dims[4], VS_N_X, VS_N_U, VS_N_Z,
                VS_N_Y);
        fclose(f);
        return 1;
    }
    if (!read_doubles(f, reset_u, VS_N_U) || !read_doubles(f, reset_z, VS_N_Z)) {
        fprintf(stderr, "observer: %s is truncated\n", path);
        fclose(f);
        return 1;
    }
    for (j = 0; j < VS_N_U; ++j) {
        uf[j] = (vs_real)reset_u[j];
    }
    for (j = 0; j < VS_N_Z; ++j) {
        zf[j] = (vs_real)reset_z[j];
    }
    if (vs_init(&obs) != VS_OK || vs_reset(&obs, uf, zf) != VS_OK) {
        fprintf(stderr, "observer: vs_init/vs_reset failed\n");
        fclose(f);
        return 1;
    }
    for (k = 0; k < dims[0]; ++k) {
        if (!read_doubles(f, u, VS_N_U) || !read_doubles(f, z, VS_N_Z) ||
            !read_doubles(f, yref, VS_N_Y) || !read_doubles(f, &status, 1)) {
            fprintf(stderr, "observer: %s is truncated at sample %ld\n", path, k);
            fclose(f);
            return 1;
        }
        for (j = 0; j < VS_N_U; ++j) {
            uf[j] = (vs_real)u[j];
        }
        for (j = 0; j < VS_N_Z; ++j) {
            zf[j] = (vs_real)z[j];
        }
        st = (int)vs_step(&obs, uf, zf, y);
        if (st != (int)status) {
            if (mismatches < 5) {
                fprintf(stderr, "observer: sample %ld status %d, Python %d\n", k, st, (int)status);
            }
            ++mismatches;
        }
        if (st != VS_OK) {
            ++rejected;
        }
        for (j = 0; j < VS_N_Y; ++j) {
            err = fabs((double)y[j] - yref[j]);
            if (!(err <= max_err)) { /* also catches NaN */
                max_err = err;
                worst_k = k;
            }
        }
    }
    fclose(f);
    printf("observer: %ld samples (%ld rejected), n=%d m=%d q=%d p=%d, float %u bytes: "
           "max |y_C - y_Python| = %.3e (tolerance %.1e) at sample %ld; status mismatches %ld\n",
           (long)dims[0], rejected, VS_N_X, VS_N_U, VS_N_Z, VS_N_Y, (unsigned)sizeof(vs_real),
           max_err, tol, worst_k, mismatches);
    return (max_err <= tol && mismatches == 0) ? 0 : 1;
}

static int test_rtd(const char *path)
{
    FILE *f = fopen(path, "rb");
    char magic[8];
    int32_t head[3]; /* count, bits, bipolar */
    double par[4];   /* gain, r_ref, r0, tolerance */
    double rec[3];   /* code, status, temperature */
    rtd_adc_config cfg;
    double max_err = 0.0, err, worst_t = 0.0;
    long k, mismatches = 0, compared = 0;
    vs_real t;
    int st;
    if (f == NULL) {
        fprintf(stderr, "rtd: cannot open %s\n", path);
        return 1;
    }
    if (!read_exact(f, magic, 8) || memcmp(magic, "TGVSRTD1", 8) != 0 ||
        !read_exact(f, head, sizeof head) || !read_doubles(f, par, 4)) {
        fprintf(stderr, "rtd: %s is not a thermogym RTD vector file\n", path);
        fclose(f);
        return 1;
    }
    cfg.bits = (uint8_t)head[1];
    cfg.bipolar = (uint8_t)head[2];
    cfg.gain = (vs_real)par[0];
    cfg.r_ref = (vs_real)par[1];
    cfg.r0 = (vs_real)par[2];
    for (k = 0; k < head[0]; ++k) {
        if (!read_doubles(f, rec, 3)) {
            fprintf(stderr, "rtd: %s is truncated at item %ld\n", path, k);
            fclose(f);
            return 1;
        }
        st = (int)rtd_code_to_temperature(&cfg, (uint32_t)rec[0], &t);
        if (st != (int)rec[1]) {
            if (mismatches < 5) {
                fprintf(stderr, "rtd: code %.0f status %d, Python %d (T_C %.6f, T_Python %.6f)\n",
                        rec[0], st, (int)rec[1], (double)t, rec[2]);
            }
            ++mismatches;
        }
        if (rec[2] == rec[2]) { /* a reference temperature exists */
            err = fabs((double)t - rec[2]);
            ++compared;
            if (!(err <= max_err)) {
                max_err = err;
                worst_t = rec[2];
            }
        }
    }
    fclose(f);
    printf("rtd: %ld codes (%ld with a temperature): max |T_C - T_Python| = %.3e degC "
           "(tolerance %.1e) at %.3f degC; status mismatches %ld\n",
           (long)head[0], compared, max_err, par[3], worst_t, mismatches);
    return (max_err <= par[3] && mismatches == 0) ? 0 : 1;
}

int main(int argc, char **argv)
{
    int fail = 0;
    if (argc < 2) {
        fprintf(stderr, "usage: %s OBSERVER_VECTORS [RTD_VECTORS]\n", argv[0]);
        return 2;
    }
    fail |= test_observer(argv[1]);
    if (argc > 2) {
        fail |= test_rtd(argv[2]);
    }
    printf("%s\n", fail ? "FAIL" : "PASS");
    return fail;
}
