/*
 * C glue of the sparse route: readers of the text files that
 * CalculiX writes with *FREQUENCY, SOLVER=MATRIXSTORAGE, and one CHOLMOD
 * factorisation of the assembled stiffness K shared by several right-hand
 * sides.
 *
 *   job.sti / job.mas   "row col value" per line, 1-based equation numbers,
 *                       upper triangle (row <= col) of K / M; or, written
 *                       by ccx with core/sk_ccxio.c preloaded, a binary
 *                       .sti: the header "SKSTI-BINARY-1\n", then (int32
 *                       row, int32 col, float64 value) records (exact
 *                       values, nothing to parse)
 *   job.dof             "node.direction" per line: equation i is that dof
 *
 * Every function is prefixed sk_c_ and returns an int status that the
 * Fortran side (core/sk_sparse.f90) maps to the codes of sk_errors:
 *   0 ok, 1 sizes inconsistent, 5 matrix not positive definite (singular),
 *   31 file missing, unreadable or malformed, 32 out of memory.
 * Text is read in one pass over a large buffer per call (the counting
 * pass reads the indices only; numbers by an exact fast path, else strtod).
 */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdint.h>
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

/* Fast readers of the numbers ccx writes ("%d", "%.13e"): digits and an
 * exponent accumulated exactly and combined with one correctly rounded
 * multiplication or division by an exact power of ten (Clinger's fast
 * path: mantissa <= 2^53, |power| <= 22), so the value is the one strtod
 * gives; anything else (more digits, large exponents, inf/nan) goes to
 * strtod. */
static const char *sk_skip_ws(const char *p)
{
    while (*p == ' ' || *p == '\t' || *p == '\r') p++;
    return p;
}

static int sk_read_long(const char **pp, long *out)
{
    const char *p = sk_skip_ws(*pp);
    int neg = 0;
    if (*p == '+' || *p == '-') neg = (*p++ == '-');
    if (*p < '0' || *p > '9') return 0;
    long v = 0;
    while (*p >= '0' && *p <= '9') {
        if (v > 214748364L) return 0;  /* beyond an int: rejected by the caller's range check */
        v = 10 * v + (*p++ - '0');
    }
    *out = neg ? -v : v;
    *pp = p;
    return 1;
}

static int sk_read_double(const char **pp, double *out)
{
    static const double p10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                   1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
    const char *start = sk_skip_ws(*pp), *p = start;
    int neg = 0, ndig = 0, frac = 0;
    unsigned long long m = 0;
    if (*p == '+' || *p == '-') neg = (*p++ == '-');
    while (*p >= '0' && *p <= '9') {
        m = 10 * m + (unsigned long long)(*p++ - '0');
        ndig++;
    }
    if (*p == '.') {
        p++;
        while (*p >= '0' && *p <= '9') {
            m = 10 * m + (unsigned long long)(*p++ - '0');
            ndig++;
            frac++;
        }
    }
    long e = 0;
    if (ndig > 0 && (*p == 'e' || *p == 'E')) {
        const char *q = p + 1;
        if (!sk_read_long(&q, &e) || q == p + 1) ndig = 0; /* malformed exponent: let strtod judge */
        p = q;
    }
    long e10 = e - frac;
    if (ndig > 0 && ndig <= 19 && m <= (1ULL << 53) && e10 >= -22 && e10 <= 22) {
        double v = (double)m;
        v = e10 >= 0 ? v * p10[e10] : v / p10[-e10];
        *out = neg ? -v : v;
        *pp = p;
        return 1;
    }
    char *q;
    errno = 0;
    double v = strtod(start, &q);
    if (q == start || errno == ERANGE) return 0;
    *out = v;
    *pp = q;
    return 1;
}

