/*
 * step_sundials.h: what the SUNDIALS steppers (step_cvode.c, step_erk.c) share: a context
 * whose errors land in the problem's message, and dense output from a GetDky function.
 */
#ifndef IMPACTGEN_STEP_SUNDIALS_H
#define IMPACTGEN_STEP_SUNDIALS_H

#include <nvector/nvector_serial.h>
#include <sundials/sundials_types.h>
#include <sundials/sundials_version.h>

#include "stepper.h"

#ifndef SUNDIALS_VERSION_MAJOR
#error "SUNDIALS_VERSION_MAJOR is not defined: impactgen needs SUNDIALS 6 or 7"
#endif
#if SUNDIALS_VERSION_MAJOR < 6
#error "impactgen needs SUNDIALS 6 or newer"
#endif

/* A new context; with SUNDIALS 7 its error handler keeps the last message in
 * problem->message instead of printing it. Returns 0 or -1. */
int ig_sundials_context(SUNContext *ctx, const ig_problem *problem);

#if SUNDIALS_VERSION_MAJOR < 7
/* SUNDIALS 6's error handler (user data: the ig_problem) keeping failures' messages. */
void ig_sundials_on_error(int code, const char *module, const char *func, char *msg, void *data);
#endif

/* rows[k * n + i] = y_i^(k)(t) / k!, k < terms, from get_dky (CVodeGetDky or
 * ERKStepGetDky) on mem, zero past order. dky: a work vector of n. Returns 0 or -1. */
int ig_sundials_taylor(int n, int (*get_dky)(void *, sunrealtype, int, N_Vector), void *mem, N_Vector dky,
                       int order, double t, double *rows, int terms);

#endif /* IMPACTGEN_STEP_SUNDIALS_H */
