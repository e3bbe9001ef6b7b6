/* The SPH sea-ice model: one dynamic step, driven from outside.
 *
 * Step n -> n+1 (params.dt):
 *  1. reorder particles by cell (locality), mirror ghosts at coasts,
 *     neighbour lists with cached kernel values and gradients;
 *  2. SPH density M_k = sum_j m_j W_kj, concentration A = M/(rho_i h_i);
 *     A > 1 ridges: A = 1 and h_i = M/rho_i (volume conserved: mass fixed);
 *  3. ice strength, regime per particle (auto: free drift where
 *     exp(-C(1-A)) < auto_tolerance in the whole neighbourhood);
 *  4. momentum with the chosen stress solver; water drag and Coriolis
 *     implicit (Coriolis trapezoidal, so it conserves kinetic energy);
 *  5. positions (trapezoidal), coasts, open boundaries, smoothing length;
 *  6. thermodynamics when its step falls due; budgets and health.
 */
#include "core/model.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/kernel.h"
#include "core/neighbours.h"
#include "core/rheology.h"

#include <gsl/gsl_errno.h>
#include <gsl/gsl_spblas.h>
#include <gsl/gsl_splinalg.h>
#include <gsl/gsl_spmatrix.h>
#include <gsl/gsl_vector.h>

#define OMEGA_EARTH 7.292e-5
/* Bound of lambda_max h^2 / nu of the SPH viscous operator (measured). */
#define SPH_VISCOUS_EIG 1.25
/* Threads pay off only above a few thousand particles: the solver runs
 * thousands of short passes per step, each a fork/join. */
#define SPH_OMP_WORTH(n) ((n) >= 4096)
/* Measured stability envelope (bench_stability, 4-day coast runs):
 * fixed-parameter mEVP (alpha = beta = 300) blew up or clumped at
 * dt 300 s below 2 km and at 1800 s; adaptive EVP is stable at dt/dx =
 * 0.06 s/m and blew up at 0.3 s/m (1 km, 300 s) and clumped at 0.45;
 * refused above 0.2 s/m (between the two; runs at 0.14 are tested).
 * On the current core the same channel no longer blows up at 0.3-0.9 s/m
 * in 96 h, but the state departs from the small-step one (docs/dynamics.md,
 * "Auto time stepping"); the bound stays until the envelope is re-measured
 * with an accuracy criterion. */
#define SPH_MEVP_FIXED_DT_MAX 300.0
#define SPH_MEVP_FIXED_DT_FINE 60.0
#define SPH_AEVP_DT_PER_M 0.2
/* With replacement pressure: plastic-wave Courant number dt c_p / spacing,
 * c_p = sqrt(k P0 / rho_i) the uniaxial plastic wave speed of packed ice
 * (PHYSICS.md s. 8). Measured on the R300 channel (tests/test_r300.c,
 * docs/dynamics.md): holds its steady state at 0.137 (5 km, 120 s),
 * drifts with growing kinetic energy at 0.205 (5 km 180 s; 2.5 km 90 s). */
#define SPH_REPLACEMENT_COURANT_MAX 0.15
/* Smallest concentration a parcel is diluted to by divergence. */
#define SPH_CONC_MIN 0.05
#define DEG2RAD (M_PI / 180.0)

struct sph_model {
    sph_params prm;
    sph_kernel kern;
    sph_particles *P; /* capacity 2*cap: live particles then ghosts */
    size_t cap;
    size_t ng;        /* ghosts this step, at indices [n, n + ng) */
    int *ghost_src;
    double *ghost_nx, *ghost_ny, *ghost_n2x, *ghost_n2y;
    sph_nbr *nb;
    int has_mask;
    sph_landmask mask;
    unsigned char *land;
    unsigned char *near_land; /* sea cells within the ghost radius of land */
    double near_radius;
    /* workspaces, [2*cap] */
    double *un, *vn;     /* velocity at the start of the step */
    double *zeta;        /* last bulk viscosity */
    double *vfluct;      /* fluctuating velocity (collision rheology) */
    double *dvel;        /* per-particle velocity change of the last iteration */
    double *scratch;     /* permutation and misc, [2*cap*SPH_MAX_LAYERS] */
    int *order;
    int *active;         /* particles iterated by the stress solver */
    size_t nactive;
    unsigned char *loose; /* per particle: free drift in auto mode */
    double dens_scale;   /* lattice calibration of the truncated kernel */
    double *fcor;        /* Coriolis parameter per particle, set each step */
    double cos_air, sin_air, cos_water, sin_water; /* turning angles */
    sph_thermo_work *tw;
    /* implicit solver workspace (allocated at create when the solver is
     * implicit; GSL grows its sparse matrices to their high-water mark on
     * the first steps, then reuses them) */
    gsl_spmatrix *Bt, *Ct, *Dt, *Kt, *B, *Cm, *D, *K, *T, *L, *A;
    gsl_vector *xv, *bv, *dv;
    gsl_splinalg_itersolve *gmres;
    double *ghost_G; /* per ghost: 2x2 velocity map and 3x3 stress map */
    double *binv;    /* [6*c2] gradient correction per particle: B^-1 of the strain
                        rates (b11, b12, b22), then of the stress divergence */
    sph_budget budget;
    sph_step_stats stats;
    double time, thermo_accum;
    long steps;
};

static int implicit_create(sph_model *m);

static void set_turning(sph_model *m)
{
    m->cos_air = cos(m->prm.turn_air * DEG2RAD);
    m->sin_air = sin(m->prm.turn_air * DEG2RAD);
    m->cos_water = cos(m->prm.turn_water * DEG2RAD);
    m->sin_water = sin(m->prm.turn_water * DEG2RAD);
}

sph_model *sph_model_create(const sph_params *p, size_t cap, const sph_landmask *mask)
{
    const char *nm;
    double lo, hi;
    if (!p || cap == 0 || sph_params_check(p, &nm, &lo, &hi) != SPH_STEP_OK)
        return NULL;
    sph_model *m = calloc(1, sizeof *m);
    if (!m)
        return NULL;
    m->prm = *p;
    m->cap = cap;
    sph_kernel_init(&m->kern, p->kernel, p->kernel_radius);
    int nl = p->thermo.nlayers > 0 ? p->thermo.nlayers : 1;
    if (nl > SPH_MAX_LAYERS)
        nl = SPH_MAX_LAYERS;
    int with_mask = mask && mask->land && mask->nx > 0 && mask->ny > 0;
    /* ghosts: up to three per particle near a corner */
    size_t c2 = with_mask ? 4 * cap : cap;
    m->P = sph_particles_create(c2, nl);
    m->nb = sph_nbr_create(cap, c2, p->max_neighbours);
    m->ghost_src = calloc(c2, sizeof(int));
    m->ghost_nx = calloc(c2, sizeof(double));
    m->ghost_ny = calloc(c2, sizeof(double));
    m->ghost_n2x = calloc(c2, sizeof(double));
    m->ghost_n2y = calloc(c2, sizeof(double));
    m->un = calloc(c2, sizeof(double));
    m->vn = calloc(c2, sizeof(double));
    m->zeta = calloc(c2, sizeof(double));
    m->vfluct = calloc(c2, sizeof(double));
    m->dvel = calloc(c2, sizeof(double));
    m->binv = calloc(6 * c2, sizeof(double));
    for (size_t q = 0; m->binv && q < 2 * c2; q++) { /* B^-1 = I: no correction */
        m->binv[3 * q] = 1.0;
        m->binv[3 * q + 2] = 1.0;
    }
    m->fcor = calloc(c2, sizeof(double));
    m->scratch = calloc(c2 * SPH_MAX_LAYERS, sizeof(double));
    m->order = calloc(c2, sizeof(int));
    m->active = calloc(c2, sizeof(int));
    m->loose = calloc(c2, 1);
    m->tw = sph_thermo_work_create(c2, nl);
    int ok = m->P && m->nb && m->ghost_src && m->ghost_nx && m->ghost_ny && m->ghost_n2x && m->ghost_n2y && m->un && m->vn &&
             m->zeta && m->vfluct && m->dvel && m->binv && m->fcor && m->scratch && m->order && m->active && m->loose && m->tw;
    if (ok && with_mask) {
        size_t nc = (size_t)mask->nx * (size_t)mask->ny;
        m->land = malloc(nc);
        m->near_land = calloc(nc, 1);
        ok = m->land && m->near_land;
        if (ok) {
            memcpy(m->land, mask->land, nc);
            m->mask = *mask;
            m->mask.land = m->land;
            m->has_mask = 1;
        }
    }
    if (!ok) {
        sph_model_free(m);
        return NULL;
    }
    m->dens_scale = 1.0;
    set_turning(m);
    if (p->solver == SPH_SOLVER_IMPLICIT && implicit_create(m) != 0) {
        sph_model_free(m);
        return NULL;
    }
    return m;
}

void sph_model_free(sph_model *m)
{
    if (!m)
        return;
    sph_particles_free(m->P);
    sph_nbr_free(m->nb);
    free(m->ghost_src);
    free(m->ghost_nx);
    free(m->ghost_ny);
    free(m->ghost_n2x);
    free(m->ghost_n2y);
    free(m->un);
    free(m->vn);
    free(m->zeta);
    free(m->vfluct);
    free(m->dvel);
    free(m->binv);
    free(m->fcor);
    free(m->scratch);
    free(m->order);
    free(m->active);
    free(m->loose);
    free(m->land);
    free(m->near_land);
    sph_thermo_work_free(m->tw);
    gsl_spmatrix *mats[] = {m->Bt, m->Ct, m->Dt, m->Kt, m->B, m->Cm, m->D, m->K, m->T, m->L, m->A};
    for (size_t i = 0; i < sizeof mats / sizeof mats[0]; i++)
        if (mats[i])
            gsl_spmatrix_free(mats[i]);
    if (m->xv)
        gsl_vector_free(m->xv);
    if (m->bv)
        gsl_vector_free(m->bv);
    if (m->dv)
        gsl_vector_free(m->dv);
    if (m->gmres)
        gsl_splinalg_itersolve_free(m->gmres);
    free(m->ghost_G);
    free(m);
}

sph_particles *sph_model_particles(sph_model *m) { return m->P; }
const sph_params *sph_model_params(const sph_model *m) { return &m->prm; }
const sph_budget *sph_model_budget(const sph_model *m) { return &m->budget; }
double sph_model_time(const sph_model *m) { return m->time; }
long sph_model_steps(const sph_model *m) { return m->steps; }
const sph_step_stats *sph_model_stats(const sph_model *m) { return &m->stats; }
size_t sph_model_capacity(const sph_model *m) { return m->cap; }
size_t sph_model_ghosts(const sph_model *m) { return m->ng; }

