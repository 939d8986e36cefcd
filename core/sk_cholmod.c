/*
 * CHOLMOD glue of the sparse route: one factorisation of the assembled
 * stiffness K shared by several right-hand sides, and the rigid coupling
 * of a face to a reference point solved on that K (core/sk_sparse.f90
 * calls them; the matrix files are read by sk_ccxread.c).
 *
 * Every function is prefixed sk_c_ and returns a status of sk_status.h:
 *   0 ok, 1 sizes inconsistent, 5 matrix not positive definite (singular),
 *   32 out of memory.
 */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <cholmod.h>

#include "sk_status.h"

static double sk_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* ---- CHOLMOD ----------------------------------------------------------- */

/*
 * Symbolic analysis of a symmetric A (upper storage) with a METIS ordering
 * of its node graph: consecutive equations whose columns have the same
 * pattern (the three directions of a finite-element node) form one vertex,
 * METIS orders the (about 9 times smaller) graph of those vertices and each
 * vertex's equations stay together. CHOLMOD's default instead tries AMD and
 * METIS on the full graph (3.9 s against 0.9 s on a 284k-equation K, the
 * same fill). Falls back to the default analysis when there is nothing to
 * compress or METIS is not available.
 */
static cholmod_factor *sk_analyze(cholmod_sparse *A, cholmod_common *cm)
{
    size_t n = A->nrow;
    cholmod_factor *L = NULL;
    cholmod_sparse *F = cholmod_l_copy(A, 0, 0, cm); /* both triangles, pattern */
    SuiteSparse_long *grp = malloc(sizeof(SuiteSparse_long) * (n + 1));
    SuiteSparse_long *first = malloc(sizeof(SuiteSparse_long) * (n + 1));
    SuiteSparse_long *mark = malloc(sizeof(SuiteSparse_long) * (n + 1));
    SuiteSparse_long *perm = malloc(sizeof(SuiteSparse_long) * (n + 1));
    cholmod_sparse *G = NULL;
    if (!F || !grp || !first || !mark || !perm) goto fallback;
    {
        SuiteSparse_long *Fp = F->p, *Fi = F->i;
        /* cholmod_l_copy returns sorted columns: equal patterns compare entrywise */
        SuiteSparse_long ng = 0;
        for (size_t j = 0; j < n; j++) {
            int same = j > 0 && Fp[j + 1] - Fp[j] == Fp[j] - Fp[j - 1] &&
                       memcmp(Fi + Fp[j], Fi + Fp[j - 1], sizeof(SuiteSparse_long) * (size_t)(Fp[j] - Fp[j - 1])) == 0;
            if (!same) first[ng++] = (SuiteSparse_long)j;
            grp[j] = ng - 1;
        }
        first[ng] = (SuiteSparse_long)n;
        if ((size_t)ng == n) goto fallback;
        /* the vertex graph, upper triangle, from each vertex's first column */
        G = cholmod_l_allocate_sparse((size_t)ng, (size_t)ng, F->nzmax / 4 + (size_t)ng, 0, 1, 1, CHOLMOD_PATTERN, cm);
        if (!G) goto fallback;
        SuiteSparse_long *Gp = G->p, *Gi = G->i, nz = 0;
        for (SuiteSparse_long g = 0; g < ng; g++) mark[g] = -1;
        for (SuiteSparse_long g = 0; g < ng; g++) {
            SuiteSparse_long j = first[g];
            Gp[g] = nz;
            for (SuiteSparse_long k = Fp[j]; k < Fp[j + 1]; k++) {
                SuiteSparse_long h = grp[Fi[k]];
                if (h <= g && mark[h] != g) {
                    if ((size_t)nz >= G->nzmax) goto fallback;
                    mark[h] = g;
                    Gi[nz++] = h;
                }
            }
        }
        Gp[ng] = nz;
        cholmod_l_free_sparse(&F, cm);
        if (!cholmod_l_metis(G, NULL, 0, 0, mark, cm)) goto fallback; /* mark: the vertex order */
        size_t k = 0;
        for (SuiteSparse_long q = 0; q < ng; q++)
            for (SuiteSparse_long j = first[mark[q]]; j < first[mark[q] + 1]; j++) perm[k++] = j;
        int nm = cm->nmethods, ord = cm->method[0].ordering;
        cm->nmethods = 1;
        cm->method[0].ordering = CHOLMOD_GIVEN;
        L = cholmod_l_analyze_p(A, perm, NULL, 0, cm);
        cm->nmethods = nm;
        cm->method[0].ordering = ord;
    }
fallback:
    if (F) cholmod_l_free_sparse(&F, cm);
    if (G) cholmod_l_free_sparse(&G, cm);
    free(grp);
    free(first);
    free(mark);
    free(perm);
    if (!L) {
        cm->status = CHOLMOD_OK;
        L = cholmod_l_analyze(A, cm);
    }
    return L;
}

