/*
 * LD_PRELOAD shim for ccx's *FREQUENCY, SOLVER=MATRIXSTORAGE run (the
 * matrix route, fea/solve.py). ccx 2.20 writes K (job.sti) and M (job.mas)
 * as "%d %d %20.13e\n" lines with __fprintf_chk: on a 284k-equation K that
 * formatting is 56 % of ccx's CPU time, and the reader's parse comes on top.
 * With this library preloaded:
 *   - job.mas (unused by stiffkit) gets no output at all;
 *   - with STIFFKIT_EXACT_K=1 in the environment, job.sti gets the header
 *     SK_STI_MAGIC and then binary records (int32 row, int32 col, float64
 *     value): no formatting, no parsing, and the value exact (the text has
 *     14 digits). fea/solve.py sets it for every matrix-route run (unless
 *     the user's STIFFKIT_EXACT_K=0): on the slender structured beam
 *     (examples/beam.toml, 116k nodes) the 14-digit rounding of K moves the
 *     bending compliance by 3.5e-4 relative (cond(K) amplifies it); one step
 *     of iterative refinement on the exact K moves the solution by < 4e-7,
 *     so the exact-K figure is the FE model's own.
 * Only streams whose path ends in .sti or .mas, and only that exact format
 * string, are diverted; every other call goes to glibc unchanged, so a ccx
 * that writes differently produces its ordinary text (which the reader,
 * core/sk_cholmod.c, still reads). Written for glibc (dlsym RTLD_NEXT).
 */
#undef _FILE_OFFSET_BITS /* meson's default renames fopen to fopen64: ccx calls fopen */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SK_STI_MAGIC "SKSTI-BINARY-1\n"
#define SK_STI_FORMAT "%d %d %20.13e\n"
/* exported even when built with hidden visibility (meson extension modules) */
#define SK_EXPORT __attribute__((visibility("default")))

static FILE *sk_sti = NULL, *sk_mas = NULL;

static int sk_ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s), m = strlen(suffix);
    return n >= m && strcmp(s + n - m, suffix) == 0;
}

static FILE *sk_opened(FILE *f, const char *path, const char *mode)
{
    if (f && path && mode && mode[0] == 'w') {
        const char *exact = getenv("STIFFKIT_EXACT_K");
        if (sk_ends_with(path, ".sti") && exact && strcmp(exact, "1") == 0) {
            sk_sti = f;
            fwrite(SK_STI_MAGIC, 1, sizeof(SK_STI_MAGIC) - 1, f);
        } else if (sk_ends_with(path, ".mas")) {
            sk_mas = f;
        }
    }
    return f;
}

SK_EXPORT FILE *fopen(const char *path, const char *mode)
{
    static FILE *(*real)(const char *, const char *) = NULL;
    if (!real) real = (FILE * (*)(const char *, const char *)) dlsym(RTLD_NEXT, "fopen");
    return sk_opened(real(path, mode), path, mode);
}

SK_EXPORT FILE *fopen64(const char *path, const char *mode)
{
    static FILE *(*real)(const char *, const char *) = NULL;
    if (!real) real = (FILE * (*)(const char *, const char *)) dlsym(RTLD_NEXT, "fopen64");
    return sk_opened(real(path, mode), path, mode);
}

SK_EXPORT int fclose(FILE *f)
{
    static int (*real)(FILE *) = NULL;
    if (!real) real = (int (*)(FILE *))dlsym(RTLD_NEXT, "fclose");
    if (f == sk_sti) sk_sti = NULL;
    if (f == sk_mas) sk_mas = NULL;
    return real(f);
}

static int sk_divert(FILE *f, const char *fmt, va_list ap)
{
    if (f == sk_mas && strcmp(fmt, SK_STI_FORMAT) == 0) return 1;
    if (f == sk_sti && strcmp(fmt, SK_STI_FORMAT) == 0) {
        struct {
            int32_t row, col;
            double val;
        } rec;
        rec.row = (int32_t)va_arg(ap, int);
        rec.col = (int32_t)va_arg(ap, int);
        rec.val = va_arg(ap, double);
        return fwrite(&rec, sizeof rec, 1, f) == 1 ? 1 : -1;
    }
    return 0;
}

SK_EXPORT int __fprintf_chk(FILE *f, int flag, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int d = sk_divert(f, fmt, ap);
    va_end(ap);
    if (d > 0) return 1;
    if (d < 0) return -1;
    va_start(ap, fmt);
    int r = __vfprintf_chk(f, flag, fmt, ap);
    va_end(ap);
    return r;
}

SK_EXPORT int fprintf(FILE *f, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int d = sk_divert(f, fmt, ap);
    va_end(ap);
    if (d > 0) return 1;
    if (d < 0) return -1;
    va_start(ap, fmt);
    int r = vfprintf(f, fmt, ap);
    va_end(ap);
    return r;
}