int sph_model_set_params(sph_model *m, const sph_params *p)
{
    const char *nm;
    double lo, hi;
    if (sph_params_check(p, &nm, &lo, &hi) != SPH_STEP_OK)
        return SPH_STEP_FATAL;
    if (p->max_neighbours != m->prm.max_neighbours ||
        (p->thermo.nlayers > 0 ? p->thermo.nlayers : 1) != m->P->nlayers)
        return SPH_STEP_FATAL;
    m->prm = *p;
    sph_kernel_init(&m->kern, p->kernel, p->kernel_radius);
    set_turning(m);
    return SPH_STEP_OK;
}

/* ------------------------------------------------------------------ */
/* the stability envelope and auto time stepping                       */

double sph_params_stable_dt(const sph_params *p, double spacing, const char **why)
{
    double lim = HUGE_VAL;
    const char *w = "no measured stability bound (free drift, or a solver that sub-steps or is implicit)";
    if (p->physics == SPH_PHYSICS_FREE_DRIFT || !(spacing > 0.0)) {
        if (why)
            *why = w;
        return lim;
    }
    if (p->solver == SPH_SOLVER_MEVP && !p->evp_adaptive) {
        lim = spacing < 2000.0 ? SPH_MEVP_FIXED_DT_FINE : SPH_MEVP_FIXED_DT_MAX;
        w = "is outside the measured stable region of fixed-parameter mEVP "
            "(blow-up or clumping measured beyond it); refused";
    }
    if (p->solver == SPH_SOLVER_MEVP && p->evp_adaptive && SPH_AEVP_DT_PER_M * spacing < lim) {
        lim = SPH_AEVP_DT_PER_M * spacing;
        w = "is outside the measured stable region of adaptive EVP "
            "(dt / spacing above 0.2 s/m; stable at 0.06-0.15, blow-up measured at 0.3 on "
            "an earlier core); refused";
    }
    if (p->rheology == SPH_RHEOLOGY_VP && p->replacement_pressure) {
        double k = 0.5 * (1.0 + sqrt(1.0 + 1.0 / (p->ecc * p->ecc)));
        double cp = sqrt(k * p->P0 / p->rho_i);
        double d = cp > 0.0 ? SPH_REPLACEMENT_COURANT_MAX * spacing / cp : HUGE_VAL;
        if (d < lim) {
            lim = d;
            w = "is outside the measured stable region with replacement pressure "
                "(plastic-wave Courant number dt c_p / spacing above 0.15; "
                "stable at 0.137, drift and growth measured at 0.205); refused";
        }
    }
    if (why)
        *why = w;
    return lim;
}

double sph_params_auto_dt(const sph_params *p, double spacing, double base, const char **why)
{
    const char *w = NULL;
    double stable = sph_params_stable_dt(p, spacing, &w);
    int rp = p->rheology == SPH_RHEOLOGY_VP && p->replacement_pressure;
    double bound = (rp ? SPH_AUTO_DT_SAFETY_RP : SPH_AUTO_DT_SAFETY) * stable;
    const char *b = rp ? "half the measured stable step" : "0.6 of the measured stable step";
    double cor = SPH_AUTO_DT_CORIOLIS / (2.0 * OMEGA_EARTH);
    if (!(bound <= cor)) {
        bound = cor;
        b = "the Coriolis accuracy bound f dt <= 0.1";
    }
    if (!(base > 0.0) || !isfinite(base))
        base = bound;
    double n = ceil(base / bound - 1e-9);
    if (n < 1.0)
        n = 1.0;
    if (why)
        *why = n == 1.0 && base < bound ? "the step it must divide (thermodynamics, output)" : b;
    return base / n;
}

double sph_model_spacing(const sph_model *m)
{
    const sph_particles *P = m->P;
    double s = HUGE_VAL;
    for (size_t k = 0; k < P->n; k++) {
        double h = P->sml0[k] > 0.0 ? P->sml0[k] : P->sml[k];
        s = fmin(s, h / m->prm.sml_factor);
    }
    return s;
}

/* ------------------------------------------------------------------ */
/* land mask                                                           */

static int mask_cell(const sph_model *m, double x, double y, int *ci, int *cj)
{
    const sph_landmask *k = &m->mask;
    double fi = floor((x - k->x0) / k->dx), fj = floor((y - k->y0) / k->dy);
    /* written so that a NaN position is outside (no out-of-range index) */
    if (!(fi >= 0 && fj >= 0 && fi < k->nx && fj < k->ny))
        return 0;
    *ci = (int)fi;
    *cj = (int)fj;
    return 1;
}

/* 1 if the point is land (or outside a closed domain). */
static int is_land(const sph_model *m, double x, double y)
{
    if (!m->has_mask)
        return 0;
    int i, j;
    if (!mask_cell(m, x, y, &i, &j))
        return m->mask.closed_outside;
    return m->land[(size_t)j * m->mask.nx + i] != 0;
}

static int outside_open(const sph_model *m, double x, double y)
{
    /* a non-finite position is a blow-up for check_health to report, not outflow */
    if (!m->has_mask || m->mask.closed_outside || !isfinite(x) || !isfinite(y))
        return 0;
    int i, j;
    return !mask_cell(m, x, y, &i, &j);
}

static int land_at(const sph_model *m, int i, int j)
{
    const sph_landmask *k = &m->mask;
    if (i < 0 || j < 0 || i >= k->nx || j >= k->ny)
        return k->closed_outside;
    return k->land[(size_t)j * k->nx + i] != 0;
}

/* Marks sea cells within `radius` of a land cell (done once, at init). */
static void mark_near_land(sph_model *m, double radius)
{
    const sph_landmask *k = &m->mask;
    int ri = (int)ceil(radius / k->dx) + 1, rj = (int)ceil(radius / k->dy) + 1;
    m->near_radius = radius;
    for (int j = 0; j < k->ny; j++)
        for (int i = 0; i < k->nx; i++) {
            unsigned char nl = 0;
            for (int b = -rj; b <= rj && !nl; b++)
                for (int a = -ri; a <= ri && !nl; a++)
                    if (land_at(m, i + a, j + b))
                        nl = 1;
            m->near_land[(size_t)j * k->nx + i] = nl;
        }
}

/* Nearest land cell (as a rectangle) within radius: distance and the unit
 * normal pointing from the coast into the sea. Returns 0 if none. */
/* With (exnx, exny) non-zero, only land in front of the first wall's
 * tangent line through (exx, exy) counts: a second, different wall. */
static int nearest_coast(const sph_model *m, double x, double y, double radius, double *dist,
                         double *nx, double *ny, double exx, double exy, double exnx, double exny)
{
    const sph_landmask *k = &m->mask;
    int ci, cj;
    if (!mask_cell(m, x, y, &ci, &cj))
        return 0;
    if (!m->near_land[(size_t)cj * k->nx + ci])
        return 0;
    int ri = (int)ceil(radius / k->dx) + 1, rj = (int)ceil(radius / k->dy) + 1;
    double best = radius, bx = 0, by = 0;
    int found = 0;
    for (int j = cj - rj; j <= cj + rj; j++)
        for (int i = ci - ri; i <= ci + ri; i++) {
            if (!land_at(m, i, j))
                continue;
            double xl = k->x0 + i * k->dx, yl = k->y0 + j * k->dy;
            double px = fmin(fmax(x, xl), xl + k->dx), py = fmin(fmax(y, yl), yl + k->dy);
            double d = hypot(x - px, y - py);
            /* a second wall: its nearest point lies in front of the first
             * wall (not another point of the same coast) */
            if ((exnx != 0.0 || exny != 0.0) &&
                (px - exx) * exnx + (py - exy) * exny <= 1e-6 * k->dx)
                continue;
            if (d < best && d > 0.0) {
                best = d;
                bx = px;
                by = py;
                found = 1;
            }
        }
    if (!found)
        return 0;
    *dist = best;
    *nx = (x - bx) / best;
    *ny = (y - by) / best;
    return 1;
}

/* Mirror ghosts: each live particle within the kernel support of a coast
 * is reflected across the local coast line (the tangent at the nearest
 * land point); near a second wall facing another way (a corner) it is
 * also reflected across that one, and across both. Ghosts carry the
 * source's mass, density, thickness and strength, mirrored velocity (free
 * slip: normal component reversed; no slip: whole velocity reversed) and
 * mirrored stress R S R, R = I - 2 n n^T (applied per wall). */
static int add_ghost(sph_model *m, size_t k, double gx, double gy, double n1x, double n1y,
                     double n2x, double n2y)
{
    sph_particles *P = m->P;
    size_t q = P->n + m->ng;
    if (q >= P->cap)
        return 0;
    sph_particles_copy_one(P, q, P, k);
    P->x[q] = gx;
    P->y[q] = gy;
    m->ghost_src[m->ng] = (int)k;
    m->ghost_nx[m->ng] = n1x;
    m->ghost_ny[m->ng] = n1y;
    m->ghost_n2x[m->ng] = n2x;
    m->ghost_n2y[m->ng] = n2y;
    m->ng++;
    return 1;
}

static void build_ghosts(sph_model *m)
{
    sph_particles *P = m->P;
    size_t n = P->n;
    m->ng = 0;
    if (!m->has_mask)
        return;
    for (size_t k = 0; k < n; k++) {
        double radius = m->kern.radius * P->sml[k];
        double d1, n1x, n1y, d2, n2x, n2y;
        double x = P->x[k], y = P->y[k];
        P->regime[k] &= (unsigned char)~SPH_REGIME_NEAR_COAST;
        if (!nearest_coast(m, x, y, radius, &d1, &n1x, &n1y, 0.0, 0.0, 0.0, 0.0))
            continue;
        P->regime[k] |= SPH_REGIME_NEAR_COAST;
        double g1x = x - 2.0 * d1 * n1x, g1y = y - 2.0 * d1 * n1y;
        add_ghost(m, k, g1x, g1y, n1x, n1y, 0.0, 0.0);
        if (nearest_coast(m, x, y, radius, &d2, &n2x, &n2y, x - d1 * n1x, y - d1 * n1y, n1x,
                          n1y)) {
            add_ghost(m, k, x - 2.0 * d2 * n2x, y - 2.0 * d2 * n2y, n2x, n2y, 0.0, 0.0);
            /* a corner (walls at an angle) also needs the doubly mirrored ghost;
             * facing walls (a channel) do not */
            if (fabs(n1x * n2x + n1y * n2y) < 0.5)
                add_ghost(m, k, g1x - 2.0 * d2 * n2x, g1y - 2.0 * d2 * n2y, n1x, n1y, n2x, n2y);
        }
    }
}

/* Ghost velocities. For the rheology (mirror = 1) the ghost is a true
 * mirror image: normal component reversed, so ice converging on a coast
 * is compressed and ice leaving it is in divergence, where the
 * viscous-plastic stress relaxes. This pairs the ghosts' stress push with
 * the strain it does work against: with the normal velocity not reversed
 * for ice moving away, a compressed parcel kept its stress and the ghosts
 * kept pushing it off the coast, feeding kinetic energy in (a pack
 * bounced off a wall at 13 times its impact speed, bench plastic_wave).
 * For continuity (mirror = 0) a coast pushes but never pulls: ice moving
 * towards it (u.n < 0) sees the mirrored normal velocity, ice moving away
 * sees its own, so leaving a coast opens water behind it instead of
 * stretching the parcel. Tangentially: free slip keeps the component, no
 * slip reverses it. */