/*
 * Solve K X = B for nrhs right-hand sides with one factorisation.
 * K: n x n symmetric positive definite from nnz 1-based triplets of its
 * upper triangle (row <= col; entries below the diagonal are rejected,
 * duplicates are summed). B, X: n x nrhs column-major.
 * times[0..2]: ordering/analysis, numeric factorisation, solves (s);
 * stats[0]: nonzeros of the factor L.
 */
int sk_c_cholmod_solve(int n, long nnz, const int *rows, const int *cols,
                       const double *vals, int nrhs, const double *b, double *x,
                       double *times, double *stats)
{
    if (n < 1 || nnz < 1 || nrhs < 1) return SK_ERR_SIZE;
    for (long k = 0; k < nnz; k++) {
        if (rows[k] < 1 || cols[k] < 1 || rows[k] > n || cols[k] > n || rows[k] > cols[k])
            return SK_ERR_SIZE;
    }
    cholmod_common cm;
    cholmod_l_start(&cm);
    cm.print = 0;
    cm.error_handler = NULL;
    cm.supernodal = CHOLMOD_SUPERNODAL;   /* LL^T: an indefinite K is reported */
    int status = SK_OK;
    cholmod_triplet *T = NULL;
    cholmod_sparse *A = NULL;
    cholmod_factor *L = NULL;
    cholmod_dense *B = NULL, *X = NULL;
    double t0 = sk_now(), t1, t2, t3;

    T = cholmod_l_allocate_triplet((size_t)n, (size_t)n, (size_t)nnz, 1, CHOLMOD_REAL, &cm);
    if (!T) {
        status = SK_ERR_NOMEM;
        goto out;
    }
    SuiteSparse_long *ti = T->i, *tj = T->j;
    double *tx = T->x;
    for (long k = 0; k < nnz; k++) {
        ti[k] = rows[k] - 1;
        tj[k] = cols[k] - 1;
        tx[k] = vals[k];
    }
    T->nnz = (size_t)nnz;
    A = cholmod_l_triplet_to_sparse(T, (size_t)nnz, &cm);
    cholmod_l_free_triplet(&T, &cm);
    if (!A) {
        status = SK_ERR_NOMEM;
        goto out;
    }
    L = sk_analyze(A, &cm);
    t1 = sk_now();
    if (!L) {
        status = cm.status == CHOLMOD_OUT_OF_MEMORY ? SK_ERR_NOMEM : SK_ERR_SIZE;
        goto out;
    }
    cholmod_l_factorize(A, L, &cm);
    t2 = sk_now();
    if (cm.status == CHOLMOD_NOT_POSDEF || L->minor < (size_t)n) {
        status = SK_ERR_SINGULAR;
        goto out;
    }
    if (cm.status < CHOLMOD_OK) {
        status = cm.status == CHOLMOD_OUT_OF_MEMORY ? SK_ERR_NOMEM : SK_ERR_SIZE;
        goto out;
    }
    B = cholmod_l_allocate_dense((size_t)n, (size_t)nrhs, (size_t)n, CHOLMOD_REAL, &cm);
    if (!B) {
        status = SK_ERR_NOMEM;
        goto out;
    }
    memcpy(B->x, b, sizeof(double) * (size_t)n * (size_t)nrhs);
    X = cholmod_l_solve(CHOLMOD_A, L, B, &cm);
    t3 = sk_now();
    if (!X) {
        status = SK_ERR_NOMEM;
        goto out;
    }
    memcpy(x, X->x, sizeof(double) * (size_t)n * (size_t)nrhs);
    times[0] = t1 - t0;
    times[1] = t2 - t1;
    times[2] = t3 - t2;
    stats[0] = cm.lnz;
out:
    if (X) cholmod_l_free_dense(&X, &cm);
    if (B) cholmod_l_free_dense(&B, &cm);
    if (L) cholmod_l_free_factor(&L, &cm);
    if (A) cholmod_l_free_sparse(&A, &cm);
    cholmod_l_finish(&cm);
    return status;
}

/*
 * Rigid coupling of a face to a reference point, solved on the assembled K:
 * the nc coupled nodes move as u_i = t + phi x r_i (r_i = node - reference),
 * so with the transformation T from the reduced unknowns (free equations,
 * then t, phi) to all n equations, K' = T^T K T is factorised once and the
 * six unit wrenches at the reference point are solved for.
 * ceq[3*i+d]: 1-based equation of node i, direction d (0: constrained).
 * Outputs u (n x 6, all equations, column j = unit wrench j) and q (6 x 6,
 * the reference-point motion = compliance of the rigidly coupled face).
 */
