/*
 * small_kernels.c: see small_kernels.h. Each kernel does what the SUNDIALS serial vector,
 * dense matrix or dense linear solver does, in the same order of operations, so results
 * agree with the library's to the last bit where the compiler does not contract a*b + c.
 * Outputs may alias inputs (CVODE relies on it): every loop reads element i of its inputs
 * before it writes element i of its output.
 */
#include <math.h>
#include <string.h>

#include <sundials/sundials_version.h>

#include "small_kernels.h"

#if SUNDIALS_VERSION_MAJOR >= 7
typedef SUNErrCode ig_code; /* what SUNDIALS 7 ops return */
#define IG_LS_SUCCESS SUN_SUCCESS /* 7 dropped SUNLS_SUCCESS for the common code */
#else
typedef int ig_code;
#define IG_LS_SUCCESS SUNLS_SUCCESS
#endif

#define DATA(v) NV_DATA_S(v)
#define LENGTH(v) NV_LENGTH_S(v)

/* ---- vector operations ---- */

/* z = a x + b y; like the library, a (x + y) when a == b and a (x - y) when a == -b */
static void linear_sum(sunrealtype a, N_Vector x, sunrealtype b, N_Vector y, N_Vector z)
{
    const sunrealtype *xd = DATA(x), *yd = DATA(y);
    sunrealtype *zd = DATA(z);
    const sunindextype n = LENGTH(z);
    if (a == b)
        for (sunindextype i = 0; i < n; ++i) zd[i] = a * (xd[i] + yd[i]);
    else if (a == -b)
        for (sunindextype i = 0; i < n; ++i) zd[i] = a * (xd[i] - yd[i]);
    else
        for (sunindextype i = 0; i < n; ++i) zd[i] = a * xd[i] + b * yd[i];
}

static void set_const(sunrealtype c, N_Vector z)
{
    sunrealtype *zd = DATA(z);
    for (sunindextype i = 0, n = LENGTH(z); i < n; ++i) zd[i] = c;
}

static void scale(sunrealtype c, N_Vector x, N_Vector z)
{
    const sunrealtype *xd = DATA(x);
    sunrealtype *zd = DATA(z);
    for (sunindextype i = 0, n = LENGTH(z); i < n; ++i) zd[i] = c * xd[i];
}

static void absolute(N_Vector x, N_Vector z)
{
    const sunrealtype *xd = DATA(x);
    sunrealtype *zd = DATA(z);
    for (sunindextype i = 0, n = LENGTH(z); i < n; ++i) zd[i] = fabs(xd[i]);
}

static void inverse(N_Vector x, N_Vector z)
{
    const sunrealtype *xd = DATA(x);
    sunrealtype *zd = DATA(z);
    for (sunindextype i = 0, n = LENGTH(z); i < n; ++i) zd[i] = 1.0 / xd[i];
}

static sunrealtype minimum(N_Vector x)
{
    const sunrealtype *xd = DATA(x);
    sunrealtype m = xd[0];
    for (sunindextype i = 1, n = LENGTH(x); i < n; ++i)
        if (xd[i] < m) m = xd[i];
    return m;
}

static sunrealtype weighted_square_sum(N_Vector x, N_Vector w)
{
    const sunrealtype *xd = DATA(x), *wd = DATA(w);
    sunrealtype sum = 0.0;
    for (sunindextype i = 0, n = LENGTH(x); i < n; ++i) {
        const sunrealtype p = xd[i] * wd[i];
        sum += p * p;
    }
    return sum;
}

static sunrealtype wrms_norm(N_Vector x, N_Vector w)
{
    return sqrt(weighted_square_sum(x, w) / (sunrealtype)LENGTH(x));
}