static inline void reflect_vec(double nx, double ny, int no_slip, int mirror, double *u,
                               double *v)
{
    if (nx == 0.0 && ny == 0.0)
        return;
    double un = *u * nx + *v * ny;
    double ut_x = *u - un * nx, ut_y = *v - un * ny;
    double gn = (mirror || un < 0.0) ? -un : un;
    if (no_slip) {
        ut_x = -ut_x;
        ut_y = -ut_y;
    }
    *u = ut_x + gn * nx;
    *v = ut_y + gn * ny;
}

static void ghost_velocity(sph_model *m, double *u, double *v, int mirror)
{
    size_t n = m->P->n;
    for (size_t g = 0; g < m->ng; g++) {
        size_t q = n + g, k = (size_t)m->ghost_src[g];
        double a = u[k], b = v[k];
        reflect_vec(m->ghost_nx[g], m->ghost_ny[g], m->prm.coast_no_slip, mirror, &a, &b);
        reflect_vec(m->ghost_n2x[g], m->ghost_n2y[g], m->prm.coast_no_slip, mirror, &a, &b);
        u[q] = a;
        v[q] = b;
    }
}

static inline void reflect_tensor(double nx, double ny, double *a, double *b, double *c)
{
    if (nx == 0.0 && ny == 0.0)
        return;
    /* S' = R S R with R = I - 2 n n^T; S = [[a, b], [b, c]] */
    double r11 = 1 - 2 * nx * nx, r12 = -2 * nx * ny, r22 = 1 - 2 * ny * ny;
    double t11 = r11 * *a + r12 * *b, t12 = r11 * *b + r12 * *c;
    double t21 = r12 * *a + r22 * *b, t22 = r12 * *b + r22 * *c;
    double s11 = t11 * r11 + t12 * r12, s12 = t11 * r12 + t12 * r22;
    double s22 = t21 * r12 + t22 * r22;
    *a = s11;
    *b = s12;
    *c = s22;
}

/* Ghost stress: the source's stress mirrored, R S R. An even mirror image
 * has no normal gradient at the coast, but ice resting on a coast carries
 * one: the normal momentum balance there (v.n = 0) gives
 * d(sigma_nn)/dn = -F.n, F the external force per area (air and water
 * stress, sea-surface tilt). So the ghost's sigma_nn is extrapolated
 * through the coast, sigma_nn(ghost) = sigma_nn(source) + 2 d F.n (d the
 * source's distance from the coast), the SPH counterpart of a hydrostatic
 * ghost pressure. Only where F presses the ice on the coast (F.n < 0): a
 * coast never pulls. Without it the first rows at a wall compressed until
 * their own stress made up the missing gradient (R300: 2.1 m instead of
 * 1.27 m at the wall). Corner ghosts (two walls) are mirrored only. */
static double ghost_normal_force(const sph_model *m, size_t k, double nx, double ny)
{
    const sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    double ua = P->ua[k], va = P->va[k], sa = hypot(ua, va);
    double tax = p->rho_a * p->Ca * sa * (ua * m->cos_air - va * m->sin_air);
    double tay = p->rho_a * p->Ca * sa * (ua * m->sin_air + va * m->cos_air);
    double rx = P->uw[k] - P->u[k], ry = P->vw[k] - P->v[k], sw = hypot(rx, ry);
    double twx = p->rho_w * p->Cw * sw * (rx * m->cos_water - ry * m->sin_water);
    double twy = p->rho_w * p->Cw * sw * (rx * m->sin_water + ry * m->cos_water);
    double fx = tax + twx - P->dens[k] * p->gravity * P->sshx[k];
    double fy = tay + twy - P->dens[k] * p->gravity * P->sshy[k];
    return fx * nx + fy * ny;
}

static void ghost_stress(sph_model *m)
{
    sph_particles *P = m->P;
    size_t n = P->n;
    for (size_t g = 0; g < m->ng; g++) {
        size_t q = n + g, k = (size_t)m->ghost_src[g];
        double a = P->s11[k], b = P->s12[k], c = P->s22[k];
        reflect_tensor(m->ghost_nx[g], m->ghost_ny[g], &a, &b, &c);
        reflect_tensor(m->ghost_n2x[g], m->ghost_n2y[g], &a, &b, &c);
        double nx = m->ghost_nx[g], ny = m->ghost_ny[g];
        if (m->ghost_n2x[g] == 0.0 && m->ghost_n2y[g] == 0.0) {
            double fn = ghost_normal_force(m, k, nx, ny);
            if (fn < 0.0) {
                double d = 0.5 * ((P->x[k] - P->x[q]) * nx + (P->y[k] - P->y[q]) * ny);
                /* at most the ice's own strength: a stress step the ice
                 * could not carry is no gradient of a resting state */
                double ds = fmax(2.0 * d * fn, -P->pres[k]);
                a += ds * nx * nx;
                b += ds * nx * ny;
                c += ds * ny * ny;
            }
        }
        P->s11[q] = a;
        P->s12[q] = b;
        P->s22[q] = c;
        P->dens[q] = P->dens[k];
        P->pres[q] = P->pres[k];
        P->conc[q] = P->conc[k];
        P->thick[q] = P->thick[k];
    }
}

/* ------------------------------------------------------------------ */
/* SPH passes                                                          */

static double max_sml(const sph_particles *P, size_t n)
{
    double hmax = 0.0;
    for (size_t k = 0; k < n; k++)
        hmax = fmax(hmax, P->sml[k]);
    return hmax;
}

/* Reorders live particles by cell so that neighbours are close in memory. */
static void reorder(sph_model *m)
{
    sph_particles *P = m->P;
    size_t n = P->n;
    if (n < 2)
        return;
    double cell = m->kern.radius * max_sml(P, n);
    sph_nbr_grid(m->nb, n, P->x, P->y, cell);
    int ident = 1;
    for (size_t i = 0; i < n; i++) {
        m->order[i] = m->nb->sorted[i];
        ident &= m->order[i] == (int)i;
    }
    if (!ident)
        sph_particles_permute(P, m->order, m->scratch);
}

static void density_pass(sph_model *m)
{
    sph_particles *P = m->P;
    const sph_nbr *nb = m->nb;
    size_t n = P->n;
    double scale = m->dens_scale;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        const size_t base = nb->off[k];
        double s = 0.0;
        for (int q = 0; q < nb->count[k]; q++)
            s += P->mass[nb->idx[base + q]] * nb->w[base + q];
        P->dens[k] = scale * s;
    }
}

/* Concentration, ridging, strength, and the auto regime's loose flags. */
static void diagnose(sph_model *m)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    size_t n = P->n;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        double hbar = P->dens[k] / p->rho_i;
        double A = hbar / P->thick[k];
        if (A > 1.0) { /* ridging: A = 1, the ice thickens at constant volume */
            P->thick[k] = hbar;
            A = 1.0;
        }
        P->conc[k] = A;
        P->pres[k] = sph_ice_strength(p, hbar, A);
        double factor = exp(-p->C * (1.0 - A));
        m->loose[k] = p->physics == SPH_PHYSICS_FREE_DRIFT ||
                      (p->physics == SPH_PHYSICS_AUTO && factor < p->auto_tolerance);
    }
}

/* The EVP stress memory can lag behind a strength that fell (divergence,
 * melt): a stress outside the current yield ellipse is projected back
 * onto it, S = -P/2 I + (S + P/2 I) / r, r the ellipse radius. Without
 * this a diluted parcel kept the stress of its packed past and S/M^2
 * blew up near coasts (demo). VP only: the collision rheology has no
 * ellipse. */
static void clamp_stress_memory(sph_model *m)
{
    sph_particles *P = m->P;
    if (m->prm.rheology != SPH_RHEOLOGY_VP)
        return;
    double e = m->prm.ecc;
    size_t n = P->n;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        double Pk = P->pres[k];
        double a = P->s11[k], b = P->s22[k], c = P->s12[k];
        if (!(Pk > 0.0)) {
            P->s11[k] = P->s22[k] = P->s12[k] = 0.0;
            continue;
        }
        double sI = 0.5 * (a + b), sII = sqrt(0.25 * (a - b) * (a - b) + c * c);
        double x = (sI + 0.5 * Pk) / (0.5 * Pk), y = sII / (0.5 * Pk / e);
        double r = sqrt(x * x + y * y);
        if (r > 1.0) {
            double h = 0.5 * Pk;
            P->s11[k] = -h + (a + h) / r;
            P->s22[k] = -h + (b + h) / r;
            P->s12[k] = c / r;
        }
    }
}

/* Active set: particles that are packed or have a packed neighbour. */
static void select_active(sph_model *m)
{
    sph_particles *P = m->P;
    const sph_nbr *nb = m->nb;
    size_t n = P->n, na = 0;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        int act = 0;
        if (m->prm.physics != SPH_PHYSICS_FREE_DRIFT) {
            const size_t base = nb->off[k];
            for (int q = 0; q < nb->count[k] && !act; q++) {
                int j = nb->idx[base + q];
                size_t src = (size_t)j < n ? (size_t)j : (size_t)m->ghost_src[(size_t)j - n];
                act = !m->loose[src];
            }
        }
        P->regime[k] &= (unsigned char)~(SPH_REGIME_FREE_DRIFT | SPH_REGIME_RHEOLOGY);
        P->regime[k] |= act ? SPH_REGIME_RHEOLOGY : SPH_REGIME_FREE_DRIFT;
    }
    for (size_t k = 0; k < n; k++) /* serial: the list in particle order */
        if (P->regime[k] & SPH_REGIME_RHEOLOGY)
            m->active[na++] = (int)k;
    m->nactive = na;
}

/* Strain rates (seed eq. 15, sign settled by the linear-field test) and
 * the fluctuating velocity for the collision rheology, for the listed
 * particles (list NULL: all live particles). */
