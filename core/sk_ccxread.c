/*
 * Readers of the text files that CalculiX writes with *FREQUENCY,
 * SOLVER=MATRIXSTORAGE (the sparse route; core/sk_sparse.f90 calls them):
 *
 *   job.sti / job.mas   "row col value" per line, 1-based equation numbers,
 *                       upper triangle (row <= col) of K / M; or, written
 *                       by ccx with core/sk_ccxio.c preloaded, a binary
 *                       .sti: the header "SKSTI-BINARY-1\n", then (int32
 *                       row, int32 col, float64 value) records (exact
 *                       values, nothing to parse)
 *   job.dof             "node.direction" per line: equation i is that dof
 *
 * Every function is prefixed sk_c_ and returns a status of sk_status.h:
 *   0 ok, 1 sizes inconsistent, 31 file missing, unreadable or malformed,
 *   32 out of memory.
 * Text is read in one pass over a large buffer per call (the counting
 * pass reads the indices only; numbers by an exact fast path, else strtod).
 */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sk_status.h"

#define SK_BUF (1 << 22)

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
