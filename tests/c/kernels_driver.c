/*
 * kernels_driver.c: the small kernels (src/impactgen/native/small_kernels.c) against the
 * SUNDIALS library's own serial vector, dense matrix and dense LU, bit for bit, on the
 * calls CVODE makes: special coefficients, outputs aliasing inputs, singular matrices.
 * Prints "kernels: ok (N checks)" and exits 0, or names the first disagreement and exits 1.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <sundials/sundials_version.h>

#include "small_kernels.h"

#define NV 5 /* vectors per side */

static int checks = 0;
static int failures = 0;

static unsigned long long seed = 12345u;
static double uniform(void)
{
    seed = seed * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(seed >> 11) / 9007199254740992.0 * 2.0 - 1.0;
}

typedef struct {
    N_Vector lib[NV];  /* library ops */
    N_Vector mine[NV]; /* clones of a vector with the kernels */
    sunindextype n;
} pair;

static void fill(pair *p)
{
    for (int k = 0; k < NV; ++k)
        for (sunindextype i = 0; i < p->n; ++i) {
            const double v = uniform() * (k + 1);
            NV_Ith_S(p->lib[k], i) = v;
            NV_Ith_S(p->mine[k], i) = v;
        }
}

static void same_vectors(const pair *p, const char *what)
{
    ++checks;
    for (int k = 0; k < NV; ++k)
        if (memcmp(NV_DATA_S(p->lib[k]), NV_DATA_S(p->mine[k]), sizeof(double) * (size_t)p->n) != 0) {
            printf("kernels: %s differs from the library (n = %ld, vector %d)\n", what, (long)p->n, k);
            ++failures;
            return;
        }
}

static void same_number(double a, double b, const char *what, sunindextype n)
{
    ++checks;
    if (memcmp(&a, &b, sizeof a) != 0) {
        printf("kernels: %s differs from the library (n = %ld): %.17g vs %.17g\n", what, (long)n, a, b);
        ++failures;
    }
}