static void strain_pass(sph_model *m, const int *list, size_t count)
{
    sph_particles *P = m->P;
    const sph_nbr *nb = m->nb;
    const double *u = P->u, *v = P->v, *mass = P->mass;
    int want_fluct = m->prm.rheology == SPH_RHEOLOGY_COLLISION;
    const int gc = m->prm.gradient_correction;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(count))
    for (size_t i = 0; i < count; i++) {
        size_t k = list ? (size_t)list[i] : i;
        const size_t base = nb->off[k];
        double a11 = 0, a22 = 0, a12 = 0, a21 = 0, fl = 0, wsum = 0;
        for (int q = 0; q < nb->count[k]; q++) {
            size_t s = base + (size_t)q;
            int j = nb->idx[s];
            double du = u[j] - u[k], dv = v[j] - v[k];
            double gx = nb->gx[s], gy = nb->gy[s];
            a11 += mass[j] * du * gx;
            a22 += mass[j] * dv * gy;
            if (gc) { /* the two off-diagonal gradients apart */
                a12 += mass[j] * dv * gx;
                a21 += mass[j] * du * gy;
            } else {
                a12 += mass[j] * (dv * gx + du * gy);
            }
            if (want_fluct) {
                double wj = mass[j] / P->dens[j] * nb->w[s];
                fl += wj * (du * du + dv * dv);
                wsum += wj;
            }
        }
        double iM = 1.0 / P->dens[k];
        if (gc) {
            /* velocity gradient G_ab = sum_j m_j dv_a g_b / M_k, i.e.
             * [[a11, a21], [a12, a22]]; corrected: G B_k^-1 */
            const double *bi = m->binv + 6 * k;
            double g11 = a11 * bi[0] + a21 * bi[1], g12 = a11 * bi[1] + a21 * bi[2];
            double g21 = a12 * bi[0] + a22 * bi[1], g22 = a12 * bi[1] + a22 * bi[2];
            a11 = g11;
            a22 = g22;
            a12 = g12 + g21;
        }
        P->e11[k] = a11 * iM;
        P->e22[k] = a22 * iM;
        P->e12[k] = 0.5 * a12 * iM;
        if (want_fluct) {
            double vf = wsum > 0 ? sqrt(fl / wsum) : 0.0;
            m->vfluct[k] = fmax(vf, m->prm.coll_vfluct_min);
        }
    }
}

/* The coast ghosts' part of particle k's velocity divergence (the strain
 * pass's sum restricted to ghost neighbours). */
static double coast_divergence(const sph_model *m, size_t k)
{
    const sph_particles *P = m->P;
    const sph_nbr *nb = m->nb;
    const size_t base = nb->off[k], n = P->n;
    double a = 0.0;
    for (int q = 0; q < nb->count[k]; q++) {
        size_t s = base + (size_t)q;
        size_t j = (size_t)nb->idx[s];
        if (j < n)
            continue;
        const double *bi = m->binv + 6 * k;
        double gx = bi[0] * nb->gx[s] + bi[1] * nb->gy[s], gy = bi[1] * nb->gx[s] + bi[2] * nb->gy[s];
        a += P->mass[j] * ((P->u[j] - P->u[k]) * gx + (P->v[j] - P->v[k]) * gy);
    }
    return a / P->dens[k];
}

/* Constitutive stress for particle k from its strain rates; returns zeta. */
static inline double target_stress(const sph_model *m, size_t k, double *s11, double *s22,
                                   double *s12)
{
    const sph_particles *P = m->P;
    if (m->loose[k]) {
        *s11 = *s22 = *s12 = 0.0;
        return 0.0;
    }
    if (m->prm.rheology == SPH_RHEOLOGY_COLLISION)
        return sph_collision_stress(&m->prm, P->thick[k], P->conc[k], m->vfluct[k], P->e11[k],
                                    P->e22[k], P->e12[k], s11, s22, s12);
    return sph_vp_stress(&m->prm, P->pres[k], P->e11[k], P->e22[k], P->e12[k], s11, s22, s12);
}

/* Symmetric stress divergence (seed eq. 13): a_k = [div(hbar sigma)/M]_k. */
static void divergence_pass(sph_model *m, const int *list, size_t count)
{
    sph_particles *P = m->P;
    const sph_nbr *nb = m->nb;
    const int gc = m->prm.gradient_correction;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(count))
    for (size_t i = 0; i < count; i++) {
        size_t k = list ? (size_t)list[i] : i;
        const size_t base = nb->off[k];
        double iMk2 = 1.0 / (P->dens[k] * P->dens[k]);
        double tk11 = P->s11[k] * iMk2, tk22 = P->s22[k] * iMk2, tk12 = P->s12[k] * iMk2;
        double ax = 0, ay = 0;
        const double *bk = m->binv + 6 * k + 3;
        for (int q = 0; q < nb->count[k]; q++) {
            size_t s = base + (size_t)q;
            int j = nb->idx[s];
            double iMj2 = 1.0 / (P->dens[j] * P->dens[j]);
            double t11 = P->s11[j] * iMj2 + tk11, t22 = P->s22[j] * iMj2 + tk22,
                   t12 = P->s12[j] * iMj2 + tk12;
            double gx = nb->gx[s], gy = nb->gy[s];
            if (gc) { /* (B_k^-1 + B_j^-1)/2 grad W: still antisymmetric in k, j */
                const double *bj = m->binv + 6 * (size_t)j + 3;
                double cx = 0.5 * ((bk[0] + bj[0]) * gx + (bk[1] + bj[1]) * gy);
                gy = 0.5 * ((bk[1] + bj[1]) * gx + (bk[2] + bj[2]) * gy);
                gx = cx;
            }
            ax += P->mass[j] * (t11 * gx + t12 * gy);
            ay += P->mass[j] * (t12 * gx + t22 * gy);
        }
        P->ax[k] = ax;
        P->ay[k] = ay;
    }
}

/* Momentum for particle k with implicit water drag (lagged speed) and
 * trapezoidal Coriolis, solved as a 2x2 system:
 *   (1+beta) u' = beta u_p + u_n + dt [a_int + tau_a/(rho h) - g grad xi
 *                 + c R_w (U_w - u') - f k x (u' + u_n)/2]
 * c = rho_w C_w |U_w - u_p| / M. beta = 0 is a plain implicit
 * step; beta > 0 is the mEVP pseudo-time iteration (Kimmritz et al. 2015),
 * whose fixed point is the same time-discrete equation. */
static inline void momentum(const sph_model *m, size_t k, double beta, double up, double vp,
                            double un, double vn, double dt, double *uo, double *vo)
{
    const sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    /* mass per unit area M = rho_i A h_i: PHYSICS.md eq. 2 applies the
     * full drag to M (Hibler 1979), so loose ice responds faster */
    double rho_h = P->dens[k];
    double ua = P->ua[k], va = P->va[k];
    /* sqrt rather than hypot: this runs once per particle and iteration
     * (hypot's overflow care cost 5 % of a packed run), and wind and
     * current speeds are far from overflow */
    double sa = sqrt(ua * ua + va * va);
    double ca = m->cos_air, sna = m->sin_air;
    double tax = p->rho_a * p->Ca * sa * (ua * ca - va * sna);
    double tay = p->rho_a * p->Ca * sa * (ua * sna + va * ca);
    double uw = P->uw[k], vw = P->vw[k];
    double dux = uw - up, duy = vw - vp;
    double c = p->rho_w * p->Cw * sqrt(dux * dux + duy * duy) / rho_h;
    double cw = m->cos_water, sw = m->sin_water;
    double f = m->fcor[k];
    double rx = beta * up + un +
                dt * (P->ax[k] + tax / rho_h + c * (cw * uw - sw * vw) -
                      p->gravity * P->sshx[k] + 0.5 * f * vn);
    double ry = beta * vp + vn +
                dt * (P->ay[k] + tay / rho_h + c * (sw * uw + cw * vw) -
                      p->gravity * P->sshy[k] - 0.5 * f * un);
    double d11 = 1.0 + beta + dt * c * cw, d22 = d11;
    double d12 = -dt * (c * sw + 0.5 * f), d21 = -d12;
    double det = d11 * d22 - d12 * d21;
    *uo = (d22 * rx - d12 * ry) / det;
    *vo = (d11 * ry - d21 * rx) / det;
}

/* Free drift (no internal force) for the particles not in the active set. */
static void free_drift_pass(sph_model *m)
{
    sph_particles *P = m->P;
    size_t n = P->n;
    double dt = m->prm.dt;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        if (P->regime[k] & SPH_REGIME_RHEOLOGY)
            continue;
        P->ax[k] = P->ay[k] = 0.0;
        P->s11[k] = P->s22[k] = P->s12[k] = 0.0;
        /* Picard sweeps on the lagged drag speed until the velocity settles
         * (long steps need more than a few: c dt >> 1) */
        double u = m->un[k], v = m->vn[k];
        for (int it = 0; it < 60; it++) {
            double un, vn;
            momentum(m, k, 0.0, u, v, m->un[k], m->vn[k], dt, &un, &vn);
            double d = fabs(un - u) + fabs(vn - v);
            /* the plain lagged iteration oscillates when c dt >> 1 (its
             * derivative tends to -1); averaging removes that mode */
            if (it == 0) {
                u = un;
                v = vn;
            } else {
                u = 0.5 * (u + un);
                v = 0.5 * (v + vn);
            }
            if (d <= 1e-13 * (1.0 + fabs(u) + fabs(v)))
                break;
        }
        P->u[k] = u;
        P->v[k] = v;
    }
}

/* Explicit viscous step limit. Forward Euler on the viscous operator is
 * stable for dt < 2 / lambda_max = 2 h^2 / (SPH_VISCOUS_EIG nu), nu =
 * zeta_max (1 + e^-2) / M; the limit used is safety * h^2 / nu (default
 * safety 1, inside the bound 1.6). */
static double explicit_limit(const sph_model *m)
{
    const sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    double lim = HUGE_VAL;
    for (size_t i = 0; i < m->nactive; i++) {
        size_t k = (size_t)m->active[i];
        double zmax;
        if (p->rheology == SPH_RHEOLOGY_COLLISION) {
            zmax = m->zeta[k];
        } else {
            zmax = fmin(P->pres[k] / (2.0 * p->delta_min), p->zeta_max_factor * P->pres[k]);
        }
        double nu = zmax * (1.0 + 1.0 / (p->ecc * p->ecc)) / P->dens[k];
        if (nu > 0.0)
            lim = fmin(lim, p->explicit_safety * P->sml[k] * P->sml[k] / nu);
    }
    return lim;
}

double sph_model_explicit_dt_limit(sph_model *m) { return explicit_limit(m); }

static int solve_explicit(sph_model *m, sph_status *st)
{
    sph_particles *P = m->P;
    double dt = m->prm.dt;
    double lim = explicit_limit(m);
    m->stats.dt_limit_explicit = lim;
    int nsub = 1;
    if (dt > lim) {
        double want = ceil(dt / lim);
        if (m->prm.unstable == SPH_UNSTABLE_REFUSE || want > m->prm.max_substeps)
            return sph_status_set(st, SPH_STEP_RECOVERABLE, -1, "time step", dt, lim,
                                  "exceeds the explicit solver's stability limit");
        nsub = (int)want;
    }
    double dts = dt / nsub;
    const int *act = m->active;
    size_t na = m->nactive;
    for (int s = 0; s < nsub; s++) {
        ghost_velocity(m, P->u, P->v, 1);
        strain_pass(m, act, na);
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(na))
        for (size_t i = 0; i < na; i++) {
            size_t k = (size_t)act[i];
            m->zeta[k] = target_stress(m, k, &P->s11[k], &P->s22[k], &P->s12[k]);
        }
        ghost_stress(m);
        divergence_pass(m, act, na);
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(na))
        for (size_t i = 0; i < na; i++) {
            size_t k = (size_t)act[i];
            double u = P->u[k], v = P->v[k];
            momentum(m, k, 0.0, u, v, u, v, dts, &P->u[k], &P->v[k]);
        }
    }
    m->stats.substeps = nsub;
    return SPH_STEP_OK;
}

