/* The C floor of benchmarks/bench.py: a plain DOP853 loop in C, for timing only.
 *
 * The same method and step-size control as lagrangian's compiled integrator (and SciPy's
 * solve_ivp(method="DOP853")): Hairer, Norsett and Wanner's 8(5,3) pair, the initial step of
 * their section II.4, step factor 0.9 err^(-1/8) within [0.2, 10]. No dense output: it returns
 * the state at t_end only. The model's right-hand side is lagrangian's generated C (lg_rhs, with
 * its LDL^T solve), included at compile time; the stages are written out with their coefficients
 * in dop853_stages.h, which bench.py generates from SciPy's table.
 *
 * Build (bench.py does this):  gcc -O2 -DN=<n> -DMODEL='"model.c"' -I<dir> dop853.c -lm
 * Run:  ./a.out t_end rtol atol repeats x0_1 .. x0_2n p_1 .. p_k
 * Prints: median CPU seconds per integration, nfev, steps, then the final state.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include MODEL

#define NX (2 * N)

static long nfev;

static double rhs(double t, const double *x, const double *p, double *dx, double *work) {
    double u[1] = {0.0};
    nfev++;
    return lg_rhs(t, (double *)x, u, (double *)p, dx, work);
}

#include "dop853_stages.h" /* dop_stages(), dop_errors() */

static double rms(const double *a, const double *s) {
    double acc = 0.0;
    for (int i = 0; i < NX; i++) acc += (a[i] / s[i]) * (a[i] / s[i]);
    return sqrt(acc / NX);
}

/* Integrate from t = 0 to t_end; y is overwritten by the final state. Returns 0 on success. */
static int integrate(double t_end, double *y, double rtol, double atol, const double *p, long *steps) {
    double K[16][NX], ynew[NX], xs[NX], sc[NX], work[N * N + 2 * N];
    double t = 0.0, h_abs, r;
    *steps = 0;
    if (rhs(t, y, p, K[0], work) <= 1e-12) return 2;
    for (int i = 0; i < NX; i++) sc[i] = atol + fabs(y[i]) * rtol;
    double d0 = rms(y, sc), d1 = rms(K[0], sc);
    double h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    if (h0 > t_end) h0 = t_end;
    for (int i = 0; i < NX; i++) xs[i] = y[i] + h0 * K[0][i];
    if (rhs(t + h0, xs, p, K[1], work) <= 1e-12) return 2;
    for (int i = 0; i < NX; i++) ynew[i] = K[1][i] - K[0][i];
    double d2 = rms(ynew, sc) / h0, h1;
    if (d1 <= 1e-15 && d2 <= 1e-15) h1 = fmax(1e-6, h0 * 1e-3);
    else h1 = pow(0.01 / fmax(d1, d2), 1.0 / 8.0);
    h_abs = fmin(fmin(100.0 * h0, h1), t_end);
    while (t < t_end) {
        double min_step = 10.0 * fabs(nextafter(t, INFINITY) - t);
        if (h_abs < min_step) h_abs = min_step;
        int rejected = 0;
        double h_next;
        for (;;) {
            if (h_abs < min_step) return -1;
            double t_new = t + h_abs;
            if (t_new > t_end) t_new = t_end;
            double h = t_new - t;
            h_abs = fabs(h);
            if (dop_stages(t, h, y, K, xs, ynew, p, work, &r)) return 2;
            double e5, e3, err;
            dop_errors(K, y, ynew, rtol, atol, &e5, &e3);
            err = (e5 == 0.0 && e3 == 0.0) ? 0.0 : h_abs * e5 / sqrt((e5 + 0.01 * e3) * NX);
            if (err < 1.0) {
                double factor = err == 0.0 ? 10.0 : fmin(10.0, 0.9 * pow(err, -1.0 / 8.0));
                if (rejected) factor = fmin(1.0, factor);
                h_next = h_abs * factor;
                t = t_new;
                break;
            }
            h_abs *= fmax(0.2, 0.9 * pow(err, -1.0 / 8.0));
            rejected = 1;
        }
        (*steps)++;
        for (int i = 0; i < NX; i++) {
            y[i] = ynew[i];
            K[0][i] = K[12][i];
        }
        h_abs = h_next;
    }
    return 0;
}

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    if (argc < 5 + NX) {
        fprintf(stderr, "usage: %s t_end rtol atol repeats x0[%d] p...\n", argv[0], NX);
        return 2;
    }
    double t_end = atof(argv[1]), rtol = atof(argv[2]), atol = atof(argv[3]);
    int repeats = atoi(argv[4]);
    double x0[NX], y[NX], p[64];
    for (int i = 0; i < NX; i++) x0[i] = atof(argv[5 + i]);
    int np = argc - 5 - NX;
    for (int i = 0; i < np && i < 64; i++) p[i] = atof(argv[5 + NX + i]);
    double *times = malloc(sizeof(double) * (repeats > 0 ? repeats : 1));
    long steps = 0, fev = 0;
    int status = 0;
    for (int k = 0; k < repeats; k++) {
        struct timespec a, b;
        for (int i = 0; i < NX; i++) y[i] = x0[i];
        nfev = 0;
        clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &a);
        status = integrate(t_end, y, rtol, atol, p, &steps);
        clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &b);
        times[k] = (b.tv_sec - a.tv_sec) + 1e-9 * (b.tv_nsec - a.tv_nsec);
        fev = nfev;
    }
    qsort(times, repeats, sizeof(double), cmp);
    printf("%.9g %ld %ld %d", times[repeats / 2], fev, steps, status);
    for (int i = 0; i < NX; i++) printf(" %.17g", y[i]);
    printf("\n");
    free(times);
    return 0;
}
