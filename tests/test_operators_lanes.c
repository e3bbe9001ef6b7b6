/* The strain-rate and stress-divergence passes (src/core/operators.c) run
 * two particles side by side in two-double lanes, and the divergence
 * reads S / M^2 from a per-slot record (issue 22, item 3). Their results
 * must be, bit for bit, the documented sums evaluated per particle in its
 * neighbour list's order (seed eqs. 13 and 15; PHYSICS.md section 4):
 *   e_11 = sum_j m_j (u_j - u_k) gx_kj / M_k, e_22 likewise with v, gy,
 *   e_12 = sum_j m_j ((v_j - v_k) gx + (u_j - u_k) gy) / (2 M_k),
 *   a_k  = sum_j m_j (S_j / M_j^2 + S_k / M_k^2) grad_k W_kj,
 * with the kernel gradient correction's B^-1 where it is on. The test
 * sums them itself, over the model's own lists, and compares the bits;
 * on a jittered lattice the lists have different lengths (the lanes'
 * scalar tails), the particle count is odd (the lone last particle), and
 * sub-lists exercise the active-set form and both divergence paths (a
 * short list: S / M^2 per pair; a long one: per slot).
 * 1 and 2 threads above the threading threshold: the same bits.
 * Analytic: with the gradient correction a linear velocity field's strain
 * rates are exact (B^-1 cancels the kernel's moment), so e_11 = a,
 * e_22 = d, e_12 = (b + c) / 2 for u = a x + b y, v = c x + d y. */
#include <omp.h>
#include <string.h>

#include "check.h"
#include "lattice.h"
#include "../src/core/model_impl.h"

#define NX 23
#define NY 19
/* above the passes' threading threshold (SPH_OMP_WORTH: 4096) */
#define TX 71
#define TY 67

static unsigned rng = 2024u;
static double urand(void)
{
    rng = rng * 1103515245u + 12345u;
    return (double)(rng >> 8 & 0xffff) / 65535.0 - 0.5;
}

/* model.compact_gradients of the scenes (core/neighbours.h's factor form) */
static int compact;

static sph_params lanes_params(sph_kernel_kind kind, int gc)
{
    sph_params p;
    sph_params_default(&p);
    p.kernel = kind;
    p.kernel_radius = 2.0;
    p.sml_factor = kind == SPH_KERNEL_GAUSSIAN ? 1.0 : 1.3;
    p.physics = SPH_PHYSICS_FULL;
    p.gradient_correction = gc;
    p.compact_gradients = compact;
    p.thermo_dt = 0;
    return p;
}

static sph_model *jittered_n(sph_kernel_kind kind, int gc, double dx, int nx, int ny);
static sph_model *jittered(sph_kernel_kind kind, int gc, double dx)
{
    return jittered_n(kind, gc, dx, NX, NY);
}

static sph_model *jittered_n(sph_kernel_kind kind, int gc, double dx, int nx, int ny)
{
    sph_params p = lanes_params(kind, gc);
    sph_model *m = sph_model_create(&p, (size_t)nx * (size_t)ny, NULL);
    sph_particles *P = sph_model_particles(m);
    lattice_fill(P, &p, nx, ny, 0, 0, dx, 1.0, 1.0, 40.6);
    for (size_t k = 0; k < P->n; k++) {
        P->x[k] += 0.3 * dx * urand();
        P->y[k] += 0.3 * dx * urand();
        P->u[k] = 0.05 * urand();
        P->v[k] = 0.05 * urand();
    }
    sph_status st;
    if (sph_model_init(m, &st) != 0) {
        CHECK(0, "init: %s %s", st.quantity, st.what);
        sph_model_free(m);
        return NULL;
    }
    return m;
}

/* grad_k W_kj from the kernel at the particles' positions (unchanged since
 * the model's build): F (x_k - x_j), with F of r^2 and the pair's
 * smoothing length (h_k + h_j) / 2 (core/neighbours.h), not the lists'
 * stored form. */
static void ref_grad(const sph_model *m, size_t k, size_t j, double *gx, double *gy)
{
    const sph_particles *P = m->P;
    double dx = P->x[k] - P->x[j], dy = P->y[k] - P->y[j], W, F;
    sph_kernel_eval(&m->kern, dx * dx + dy * dy, 0.5 * (P->sml[k] + P->sml[j]), &W, &F);
    *gx = F * dx;
    *gy = F * dy;
}