static int sph_solve_implicit(sph_model *m, sph_status *st);

static int solve_mevp(sph_model *m, sph_status *st)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    double dt = p->dt;
    const int *act = m->active;
    size_t na = m->nactive;
    int it;
    double resid = 0.0;
    /* auto: stall detection on the RMS velocity change (the maximum is
     * dominated by single particles and is no measure of progress): no new
     * minimum in win iterations */
    const int win = p->physics == SPH_PHYSICS_AUTO ? p->evp_stall_window : 0;
    double rms_ref = 0.0;
    int it_ref = 0;
    m->stats.stalled = 0;
    for (it = 0; it < p->evp_iterations; it++) {
        ghost_velocity(m, P->u, P->v, 1);
        strain_pass(m, act, na);
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(na))
        for (size_t i = 0; i < na; i++) {
            size_t k = (size_t)act[i];
            double t11, t22, t12;
            double z = target_stress(m, k, &t11, &t22, &t12);
            m->zeta[k] = z;
            double alpha = p->evp_alpha;
            if (p->evp_adaptive) {
                /* aEVP (Kimmritz, Losch & Danilov 2016): alpha = beta = 2 sqrt(gamma),
                 * gamma = dt lambda_max of the SPH viscous operator. Power
                 * iteration on lattices gives lambda_max h^2 / nu = 0.68-0.74
                 * (Gaussian, h = dx) and 1.15-1.23 (Wendland C2, cubic spline,
                 * h = 1.3 dx), nu = zeta (1 + e^-2) / M; SPH_VISCOUS_EIG = 1.25
                 * bounds them all (docs/dynamics.md). */
                double gam = SPH_VISCOUS_EIG * z * (1.0 + 1.0 / (p->ecc * p->ecc)) * dt /
                             (P->dens[k] * P->sml[k] * P->sml[k]);
                alpha = fmax(2.0 * sqrt(gam), 10.0);
            }
            m->scratch[k] = alpha; /* beta = alpha */
            double ia = 1.0 / alpha;
            P->s11[k] += (t11 - P->s11[k]) * ia;
            P->s22[k] += (t22 - P->s22[k]) * ia;
            P->s12[k] += (t12 - P->s12[k]) * ia;
        }
        ghost_stress(m);
        divergence_pass(m, act, na);
        double r = 0.0;
        /* velocity update; the max change is reduced serially afterwards */
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(na))
        for (size_t i = 0; i < na; i++) {
            size_t k = (size_t)act[i];
            double beta = p->evp_adaptive ? m->scratch[k] : p->evp_beta;
            double u, v;
            momentum(m, k, beta, P->u[k], P->v[k], m->un[k], m->vn[k], dt, &u, &v);
            m->dvel[k] = fmax(fabs(u - P->u[k]), fabs(v - P->v[k]));
            P->u[k] = u;
            P->v[k] = v;
        }
        double s2 = 0.0;
        for (size_t i = 0; i < na; i++) {
            double d = m->dvel[(size_t)act[i]];
            r = fmax(r, d);
            s2 += d * d;
        }
        resid = r;
        if (!isfinite(r))
            return sph_status_set(st, SPH_STEP_FATAL, -1, "mEVP residual", r, 0.0,
                                  "is not finite (the stress iteration diverged)");
        if (r < p->evp_tol) {
            it++;
            break;
        }
        if (win > 0) {
            double rms = sqrt(s2 / (double)na);
            if (it == 0 || rms < rms_ref) {
                rms_ref = rms;
                it_ref = it;
            } else if (it - it_ref >= win) {
                m->stats.stalled = 1;
                it++;
                break;
            }
        }
    }
    m->stats.iterations = it;
    m->stats.residual = resid;
    return SPH_STEP_OK;
}


/* Kernel gradient correction (model.gradient_correction; Bonet & Lok
 * 1999, Randles & Libersky 1996). The SPH gradient of a linear field is
 * B_k times the true one, B_k = sum_j V_j (-F_kj) d d^T (d = r_k - r_j);
 * B = I only on a regular lattice with a kernel whose lattice sums are
 * exact. Where the smoothing length varies (seed eq. 10 under uniaxial
 * compression shrinks h across the flow too) or spacing is anisotropic,
 * B departs from I by a few per cent, and the resting stress gradient a
 * uniform wind needs comes out that much steeper (R300: ridged zone
 * +2.7 % without, +0.47 % with; docs/dynamics.md). With the correction
 * the strain rates use B_k^-1 grad W_kj, with V_j = m_j / M_k (the strain
 * pass's weights: exact for a linear velocity field), and the symmetric
 * stress divergence (B_k^-1 + B_j^-1)/2 grad W_kj with V_j = m_j / M_j
 * (the divergence's own consistency weights), which stays antisymmetric
 * in k, j: internal forces still sum to zero. B^-1 = I where the
 * correction is off, and where B is ill-conditioned (det B < 1/4: a
 * corner, a particle with few neighbours). Ghosts take their source's
 * B^-1, mirrored. */
static void invert_moment(double b11, double b12, double b22, double *bi)
{
    double det = b11 * b22 - b12 * b12;
    if (det > 0.25 && b11 > 0.0 && b22 > 0.0) {
        bi[0] = b22 / det;
        bi[1] = -b12 / det;
        bi[2] = b11 / det;
    } else {
        bi[0] = 1.0;
        bi[1] = 0.0;
        bi[2] = 1.0;
    }
}

static void gradient_correction_pass(sph_model *m)
{
    sph_particles *P = m->P;
    const sph_nbr *nb = m->nb;
    const size_t n = P->n;
    if (!m->prm.gradient_correction)
        return; /* binv stays the identity sph_model_create set */
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        double b11 = 0, b12 = 0, b22 = 0, c11 = 0, c12 = 0, c22 = 0;
        const size_t base = nb->off[k];
        for (int q = 0; q < nb->count[k]; q++) {
            size_t s = base + (size_t)q;
            int j = nb->idx[s];
            double dx = P->x[k] - P->x[j], dy = P->y[k] - P->y[j];
            double t11 = -nb->gx[s] * dx, t12 = -nb->gx[s] * dy, t22 = -nb->gy[s] * dy;
            b11 += P->mass[j] * t11;
            b12 += P->mass[j] * t12;
            b22 += P->mass[j] * t22;
            double V = P->mass[j] / P->dens[j];
            c11 += V * t11;
            c12 += V * t12;
            c22 += V * t22;
        }
        double iM = 1.0 / P->dens[k];
        invert_moment(b11 * iM, b12 * iM, b22 * iM, m->binv + 6 * k);
        invert_moment(c11, c12, c22, m->binv + 6 * k + 3);
    }
    for (size_t g = 0; g < m->ng; g++) {
        size_t q = n + g, k = (size_t)m->ghost_src[g];
        for (int h = 0; h < 6; h += 3) {
            double a = m->binv[6 * k + h], b = m->binv[6 * k + h + 1], c = m->binv[6 * k + h + 2];
            reflect_tensor(m->ghost_nx[g], m->ghost_ny[g], &a, &b, &c);
            reflect_tensor(m->ghost_n2x[g], m->ghost_n2y[g], &a, &b, &c);
            m->binv[6 * q + h] = a;
            m->binv[6 * q + h + 1] = b;
            m->binv[6 * q + h + 2] = c;
        }
    }
}

/* Neighbours, density and diagnosis at the current positions. */
static int prepare(sph_model *m, sph_status *st)
{
    sph_particles *P = m->P;
    reorder(m);
    build_ghosts(m);
    size_t nall = P->n + m->ng;
    double cell = m->kern.radius * max_sml(P, nall);
    sph_nbr_grid(m->nb, nall, P->x, P->y, cell);
    long over = -1;
    if (sph_nbr_build(m->nb, &m->kern, P->n, P->x, P->y, P->sml, &over))
        return sph_status_set(st, SPH_STEP_RECOVERABLE, over >= 0 ? P->id[over] : -1,
                              "neighbour count", (double)m->prm.max_neighbours,
                              (double)m->prm.max_neighbours,
                              "exceeds max_neighbours (particle clumping)");
    if (m->prm.summation_density)
        density_pass(m);
    /* ghosts take their source's state */
    for (size_t g = 0; g < m->ng; g++) {
        size_t q = P->n + g, k = (size_t)m->ghost_src[g];
        P->dens[q] = P->dens[k];
    }
    diagnose(m);
    gradient_correction_pass(m);
    clamp_stress_memory(m);
    ghost_stress(m);
    select_active(m);
    return SPH_STEP_OK;
}

static void update_budget(sph_model *m)
{
    sph_particles *P = m->P;
    double mass = 0, area = 0, vol = 0, ke = 0;
    for (size_t k = 0; k < P->n; k++) { /* serial: bit-reproducible */
        mass += P->mass[k];
        area += P->mass[k] / (m->prm.rho_i * P->thick[k]);
        vol += P->mass[k] / m->prm.rho_i;
        ke += 0.5 * P->mass[k] * (P->u[k] * P->u[k] + P->v[k] * P->v[k]);
    }
    m->budget.mass = mass;
    m->budget.area = area;
    m->budget.volume = vol;
    m->budget.kinetic_energy = ke;
}

static int check_health(sph_model *m, sph_status *st)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    for (size_t k = 0; k < P->n; k++) {
        const double vals[] = {P->x[k], P->y[k], P->u[k], P->v[k], P->thick[k], P->mass[k]};
        static const char *const names[] = {"x position", "y position", "x velocity",
                                            "y velocity", "thickness", "mass"};
        for (int q = 0; q < 6; q++)
            if (!isfinite(vals[q]))
                return sph_status_set(st, SPH_STEP_FATAL, P->id[k], names[q], vals[q], 0.0,
                                      "is not finite (numerical blow-up)");
        double sp = hypot(P->u[k], P->v[k]);
        if (sp > p->speed_limit)
            return sph_status_set(st, SPH_STEP_FATAL, P->id[k], "speed", sp, p->speed_limit,
                                  "exceeds the speed limit (numerical blow-up)");
        /* a parcel ridged without bound (e.g. converging on a coast) is a
         * numerical pile-up: no sea-ice cover is tens of metres thick */
        double hbar = P->dens[k] / p->rho_i;
        if (!(hbar <= p->thickness_limit))
            return sph_status_set(st, SPH_STEP_FATAL, P->id[k], "mean thickness", hbar,
                                  p->thickness_limit,
                                  "exceeds the thickness limit (numerical pile-up)");
    }
    const sph_budget *b = &m->budget;
    double expect = b->mass_initial + b->growth + b->new_ice - b->melt_top - b->melt_bottom -
                    b->lateral_melt - b->outflow;
    double tol = p->mass_tolerance * fmax(fabs(expect), fabs(b->mass)) + 1e-300;
    if (fabs(b->mass - expect) > tol)
        return sph_status_set(st, SPH_STEP_FATAL, -1, "total mass", b->mass, expect,
                              "changed beyond round-off with no source or sink to explain it");
    return SPH_STEP_OK;
}