static int sk_trip_line(char *line, void *vctx)
{
    sk_trip_ctx *c = vctx;
    if (sk_blank(line)) return SK_OK;
    const char *p = line;
    long r, col;
    if (!sk_read_long(&p, &r) || !sk_read_long(&p, &col)) return SK_ERR_IO;
    if (r < 1 || col < 1 || r > 2147483647L || col > 2147483647L) return SK_ERR_IO;
    if (c->cap > 0) {  /* the counting pass reads only the indices */
        double v;
        if (!sk_read_double(&p, &v) || !sk_blank(p)) return SK_ERR_IO;
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

/* The binary .sti that ccx writes with core/sk_ccxio.c preloaded: this
 * header, then (int32 row, int32 col, float64 value) records. */
#define SK_STI_MAGIC "SKSTI-BINARY-1\n"
#define SK_STI_MAGIC_LEN (sizeof(SK_STI_MAGIC) - 1)
#define SK_REC 16

/* 1 for a binary file (fh positioned after the header), 0 for text (fh
 * rewound), -1 on a read error. */
static int sk_binary(FILE *fh)
{
    char head[SK_STI_MAGIC_LEN];
    size_t got = fread(head, 1, SK_STI_MAGIC_LEN, fh);
    if (got == SK_STI_MAGIC_LEN && memcmp(head, SK_STI_MAGIC, SK_STI_MAGIC_LEN) == 0) return 1;
    if (ferror(fh)) return -1;
    rewind(fh);
    return 0;
}

/* Scan the binary records: count them (c->cap == 0) or store them. */
static int sk_trip_binary(FILE *fh, sk_trip_ctx *c)
{
    enum { CHUNK = 1 << 16 };
    unsigned char *buf = malloc((size_t)CHUNK * SK_REC);
    if (!buf) return SK_ERR_NOMEM;
    int status = SK_OK;
    size_t got;
    while ((got = fread(buf, 1, (size_t)CHUNK * SK_REC, fh)) > 0) {
        if (got % SK_REC) {  /* a truncated record */
            status = SK_ERR_IO;
            break;
        }
        for (size_t k = 0; k < got / SK_REC; k++) {
            int32_t r, col;
            double v;
            memcpy(&r, buf + k * SK_REC, 4);
            memcpy(&col, buf + k * SK_REC + 4, 4);
            memcpy(&v, buf + k * SK_REC + 8, 8);
            if (r < 1 || col < 1) {
                status = SK_ERR_IO;
                goto done;
            }
            if (c->cap > 0) {
                if (c->count >= c->cap) {
                    status = SK_ERR_SIZE;
                    goto done;
                }
                c->rows[c->count] = r;
                c->cols[c->count] = col;
                c->vals[c->count] = v;
            }
            c->count++;
            if (r > c->maxidx) c->maxidx = r;
            if (col > c->maxidx) c->maxidx = col;
        }
    }
    if (ferror(fh)) status = SK_ERR_IO;
done:
    free(buf);
    return status;
}

/* Text (ccx's own) or binary (sk_ccxio.c) triplets. */
static int sk_scan_triplets(const char *path, sk_trip_ctx *c)
{
    FILE *fh = fopen(path, "rb");
    if (!fh) return SK_ERR_IO;
    int bin = sk_binary(fh);
    int st = bin < 0 ? SK_ERR_IO : bin ? sk_trip_binary(fh, c) : SK_OK;
    fclose(fh);
    if (bin == 0) st = sk_scan_lines(path, sk_trip_line, c);
    return st;
}

/* Number of entries and largest equation number of a .sti/.mas file. */
int sk_c_triplet_count(const char *path, long *nnz, int *neq)
{
    sk_trip_ctx c = {0, 0, 0, NULL, NULL, NULL};
    int st = sk_scan_triplets(path, &c);
    *nnz = c.count;
    *neq = c.maxidx;
    return st;
}

/* Read exactly nnz entries (1-based rows/cols as in the file). */
int sk_c_triplet_read(const char *path, long nnz, int *rows, int *cols, double *vals)
{
    if (nnz < 1) return SK_ERR_SIZE;
    sk_trip_ctx c = {0, nnz, 0, rows, cols, vals};
    int st = sk_scan_triplets(path, &c);
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
                       int nc, const int *ceq, const double *r, double *u, double *q,
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
    for (int j = 0; j < 6; j++) ((double *)B->x)[(size_t)j * (size_t)m + (size_t)(nfree + j)] = 1.0;
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
