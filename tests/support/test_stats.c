/* test_stats.c — see test_stats.h. */
#include "test_stats.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "test_support.h"

/* Regularised upper incomplete gamma Q(a, x) (Numerical Recipes 6.2:
 * series below a + 1, continued fraction above). */
double sg_test_gamma_q(double a, double x)
{
    if (x <= 0.0)
        return 1.0;
    double gln = lgamma(a);
    if (x < a + 1.0) {
        double ap = a, sum = 1.0 / a, del = sum;
        for (int n = 0; n < 10000 && fabs(del) > fabs(sum) * 1e-15; ++n) {
            ap += 1.0;
            del *= x / ap;
            sum += del;
        }
        return 1.0 - sum * exp(-x + a * log(x) - gln);
    }
    double b = x + 1.0 - a, c = 1.0 / 1e-300, d = 1.0 / b, h = d;
    for (int i = 1; i < 10000; ++i) {
        double an = -i * (i - a);
        b += 2.0;
        d = an * d + b;
        if (fabs(d) < 1e-300)
            d = 1e-300;
        c = b + an / c;
        if (fabs(c) < 1e-300)
            c = 1e-300;
        d = 1.0 / d;
        double del = d * c;
        h *= del;
        if (fabs(del - 1.0) < 1e-15)
            break;
    }
    return exp(-x + a * log(x) - gln) * h;
}

typedef struct keyed {
    double key;   /* expected count */
    size_t index; /* cell            */
} keyed;

static int by_expected(const void *a, const void *b)
{
    const keyed *x = a, *y = b;
    if (x->key != y->key)
        return (x->key > y->key) - (x->key < y->key);
    return (x->index > y->index) - (x->index < y->index);
}

/* Pearson chi-square p-value of observed vs expected counts, pooling cells
 * under 5 expected (smallest first) so the chi-square approximation holds.
 * A sample in a cell of expected 0 is an outright failure (p = 0). On a
 * failure the table goes to <tmpdir>/<name>.tsv for plotting. */
double sg_test_chi2(const char *name, const double *obs, const double *expd, size_t n, int *dof_out,
                        double *chi2_out)
{
    keyed *idx = malloc((n ? n : 1) * sizeof *idx);
    assert_non_null(idx);
    for (size_t i = 0; i < n; ++i) {
        idx[i].key = expd[i];
        idx[i].index = i;
        if (expd[i] == 0.0 && obs[i] > 0.0) {
            fprintf(stderr, "%s: %g samples in cell %zu whose expected count is 0\n", name, obs[i], i);
            free(idx);
            *dof_out = 0;
            *chi2_out = INFINITY;
            return 0.0;
        }
    }
    qsort(idx, n, sizeof *idx, by_expected);
    double chi2 = 0.0, po = 0.0, pe = 0.0, last_o = 0.0, last_e = 0.0;
    int cells = 0;
    for (size_t k = 0; k < n; ++k) {
        double o = obs[idx[k].index], e = expd[idx[k].index];
        if (e < 5.0) {
            po += o;
            pe += e;
            if (pe < 5.0)
                continue;
            o = po;
            e = pe;
            po = pe = 0.0;
        }
        chi2 += (o - e) * (o - e) / e;
        ++cells;
        last_o = o;
        last_e = e;
    }
    if (pe > 0.0 && cells > 0) { /* leftover pool: merge into the last cell */
        chi2 -= (last_o - last_e) * (last_o - last_e) / last_e;
        last_o += po;
        last_e += pe;
        chi2 += (last_o - last_e) * (last_o - last_e) / last_e;
    }
    free(idx);
    int dof = cells - 1;
    double p = dof > 0 ? sg_test_gamma_q(0.5 * dof, 0.5 * chi2) : 1.0;
    *dof_out = dof;
    *chi2_out = chi2;
    return p;
}

void sg_test_dump_table(const char *name, const double *obs, const double *expd, size_t n, size_t cols)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s.tsv", sg_test_tmpdir(), name);
    FILE *f = fopen(path, "w");
    if (!f)
        return;
    fprintf(f, "row\tcol\tobserved\texpected\n");
    for (size_t i = 0; i < n; ++i)
        fprintf(f, "%zu\t%zu\t%.0f\t%.3f\n", i / cols, i % cols, obs[i], expd[i]);
    fclose(f);
    fprintf(stderr, "%s: table written to %s\n", name, path);
}

/* Sidak: each of m tests at 1 - (1 - alpha)^(1/m) keeps the family at alpha. */
double sg_test_sidak(double alpha, int m) { return 1.0 - pow(1.0 - alpha, 1.0 / m); }

/* Fibonacci lattice F_22 points, generator F_21, shifted by (s0, s1)
 * (Cranley-Patterson), point i. Independent random shifts make each
 * lattice sum an unbiased estimate whose spread gives a standard error. */
void sg_test_lattice(size_t i, double s0, double s1, double *u0, double *u1)
{
    double a = (double)i / SG_TEST_LATTICE_N + s0, b = (double)((i * SG_TEST_LATTICE_G) % SG_TEST_LATTICE_N) / SG_TEST_LATTICE_N + s1;
    *u0 = a - floor(a);
    *u1 = b - floor(b);
}

