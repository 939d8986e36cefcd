/*
 * C glue of the sparse route (issue 3): readers of the text files that
 * CalculiX writes with *FREQUENCY, SOLVER=MATRIXSTORAGE, and one CHOLMOD
 * factorisation of the assembled stiffness K shared by several right-hand
 * sides.
 *
 *   job.sti / job.mas   "row col value" per line, 1-based equation numbers,
 *                       upper triangle (row <= col) of K / M
 *   job.dof             "node.direction" per line: equation i is that dof
 *
 * Every function is prefixed sk_c_ and returns an int status that the
 * Fortran side (core/sk_sparse.f90) maps to the codes of sk_errors:
 *   0 ok, 1 sizes inconsistent, 5 matrix not positive definite (singular),
 *   31 file missing, unreadable or malformed, 32 out of memory.
 * Reading is a single pass over a large buffer with strtol/strtod: the
 * 2 mm beam's .sti (426 MB) reads in a few seconds.
 */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <cholmod.h>

#define SK_OK 0
#define SK_ERR_SIZE 1
#define SK_ERR_SINGULAR 5
#define SK_ERR_IO 31
#define SK_ERR_NOMEM 32

#define SK_BUF (1 << 22)

static double sk_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Line reader over a big buffer: calls fn(line, ctx) for every line;
 * a nonzero return stops the scan and is returned. */
typedef int (*sk_line_fn)(char *line, void *ctx);

static int sk_scan_lines(const char *path, sk_line_fn fn, void *ctx)
{
    FILE *fh = fopen(path, "rb");
    if (!fh) return SK_ERR_IO;
    char *buf = malloc(SK_BUF + 1);
    if (!buf) {
        fclose(fh);
        return SK_ERR_NOMEM;
    }
    size_t keep = 0;
    int status = SK_OK;
    for (;;) {
        size_t got = fread(buf + keep, 1, SK_BUF - keep, fh);
        size_t have = keep + got;
        int eof = (got == 0) || feof(fh);
        if (have == 0) break;
        buf[have] = '\0';
        char *start = buf;
        char *end = buf + have;
        for (;;) {
            char *nl = memchr(start, '\n', (size_t)(end - start));
            if (!nl) break;
            *nl = '\0';
            status = fn(start, ctx);
            if (status) goto done;
            start = nl + 1;
        }
        keep = (size_t)(end - start);
        if (eof) {
            if (keep > 0) {             /* last line without newline */
                start[keep] = '\0';
                status = fn(start, ctx);
            }
            break;
        }
        if (keep == SK_BUF) {          /* a line longer than the buffer */
            status = SK_ERR_IO;
            break;
        }
        memmove(buf, start, keep);
    }
    if (ferror(fh)) status = SK_ERR_IO;
done:
    free(buf);
    fclose(fh);
    return status;
}

static int sk_blank(const char *s)
{
    while (*s == ' ' || *s == '\t' || *s == '\r') s++;
    return *s == '\0';
}

/* ---- triplets ---------------------------------------------------------- */

typedef struct {
    long count;      /* entries seen */
    long cap;        /* capacity of the arrays (0: count only) */
    int maxidx;
    int *rows, *cols;
    double *vals;
} sk_trip_ctx;

static int sk_trip_line(char *line, void *vctx)
{
    sk_trip_ctx *c = vctx;
    if (sk_blank(line)) return SK_OK;
    char *p = line, *q;
    errno = 0;
    long r = strtol(p, &q, 10);
    if (q == p) return SK_ERR_IO;
    p = q;
    long col = strtol(p, &q, 10);
    if (q == p) return SK_ERR_IO;
    p = q;
    double v = strtod(p, &q);
    if (q == p || errno == ERANGE) return SK_ERR_IO;
    if (!sk_blank(q)) return SK_ERR_IO;
    if (r < 1 || col < 1 || r > 2147483647L || col > 2147483647L) return SK_ERR_IO;
    if (c->cap > 0) {
        if (c->count >= c->cap) return SK_ERR_SIZE;
        c->rows[c->count] = (int)r;
        c->cols[c->count] = (int)col;
        c->vals[c->count] = v;
    }
    c->count++;
    if (r > c->maxidx) c->maxidx = (int)r;
    if (col > c->maxidx) c->maxidx = (int)col;
    return SK_OK;
}

/* Number of entries and largest equation number of a .sti/.mas file. */
int sk_c_triplet_count(const char *path, long *nnz, int *neq)
{
    sk_trip_ctx c = {0, 0, 0, NULL, NULL, NULL};
    int st = sk_scan_lines(path, sk_trip_line, &c);
    *nnz = c.count;
    *neq = c.maxidx;
    return st;
}

/* Read exactly nnz entries (1-based rows/cols as in the file). */
int sk_c_triplet_read(const char *path, long nnz, int *rows, int *cols, double *vals)
{
    if (nnz < 1) return SK_ERR_SIZE;
    sk_trip_ctx c = {0, nnz, 0, rows, cols, vals};
    int st = sk_scan_lines(path, sk_trip_line, &c);
    if (st) return st;
    return c.count == nnz ? SK_OK : SK_ERR_SIZE;
}

/* ---- .dof -------------------------------------------------------------- */

typedef struct {
    int count, cap;
    int *node, *dir;
} sk_dof_ctx;

static int sk_dof_line(char *line, void *vctx)
{
    sk_dof_ctx *c = vctx;
    if (sk_blank(line)) return SK_OK;
    char *p = line, *q;
    long node = strtol(p, &q, 10);
    if (q == p || *q != '.') return SK_ERR_IO;
    p = q + 1;
    long dir = strtol(p, &q, 10);
    if (q == p || !sk_blank(q) || node < 1 || dir < 1 || dir > 6) return SK_ERR_IO;
    if (c->cap > 0) {
        if (c->count >= c->cap) return SK_ERR_SIZE;
        c->node[c->count] = (int)node;
        c->dir[c->count] = (int)dir;
    }
    c->count++;
    return SK_OK;
}

/* Equations listed in a .dof file (node.direction per line). */
int sk_c_dof_count(const char *path, int *neq)
{
    sk_dof_ctx c = {0, 0, NULL, NULL};
    int st = sk_scan_lines(path, sk_dof_line, &c);
    *neq = c.count;
    return st;
}

int sk_c_dof_read(const char *path, int neq, int *node, int *dir)
{
    if (neq < 1) return SK_ERR_SIZE;
    sk_dof_ctx c = {0, neq, node, dir};
    int st = sk_scan_lines(path, sk_dof_line, &c);
    if (st) return st;
    return c.count == neq ? SK_OK : SK_ERR_SIZE;
}

/* ---- CHOLMOD ----------------------------------------------------------- */

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
    L = cholmod_l_analyze(A, &cm);
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
