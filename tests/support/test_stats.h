/* test_stats.h — statistics for estimator tests (STYLE.md "Estimators"):
 * chi-square goodness of fit with pooling, Sidak correction, and a shifted
 * Fibonacci lattice for QMC integrals with a standard error. */
#ifndef SG_TEST_STATS_H
#define SG_TEST_STATS_H

#include <stddef.h>

/* Regularised upper incomplete gamma Q(a, x) (Numerical Recipes 6.2). */
double sg_test_gamma_q(double a, double x);

/* Pearson chi-square p-value of observed vs expected counts over n cells,
 * pooling cells under 5 expected (smallest first). A count in a cell of
 * expected 0 is an outright failure (p = 0). *dof_out and *chi2_out get the
 * degrees of freedom and the statistic. */
double sg_test_chi2(const char *name, const double *obs, const double *expd, size_t n, int *dof_out,
                    double *chi2_out);

/* Writes observed and expected counts to <tmpdir>/<name>.tsv for plotting. */
void sg_test_dump_table(const char *name, const double *obs, const double *expd, size_t n, size_t cols);

/* Per-test level that keeps a family of m tests at alpha (Sidak). */
double sg_test_sidak(double alpha, int m);

/* Fibonacci lattice of SG_TEST_LATTICE_N points (generator
 * SG_TEST_LATTICE_G), Cranley-Patterson shifted by (s0, s1): point i. */
#define SG_TEST_LATTICE_N 17711
#define SG_TEST_LATTICE_G 10946
void sg_test_lattice(size_t i, double s0, double s1, double *u0, double *u1);

#endif
