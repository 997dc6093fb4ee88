/* A compiled model's right-hand side (ph_rhs of its shared library), timed in C: the thread's
 * CPU time per call, the minimum over rounds of many calls. Used by benchmarks/bench_pinocchio.py,
 * which writes the state and parameters (one number per line: n, x[0..n), m, p[0..m)). */
#define _POSIX_C_SOURCE 199309L
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static double cpu_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

int main(int argc, char **argv)
{
    if (argc < 4) { fprintf(stderr, "usage: model_rhs LIBRARY STATE REPS\n"); return 2; }
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) { fprintf(stderr, "%s\n", dlerror()); return 1; }
    void (*rhs)(double, const double *, const double *, double *) =
        (void (*)(double, const double *, const double *, double *))dlsym(lib, "ph_rhs");
    FILE *f = fopen(argv[2], "r");
    int n, m;
    if (!rhs || !f || fscanf(f, "%d", &n) != 1) return 1;
    double *x = malloc(sizeof(double) * n), *out = malloc(sizeof(double) * n);
    for (int i = 0; i < n; ++i) if (fscanf(f, "%lf", x + i) != 1) return 1;
    if (fscanf(f, "%d", &m) != 1) return 1;
    double *p = malloc(sizeof(double) * (m > 0 ? m : 1));
    for (int i = 0; i < m; ++i) if (fscanf(f, "%lf", p + i) != 1) return 1;
    fclose(f);
    const int reps = atoi(argv[3]);
    double best = 1e9;
    for (int r = 0; r < 30; ++r) {
        const double t0 = cpu_now();
        for (int k = 0; k < reps; ++k) {
            x[0] += 1e-15;
            rhs(0.0, x, p, out);
        }
        const double t = (cpu_now() - t0) / reps;
        if (t < best) best = t;
    }
    printf("%.6e", best);
    for (int i = 0; i < n; ++i) printf(" %.17g", out[i]);
    printf("\n");
    return 0;
}