int sph_model_init(sph_model *m, sph_status *st)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    sph_status_clear(st);
    if (P->n > m->cap)
        return sph_status_set(st, SPH_STEP_FATAL, -1, "particle count", (double)P->n,
                              (double)m->cap, "exceeds the model capacity");
    for (size_t k = 0; k < P->n; k++) {
        if (!(P->mass[k] > 0.0) || !isfinite(P->mass[k]))
            return sph_status_set(st, SPH_STEP_FATAL, P->id[k], "mass", P->mass[k], 0.0,
                                  "must be positive");
        if (!(P->thick[k] > 0.0) || !isfinite(P->thick[k]))
            return sph_status_set(st, SPH_STEP_FATAL, P->id[k], "thickness", P->thick[k], 0.0,
                                  "must be positive");
        if (!(P->conc[k] > 0.0 && P->conc[k] <= 1.0))
            return sph_status_set(st, SPH_STEP_FATAL, P->id[k], "concentration", P->conc[k],
                                  1.0, "must be in (0, 1]");
        if (!(P->sml[k] > 0.0) || !isfinite(P->sml[k]))
            return sph_status_set(st, SPH_STEP_FATAL, P->id[k], "smoothing length", P->sml[k],
                                  0.0, "must be positive");
        if (!(P->sml0[k] > 0.0))
            P->sml0[k] = P->sml[k];
        if (!isfinite(P->x[k]) || !isfinite(P->y[k]))
            return sph_status_set(st, SPH_STEP_FATAL, P->id[k], "position", P->x[k], 0.0,
                                  "is not finite");
    }
    /* The measured stability envelope (docs/bench.md, bench/run.sh,
     * docs/bench/stability.csv): outside it a run is refused here, before
     * anything is computed, rather than written out as a forecast. */
    double spacing = sph_model_spacing(m);
    const char *why = NULL;
    double dtmax = sph_params_stable_dt(p, spacing, &why);
    if (P->n > 0 && p->dt > dtmax)
        return sph_status_set(st, SPH_STEP_RECOVERABLE, -1, "time step", p->dt, dtmax, why);
    if (m->has_mask)
        mark_near_land(m, m->kern.radius * p->sml_max_factor * max_sml(P, P->n));
    /* Calibrate the kernel's lattice sum: intended M = rho_i A h_i from the
     * seeded state, over interior particles (full neighbourhoods). */
    m->dens_scale = 1.0;
    reorder(m);
    double *seed_thick = m->dvel, *seed_conc = m->zeta; /* seeded state, before diagnosis */
    for (size_t k = 0; k < P->n; k++) {
        seed_thick[k] = P->thick[k];
        seed_conc[k] = P->conc[k];
    }
    for (size_t k = 0; k < P->n; k++)
        P->dens[k] = p->rho_i * seed_conc[k] * seed_thick[k];
    int rc = prepare(m, st);
    if (rc != SPH_STEP_OK)
        return rc;
    int maxc = 0;
    for (size_t k = 0; k < P->n; k++)
        maxc = m->nb->count[k] > maxc ? m->nb->count[k] : maxc;
    size_t ni = 0;
    double *ratio = m->scratch;
    for (size_t k = 0; k < P->n; k++)
        if (m->nb->count[k] >= (int)(0.9 * maxc) && P->dens[k] > 0)
            ratio[ni++] = p->rho_i * seed_conc[k] * seed_thick[k] / P->dens[k];
    if (ni >= 5) {
        /* median by insertion sort on a bounded sample */
        size_t ns = ni < 2001 ? ni : 2001;
        for (size_t a = 1; a < ns; a++) {
            double t = ratio[a];
            size_t b = a;
            while (b > 0 && ratio[b - 1] > t) {
                ratio[b] = ratio[b - 1];
                b--;
            }
            ratio[b] = t;
        }
        double med = ratio[ns / 2];
        if (med > 0.8 && med < 1.25 && p->summation_density)
            m->dens_scale = med;
    }
    /* re-diagnose with the calibrated density from the seeded state */
    for (size_t k = 0; k < P->n; k++) {
        P->thick[k] = seed_thick[k];
        P->conc[k] = seed_conc[k];
        P->dens[k] = p->rho_i * seed_conc[k] * seed_thick[k];
    }
    rc = prepare(m, st);
    if (rc != SPH_STEP_OK)
        return rc;
    for (size_t k = 0; k < P->n; k++)
        P->dens0[k] = P->dens[k];
    memset(&m->budget, 0, sizeof m->budget);
    update_budget(m);
    m->budget.mass_initial = m->budget.mass;
    m->time = 0.0;
    m->thermo_accum = 0.0;
    m->steps = 0;
    return SPH_STEP_OK;
}

void sph_model_get_clock(const sph_model *m, sph_model_clock *c)
{
    c->time = m->time;
    c->steps = m->steps;
    c->thermo_accum = m->thermo_accum;
    c->dens_scale = m->dens_scale;
    c->budget = m->budget;
}

int sph_model_resume(sph_model *m, const sph_model_clock *c, sph_status *st)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    sph_status_clear(st);
    if (P->n > m->cap)
        return sph_status_set(st, SPH_STEP_FATAL, -1, "particle count", (double)P->n,
                              (double)m->cap, "exceeds the model capacity");
    double sml0_max = 0.0;
    for (size_t k = 0; k < P->n; k++) {
        const double must_pos[] = {P->mass[k], P->thick[k], P->sml[k], P->sml0[k], P->dens[k],
                                   P->dens0[k]};
        static const char *const names[] = {"mass", "thickness", "smoothing length",
                                            "reference smoothing length", "density",
                                            "reference density"};
        for (int q = 0; q < 6; q++)
            if (!(must_pos[q] > 0.0) || !isfinite(must_pos[q]))
                return sph_status_set(st, SPH_STEP_FATAL, P->id[k], names[q], must_pos[q], 0.0,
                                      "must be positive");
        if (!(P->conc[k] > 0.0 && P->conc[k] <= 1.0))
            return sph_status_set(st, SPH_STEP_FATAL, P->id[k], "concentration", P->conc[k],
                                  1.0, "must be in (0, 1]");
        if (!isfinite(P->x[k]) || !isfinite(P->y[k]) || !isfinite(P->u[k]) ||
            !isfinite(P->v[k]))
            return sph_status_set(st, SPH_STEP_FATAL, P->id[k], "position or velocity",
                                  P->x[k], 0.0, "is not finite");
        sml0_max = fmax(sml0_max, P->sml0[k]);
    }
    if (!(c->dens_scale > 0.0) || !isfinite(c->time) || !isfinite(c->thermo_accum))
        return sph_status_set(st, SPH_STEP_FATAL, -1, "clock", c->dens_scale, 0.0,
                              "is not valid");
    const char *why = NULL;
    double dtmax = sph_params_stable_dt(p, sph_model_spacing(m), &why);
    if (P->n > 0 && p->dt > dtmax)
        return sph_status_set(st, SPH_STEP_RECOVERABLE, -1, "time step", p->dt, dtmax, why);
    /* the same radius as sph_model_init used: there every sml equalled sml0 */
    if (m->has_mask)
        mark_near_land(m, m->kern.radius * p->sml_max_factor * sml0_max);
    m->dens_scale = c->dens_scale;
    m->budget = c->budget;
    m->time = c->time;
    m->steps = c->steps;
    m->thermo_accum = c->thermo_accum;
    return SPH_STEP_OK;
}

/* Keeps particles out of land; removes those leaving an open boundary. */
static void move_and_constrain(sph_model *m)
{
    sph_particles *P = m->P;
    double dt = m->prm.dt;
    size_t n = P->n;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        double x0 = P->x[k], y0 = P->y[k];
        double x1 = x0 + 0.5 * dt * (m->un[k] + P->u[k]);
        double y1 = y0 + 0.5 * dt * (m->vn[k] + P->v[k]);
        if (is_land(m, x1, y1)) {
            if (!is_land(m, x1, y0)) {
                y1 = y0;
                P->v[k] = 0.0;
            } else if (!is_land(m, x0, y1)) {
                x1 = x0;
                P->u[k] = 0.0;
            } else {
                x1 = x0;
                y1 = y0;
                P->u[k] = P->v[k] = 0.0;
            }
        }
        P->x[k] = x1;
        P->y[k] = y1;
    }
}

/* Removes particles that left an open boundary (after the strain pass:
 * removal reorders the arrays the neighbour lists point into). */
static void remove_outflow(sph_model *m)
{
    sph_particles *P = m->P;
    for (size_t k = P->n; k-- > 0;) {
        if (outside_open(m, P->x[k], P->y[k])) {
            m->budget.outflow += P->mass[k];
            m->budget.removed_particles++;
            sph_particles_remove(P, k);
        }
    }
}

static void update_sml(sph_model *m)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    if (!p->variable_sml)
        return;
    size_t n = P->n;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        double div = P->e11[k] + P->e22[k];
        double h = P->sml0[k] * sqrt(P->dens0[k] / P->dens[k]) * (1.0 + 0.5 * p->dt * div);
        double lo = p->sml_min_factor * P->sml0[k], hi = p->sml_max_factor * P->sml0[k];
        P->sml[k] = fmin(fmax(h, lo), hi);
    }
}

static void regime_fractions(sph_model *m)
{
    sph_particles *P = m->P;
    size_t fd = 0, rh = 0, zl = 0, ml = 0;
    for (size_t k = 0; k < P->n; k++) {
        fd += (P->regime[k] & SPH_REGIME_FREE_DRIFT) != 0;
        rh += (P->regime[k] & SPH_REGIME_RHEOLOGY) != 0;
        zl += (P->regime[k] & SPH_REGIME_ZERO_LAYER) != 0;
        ml += (P->regime[k] & SPH_REGIME_MULTI_LAYER) != 0;
    }
    double n = P->n > 0 ? (double)P->n : 1.0;
    m->stats.frac_free_drift = (double)fd / n;
    m->stats.frac_rheology = (double)rh / n;
    m->stats.frac_zero_layer = (double)zl / n;
    m->stats.frac_multi_layer = (double)ml / n;
}