/* The strain rates of particle k as documented, in list order. */
static void ref_strain(const sph_model *m, size_t k, double *e11, double *e22, double *e12)
{
    const sph_particles *P = m->P;
    const sph_nbr *nb = m->nb;
    const int gc = m->prm.gradient_correction;
    double a11 = 0, a22 = 0, a12 = 0, a21 = 0;
    for (int q = 0; q < nb->count[k]; q++) {
        size_t s = nb->off[k] + (size_t)q, j = (size_t)nb->idx[s];
        double du = P->u[j] - P->u[k], dv = P->v[j] - P->v[k], gx, gy;
        ref_grad(m, k, j, &gx, &gy);
        a11 += P->mass[j] * du * gx;
        a22 += P->mass[j] * dv * gy;
        if (gc) {
            a12 += P->mass[j] * dv * gx;
            a21 += P->mass[j] * du * gy;
        } else {
            a12 += P->mass[j] * (dv * gx + du * gy);
        }
    }
    if (gc) { /* the velocity gradient G = [[a11, a21], [a12, a22]] times B^-1 */
        const double *bi = m->binv + 6 * k;
        const double G[2][2] = {{a11, a21}, {a12, a22}}, B[2][2] = {{bi[0], bi[1]}, {bi[1], bi[2]}};
        double C[2][2];
        for (int r = 0; r < 2; r++)
            for (int c = 0; c < 2; c++)
                C[r][c] = G[r][0] * B[0][c] + G[r][1] * B[1][c];
        a11 = C[0][0];
        a22 = C[1][1];
        a12 = C[0][1] + C[1][0];
    }
    double iM = 1.0 / P->dens[k];
    *e11 = a11 * iM;
    *e22 = a22 * iM;
    *e12 = 0.5 * a12 * iM;
}

static void ref_divergence(const sph_model *m, size_t k, double *ax, double *ay)
{
    const sph_particles *P = m->P;
    const sph_nbr *nb = m->nb;
    const int gc = m->prm.gradient_correction;
    double iMk2 = 1.0 / (P->dens[k] * P->dens[k]);
    double tk11 = P->s11[k] * iMk2, tk22 = P->s22[k] * iMk2, tk12 = P->s12[k] * iMk2;
    const double *bk = m->binv + 6 * k + 3;
    double sx = 0, sy = 0;
    for (int q = 0; q < nb->count[k]; q++) {
        size_t s = nb->off[k] + (size_t)q, j = (size_t)nb->idx[s];
        double iMj2 = 1.0 / (P->dens[j] * P->dens[j]);
        double t11 = P->s11[j] * iMj2 + tk11, t22 = P->s22[j] * iMj2 + tk22,
               t12 = P->s12[j] * iMj2 + tk12;
        double gx, gy;
        ref_grad(m, k, j, &gx, &gy);
        if (gc) {
            const double *bj = m->binv + 6 * j + 3;
            double cx = 0.5 * ((bk[0] + bj[0]) * gx + (bk[1] + bj[1]) * gy);
            gy = 0.5 * ((bk[1] + bj[1]) * gx + (bk[2] + bj[2]) * gy);
            gx = cx;
        }
        sx += P->mass[j] * (t11 * gx + t12 * gy);
        sy += P->mass[j] * (t12 * gx + t22 * gy);
    }
    *ax = sx;
    *ay = sy;
}

static int same_bits(double a, double b) { return memcmp(&a, &b, sizeof a) == 0; }

/* Compares the passes' output for the listed particles with the sums. */
static void compare(sph_model *m, const int *list, size_t count, const char *what)
{
    sph_particles *P = m->P;
    size_t bad_e = 0, bad_a = 0, nodd = 0, nonfinite = 0;
    for (size_t i = 0; i < count; i++) {
        size_t k = list ? (size_t)list[i] : i;
        double e11, e22, e12, ax, ay;
        ref_strain(m, k, &e11, &e22, &e12);
        ref_divergence(m, k, &ax, &ay);
        bad_e += !same_bits(e11, P->e11[k]) || !same_bits(e22, P->e22[k]) || !same_bits(e12, P->e12[k]);
        bad_a += !same_bits(ax, P->ax[k]) || !same_bits(ay, P->ay[k]);
        nonfinite += !isfinite(e11) || !isfinite(e22) || !isfinite(e12) || !isfinite(ax) ||
                     !isfinite(ay) || (e11 == 0.0 && ax == 0.0);
        if (i + 1 < count) {
            size_t k1 = list ? (size_t)list[i + 1] : i + 1;
            nodd += m->nb->count[k] != m->nb->count[k1];
        }
    }
    CHECK(bad_e == 0, "%s: strain rates bit for bit the list-order sums (%zu of %zu differ)", what,
          bad_e, count);
    CHECK(bad_a == 0, "%s: stress divergence bit for bit the list-order sums (%zu of %zu differ)",
          what, bad_a, count);
    CHECK(nonfinite == 0, "%s: finite, non-zero sums (%zu not)", what, nonfinite);
    CHECK(nodd > count / 4, "%s: neighbouring entries have lists of different lengths (%zu)", what,
          nodd);
}