static void vector_checks(SUNContext ctx, sunindextype n)
{
    pair p;
    p.n = n;
    N_Vector lib0 = N_VNew_Serial(n, ctx), mine0 = N_VNew_Serial(n, ctx);
    SUNMatrix A = SUNDenseMatrix(n, n, ctx);
    SUNLinearSolver LS = SUNLinSol_Dense(mine0, A, ctx);
    N_VEnableFusedOps_Serial(lib0, SUNTRUE);
    N_VEnableFusedOps_Serial(mine0, SUNTRUE);
    ig_use_small_kernels(mine0, A, LS);
    for (int k = 0; k < NV; ++k) {
        p.lib[k] = N_VClone(lib0);
        p.mine[k] = N_VClone(mine0);
    }
    static const double coef[][2] = {{1, 1}, {1, -1}, {-1, 1}, {-1, -1}, {2.5, 2.5}, {2.5, -2.5},
                                     {1, 0.3}, {0.3, 1}, {-1, 0.3}, {0.3, -1}, {0.3, 0.7}, {0, 0.7}};
    char what[96];
    for (size_t c = 0; c < sizeof coef / sizeof coef[0]; ++c) {
        const double a = coef[c][0], b = coef[c][1];
        for (int out = 0; out < 3; ++out) { /* z separate, z == x, z == y */
            fill(&p);
            N_VLinearSum(a, p.lib[0], b, p.lib[1], p.lib[out == 0 ? 2 : out - 1]);
            N_VLinearSum(a, p.mine[0], b, p.mine[1], p.mine[out == 0 ? 2 : out - 1]);
            snprintf(what, sizeof what, "linear sum a = %g, b = %g, output %d", a, b, out);
            same_vectors(&p, what);
        }
    }
    static const double scales[] = {1.0, -1.0, 0.37};
    for (size_t c = 0; c < 3; ++c)
        for (int out = 0; out < 2; ++out) {
            fill(&p);
            N_VScale(scales[c], p.lib[0], p.lib[out]);
            N_VScale(scales[c], p.mine[0], p.mine[out]);
            same_vectors(&p, "scale");
        }
    fill(&p);
    N_VConst(0.25, p.lib[1]);
    N_VConst(0.25, p.mine[1]);
    N_VAbs(p.lib[0], p.lib[2]);
    N_VAbs(p.mine[0], p.mine[2]);
    N_VInv(p.lib[3], p.lib[3]);
    N_VInv(p.mine[3], p.mine[3]);
    same_vectors(&p, "const, abs and inverse");
    fill(&p);
    same_number(N_VMin(p.lib[2]), N_VMin(p.mine[2]), "minimum", n);
    same_number(N_VWrmsNorm(p.lib[0], p.lib[1]), N_VWrmsNorm(p.mine[0], p.mine[1]), "WRMS norm", n);
    same_number(N_VWSqrSumLocal(p.lib[0], p.lib[1]), N_VWSqrSumLocal(p.mine[0], p.mine[1]),
                "weighted square sum", n);

    double c[NV] = {1.0, -0.7, 0.3, 1.9, -2.2};
    for (int nvec = 1; nvec <= 4; ++nvec)
        for (int variant = 0; variant < 3; ++variant) { /* z separate, z == X[0], z == X[0] with c0 = 1 */
            c[0] = variant == 2 ? 1.0 : 0.45;
            fill(&p);
            N_Vector *zl = variant ? &p.lib[0] : &p.lib[4], *zm = variant ? &p.mine[0] : &p.mine[4];
            N_VLinearCombination(nvec, c, p.lib, *zl);
            N_VLinearCombination(nvec, c, p.mine, *zm);
            snprintf(what, sizeof what, "linear combination of %d, variant %d", nvec, variant);
            same_vectors(&p, what);
        }
    for (int nvec = 1; nvec <= 2; ++nvec)
        for (int in_place = 0; in_place < 2; ++in_place) {
            fill(&p);
            N_VScaleAddMulti(nvec, c, p.lib[0], &p.lib[1], in_place ? &p.lib[1] : &p.lib[3]);
            N_VScaleAddMulti(nvec, c, p.mine[0], &p.mine[1], in_place ? &p.mine[1] : &p.mine[3]);
            same_vectors(&p, "scale-add multi");
            fill(&p);
            N_VScaleVectorArray(nvec, c, &p.lib[0], in_place ? &p.lib[0] : &p.lib[2]);
            N_VScaleVectorArray(nvec, c, &p.mine[0], in_place ? &p.mine[0] : &p.mine[2]);
            same_vectors(&p, "scale vector array");
        }
    for (int k = 0; k < NV; ++k) {
        N_VDestroy(p.lib[k]);
        N_VDestroy(p.mine[k]);
    }
    SUNLinSolFree(LS);
    SUNMatDestroy(A);
    N_VDestroy(lib0);
    N_VDestroy(mine0);
}

static void same_matrices(SUNMatrix A, SUNMatrix B, const char *what)
{
    ++checks;
    if (memcmp(SM_DATA_D(A), SM_DATA_D(B), sizeof(double) * (size_t)SM_LDATA_D(A)) != 0) {
        printf("kernels: %s differs from the library (n = %ld)\n", what, (long)SM_ROWS_D(A));
        ++failures;
    }
}