/* z = sum_k c[k] X[k], summed left to right; z may be one of the X[k] */
static ig_code linear_combination(int nvec, sunrealtype *c, N_Vector *X, N_Vector z)
{
    if (nvec == 1) {
        scale(c[0], X[0], z);
        return 0;
    }
    if (nvec == 2) {
        linear_sum(c[0], X[0], c[1], X[1], z);
        return 0;
    }
    sunrealtype *zd = DATA(z);
    for (sunindextype i = 0, n = LENGTH(z); i < n; ++i) {
        sunrealtype sum = c[0] * DATA(X[0])[i];
        for (int k = 1; k < nvec; ++k) sum += c[k] * DATA(X[k])[i];
        zd[i] = sum;
    }
    return 0;
}

/* Z[k] = a[k] x + Y[k] */
static ig_code scale_add_multi(int nvec, sunrealtype *a, N_Vector x, N_Vector *Y, N_Vector *Z)
{
    const sunrealtype *xd = DATA(x);
    const sunindextype n = LENGTH(x);
    for (int k = 0; k < nvec; ++k) {
        const sunrealtype *yd = DATA(Y[k]);
        sunrealtype *zd = DATA(Z[k]);
        for (sunindextype i = 0; i < n; ++i) zd[i] = a[k] * xd[i] + yd[i];
    }
    return 0;
}

/* Z[k] = c[k] X[k] */
static ig_code scale_vector_array(int nvec, sunrealtype *c, N_Vector *X, N_Vector *Z)
{
    for (int k = 0; k < nvec; ++k) scale(c[k], X[k], Z[k]);
    return 0;
}

/* ---- dense matrix operations (column-major, as SUNMATRIX_DENSE stores them) ---- */

static ig_code matrix_copy(SUNMatrix A, SUNMatrix B)
{
    if (SM_LDATA_D(A) != SM_LDATA_D(B)) return SUNMatCopy_Dense(A, B); /* its error code */
    memcpy(SM_DATA_D(B), SM_DATA_D(A), sizeof(sunrealtype) * (size_t)SM_LDATA_D(A));
    return 0;
}

static ig_code matrix_zero(SUNMatrix A)
{
    memset(SM_DATA_D(A), 0, sizeof(sunrealtype) * (size_t)SM_LDATA_D(A));
    return 0;
}

/* A = c A + I */
static ig_code matrix_scale_add_identity(sunrealtype c, SUNMatrix A)
{
    sunrealtype **cols = SM_COLS_D(A);
    for (sunindextype j = 0; j < SM_COLUMNS_D(A); ++j) {
        for (sunindextype i = 0; i < SM_ROWS_D(A); ++i) cols[j][i] *= c;
        if (j < SM_ROWS_D(A)) cols[j][j] += 1.0;
    }
    return 0;
}

static void use_matrix_kernels(SUNMatrix A);

/* the library's clone builds a fresh matrix with the library's ops: give it ours */
static SUNMatrix matrix_clone(SUNMatrix A)
{
    SUNMatrix B = SUNMatClone_Dense(A);
    if (B) use_matrix_kernels(B);
    return B;
}

static void use_matrix_kernels(SUNMatrix A)
{
    A->ops->clone = matrix_clone;
    A->ops->copy = matrix_copy;
    A->ops->zero = matrix_zero;
    A->ops->scaleaddi = matrix_scale_add_identity;
}

/* ---- dense LU with partial pivoting, in place, as SUNDlsMat_denseGETRF/GETRS ---- */

static sunindextype lu_factor(sunrealtype **a, sunindextype n, sunindextype *pivots)
{
    for (sunindextype k = 0; k < n; ++k) {
        sunrealtype *col_k = a[k];
        sunindextype l = k;
        for (sunindextype i = k + 1; i < n; ++i)
            if (fabs(col_k[i]) > fabs(col_k[l])) l = i;
        pivots[k] = l;
        if (col_k[l] == 0.0) return k + 1; /* singular: the library's convention */
        if (l != k) {
            for (sunindextype j = 0; j < n; ++j) {
                const sunrealtype t = a[j][l];
                a[j][l] = a[j][k];
                a[j][k] = t;
            }
        }
        const sunrealtype mult = 1.0 / col_k[k];
        for (sunindextype i = k + 1; i < n; ++i) col_k[i] *= mult;
        for (sunindextype j = k + 1; j < n; ++j) {
            sunrealtype *col_j = a[j];
            const sunrealtype a_kj = col_j[k];
            if (a_kj != 0.0)
                for (sunindextype i = k + 1; i < n; ++i) col_j[i] -= a_kj * col_k[i];
        }
    }
    return 0;
}

