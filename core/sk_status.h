/*
 * Status codes of the C glue (sk_ccxread.c, sk_cholmod.c): the values of
 * core/sk_errors.f90 that the Fortran side (core/sk_sparse.f90) maps to
 * its own codes; tests/test_architecture.py checks that they agree.
 */
#ifndef SK_STATUS_H
#define SK_STATUS_H

#define SK_OK 0
#define SK_ERR_SIZE 1
#define SK_ERR_SINGULAR 5
#define SK_ERR_IO 31
#define SK_ERR_NOMEM 32

#endif
