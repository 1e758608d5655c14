/*
 * step_sundials.c: what the SUNDIALS steppers share (step_sundials.h).
 */
#include <stdio.h>
#include <string.h>

#include "step_sundials.h"

#if SUNDIALS_VERSION_MAJOR >= 7
static void on_error(int line, const char *func, const char *file, const char *msg, SUNErrCode code, void *data,
                     SUNContext ctx)
{
    (void)line; (void)file; (void)code; (void)ctx;
    const ig_problem *problem = (const ig_problem *)data;
    ig_stepper_say(problem, "%s: %s", func ? func : "SUNDIALS", msg ? msg : "");
}
#else
void ig_sundials_on_error(int code, const char *module, const char *func, char *msg, void *data)
{
    (void)module;
    const ig_problem *problem = (const ig_problem *)data;
    if (code >= 0) return; /* a warning, not a failure */
    ig_stepper_say(problem, "%s: %s", func ? func : "CVODE", msg ? msg : "");
}
#endif

int ig_sundials_context(SUNContext *ctx, const ig_problem *problem)
{
#if SUNDIALS_VERSION_MAJOR >= 7
    if (SUNContext_Create(SUN_COMM_NULL, ctx) != 0) return -1;
    SUNContext_ClearErrHandlers(*ctx);
    SUNContext_PushErrHandler(*ctx, on_error, (void *)problem);
#else
    (void)problem;
    if (SUNContext_Create(NULL, ctx) != 0) return -1;
#endif
    return 0;
}

int ig_sundials_taylor(int n, int (*get_dky)(void *, sunrealtype, int, N_Vector), void *mem, N_Vector dky,
                       int order, double t, double *rows, int terms)
{
    const double *d = N_VGetArrayPointer(dky);
    double factorial = 1.0;
    int failed = 0;
    for (int k = 0; k < terms; ++k) {
        double *row = rows + (size_t)k * n;
        if (k > order || failed) {
            memset(row, 0, sizeof(double) * (size_t)n);
            continue;
        }
        if (k > 0) factorial *= k;
        if (get_dky(mem, t, k, dky) != 0) {
            failed = 1;
            memset(row, 0, sizeof(double) * (size_t)n);
            continue;
        }
        for (int i = 0; i < n; ++i) row[i] = d[i] / factorial;
    }
    return failed ? -1 : 0;
}