static void lu_solve(sunrealtype *const *a, sunindextype n, const sunindextype *pivots, sunrealtype *b)
{
    for (sunindextype k = 0; k < n; ++k) {
        const sunindextype p = pivots[k];
        if (p != k) {
            const sunrealtype t = b[k];
            b[k] = b[p];
            b[p] = t;
        }
    }
    for (sunindextype k = 0; k < n - 1; ++k) {
        const sunrealtype *col_k = a[k];
        const sunrealtype b_k = b[k];
        for (sunindextype i = k + 1; i < n; ++i) b[i] -= col_k[i] * b_k;
    }
    for (sunindextype k = n - 1; k > 0; --k) {
        const sunrealtype *col_k = a[k];
        b[k] /= col_k[k];
        const sunrealtype b_k = b[k];
        for (sunindextype i = 0; i < k; ++i) b[i] -= col_k[i] * b_k;
    }
    b[0] /= a[0][0];
}

static SUNLinearSolverContent_Dense dense_content(SUNLinearSolver S)
{
    return (SUNLinearSolverContent_Dense)S->content;
}

static int dense_setup(SUNLinearSolver S, SUNMatrix A)
{
    SUNLinearSolverContent_Dense c = dense_content(S);
    if (SM_ROWS_D(A) != c->N || SM_COLUMNS_D(A) != c->N) return SUNLinSolSetup_Dense(S, A);
    c->last_flag = lu_factor(SM_COLS_D(A), c->N, c->pivots);
    return c->last_flag > 0 ? SUNLS_LUFACT_FAIL : IG_LS_SUCCESS;
}

static int dense_solve(SUNLinearSolver S, SUNMatrix A, N_Vector x, N_Vector b, sunrealtype tol)
{
    SUNLinearSolverContent_Dense c = dense_content(S);
    if (SM_ROWS_D(A) != c->N || SM_COLUMNS_D(A) != c->N || LENGTH(x) != c->N)
        return SUNLinSolSolve_Dense(S, A, x, b, tol);
    if (x != b) memcpy(DATA(x), DATA(b), sizeof(sunrealtype) * (size_t)c->N);
    lu_solve(SM_COLS_D(A), c->N, c->pivots, DATA(x));
    c->last_flag = IG_LS_SUCCESS;
    return IG_LS_SUCCESS;
}

void ig_use_small_vector_kernels(N_Vector y)
{
    N_Vector_Ops v = y->ops;
    v->nvlinearsum = linear_sum;
    v->nvconst = set_const;
    v->nvscale = scale;
    v->nvabs = absolute;
    v->nvinv = inverse;
    v->nvmin = minimum;
    v->nvwrmsnorm = wrms_norm;
    v->nvwsqrsumlocal = weighted_square_sum;
    /* fused operations only where enabled: CVODE falls back to single ones when NULL */
    if (v->nvlinearcombination) v->nvlinearcombination = linear_combination;
    if (v->nvscaleaddmulti) v->nvscaleaddmulti = scale_add_multi;
    if (v->nvscalevectorarray) v->nvscalevectorarray = scale_vector_array;
}

void ig_use_small_kernels(N_Vector y, SUNMatrix A, SUNLinearSolver LS)
{
    ig_use_small_vector_kernels(y);
    use_matrix_kernels(A);

    LS->ops->setup = dense_setup;
    LS->ops->solve = dense_solve;
}