int sph_model_step(sph_model *m, sph_status *st)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    sph_status_clear(st);
    st->step = m->steps;
    m->stats.substeps = 1;
    m->stats.iterations = 0;
    m->stats.stalled = 0;
    m->stats.residual = 0.0;
    int rc = prepare(m, st);
    if (rc != SPH_STEP_OK)
        return rc;
    size_t n = P->n;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        m->un[k] = P->u[k];
        m->vn[k] = P->v[k];
        P->ax[k] = P->ay[k] = 0.0;
        m->fcor[k] = p->coriolis ? 2.0 * OMEGA_EARTH * sin(P->lat[k] * DEG2RAD) : 0.0;
    }
    free_drift_pass(m);
    if (m->nactive > 0) {
        if (p->solver == SPH_SOLVER_EXPLICIT)
            rc = solve_explicit(m, st);
        else if (p->solver == SPH_SOLVER_IMPLICIT)
            rc = sph_solve_implicit(m, st);
        else
            rc = solve_mevp(m, st);
        if (rc != SPH_STEP_OK)
            return rc;
    }
    /* positions first: a move blocked by land zeroes the blocked velocity,
     * and only the realised motion may compress a parcel (a particle held
     * at a coast otherwise kept "converging" into land and ridged without
     * bound) */
    move_and_constrain(m);
    /* final strain rates of every particle, for output, continuity and
     * the smoothing length: ghosts are true mirrors, so compression
     * against a coast and its release balance (a row oscillating at a wall
     * does not ratchet up); the release is capped by what the coast
     * compressed (coastc), so ice leaving a coast opens water behind it
     * instead of stretching its parcel. */
    ghost_velocity(m, P->u, P->v, 1);
    strain_pass(m, NULL, P->n);
    if (!p->summation_density) {
        /* continuity in the Lagrangian frame, implicit so M stays positive */
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
        for (size_t k = 0; k < n; k++) {
            double div = P->e11[k] + P->e22[k];
            if (P->regime[k] & SPH_REGIME_NEAR_COAST) {
                double dg = coast_divergence(m, k);
                if (dg < 0.0) {
                    P->coastc[k] -= p->dt * dg;
                } else {
                    double rel = fmin(dg, P->coastc[k] / p->dt);
                    P->coastc[k] -= p->dt * rel;
                    div -= dg - rel;
                }
            }
            double fac = 1.0 + p->dt * div;
            P->dens[k] /= fac > 0.1 ? fac : 0.1;
            /* a parcel spread below SPH_CONC_MIN is open water with a trace
             * of ice: its footprint stops growing (docs/dynamics.md) */
            double floor_dens = SPH_CONC_MIN * p->rho_i * P->thick[k];
            if (P->dens[k] < floor_dens)
                P->dens[k] = floor_dens;
        }
    }
    remove_outflow(m);
    update_sml(m);
    m->time += p->dt;
    m->steps++;
    if (p->thermo_dt > 0.0 && p->thermo.model != SPH_THERMO_OFF) {
        m->thermo_accum += p->dt;
        if (m->thermo_accum >= p->thermo_dt - 1e-9 * p->thermo_dt) {
            for (size_t k = 0; k < P->n; k++)
                m->dvel[k] = P->mass[k];
            rc = sph_thermo_step(&p->thermo, P, m->thermo_accum, m->tw, &m->budget, st);
            /* the footprint is fixed: mass per area scales with the mass */
            if (!p->summation_density)
                for (size_t k = 0; k < P->n; k++)
                    if (m->dvel[k] > 0.0)
                        P->dens[k] *= P->mass[k] / m->dvel[k];
            m->thermo_accum = 0.0;
            if (rc != SPH_STEP_OK)
                return rc;
            for (size_t k = P->n; k-- > 0;)
                if (!(P->mass[k] > 0.0))
                    sph_particles_remove(P, k);
        }
    }
    regime_fractions(m);
    update_budget(m);
    return check_health(m, st);
}

int sph_model_interpolate(sph_model *m, size_t npts, const double *px, const double *py,
                          int nf, const double *const *fields, double *const *out_f,
                          double *out_dens)
{
    sph_particles *P = m->P;
    size_t n = P->n;
    double hmax = max_sml(P, n);
    double R = m->kern.radius;
    sph_nbr_grid(m->nb, n, P->x, P->y, R * hmax);
    const int maxc = 4096;
    int bad = 0;
#pragma omp parallel
    {
        int cand[4096];
#pragma omp for schedule(static)
        for (size_t i = 0; i < npts; i++) {
            int nc = sph_nbr_candidates(m->nb, px[i], py[i], cand, maxc);
            if (nc == maxc)
                bad = 1;
            double wsum = 0.0, dsum = 0.0;
            double acc[16] = {0};
            for (int c = 0; c < nc; c++) {
                int j = cand[c];
                double dx = px[i] - P->x[j], dy = py[i] - P->y[j];
                double W, F;
                sph_kernel_eval(&m->kern, dx * dx + dy * dy, P->sml[j], &W, &F);
                if (W <= 0.0)
                    continue;
                double wj = P->mass[j] / P->dens[j] * W;
                wsum += wj;
                dsum += P->mass[j] * W;
                for (int f = 0; f < nf && f < 16; f++)
                    acc[f] += wj * fields[f][j];
            }
            for (int f = 0; f < nf && f < 16; f++)
                out_f[f][i] = wsum > 0.0 ? acc[f] / wsum : NAN;
            if (out_dens)
                out_dens[i] = dsum;
        }
    }
    return bad || nf > 16 ? SPH_STEP_RECOVERABLE : SPH_STEP_OK;
}

int sph_model_diagnose(sph_model *m, sph_status *st)
{
    sph_particles *P = m->P;
    sph_status_clear(st);
    int rc = prepare(m, st);
    if (rc != SPH_STEP_OK)
        return rc;
    ghost_velocity(m, P->u, P->v, 1);
    strain_pass(m, NULL, P->n);
    for (size_t k = 0; k < P->n; k++)
        m->zeta[k] = target_stress(m, k, &P->s11[k], &P->s22[k], &P->s12[k]);
    ghost_stress(m);
    divergence_pass(m, NULL, P->n);
    return SPH_STEP_OK;
}



/* ------------------------------------------------------------------ */
/* Implicit solver: Picard iterations on the viscosities, each a sparse  */
/* linear solve with GSL's GMRES.                                        */
/*                                                                       */
/* With zeta, eta and the replacement pressure frozen at the current     */
/* velocities, the SPH stress divergence is linear in the velocities:    */
/*   a_int = D (C B u + S0),                                             */
/* B the strain-rate operator (seed eq. 15), C the per-particle 3x3      */
/* viscosity block, S0 = -P_r/2 (1, 1, 0), D the symmetric divergence    */
/* (seed eq. 13); mirror particles enter B and D through their linear    */
/* maps to their sources. Each Picard iteration solves                   */
/*   (I + dt (c R_w + f/2 J) - dt D C B) u = u_n + dt (tau_a/M           */
/*      + c R_w U_w - g grad xi - f/2 J u_n + D S0)                      */
/* (the same time discretisation as the mEVP fixed point).               */

#define SPH_GMRES_KRYLOV 200

static int implicit_create(sph_model *m)
{
    size_t n2 = 2 * m->cap, n3 = 3 * m->cap, nb = (size_t)m->prm.max_neighbours;
    size_t nzB = m->cap * (6 * nb + 6), nzD = m->cap * (6 * nb + 6);
    m->Bt = gsl_spmatrix_alloc_nzmax(n3, n2, nzB, GSL_SPMATRIX_COO);
    m->Ct = gsl_spmatrix_alloc_nzmax(n3, n3, 5 * m->cap + 1, GSL_SPMATRIX_COO);
    m->Dt = gsl_spmatrix_alloc_nzmax(n2, n3, nzD, GSL_SPMATRIX_COO);
    m->Kt = gsl_spmatrix_alloc_nzmax(n2, n2, 4 * m->cap + 1, GSL_SPMATRIX_COO);
    m->B = gsl_spmatrix_alloc_nzmax(n3, n2, nzB, GSL_SPMATRIX_CSC);
    m->Cm = gsl_spmatrix_alloc_nzmax(n3, n3, 5 * m->cap + 1, GSL_SPMATRIX_CSC);
    m->D = gsl_spmatrix_alloc_nzmax(n2, n3, nzD, GSL_SPMATRIX_CSC);
    m->K = gsl_spmatrix_alloc_nzmax(n2, n2, 4 * m->cap + 1, GSL_SPMATRIX_CSC);
    m->T = gsl_spmatrix_alloc_nzmax(n3, n2, nzB, GSL_SPMATRIX_CSC);
    m->L = gsl_spmatrix_alloc_nzmax(n2, n2, nzB * 4, GSL_SPMATRIX_CSC);
    m->A = gsl_spmatrix_alloc_nzmax(n2, n2, nzB * 4, GSL_SPMATRIX_CSC);
    m->xv = gsl_vector_alloc(n2);
    m->bv = gsl_vector_alloc(n2);
    m->dv = gsl_vector_alloc(n2);
    /* restart length: the viscous operator is stiff (dt lambda_max up to
     * 1e4-1e5), short restarts stall */
    m->gmres = gsl_splinalg_itersolve_alloc(gsl_splinalg_itersolve_gmres, n2,
                                            n2 < SPH_GMRES_KRYLOV ? n2 : SPH_GMRES_KRYLOV);
    m->ghost_G = calloc(m->P->cap * 13 + 1, sizeof(double));
    return m->Bt && m->Ct && m->Dt && m->Kt && m->B && m->Cm && m->D && m->K && m->T && m->L &&
                   m->A && m->xv && m->bv && m->dv && m->gmres && m->ghost_G
               ? 0
               : -1;
}

/* a += v at (i, j) of a COO matrix */
static inline void coo_add(gsl_spmatrix *a, size_t i, size_t j, double v)
{
    if (v == 0.0)
        return;
    double *p = gsl_spmatrix_ptr(a, i, j);
    if (p)
        *p += v;
    else
        gsl_spmatrix_set(a, i, j, v);
}

/* Linear maps of each mirror particle from its source, frozen for this
 * Picard iteration: G (2x2) for velocity (the push-but-never-pull rule
 * decided at the current velocity) and Q (3x3) for (S11, S22, S12). */
static void ghost_maps(sph_model *m)
{
    for (size_t g = 0; g < m->ng; g++) {
        double *G = m->ghost_G + 13 * g, *Q = G + 4;
        /* velocity: apply the rule to the unit vectors, with the rule's
         * branch fixed by the source's current velocity */
        double nx1 = m->ghost_nx[g], ny1 = m->ghost_ny[g];
        double nx2 = m->ghost_n2x[g], ny2 = m->ghost_n2y[g];
        /* the rheology's ghosts are true mirrors (ghost_velocity, mirror = 1) */
        int toward1 = 1;
        int toward2 = nx2 != 0.0 || ny2 != 0.0;
        for (int c = 0; c < 2; c++) {
            double a = c == 0, b = c == 1;
            double rounds[2][3] = {{nx1, ny1, (double)toward1}, {nx2, ny2, (double)toward2}};
            for (int r = 0; r < 2; r++) {
                double nx = rounds[r][0], ny = rounds[r][1];
                if (nx == 0.0 && ny == 0.0)
                    continue;
                double un = a * nx + b * ny;
                double tx = a - un * nx, ty = b - un * ny;
                if (m->prm.coast_no_slip) {
                    tx = -tx;
                    ty = -ty;
                }
                double gn = rounds[r][2] != 0.0 ? -un : un;
                a = tx + gn * nx;
                b = ty + gn * ny;
            }
            G[0 * 2 + c] = a; /* column c: image of unit vector c */
            G[1 * 2 + c] = b;
        }
        for (int c = 0; c < 3; c++) {
            double a = c == 0, b2 = c == 2, cc = c == 1; /* (S11, S12, S22) */
            reflect_tensor(nx1, ny1, &a, &b2, &cc);
            reflect_tensor(nx2, ny2, &a, &b2, &cc);
            Q[0 * 3 + c] = a;  /* S11 */
            Q[1 * 3 + c] = cc; /* S22 */
            Q[2 * 3 + c] = b2; /* S12 */
        }
    }
}