int sk_c_cholmod_rigid(int n, long nnz, const int *rows, const int *cols, const double *vals,
                       int nc, const int *ceq, const double *r, const double *b, double *u, double *q,
                       double *times, double *stats)
{
    if (n < 1 || nnz < 1 || nc < 1) return SK_ERR_SIZE;
    for (long k = 0; k < nnz; k++) {
        if (rows[k] < 1 || cols[k] < 1 || rows[k] > n || cols[k] > n || rows[k] > cols[k])
            return SK_ERR_SIZE;
    }
    int status = SK_OK;
    long *colmap = malloc(sizeof(long) * (size_t)n);
    if (!colmap) return SK_ERR_NOMEM;
    for (int e = 0; e < n; e++) colmap[e] = 0;
    for (int i = 0; i < 3 * nc; i++) {
        int e = ceq[i];
        if (e < 0 || e > n) {
            free(colmap);
            return SK_ERR_SIZE;
        }
        if (e > 0) {
            if (colmap[e - 1] == -1) {     /* a node listed twice */
                free(colmap);
                return SK_ERR_SIZE;
            }
            colmap[e - 1] = -1;
        }
    }
    long nfree = 0;
    for (int e = 0; e < n; e++)
        if (colmap[e] == 0) colmap[e] = nfree++;
        else colmap[e] = -1;
    long m = nfree + 6;

    cholmod_common cm;
    cholmod_l_start(&cm);
    cm.print = 0;
    cm.error_handler = NULL;
    cm.supernodal = CHOLMOD_SUPERNODAL;
    cholmod_triplet *Tk = NULL, *Tt3 = NULL;
    cholmod_sparse *K = NULL, *T = NULL, *KT = NULL, *Ttr = NULL, *Kp = NULL;
    cholmod_factor *L = NULL;
    cholmod_dense *B = NULL, *X = NULL;
    double t0 = sk_now(), t1, t2, t3;

    /* full (unsymmetric storage) K */
    long nfull = 2 * nnz;
    Tk = cholmod_l_allocate_triplet((size_t)n, (size_t)n, (size_t)nfull, 0, CHOLMOD_REAL, &cm);
    if (!Tk) { status = SK_ERR_NOMEM; goto out; }
    {
        SuiteSparse_long *ti = Tk->i, *tj = Tk->j;
        double *tx = Tk->x;
        long p = 0;
        for (long k = 0; k < nnz; k++) {
            ti[p] = rows[k] - 1; tj[p] = cols[k] - 1; tx[p] = vals[k]; p++;
            if (rows[k] != cols[k]) { ti[p] = cols[k] - 1; tj[p] = rows[k] - 1; tx[p] = vals[k]; p++; }
        }
        Tk->nnz = (size_t)p;
    }
    K = cholmod_l_triplet_to_sparse(Tk, Tk->nnz, &cm);
    cholmod_l_free_triplet(&Tk, &cm);
    if (!K) { status = SK_ERR_NOMEM; goto out; }

    /* T: n x m */
    Tt3 = cholmod_l_allocate_triplet((size_t)n, (size_t)m, (size_t)(nfree + 9 * (long)nc), 0,
                                     CHOLMOD_REAL, &cm);
    if (!Tt3) { status = SK_ERR_NOMEM; goto out; }
    {
        SuiteSparse_long *ti = Tt3->i, *tj = Tt3->j;
        double *tx = Tt3->x;
        long p = 0;
        for (int e = 0; e < n; e++)
            if (colmap[e] >= 0) { ti[p] = e; tj[p] = colmap[e]; tx[p] = 1.0; p++; }
        for (int i = 0; i < nc; i++) {
            double rx = r[3 * i], ry = r[3 * i + 1], rz = r[3 * i + 2];
            /* u = t + phi x r: rows d = 0, 1, 2; columns t (0-2), phi (3-5) */
            double c[3][6] = {{1, 0, 0, 0, rz, -ry}, {0, 1, 0, -rz, 0, rx}, {0, 0, 1, ry, -rx, 0}};
            for (int d = 0; d < 3; d++) {
                int e = ceq[3 * i + d];
                if (e == 0) continue;
                for (int k = 0; k < 6; k++) {
                    if (c[d][k] == 0.0) continue;
                    ti[p] = e - 1; tj[p] = nfree + k; tx[p] = c[d][k]; p++;
                }
            }
        }
        Tt3->nnz = (size_t)p;
    }
    T = cholmod_l_triplet_to_sparse(Tt3, Tt3->nnz, &cm);
    cholmod_l_free_triplet(&Tt3, &cm);
    if (!T) { status = SK_ERR_NOMEM; goto out; }
    KT = cholmod_l_ssmult(K, T, 0, 1, 0, &cm);
    cholmod_l_free_sparse(&K, &cm);
    Ttr = cholmod_l_transpose(T, 1, &cm);
    if (!KT || !Ttr) { status = SK_ERR_NOMEM; goto out; }
    Kp = cholmod_l_ssmult(Ttr, KT, 1, 1, 1, &cm);
    cholmod_l_free_sparse(&KT, &cm);
    cholmod_l_free_sparse(&Ttr, &cm);
    if (!Kp) { status = SK_ERR_NOMEM; goto out; }

    L = sk_analyze(Kp, &cm);
    t1 = sk_now();
    if (!L) { status = cm.status == CHOLMOD_OUT_OF_MEMORY ? SK_ERR_NOMEM : SK_ERR_SIZE; goto out; }
    cholmod_l_factorize(Kp, L, &cm);
    t2 = sk_now();
    if (cm.status == CHOLMOD_NOT_POSDEF || L->minor < (size_t)m) { status = SK_ERR_SINGULAR; goto out; }
    if (cm.status < CHOLMOD_OK) { status = cm.status == CHOLMOD_OUT_OF_MEMORY ? SK_ERR_NOMEM : SK_ERR_SIZE; goto out; }
    B = cholmod_l_zeros((size_t)m, 6, CHOLMOD_REAL, &cm);
    if (!B) { status = SK_ERR_NOMEM; goto out; }
    for (int j = 0; j < 6; j++) {
        double *bj = (double *)B->x + (size_t)j * (size_t)m;
        const double *fj = b + (size_t)j * (size_t)n;
        bj[nfree + j] = 1.0;
        /* further nodal loads f (the reaction of a distributing support): T^T f */
        for (int e = 0; e < n; e++)
            if (colmap[e] >= 0) bj[colmap[e]] += fj[e];
        for (int i = 0; i < nc; i++) {
            double rx = r[3 * i], ry = r[3 * i + 1], rz = r[3 * i + 2];
            double c[3][6] = {{1, 0, 0, 0, rz, -ry}, {0, 1, 0, -rz, 0, rx}, {0, 0, 1, ry, -rx, 0}};
            for (int d = 0; d < 3; d++) {
                int e = ceq[3 * i + d];
                if (e == 0) continue;
                for (int k = 0; k < 6; k++) bj[nfree + k] += c[d][k] * fj[e - 1];
            }
        }
    }
    X = cholmod_l_solve(CHOLMOD_A, L, B, &cm);
    t3 = sk_now();
    if (!X) { status = SK_ERR_NOMEM; goto out; }
    {
        const double *x = X->x;
        for (int j = 0; j < 6; j++)
            for (int k = 0; k < 6; k++) q[j * 6 + k] = x[(size_t)j * (size_t)m + (size_t)(nfree + k)];
        for (int j = 0; j < 6; j++) {
            double *uj = u + (size_t)j * (size_t)n;
            for (int e = 0; e < n; e++) uj[e] = colmap[e] >= 0 ? x[(size_t)j * (size_t)m + (size_t)colmap[e]] : 0.0;
            for (int i = 0; i < nc; i++) {
                double rx = r[3 * i], ry = r[3 * i + 1], rz = r[3 * i + 2];
                const double *qq = q + j * 6;
                double v[3] = {qq[0] + qq[4] * rz - qq[5] * ry, qq[1] + qq[5] * rx - qq[3] * rz,
                               qq[2] + qq[3] * ry - qq[4] * rx};
                for (int d = 0; d < 3; d++)
                    if (ceq[3 * i + d] > 0) uj[ceq[3 * i + d] - 1] = v[d];
            }
        }
    }
    times[0] = t1 - t0;
    times[1] = t2 - t1;
    times[2] = t3 - t2;
    stats[0] = cm.lnz;
out:
    if (X) cholmod_l_free_dense(&X, &cm);
    if (B) cholmod_l_free_dense(&B, &cm);
    if (L) cholmod_l_free_factor(&L, &cm);
    if (Kp) cholmod_l_free_sparse(&Kp, &cm);
    if (KT) cholmod_l_free_sparse(&KT, &cm);
    if (Ttr) cholmod_l_free_sparse(&Ttr, &cm);
    if (T) cholmod_l_free_sparse(&T, &cm);
    if (K) cholmod_l_free_sparse(&K, &cm);
    cholmod_l_finish(&cm);
    free(colmap);
    return status;
}
