/*
 * small_kernels.h: CVODE's vector, dense-matrix and dense-LU operations for small systems,
 * compiled with the model instead of taken from the SUNDIALS library.
 *
 * Why: for a model of 4 to 60 states these operations are about half of what CVODE does per
 * step, and Debian's SUNDIALS 6.4.1 library is built without optimisation (every local on
 * the stack), so each call costs five to ten times what an -O2 loop costs. The kernels give
 * the same results as SUNDIALS' serial and dense implementations (same operations in the
 * same order) and are installed by replacing entries of the objects' ops tables, which
 * SUNDIALS copies to every clone.
 */
#ifndef IMPACTGEN_SMALL_KERNELS_H
#define IMPACTGEN_SMALL_KERNELS_H

#include <nvector/nvector_serial.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

/* Install the kernels on a serial vector (before CVODE clones it), a dense matrix (before
 * CVodeSetLinearSolver clones it) and the dense linear solver built on them. */
void ig_use_small_kernels(N_Vector y, SUNMatrix A, SUNLinearSolver LS);
/* The vector kernels only (a vector CVODE uses beside y: its quadratures'). */
void ig_use_small_vector_kernels(N_Vector y);

#endif
