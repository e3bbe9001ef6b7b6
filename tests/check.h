/* Minimal test harness shared by every test program.
 *
 * Each test program is a main() that runs checks and ends with
 * `return check_summary("name");`, which prints one line
 * "name: N passed, M failed" that tests/run.sh adds up.
 *
 * Expected values in checks must come from outside the code under test:
 * an analytic solution, a published table, a conservation law.
 */
#ifndef SPHICE_TESTS_CHECK_H
#define SPHICE_TESTS_CHECK_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int check_passed_, check_failed_;

#define CHECK(cond, ...)                                                   \
    do {                                                                   \
        if (cond) {                                                        \
            check_passed_++;                                               \
        } else {                                                           \
            check_failed_++;                                               \
            fprintf(stderr, "FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond); \
            fprintf(stderr, __VA_ARGS__);                                  \
            fputc('\n', stderr);                                           \
        }                                                                  \
    } while (0)

/* |got - want| <= tol_abs + tol_rel * |want| */
#define CHECK_CLOSE(got, want, tol_rel, tol_abs, what)                       \
    do {                                                                     \
        double g_ = (got), w_ = (want);                                      \
        double t_ = (tol_abs) + (tol_rel) * fabs(w_);                        \
        CHECK(isfinite(g_) && fabs(g_ - w_) <= t_,                           \
              "%s: got %.10g want %.10g (tol %.3g, diff %.3g)", (what), g_, \
              w_, t_, fabs(g_ - w_));                                        \
    } while (0)

/* Long or heavy cases shrink when SPHICE_QUICK is set (valgrind runs). */
static inline int check_quick(void) { return getenv("SPHICE_QUICK") != NULL; }
static inline int check_long(void) { return getenv("SPHICE_LONG") != NULL; }

static inline int check_summary(const char *name)
{
    printf("%s: %d passed, %d failed\n", name, check_passed_, check_failed_);
    return check_failed_ ? 1 : 0;
}

#endif