static int sph_solve_implicit(sph_model *m, sph_status *st)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    const sph_nbr *nb = m->nb;
    size_t n = P->n, n2 = 2 * m->cap, n3 = 3 * m->cap;
    double dt = p->dt;
    double ie2 = 1.0 / (p->ecc * p->ecc);
    int it;
    double change = 0.0;
    for (it = 0; it < p->implicit_max_picard; it++) {
        ghost_velocity(m, P->u, P->v, 1);
        strain_pass(m, NULL, n);
        ghost_maps(m);
        gsl_spmatrix_set_zero(m->Bt);
        gsl_spmatrix_set_zero(m->Ct);
        gsl_spmatrix_set_zero(m->Dt);
        gsl_spmatrix_set_zero(m->Kt);
        /* S0 (frozen pressure part) is kept in s11/s22/s12 for D S0 */
        for (size_t k = 0; k < n; k++) {
            double zeta = 0, eta = 0, Pr = 0;
            if (!m->loose[k]) {
                double e11 = P->e11[k], e22 = P->e22[k], e12 = P->e12[k];
                double eI = e11 + e22, d = e11 - e22;
                double Delta = sqrt(eI * eI + (d * d + 4 * e12 * e12) * ie2);
                double Dreg = Delta > p->delta_min ? Delta : p->delta_min;
                zeta = fmin(P->pres[k] / (2.0 * Dreg), p->zeta_max_factor * P->pres[k]);
                eta = zeta * ie2;
                Pr = p->replacement_pressure ? 2.0 * zeta * Delta : P->pres[k];
            }
            m->zeta[k] = zeta;
            P->s11[k] = P->s22[k] = -0.5 * Pr;
            P->s12[k] = 0.0;
            coo_add(m->Ct, 3 * k, 3 * k, zeta + eta);
            coo_add(m->Ct, 3 * k, 3 * k + 1, zeta - eta);
            coo_add(m->Ct, 3 * k + 1, 3 * k, zeta - eta);
            coo_add(m->Ct, 3 * k + 1, 3 * k + 1, zeta + eta);
            coo_add(m->Ct, 3 * k + 2, 3 * k + 2, 2.0 * eta);
        }
        ghost_stress(m);
        for (size_t q = n; q < m->cap; q++) /* unused rows: identity, zero strain */
            coo_add(m->Kt, 2 * q, 2 * q, 1.0), coo_add(m->Kt, 2 * q + 1, 2 * q + 1, 1.0);
        for (size_t k = 0; k < n; k++) {
            const size_t base = nb->off[k];
            double iMk = 1.0 / P->dens[k], iMk2 = iMk * iMk;
            for (int s = 0; s < nb->count[k]; s++) {
                size_t sl = base + (size_t)s;
                size_t j = (size_t)nb->idx[sl];
                /* strain: B_k^-1 grad W; divergence: (B_k^-1 + B_j^-1)/2 grad W */
                const double *bs = m->binv + 6 * k, *bk = bs + 3, *bj = m->binv + 6 * j + 3;
                double gx0 = nb->gx[sl], gy0 = nb->gy[sl];
                double gx = bs[0] * gx0 + bs[1] * gy0, gy = bs[1] * gx0 + bs[2] * gy0;
                double hx = 0.5 * ((bk[0] + bj[0]) * gx0 + (bk[1] + bj[1]) * gy0);
                double hy = 0.5 * ((bk[1] + bj[1]) * gx0 + (bk[2] + bj[2]) * gy0);
                double w = P->mass[j] * iMk;
                /* strain rows of k: coefficients on (u_j, v_j) and (u_k, v_k) */
                double c[3][2] = {{w * gx, 0.0}, {0.0, w * gy}, {0.5 * w * gy, 0.5 * w * gx}};
                size_t src = j;
                const double *G = NULL, *Q = NULL;
                if (j >= n) {
                    size_t g = j - n;
                    src = (size_t)m->ghost_src[g];
                    G = m->ghost_G + 13 * g;
                    Q = G + 4;
                }
                for (int r = 0; r < 3; r++) {
                    double cu = c[r][0], cv = c[r][1];
                    if (G) {
                        coo_add(m->Bt, 3 * k + r, 2 * src, cu * G[0] + cv * G[2]);
                        coo_add(m->Bt, 3 * k + r, 2 * src + 1, cu * G[1] + cv * G[3]);
                    } else {
                        coo_add(m->Bt, 3 * k + r, 2 * j, cu);
                        coo_add(m->Bt, 3 * k + r, 2 * j + 1, cv);
                    }
                    coo_add(m->Bt, 3 * k + r, 2 * k, -cu);
                    coo_add(m->Bt, 3 * k + r, 2 * k + 1, -cv);
                }
                /* divergence rows of k: on S_j (through Q for mirrors) and S_k */
                double mj = P->mass[j], iMj2 = 1.0 / (P->dens[j] * P->dens[j]);
                double dj[2][3] = {{mj * hx * iMj2, 0.0, mj * hy * iMj2},
                                   {0.0, mj * hy * iMj2, mj * hx * iMj2}};
                double dk[2][3] = {{mj * hx * iMk2, 0.0, mj * hy * iMk2},
                                   {0.0, mj * hy * iMk2, mj * hx * iMk2}};
                for (int r = 0; r < 2; r++)
                    for (int cc = 0; cc < 3; cc++) {
                        if (Q) {
                            for (int t = 0; t < 3; t++)
                                coo_add(m->Dt, 2 * k + r, 3 * src + t, dj[r][cc] * Q[cc * 3 + t]);
                        } else {
                            coo_add(m->Dt, 2 * k + r, 3 * j + cc, dj[r][cc]);
                        }
                        coo_add(m->Dt, 2 * k + r, 3 * k + cc, dk[r][cc]);
                    }
            }
        }
        /* constant part D S0 (the frozen pressure) and the divergence of it */
        divergence_pass(m, NULL, n);
        /* diagonal blocks and right-hand side */
        double cw = m->cos_water, sw = m->sin_water;
        for (size_t k = 0; k < n; k++) {
            double rho_h = P->dens[k];
            double ua = P->ua[k], va = P->va[k], sa = hypot(ua, va);
            double tax = p->rho_a * p->Ca * sa * (ua * m->cos_air - va * m->sin_air);
            double tay = p->rho_a * p->Ca * sa * (ua * m->sin_air + va * m->cos_air);
            double uw = P->uw[k], vw = P->vw[k];
            double c = p->rho_w * p->Cw * hypot(uw - P->u[k], vw - P->v[k]) / rho_h;
            double f = m->fcor[k], un = m->un[k], vn = m->vn[k];
            coo_add(m->Kt, 2 * k, 2 * k, 1.0 + dt * c * cw);
            coo_add(m->Kt, 2 * k, 2 * k + 1, -dt * (c * sw + 0.5 * f));
            coo_add(m->Kt, 2 * k + 1, 2 * k, dt * (c * sw + 0.5 * f));
            coo_add(m->Kt, 2 * k + 1, 2 * k + 1, 1.0 + dt * c * cw);
            gsl_vector_set(m->bv, 2 * k,
                           un + dt * (P->ax[k] + tax / rho_h + c * (cw * uw - sw * vw) -
                                      p->gravity * P->sshx[k] + 0.5 * f * vn));
            gsl_vector_set(m->bv, 2 * k + 1,
                           vn + dt * (P->ay[k] + tay / rho_h + c * (sw * uw + cw * vw) -
                                      p->gravity * P->sshy[k] - 0.5 * f * un));
            gsl_vector_set(m->xv, 2 * k, P->u[k]);
            gsl_vector_set(m->xv, 2 * k + 1, P->v[k]);
        }
        for (size_t q = 2 * n; q < n2; q++) {
            gsl_vector_set(m->bv, q, 0.0);
            gsl_vector_set(m->xv, q, 0.0);
        }
        /* A = K - dt D C B */
        if (gsl_spmatrix_csc(m->B, m->Bt) || gsl_spmatrix_csc(m->Cm, m->Ct) ||
            gsl_spmatrix_csc(m->D, m->Dt) || gsl_spmatrix_csc(m->K, m->Kt) ||
            gsl_spblas_dgemm(1.0, m->Cm, m->B, m->T) || gsl_spblas_dgemm(-dt, m->D, m->T, m->L) ||
            gsl_spmatrix_add(m->A, m->K, m->L))
            return sph_status_set(st, SPH_STEP_FATAL, -1, "implicit matrix", (double)n3, 0.0,
                                  "could not be assembled (GSL sparse)");
        /* Jacobi (row) scaling: diag(A)^-1 A u = diag(A)^-1 b */
        for (size_t q = 0; q < n2; q++) {
            double d = gsl_spmatrix_get(m->A, q, q);
            gsl_vector_set(m->dv, q, d != 0.0 ? 1.0 / d : 1.0);
        }
        gsl_spmatrix_scale_rows(m->A, m->dv);
        gsl_vector_mul(m->bv, m->dv);
        int status = GSL_CONTINUE;
        size_t iter = 0;
        while (status == GSL_CONTINUE && iter++ < 500)
            status = gsl_splinalg_itersolve_iterate(m->A, m->bv, p->implicit_tol, m->xv, m->gmres);
        if (status != GSL_SUCCESS)
            return sph_status_set(st, SPH_STEP_RECOVERABLE, -1, "GMRES residual",
                                  gsl_splinalg_itersolve_normr(m->gmres), p->implicit_tol,
                                  "did not converge in 500 restarts (implicit solver)");
        change = 0.0;
        double umax = 0.0;
        for (size_t k = 0; k < n; k++) {
            double u = gsl_vector_get(m->xv, 2 * k), v = gsl_vector_get(m->xv, 2 * k + 1);
            if (!isfinite(u) || !isfinite(v))
                return sph_status_set(st, SPH_STEP_FATAL, P->id[k], "implicit velocity", u, 0.0,
                                      "is not finite");
            change = fmax(change, fmax(fabs(u - P->u[k]), fabs(v - P->v[k])));
            umax = fmax(umax, hypot(u, v));
            P->u[k] = u;
            P->v[k] = v;
        }
        if (change <= p->implicit_tol * (umax + 1e-3)) {
            it++;
            break;
        }
    }
    /* the stress of the final velocities, kept for output and diagnosis */
    ghost_velocity(m, P->u, P->v, 1);
    strain_pass(m, NULL, n);
    for (size_t k = 0; k < n; k++)
        m->zeta[k] = target_stress(m, k, &P->s11[k], &P->s22[k], &P->s12[k]);
    m->stats.iterations = it;
    m->stats.residual = change;
    return SPH_STEP_OK;
}