static void matrix_checks(SUNContext ctx, sunindextype n, int singular)
{
    N_Vector y = N_VNew_Serial(n, ctx), xl = N_VClone(y), bl = N_VClone(y);
    N_Vector ym = N_VNew_Serial(n, ctx);
    SUNMatrix Al = SUNDenseMatrix(n, n, ctx), Am = SUNDenseMatrix(n, n, ctx);
    SUNLinearSolver Ll = SUNLinSol_Dense(y, Al, ctx), Lm = SUNLinSol_Dense(ym, Am, ctx);
    ig_use_small_kernels(ym, Am, Lm);
    N_Vector xm = N_VClone(ym), bm = N_VClone(ym);
    SUNMatrix Bl = SUNMatClone(Al), Bm = SUNMatClone(Am);
    ++checks;
    if (Bm->ops->scaleaddi != Am->ops->scaleaddi || Bm->ops->copy != Am->ops->copy) {
        printf("kernels: a cloned matrix lost the kernels\n");
        ++failures;
    }
    for (sunindextype i = 0; i < n * n; ++i) SM_DATA_D(Bl)[i] = SM_DATA_D(Bm)[i] = uniform();
    if (singular) /* column 1 is twice column 0 */
        for (sunindextype i = 0; i < n; ++i) SM_COLS_D(Bl)[1][i] = SM_COLS_D(Bm)[1][i] = 2.0 * SM_COLS_D(Bl)[0][i];
    SUNMatCopy(Bl, Al);
    SUNMatCopy(Bm, Am);
    same_matrices(Al, Am, "copy");
    SUNMatScaleAddI(-0.3, Bl);
    SUNMatScaleAddI(-0.3, Bm);
    same_matrices(Bl, Bm, "scale and add identity");
    if (singular) {
        SUNMatCopy(Al, Bl);
        SUNMatCopy(Am, Bm);
    }
    const int fl = SUNLinSolSetup(Ll, Bl), fm = SUNLinSolSetup(Lm, Bm);
    same_number(fl, fm, singular ? "LU of a singular matrix: return code" : "LU: return code", n);
    same_number((double)SUNLinSolLastFlag(Ll), (double)SUNLinSolLastFlag(Lm), "LU: last flag", n);
    if (!singular) {
        same_matrices(Bl, Bm, "LU factors");
        for (sunindextype i = 0; i < n; ++i) NV_Ith_S(bl, i) = NV_Ith_S(bm, i) = uniform();
        same_number(SUNLinSolSolve(Ll, Bl, xl, bl, 0.0), SUNLinSolSolve(Lm, Bm, xm, bm, 0.0),
                    "LU solve: return code", n);
        ++checks;
        if (memcmp(NV_DATA_S(xl), NV_DATA_S(xm), sizeof(double) * (size_t)n) != 0) {
            printf("kernels: LU solve differs from the library (n = %ld)\n", (long)n);
            ++failures;
        }
        SUNLinSolSolve(Ll, Bl, bl, bl, 0.0); /* in place, as CVODE may call it */
        SUNLinSolSolve(Lm, Bm, bm, bm, 0.0);
        same_number(NV_Ith_S(bl, n - 1), NV_Ith_S(bm, n - 1), "LU solve in place", n);
    }
    SUNMatZero(Bl);
    SUNMatZero(Bm);
    same_matrices(Bl, Bm, "zero");
    N_VDestroy(y); N_VDestroy(xl); N_VDestroy(bl); N_VDestroy(ym); N_VDestroy(xm); N_VDestroy(bm);
    SUNMatDestroy(Al); SUNMatDestroy(Am); SUNMatDestroy(Bl); SUNMatDestroy(Bm);
    SUNLinSolFree(Ll); SUNLinSolFree(Lm);
}

int main(void)
{
    SUNContext ctx;
#if SUNDIALS_VERSION_MAJOR >= 7
    if (SUNContext_Create(SUN_COMM_NULL, &ctx) != 0) return 2;
#else
    if (SUNContext_Create(NULL, &ctx) != 0) return 2;
#endif
    static const sunindextype sizes[] = {1, 2, 6, 13, 41};
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; ++k) {
        vector_checks(ctx, sizes[k]);
        matrix_checks(ctx, sizes[k], 0);
        if (sizes[k] > 1) matrix_checks(ctx, sizes[k], 1);
    }
    SUNContext_Free(&ctx);
    if (failures) {
        printf("kernels: %d of %d checks failed\n", failures, checks);
        return 1;
    }
    printf("kernels: ok (%d checks)\n", checks);
    return 0;
}