static void test_passes(sph_kernel_kind kind, int gc, const char *name)
{
    char what[96];
    sph_model *m = jittered(kind, gc, 1000.0);
    if (!m)
        return;
    sph_particles *P = sph_model_particles(m);
    sph_status st;
    CHECK(sph_model_diagnose(m, &st) == 0, "%s gc=%d: diagnose", name, gc);
    CHECK(P->n % 2 == 1, "odd particle count (%zu)", P->n);
    snprintf(what, sizeof what, "%s gc=%d all", name, gc);
    compare(m, NULL, P->n, what);
    /* sub-lists (the active-set form): every 31st particle (odd length,
     * fewer pairs than slots: the divergence's per-pair path), then all
     * particles but two (per-slot path) */
    static int list[NX * NY];
    size_t c1 = 0;
    for (size_t k = 0; k < P->n; k += 31)
        list[c1++] = (int)k;
    for (size_t k = 0; k < P->n; k++) {
        P->u[k] += 0.01 * urand();
        P->s11[k] *= 1.0 + 0.1 * urand();
    }
    sph_strain_pass(m, list, c1);
    sph_divergence_pass(m, list, c1);
    snprintf(what, sizeof what, "%s gc=%d sparse list (%zu, S/M^2 per pair)", name, gc, c1);
    compare(m, list, c1, what);
    size_t c2 = 0;
    for (size_t k = 1; k < P->n; k++)
        if (k != P->n / 2)
            list[c2++] = (int)k;
    sph_strain_pass(m, list, c2);
    sph_divergence_pass(m, list, c2);
    snprintf(what, sizeof what, "%s gc=%d dense list (%zu, S/M^2 per slot)", name, gc, c2);
    compare(m, list, c2, what);
    sph_model_free(m);
}

/* With the correction, a linear velocity field's strain rates are exact. */
static void test_linear(sph_kernel_kind kind, const char *name)
{
    sph_model *m = jittered(kind, 1, 1000.0);
    if (!m)
        return;
    sph_particles *P = sph_model_particles(m);
    const double a = 2e-6, b = -1e-6, c = 0.5e-6, d = -3e-6;
    for (size_t k = 0; k < P->n; k++) {
        P->u[k] = a * P->x[k] + b * P->y[k];
        P->v[k] = c * P->x[k] + d * P->y[k];
    }
    sph_status st;
    CHECK(sph_model_diagnose(m, &st) == 0, "%s linear: diagnose", name);
    double worst = 0.0;
    size_t used = 0;
    for (size_t k = 0; k < P->n; k++) {
        const double *bi = m->binv + 6 * k;
        if (bi[0] == 1.0 && bi[1] == 0.0 && bi[2] == 1.0)
            continue; /* ill-conditioned moment: no correction there */
        used++;
        worst = fmax(worst, fabs(P->e11[k] - a));
        worst = fmax(worst, fabs(P->e22[k] - d));
        worst = fmax(worst, fabs(P->e12[k] - 0.5 * (b + c)));
    }
    CHECK(used > P->n / 2, "%s linear: corrected particles %zu of %zu", name, used, P->n);
    CHECK(worst < 1e-9 * 3e-6, "%s linear: corrected strain rates exact (worst error %.3g 1/s)", name,
          worst);
    sph_model_free(m);
}

/* 1 and 2 threads: the same bits (each list is summed whole by one
 * thread; the lanes pair list entries, whatever the split). */
static void test_threads(int gc)
{
    double *out[2] = {NULL, NULL};
    size_t n = 0;
    for (int t = 0; t < 2; t++) {
        omp_set_num_threads(t + 1);
        rng = 77u;
        sph_model *m = jittered_n(SPH_KERNEL_WENDLAND_C2, gc, 1000.0, TX, TY);
        if (!m)
            return;
        sph_particles *P = sph_model_particles(m);
        sph_status st;
        CHECK(sph_model_diagnose(m, &st) == 0, "threads=%d gc=%d: diagnose", t + 1, gc);
        n = P->n;
        out[t] = malloc(5 * n * sizeof(double));
        memcpy(out[t], P->e11, n * sizeof(double));
        memcpy(out[t] + n, P->e22, n * sizeof(double));
        memcpy(out[t] + 2 * n, P->e12, n * sizeof(double));
        memcpy(out[t] + 3 * n, P->ax, n * sizeof(double));
        memcpy(out[t] + 4 * n, P->ay, n * sizeof(double));
        sph_model_free(m);
    }
    CHECK(n >= 4096, "above the threading threshold (%zu)", n);
    CHECK(out[0] && out[1] && !memcmp(out[0], out[1], 5 * n * sizeof(double)),
          "gc=%d: strain rates and divergence bit for bit the same on 1 and 2 threads", gc);
    free(out[0]);
    free(out[1]);
    omp_set_num_threads(1);
}

int main(void)
{
    test_passes(SPH_KERNEL_GAUSSIAN, 0, "gaussian");
    test_passes(SPH_KERNEL_GAUSSIAN, 1, "gaussian");
    test_passes(SPH_KERNEL_WENDLAND_C2, 0, "wendland");
    test_passes(SPH_KERNEL_WENDLAND_C2, 1, "wendland");
    test_linear(SPH_KERNEL_GAUSSIAN, "gaussian");
    test_linear(SPH_KERNEL_WENDLAND_C2, "wendland");
    test_threads(0);
    test_threads(1);
    /* the gradients as factor and positions: the same sums, bit for bit */
    compact = 1;
    test_passes(SPH_KERNEL_GAUSSIAN, 0, "gaussian compact");
    test_passes(SPH_KERNEL_WENDLAND_C2, 1, "wendland compact");
    test_threads(0);
    compact = 0;
    return check_summary("test_operators_lanes");
}
