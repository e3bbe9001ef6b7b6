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
 *
 * This file: parameters, create/free/init/resume, the step driver, budgets
 * and health. The rooms it drives are listed in model_impl.h.
 */
#include "core/model.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/kernel.h"
#include "core/neighbours.h"
#include "lanes.h"
#include "model_impl.h"


static void set_turning(sph_model *m)
{
    m->cos_air = cos(m->prm.turn_air * DEG2RAD);
    m->sin_air = sin(m->prm.turn_air * DEG2RAD);
    m->cos_water = cos(m->prm.turn_water * DEG2RAD);
    m->sin_water = sin(m->prm.turn_water * DEG2RAD);
}

/* The rheology's extra fields, allocated outside a step when missing. */
static int rheology_fields(sph_model *m, const sph_rheology_ops *r)
{
    if ((r->fields & SPH_RHEO_FIELD_VFLUCT) && !m->vfluct)
        m->vfluct = calloc(sph_model_slots(m), sizeof(double));
    return (r->fields & SPH_RHEO_FIELD_VFLUCT) && !m->vfluct ? -1 : 0;
}

/* Switches to solver s, creating its workspace first (outside a step). */
static int use_solver(sph_model *m, const sph_solver_ops *s)
{
    if (s == m->solver)
        return 0;
    void *ws = NULL;
    if (s->create && s->create(m, &ws) != 0)
        return -1;
    if (m->solver && m->solver->free)
        m->solver->free(m->solver_ws);
    m->solver = s;
    m->solver_ws = ws;
    return 0;
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
    m->lanes4 = sph_lanes4_supported();
    m->memory_bound = SPH_MEMORY_BOUND_PARTICLES;
    m->prm.thermo.rho_w = m->prm.rho_w; /* one sea-water density: drag and freeboard */
    m->cap = cap;
    sph_kernel_init(&m->kern, p->kernel, p->kernel_radius);
    int nl = p->thermo.nlayers > 0 ? p->thermo.nlayers : 1;
    if (nl > SPH_MAX_LAYERS)
        nl = SPH_MAX_LAYERS;
    int with_mask = mask && mask->land && mask->nx > 0 && mask->ny > 0;
    /* ghosts: up to three per particle near a corner; parcels have none (the
     * slots' fields that a step writes for all of them, fsens/flat NaN, would
     * take memory) */
    int parcels_run = p->physics == SPH_PHYSICS_FREE_DRIFT && p->free_drift_parcels;
    size_t c2 = with_mask && !parcels_run ? 4 * cap : cap;
    /* the slots beyond cap are ghosts only (start_checks: n <= cap) */
    m->P = sph_particles_create_live(c2, cap, nl);
    m->nb = sph_nbr_create(cap, c2, p->max_neighbours);
    m->ghost_src = calloc(c2, sizeof(int));
    m->ghost_nx = calloc(c2, sizeof(double));
    m->ghost_ny = calloc(c2, sizeof(double));
    m->ghost_n2x = calloc(c2, sizeof(double));
    m->ghost_n2y = calloc(c2, sizeof(double));
    m->ghost_mass = calloc(c2, sizeof(double));
    m->gh_size = 64;
    while (with_mask && m->gh_size < c2)
        m->gh_size *= 2;
    m->gh_head = malloc(m->gh_size * sizeof(int));
    m->gh_next = malloc(c2 * sizeof(int));
    m->un = calloc(c2, sizeof(double));
    m->vn = calloc(c2, sizeof(double));
    m->zeta = calloc(c2, sizeof(double));
    m->dvel = calloc(c2, sizeof(double));
    m->binv = calloc(6 * c2, sizeof(double)); /* B^-1 = I set as slots come into use */
    m->fcor = calloc(c2, sizeof(double));
    m->sum_part = calloc(SPH_SUM_NQ * (c2 / SPH_SUM_BLOCK + 2), sizeof(double));
    m->scratch = calloc(c2 * SPH_MAX_LAYERS, sizeof(double));
    m->order = calloc(c2, sizeof(int));
    m->active = calloc(c2, sizeof(int));
    m->loose = calloc(c2, 1);
    m->tw = sph_thermo_work_create(c2, nl);
    int ok = m->P && m->nb && m->ghost_src && m->ghost_nx && m->ghost_ny && m->ghost_n2x && m->ghost_n2y && m->ghost_mass && m->gh_head && m->gh_next && m->un && m->vn &&
             m->zeta && m->dvel && m->binv && m->fcor && m->sum_part && m->scratch && m->order && m->active && m->loose && m->tw;
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
    m->rheo = sph_rheology_ops_of(p->rheology);
    if (!m->rheo || rheology_fields(m, m->rheo) != 0 || !sph_solver_ops_of(p->solver) ||
        use_solver(m, sph_solver_ops_of(p->solver)) != 0) {
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
    free(m->ghost_mass);
    free(m->gh_head);
    free(m->gh_next);
    free(m->un);
    free(m->vn);
    free(m->zeta);
    free(m->vfluct);
    free(m->dvel);
    free(m->binv);
    free(m->fcor);
    free(m->sum_part);
    free(m->scratch);
    free(m->order);
    free(m->active);
    free(m->loose);
    free(m->land);
    free(m->near_land);
    free(m->dd_key);
    free(m->dd_owned);
    sph_dd_ocean_free(m);
    sph_thermo_work_free(m->tw);
    sph_ocean_free(m->ocean);
    if (m->solver && m->solver->free)
        m->solver->free(m->solver_ws);
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
    /* a model created for parcels has no room for coast ghosts */
    if (m->has_mask && m->P->cap < 4 * m->cap &&
        !(p->physics == SPH_PHYSICS_FREE_DRIFT && p->free_drift_parcels))
        return SPH_STEP_FATAL;
    /* a reloaded rheology or solver gets its fields and workspace here */
    const sph_rheology_ops *r = sph_rheology_ops_of(p->rheology);
    const sph_solver_ops *s = sph_solver_ops_of(p->solver);
    if (!r || !s || rheology_fields(m, r) != 0 || use_solver(m, s) != 0)
        return SPH_STEP_FATAL;
    m->rheo = r;
    if (m->prm.gradient_correction && !p->gradient_correction)
        m->binv_ident = 0; /* the identity again, as slots are used */
    m->prm = *p;
    m->prm.thermo.rho_w = m->prm.rho_w; /* one sea-water density: drag and freeboard */
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
    /* the solver's envelope, then the rheology's: the smaller decides */
    const sph_solver_ops *s = sph_solver_ops_of(p->solver);
    const sph_rheology_ops *r = sph_rheology_ops_of(p->rheology);
    const char *sw = w, *rw = w;
    double d = s && s->stable_dt ? s->stable_dt(p, spacing, &sw) : HUGE_VAL;
    if (d < lim) {
        lim = d;
        w = sw;
    }
    d = r && r->stable_dt ? r->stable_dt(p, spacing, &rw) : HUGE_VAL;
    if (d < lim) {
        lim = d;
        w = rw;
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

/* The largest smoothing length to plan coasts for: the particles', or that
 * of the particles new ice will create. */
static double new_ice_sml(const sph_model *m, double smax)
{
    if (m->ocean && m->prm.ocean.mixed_layer && m->prm.ocean.create)
        smax = fmax(smax, m->prm.sml_factor * m->ocean->g.ds);
    return smax;
}

/* Mass per area by summation in this step: every step with
 * summation_density; with continuity, every density_reinit_steps steps
 * (step 0 included): the periodic re-initialisation of Colagrossi &
 * Landrini (2003), which bounds what continuity integrates between two
 * summations (a particle pulled off the edge of a pack: docs/ocean.md). */
static int summation_now(const sph_model *m)
{
    const int n = m->prm.density_reinit_steps;
    return m->prm.summation_density || (n > 0 && m->steps % n == 0);
}

/* Neighbour lists over the particles and their ghosts, then density and
 * diagnosis. A list that overflows max_neighbours while the coast's
 * ghosts are not yet merged (coast.c: ghosts piled up by a coast curved
 * tighter than the kernel support) merges them from now on and tries
 * again; an overflow left after that is particle clumping. */
static int prepare_lists(sph_model *m, sph_status *st)
{
    sph_particles *P = m->P;
    size_t nall = P->n + m->ng;
    /* B^-1 = I (no correction) for the slots in use: set once per slot, so
     * that the pages beyond the live particles and ghosts stay untouched
     * (4 x capacity x 48 bytes with a land mask; 190 MB at 1e6) */
    /* Only where B^-1 is read: with the correction (whose pass overwrites
     * every slot in use) or by a solver that reads the identity too
     * (solver->binv_always); elsewhere its pages stay untouched (48 bytes
     * per slot: 57 MB at 1.25e6 particles) */
    if (m->prm.gradient_correction || m->solver->binv_always) {
        for (size_t q = m->binv_ident; q < nall; q++) {
            double *b = m->binv + 6 * q;
            b[0] = b[2] = b[3] = b[5] = 1.0;
            b[1] = b[4] = 0.0;
        }
        if (nall > m->binv_ident)
            m->binv_ident = nall;
    }
    /* W_kj is read by the summation density and the collision rheology's
     * v' only: otherwise the lists leave it out (8 bytes per pair) */
    m->nb->keep_w = m->prm.summation_density || m->prm.density_reinit_steps > 0 ||
                    (m->rheo->fields & SPH_RHEO_FIELD_VFLUCT) != 0;
    /* model.compact_gradients: the pair gradients as their factor F and
     * the build's positions (core/neighbours.h; the same bits); auto
     * decides at each build, by the particle count (a run that grows
     * past the bound keeps the full form's pages it touched) */
    m->nb->factor = m->prm.compact_gradients == SPH_COMPACT_TRUE ||
                    (m->prm.compact_gradients == SPH_COMPACT_AUTO && P->n >= m->memory_bound);
    double cell = m->kern.radius * sph_max_sml(P, nall);
    sph_nbr_grid(m->nb, nall, P->x, P->y, cell);
    long over = -1;
    if (sph_nbr_build(m->nb, &m->kern, P->n, P->x, P->y, P->sml, &over) && !m->ghost_merge && m->ng > 0) {
        m->ghost_merge = 1;
        sph_build_ghosts(m);
        return prepare_lists(m, st);
    }
    if (m->canonical && over < 0)
        sph_dd_sort_lists(m);
    if (over >= 0)
        return sph_status_set(st, SPH_STEP_RECOVERABLE, SPH_FAULT_CLUMPING, over >= 0 ? P->id[over] : -1,
                              "neighbour count", (double)m->prm.max_neighbours,
                              (double)m->prm.max_neighbours,
                              "exceeds max_neighbours (particle clumping)");
    if (summation_now(m))
        sph_density_pass(m);
    /* ghosts take their source's state */
    for (size_t g = 0; g < m->ng; g++) {
        size_t q = P->n + g, k = (size_t)m->ghost_src[g];
        P->dens[q] = P->dens[k];
    }
    sph_diagnose_pass(m);
    sph_gradient_correction_pass(m);
    if (m->rheo->project_memory)
        m->rheo->project_memory(m);
    sph_ghost_stress(m);
    sph_select_active(m);
    if (m->canonical)
        sph_dd_lists_ready(m);
    return SPH_STEP_OK;
}

/* Neighbours, density and diagnosis at the current positions. */
static int prepare(sph_model *m, sph_status *st)
{
    sph_reorder(m);
    sph_build_ghosts(m);
    return prepare_lists(m, st);
}

int sph_model_ghosts_merging(const sph_model *m) { return m && m->ghost_merge; }

/* ------------------------------------------------------------------ */
/* free drift as independent parcels (model.free_drift_parcels)       */


/* 1 where a step runs without SPH machinery: whole-run free drift with
 * model.free_drift_parcels. */
static int parcels_mode(const sph_model *m)
{
    return m->prm.physics == SPH_PHYSICS_FREE_DRIFT && m->prm.free_drift_parcels;
}

const sph_landmask *sph_model_landmask(const sph_model *m)
{
    return m && m->has_mask ? &m->mask : NULL;
}

int sph_model_compact_form(const sph_model *m)
{
    return m && m->nb ? m->nb->factor : 0;
}

void sph_model_set_memory_bound(sph_model *m, size_t n)
{
    if (m)
        m->memory_bound = n;
}

double *sph_model_idle_scratch(sph_model *m, size_t *len)
{
    *len = m && m->nb && !parcels_mode(m) ? m->nb->lead : 0;
    return *len ? m->nb->gx : NULL;
}

/* The per-particle state the SPH passes would leave for a particle with
 * no neighbour but itself: zero strain rates and stress, free drift, no
 * coast ghosts; mass per area kept by continuity at zero divergence, with
 * the same floor (sph_continuity_pass). */
static inline void parcel_diagnose_one(sph_particles *P, double rho_i, int continuity, size_t k)
{
    sph_set_zero(&P->e11[k]);
    sph_set_zero(&P->e22[k]);
    sph_set_zero(&P->e12[k]);
    double floor_dens = SPH_CONC_MIN * rho_i * P->thick[k];
    if (continuity && P->dens[k] < floor_dens)
        P->dens[k] = floor_dens;
}

static void parcels_diagnose(sph_model *m)
{
    sph_particles *P = m->P;
    const double rho_i = m->prm.rho_i;
    const int continuity = !m->prm.summation_density;
    size_t n = P->n;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++)
        parcel_diagnose_one(P, rho_i, continuity, k);
}

/* Neighbours' part of prepare() for parcels: cell order (locality of the
 * forcing and of the arrays) every SPH_PARCELS_REORDER steps (parcels
 * move a fraction of a cell per step; a reorder permutes every field),
 * diagnosis, every particle loose. */
#define SPH_PARCELS_REORDER 16
static void parcels_prepare(sph_model *m)
{
    sph_particles *P = m->P;
    size_t n = P->n;
    if (m->steps % SPH_PARCELS_REORDER == 0)
        sph_reorder(m);
    m->ng = 0;
    sph_diagnose_pass(m);
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        P->regime[k] &= (unsigned char)~(SPH_REGIME_FREE_DRIFT | SPH_REGIME_RHEOLOGY |
                                         SPH_REGIME_NEAR_COAST);
        P->regime[k] |= SPH_REGIME_FREE_DRIFT;
    }
    m->nactive = 0;
}

/* The whole step of parcels in one pass over the particles, in chunks of
 * SPH_PARCELS_CHUNK (run by parcels_step when nothing else reads the state
 * between the separate passes: no ocean fluxes, no fixed state, no
 * decomposition). Each particle goes through the separate passes' own
 * operations in their order: sph_diagnose_pass, parcels_prepare's regime
 * flags, the step's start (un, vn, ax, ay, fcor), sph_parcels_drift_pass,
 * sph_move_and_constrain, parcels_diagnose and sph_update_sml (after the
 * move, before the outflow's removals: a removal moves a whole particle,
 * whose smoothing length is its own either way). The passes read and
 * write particle k's own values only, so each particle's bits are the
 * separate passes'. Also, for the end of the step: *top = 1 + the highest
 * index sph_remove_outflow removes (0: none), *first = the first particle
 * check_health's per-particle tests fail (n: none), cnt = the regime
 * counts regime_fractions makes (max, min and sums of integers: the same
 * whatever the thread count). */
#define SPH_PARCELS_CHUNK 256
/* Chunks a thread takes at a time: dynamic, so that a thread that shares
 * its core (the products' writer, another process) takes fewer and the
 * other does not wait for it at the end of the pass (docs/bench.md
 * "Session 11: free drift (fd5)"). Every particle's operations and the
 * reductions (max, min, integer sums) do not depend on who takes which. */
#define SPH_PARCELS_GRAB 4
static inline int particle_unhealthy(const sph_particles *P, const sph_params *p, size_t k);
static void parcels_step_pass(sph_model *m, size_t *top_out, size_t *first_out, size_t cnt[4])
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    const size_t n = P->n, nc = (n + SPH_PARCELS_CHUNK - 1) / SPH_PARCELS_CHUNK;
    const double rho_i = p->rho_i;
    const int continuity = !p->summation_density, vsml = p->variable_sml;
    const unsigned char clear = (unsigned char)~(SPH_REGIME_FREE_DRIFT | SPH_REGIME_RHEOLOGY |
                                                 SPH_REGIME_NEAR_COAST);
    size_t top = 0, first = n, fd = 0, rh = 0, zl = 0, ml = 0;
#pragma omp parallel for schedule(dynamic, SPH_PARCELS_GRAB) reduction(max : top) reduction(min : first) \
    reduction(+ : fd, rh, zl, ml) if (SPH_OMP_WORTH(n))
    for (size_t c = 0; c < nc; c++) {
        const size_t k0 = c * SPH_PARCELS_CHUNK, k1 = k0 + SPH_PARCELS_CHUNK < n ? k0 + SPH_PARCELS_CHUNK : n;
        for (size_t k = k0; k < k1; k++) {
            /* sph_diagnose_pass */
            double A, pres;
            (void)sph_diagnose_one(P, p, k, &A, &pres);
            sph_set_bits(&P->conc[k], A);
            sph_set_bits(&P->pres[k], pres);
            if (m->loose[k] != 1) /* free drift */
                m->loose[k] = 1;
            /* parcels_prepare */
            unsigned char rg = (unsigned char)((P->regime[k] & clear) | SPH_REGIME_FREE_DRIFT);
            if (P->regime[k] != rg)
                P->regime[k] = rg;
            /* sph_model_step's start */
            m->un[k] = P->u[k];
            m->vn[k] = P->v[k];
            sph_set_zero(&P->ax[k]);
            sph_set_zero(&P->ay[k]);
            m->fcor[k] = !p->coriolis ? 0.0
                         : p->coriolis_f != 0.0 ? p->coriolis_f
                                                : 2.0 * OMEGA_EARTH * sin(P->lat[k] * DEG2RAD);
        }
        sph_parcels_drift_range(m, k0, k1);
        for (size_t k = k0; k < k1; k++) {
            int out = sph_move_one(m, k);
            if (out && k + 1 > top)
                top = k + 1;
            /* parcels_diagnose */
            parcel_diagnose_one(P, rho_i, continuity, k);
            /* sph_update_sml */
            if (vsml)
                sph_set_bits(&P->sml[k], sph_sml_one(P, p, k));
            /* the end of the step: check_health, regime_fractions */
            if (k < first && particle_unhealthy(P, p, k))
                first = k;
            fd += (P->regime[k] & SPH_REGIME_FREE_DRIFT) != 0;
            rh += (P->regime[k] & SPH_REGIME_RHEOLOGY) != 0;
            zl += (P->regime[k] & SPH_REGIME_ZERO_LAYER) != 0;
            ml += (P->regime[k] & SPH_REGIME_MULTI_LAYER) != 0;
        }
    }
    *top_out = top;
    *first_out = first;
    cnt[0] = fd;
    cnt[1] = rh;
    cnt[2] = zl;
    cnt[3] = ml;
}

/* The budget's sums over particles [k0, k1) in index order: mass, area,
 * volume, kinetic energy, snow. */
static void budget_sums(const sph_model *m, size_t k0, size_t k1, double out[SPH_SUM_NQ])
{
    const sph_particles *P = m->P;
    double mass = 0, area = 0, vol = 0, ke = 0, snow = 0;
    for (size_t k = k0; k < k1; k++) {
        mass += P->mass[k];
        snow += sph_particle_snow_mass(&m->prm.thermo, P, k);
        area += P->mass[k] / (m->prm.rho_i * P->thick[k]);
        vol += P->mass[k] / m->prm.rho_i;
        ke += 0.5 * P->mass[k] * (P->u[k] * P->u[k] + P->v[k] * P->v[k]);
    }
    out[0] = mass;
    out[1] = area;
    out[2] = vol;
    out[3] = ke;
    out[4] = snow;
}

static void update_budget(sph_model *m)
{
    sph_particles *P = m->P;
    /* bit-reproducible whatever the thread count: blocks of SPH_SUM_BLOCK
     * in index order, their sums in block order (one block: the plain sum) */
    const size_t n = P->n, nb = (n + SPH_SUM_BLOCK - 1) / SPH_SUM_BLOCK;
    double tot[SPH_SUM_NQ];
    if (nb <= 1) {
        budget_sums(m, 0, n, tot);
    } else {
        double *part = m->sum_part;
        /* dynamic: each block's sum is its own whoever takes it */
#pragma omp parallel for schedule(dynamic, 1) if (SPH_OMP_WORTH(n))
        for (size_t b = 0; b < nb; b++) {
            size_t k1 = (b + 1) * SPH_SUM_BLOCK;
            budget_sums(m, b * SPH_SUM_BLOCK, k1 < n ? k1 : n, part + SPH_SUM_NQ * b);
        }
        for (int q = 0; q < SPH_SUM_NQ; q++)
            tot[q] = 0.0;
        for (size_t b = 0; b < nb; b++)
            for (int q = 0; q < SPH_SUM_NQ; q++)
                tot[q] += part[SPH_SUM_NQ * b + q];
    }
    double mass = tot[0], area = tot[1], vol = tot[2], ke = tot[3], snow = tot[4];
    m->budget.mass = mass;
    m->budget.area = area;
    m->budget.volume = vol;
    m->budget.kinetic_energy = ke;
    m->budget.snow = snow;
    if (sph_ocean_on(m)) {
        sph_ocean_account(m);
        m->budget.ocean = 1;
        sph_ocean_totals(m, &m->budget.energy, &m->budget.water, &m->budget.salt);
    }
}

/* 1 when particle k fails one of check_health's per-particle tests. */
static inline int particle_unhealthy(const sph_particles *P, const sph_params *p, size_t k)
{
    if (!isfinite(P->x[k]) || !isfinite(P->y[k]) || !isfinite(P->u[k]) || !isfinite(P->v[k]) ||
        !isfinite(P->thick[k]) || !isfinite(P->mass[k]))
        return 1;
    double sp2 = P->u[k] * P->u[k] + P->v[k] * P->v[k];
    double sp = sp2 > 0.81 * p->speed_limit * p->speed_limit ? hypot(P->u[k], P->v[k]) : 0.0;
    return sp > p->speed_limit || !(P->dens[k] / p->rho_i <= p->thickness_limit);
}

static int check_ocean_budget(sph_model *m, sph_status *st);

/* check_health from its first failing particle (n: none) */
static int check_health_from(sph_model *m, sph_status *st, size_t first);

static int check_health(sph_model *m, sph_status *st)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    /* the first failing particle in index order (a min reduction: the same
     * particle whatever the thread count), then its report below */
    const size_t n = P->n;
    size_t first = n;
#pragma omp parallel for schedule(static) reduction(min : first) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++)
        if (k < first && particle_unhealthy(P, p, k))
            first = k;
    return check_health_from(m, st, first);
}

static int check_health_from(sph_model *m, sph_status *st, size_t first)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    const size_t n = P->n;
    for (size_t k = first; k < n; k++) {
        const double vals[] = {P->x[k], P->y[k], P->u[k], P->v[k], P->thick[k], P->mass[k]};
        static const char *const names[] = {"x position", "y position", "x velocity",
                                            "y velocity", "thickness", "mass"};
        for (int q = 0; q < 6; q++)
            if (!isfinite(vals[q]))
                return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_NONFINITE, P->id[k], names[q], vals[q], 0.0,
                                      "is not finite (numerical blow-up)");
        /* hypot only near the limit (its overflow care is not needed for
         * finite speeds this far below it; the decision is hypot's) */
        double sp2 = P->u[k] * P->u[k] + P->v[k] * P->v[k];
        double sp = sp2 > 0.81 * p->speed_limit * p->speed_limit ? hypot(P->u[k], P->v[k]) : 0.0;
        if (sp > p->speed_limit)
            return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_SPEED, P->id[k], "speed", sp, p->speed_limit,
                                  "exceeds the speed limit (numerical blow-up)");
        /* a parcel ridged without bound (e.g. converging on a coast) is a
         * numerical pile-up: no sea-ice cover is tens of metres thick */
        double hbar = P->dens[k] / p->rho_i;
        if (!(hbar <= p->thickness_limit))
            return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_THICKNESS, P->id[k], "mean thickness", hbar,
                                  p->thickness_limit,
                                  "exceeds the thickness limit (numerical pile-up)");
    }
    if (m->dd) /* a rank holds halo copies too: the driver checks the global mass budget; the
                  ocean's budgets are global on every rank (ocean/ocean_dd.c) */
        return check_ocean_budget(m, st);
    const sph_budget *b = &m->budget;
    double expect = sph_budget_expected(b);
    /* the scale includes the sources: ice that formed and melted away
     * entirely leaves the round-off of its sums, not zero */
    double scale = fmax(fmax(fabs(expect), fabs(b->mass)), b->mass_initial + b->growth + b->new_ice);
    double tol = p->mass_tolerance * scale + 1e-300;
    if (fabs(b->mass - expect) > tol)
        return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_MASS, -1, "total mass", b->mass, expect,
                              "changed beyond round-off with no source or sink to explain it");
    double sexp = sph_budget_snow_expected(b);
    double stol = p->mass_tolerance * fmax(fmax(fabs(sexp), fabs(b->snow)), b->snow_initial + b->snowfall) + 1e-300;
    if (fabs(b->snow - sexp) > stol)
        return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_MASS, -1, "total snow mass", b->snow, sexp,
                              "changed beyond round-off with no source or sink to explain it");
    return check_ocean_budget(m, st);
}

static int check_ocean_budget(sph_model *m, sph_status *st)
{
    const sph_params *p = &m->prm;
    const sph_budget *b = &m->budget;
    if (b->ocean) { /* ice plus ocean: energy, water, salt */
        double re = sph_budget_energy_residual(b), rw = sph_budget_water_residual(b);
        double rs = sph_budget_salt_residual(b);
        if (re > p->mass_tolerance)
            return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_MASS, -1, "energy budget residual", re,
                                  p->mass_tolerance, "exceeds round-off (ice, snow and mixed-layer enthalpy)");
        if (rw > p->mass_tolerance)
            return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_MASS, -1, "water budget residual", rw,
                                  p->mass_tolerance, "exceeds round-off (ice plus ocean water)");
        if (rs > p->mass_tolerance)
            return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_MASS, -1, "salt budget residual", rs,
                                  p->mass_tolerance, "exceeds round-off (ice plus ocean salt)");
    }
    return SPH_STEP_OK;
}

/* What init and resume check first: a clear status and room for the
 * particles. */
static int start_checks(sph_model *m, sph_status *st)
{
    sph_status_clear(st);
    if (m->P->n > m->cap)
        return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_CAPACITY, -1, "particle count", (double)m->P->n,
                              (double)m->cap, "exceeds the model capacity");
    return SPH_STEP_OK;
}

int sph_model_init(sph_model *m, sph_status *st)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    if (start_checks(m, st))
        return st->code;
    for (size_t k = 0; k < P->n; k++) {
        if (!(P->mass[k] > 0.0) || !isfinite(P->mass[k]))
            return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_INVALID, P->id[k], "mass", P->mass[k], 0.0,
                                  "must be positive");
        if (!(P->thick[k] > 0.0) || !isfinite(P->thick[k]))
            return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_INVALID, P->id[k], "thickness", P->thick[k], 0.0,
                                  "must be positive");
        if (!(P->conc[k] > 0.0 && P->conc[k] <= 1.0))
            return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_INVALID, P->id[k], "concentration", P->conc[k],
                                  1.0, "must be in (0, 1]");
        if (!(P->sml[k] > 0.0) || !isfinite(P->sml[k]))
            return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_INVALID, P->id[k], "smoothing length", P->sml[k],
                                  0.0, "must be positive");
        if (!(P->sml0[k] > 0.0))
            P->sml0[k] = P->sml[k];
        if (!isfinite(P->x[k]) || !isfinite(P->y[k]))
            return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_NONFINITE, P->id[k], "position", P->x[k], 0.0,
                                  "is not finite");
    }
    /* The measured stability envelope (docs/bench.md, bench/run.sh,
     * docs/bench/stability.csv): outside it a run is refused here, before
     * anything is computed, rather than written out as a forecast. */
    double spacing = sph_model_spacing(m);
    const char *why = NULL;
    double dtmax = sph_params_stable_dt(p, spacing, &why);
    if (P->n > 0 && p->dt > dtmax)
        return sph_status_set(st, SPH_STEP_RECOVERABLE, SPH_FAULT_TIMESTEP, -1, "time step", p->dt, dtmax, why);
    if (m->has_mask)
        sph_mark_near_land(m, m->kern.radius * p->sml_max_factor * new_ice_sml(m, sph_max_sml(P, P->n)));
    /* Calibrate the kernel's lattice sum: intended M = rho_i A h_i from the
     * seeded state, over interior particles (full neighbourhoods). */
    m->dens_scale = 1.0;
    sph_reorder(m);
    double *seed_thick = m->dvel, *seed_conc = m->zeta; /* seeded state, before diagnosis */
    for (size_t k = 0; k < P->n; k++) {
        seed_thick[k] = P->thick[k];
        seed_conc[k] = P->conc[k];
    }
    for (size_t k = 0; k < P->n; k++)
        P->dens[k] = p->rho_i * seed_conc[k] * seed_thick[k];
    int parcels = parcels_mode(m);
    int rc = parcels ? (parcels_prepare(m), SPH_STEP_OK) : prepare(m, st);
    if (rc != SPH_STEP_OK)
        return rc;
    int maxc = 0;
    size_t ni = 0;
    double *ratio = m->scratch;
    if (parcels)
        goto calibrated; /* no neighbours: dens_scale only serves summation density */
    for (size_t k = 0; k < P->n; k++)
        maxc = m->nb->count[k] > maxc ? m->nb->count[k] : maxc;
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
        if (med > 0.8 && med < 1.25 && (p->summation_density || p->density_reinit_steps > 0))
            m->dens_scale = med;
    }
calibrated:
    /* re-diagnose with the calibrated density from the seeded state */
    for (size_t k = 0; k < P->n; k++) {
        P->thick[k] = seed_thick[k];
        P->conc[k] = seed_conc[k];
        P->dens[k] = p->rho_i * seed_conc[k] * seed_thick[k];
    }
    rc = parcels ? (parcels_prepare(m), SPH_STEP_OK) : prepare(m, st);
    if (rc != SPH_STEP_OK)
        return rc;
    for (size_t k = 0; k < P->n; k++)
        P->dens0[k] = P->dens[k];
    memset(&m->budget, 0, sizeof m->budget);
    if (sph_ocean_on(m))
        sph_ocean_mark(m);
    update_budget(m);
    m->budget.mass_initial = m->budget.mass;
    m->budget.snow_initial = m->budget.snow;
    m->dd_base = m->budget;
    for (int q = 0; q < SPH_DD_NSRC; q++)
        sph_xsum_clear(&m->dd_src[q]);
    if (sph_ocean_on(m)) {
        sph_ocean_totals(m, &m->budget.energy_initial, &m->budget.water_initial, &m->budget.salt_initial);
        m->budget.ocean = 1;
        m->budget.energy = m->budget.energy_initial;
        m->budget.water = m->budget.water_initial;
        m->budget.salt = m->budget.salt_initial;
    }
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
    if (start_checks(m, st))
        return st->code;
    double sml0_max = 0.0;
    for (size_t k = 0; k < P->n; k++) {
        const double must_pos[] = {P->mass[k], P->thick[k], P->sml[k], P->sml0[k], P->dens[k],
                                   P->dens0[k]};
        static const char *const names[] = {"mass", "thickness", "smoothing length",
                                            "reference smoothing length", "density",
                                            "reference density"};
        for (int q = 0; q < 6; q++)
            if (!(must_pos[q] > 0.0) || !isfinite(must_pos[q]))
                return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_INVALID, P->id[k], names[q], must_pos[q], 0.0,
                                      "must be positive");
        if (!(P->conc[k] > 0.0 && P->conc[k] <= 1.0))
            return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_INVALID, P->id[k], "concentration", P->conc[k],
                                  1.0, "must be in (0, 1]");
        if (!isfinite(P->x[k]) || !isfinite(P->y[k]) || !isfinite(P->u[k]) ||
            !isfinite(P->v[k]))
            return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_NONFINITE, P->id[k], "position or velocity",
                                  P->x[k], 0.0, "is not finite");
        sml0_max = fmax(sml0_max, P->sml0[k]);
    }
    if (!(c->dens_scale > 0.0) || !isfinite(c->time) || !isfinite(c->thermo_accum))
        return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_INVALID, -1, "clock", c->dens_scale, 0.0,
                              "is not valid");
    const char *why = NULL;
    double dtmax = sph_params_stable_dt(p, sph_model_spacing(m), &why);
    if (P->n > 0 && p->dt > dtmax)
        return sph_status_set(st, SPH_STEP_RECOVERABLE, SPH_FAULT_TIMESTEP, -1, "time step", p->dt, dtmax, why);
    /* the same radius as sph_model_init used: there every sml equalled sml0 */
    if (m->has_mask)
        sph_mark_near_land(m, m->kern.radius * p->sml_max_factor * new_ice_sml(m, sml0_max));
    m->dens_scale = c->dens_scale;
    m->budget = c->budget;
    if (m->canonical) /* a resumed model (or a rank after the scatter) owns all it holds */
        memset(m->dd_owned, 1, P->n);
    if (sph_ocean_on(m)) { /* the mixed layer is not in restart files (docs/ocean.md) */
        sph_ocean_mark(m);
        if (!m->budget.ocean) {
            sph_ocean_totals(m, &m->budget.energy_initial, &m->budget.water_initial, &m->budget.salt_initial);
            m->budget.energy = m->budget.energy_initial;
            m->budget.water = m->budget.water_initial;
            m->budget.salt = m->budget.salt_initial;
            m->budget.ocean = 1;
        }
    }
    m->dd_base = m->budget;
    for (int q = 0; q < SPH_DD_NSRC; q++)
        sph_xsum_clear(&m->dd_src[q]);
    m->time = c->time;
    m->steps = c->steps;
    m->thermo_accum = c->thermo_accum;
    return SPH_STEP_OK;
}
int sph_model_ocean_create(sph_model *m, const sph_ocean_grid *g)
{
    const sph_params *p = &m->prm;
    if (m->ocean)
        return SPH_STEP_FATAL;
    double S0 = p->thermo.ocean_salinity;
    double Tf = sph_ocean_freezing_point(p->ocean.freezing, p->thermo.mu, S0);
    m->ocean = sph_ocean_create(g, m->cap, p->ocean.depth, S0, Tf);
    if (!m->ocean || sph_dd_ocean_alloc(m))
        return SPH_STEP_FATAL;
    sph_ocean *o = m->ocean;
    /* the sea fraction of each cell from the land mask, sampled 8 x 8:
     * sea inside the domain only (beyond an open mask's grid particles
     * leave as outflow, so water there is not the model's to freeze) */
    for (size_t c = 0; m->has_mask && c < o->ncell; c++) {
        int i = (int)(c % (size_t)g->nx), j = (int)(c / (size_t)g->nx), sea = 0;
        for (int b = 0; b < 8; b++)
            for (int a = 0; a < 8; a++)
                sea += sph_is_domain_sea(m, g->x0 + (i + (a + 0.5) / 8.0) * g->dx,
                                         g->y0 + (j + (b + 0.5) / 8.0) * g->dy);
        o->seafrac[c] = sea / 64.0;
        sph_ocean_set_cell(o, c, p->ocean.depth, S0, Tf);
    }
    return SPH_STEP_OK;
}

sph_ocean *sph_model_ocean(sph_model *m) { return m->ocean; }

/* the step's statistics from the regime counts (free drift, rheology,
 * zero-layer, multi-layer) */
static void regime_fractions_from(sph_model *m, size_t fd, size_t rh, size_t zl, size_t ml)
{
    const sph_particles *P = m->P;
    double n = P->n > 0 ? (double)P->n : 1.0;
    m->stats.frac_free_drift = (double)fd / n;
    m->stats.frac_rheology = (double)rh / n;
    m->stats.frac_zero_layer = (double)zl / n;
    m->stats.frac_multi_layer = (double)ml / n;
}

static void regime_fractions(sph_model *m)
{
    sph_particles *P = m->P;
    size_t fd = 0, rh = 0, zl = 0, ml = 0;
    const size_t np = P->n;
#pragma omp parallel for schedule(static) reduction(+ : fd, rh, zl, ml) if (SPH_OMP_WORTH(np))
    for (size_t k = 0; k < np; k++) {
        fd += (P->regime[k] & SPH_REGIME_FREE_DRIFT) != 0;
        rh += (P->regime[k] & SPH_REGIME_RHEOLOGY) != 0;
        zl += (P->regime[k] & SPH_REGIME_ZERO_LAYER) != 0;
        ml += (P->regime[k] & SPH_REGIME_MULTI_LAYER) != 0;
    }
    regime_fractions_from(m, fd, rh, zl, ml);
}

/* The stress of the ice on the ocean, added to ofx_taux/ofx_tauy as
 * stress x area x time (N s): minus the water drag of the momentum
 * equation (model_impl.h sph_momentum), rho_w C_w |U_w - u| R_w (U_w - u)
 * per unit footprint, which the equation applies to the mass per area
 * M = dens, so the force on the particle is its mass / M = footprint times
 * the stress. Evaluated with the step's new velocity from the solver (its
 * fixed point: the lagged speed |U_w - u_p| equals |U_w - u| there), before
 * land blocks any motion. Reads the state only. */
static void accumulate_ocean_stress(sph_model *m)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    const double cw = m->cos_water, sw = m->sin_water, dt = p->dt;
    for (size_t k = 0; k < P->n; k++) {
        if (!(P->dens[k] > 0.0))
            continue;
        double dux = P->uw[k] - P->u[k], duy = P->vw[k] - P->v[k];
        double c = sph_drag_factor(m, k) * p->rho_w * p->Cw * sqrt(dux * dux + duy * duy) *
                   (P->mass[k] / P->dens[k]) * dt;
        P->ofx_taux[k] -= c * (cw * dux - sw * duy);
        P->ofx_tauy[k] -= c * (sw * dux + cw * duy);
    }
}

/* model.fixed_state (a comparison option): the momentum was solved on the
 * ice state as it is; positions, concentration, thickness, mass per area
 * and smoothing length stay, and there is no thermodynamics. The final
 * strain rates are the output's. */
static int fixed_state_end(sph_model *m, sph_status *st)
{
    sph_particles *P = m->P;
    sph_ghost_velocity(m, P->u, P->v, 1);
    sph_strain_pass(m, NULL, P->n);
    m->time += m->prm.dt;
    m->steps++;
    regime_fractions(m);
    update_budget(m);
    return check_health(m, st);
}

/* sph_model_step's dynamics as separate passes: neighbours (or parcels'
 * preparation), free drift, the solver, the move, the final strain rates
 * and continuity, the outflow, the smoothing length. *ended = 1 when the
 * step ended there (model.fixed_state: its rc is the step's). */
static int step_passes(sph_model *m, sph_status *st, int parcels, int *ended)
{
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    int rc = parcels ? (parcels_prepare(m), SPH_STEP_OK) : prepare(m, st);
    if (rc != SPH_STEP_OK)
        return rc;
    size_t n = P->n;
#pragma omp parallel for schedule(static) if (SPH_OMP_WORTH(n))
    for (size_t k = 0; k < n; k++) {
        m->un[k] = P->u[k];
        m->vn[k] = P->v[k];
        sph_set_zero(&P->ax[k]);
        sph_set_zero(&P->ay[k]);
        m->fcor[k] = !p->coriolis ? 0.0
                     : p->coriolis_f != 0.0 ? p->coriolis_f /* comparison option */
                                            : 2.0 * OMEGA_EARTH * sin(P->lat[k] * DEG2RAD);
    }
    if (parcels)
        sph_parcels_drift_pass(m);
    else
        sph_free_drift_pass(m);
    /* decomposed: every rank iterates (the halo exchange is collective) */
    if (m->nactive > 0 || (m->dd && p->physics != SPH_PHYSICS_FREE_DRIFT)) {
        rc = m->solver->solve(m, m->solver_ws, st);
        if (rc != SPH_STEP_OK)
            return rc;
    }
    if (p->thermo.ocean_fluxes)
        accumulate_ocean_stress(m);
    if (p->fixed_state) {
        *ended = 1;
        return fixed_state_end(m, st);
    }
    /* positions first: a move blocked by land zeroes the blocked velocity,
     * and only the realised motion may compress a parcel (a particle held
     * at a coast otherwise kept "converging" into land and ridged without
     * bound) */
    sph_move_and_constrain(m);
    if (parcels) {
        parcels_diagnose(m);
    } else {
        /* final strain rates of every particle, for output, continuity
         * and the smoothing length */
        sph_ghost_velocity(m, P->u, P->v, 1);
        sph_strain_pass(m, NULL, P->n);
        if (!p->summation_density)
            sph_continuity_pass(m);
    }
    sph_remove_outflow(m);
    sph_update_sml(m);
    return SPH_STEP_OK;
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
    m->stats.rel_residual = 0.0;
    m->stats.unconverged = 0;
    const int parcels = parcels_mode(m);
    /* parcels with nothing between the passes that reads the state: the
     * whole step in one pass (parcels_step_pass; the same bits) */
    const int fused = parcels && !m->dd && !m->canonical && !p->fixed_state && !p->thermo.ocean_fluxes;
    size_t fused_top = 0, fused_first = 0, fused_cnt[4] = {0, 0, 0, 0};
    int rc;
    if (fused) {
        if (m->steps % SPH_PARCELS_REORDER == 0)
            sph_reorder(m);
        m->ng = 0;
        m->nactive = 0;
        parcels_step_pass(m, &fused_top, &fused_first, fused_cnt);
        if (fused_top)
            sph_remove_outflow(m);
    } else {
        int ended = 0;
        rc = step_passes(m, st, parcels, &ended);
        if (ended || rc != SPH_STEP_OK)
            return rc;
    }
    m->time += p->dt;
    m->steps++;
    int thermo_ran = 0;
    if (p->thermo_dt > 0.0 && p->thermo.model != SPH_THERMO_OFF) {
        m->thermo_accum += p->dt;
        if (m->thermo_accum >= p->thermo_dt - 1e-9 * p->thermo_dt) {
            thermo_ran = 1;
            for (size_t k = 0; k < P->n; k++)
                m->dvel[k] = P->mass[k];
            double tdt = m->thermo_accum;
            /* canonical mode: the ocean's step on the view of every rank's
             * particles in id order (ocean/ocean_dd.c) */
            const int ocean_dd = sph_ocean_on(m) && m->canonical;
            if (ocean_dd && (rc = sph_dd_ocean_before(m, tdt, st)) != SPH_STEP_OK)
                return rc;
            if (sph_ocean_on(m) && !ocean_dd)
                sph_ocean_before(m, tdt);
            rc = sph_thermo_step(&p->thermo, P, tdt, m->tw, &m->budget, st);
            if (rc == SPH_STEP_OK && m->canonical) /* exact, owned only (core/dd.h) */
                for (size_t k = 0; k < P->n; k++) {
                    if (!m->dd_owned[k])
                        continue;
                    double t9[9];
                    sph_thermo_outcome_terms(m->tw, k, t9);
                    for (int q = 0; q < 9; q++)
                        sph_xsum_add(&m->dd_src[q], t9[q]);
                }
            /* the footprint is fixed: mass per area scales with the mass.
             * With the mixed layer, the reference M0 of the smoothing
             * length h = h0 sqrt(M0 / M) scales with it too, so that h
             * follows the footprint m / M, not the mass: a particle born
             * 5 cm thick that grows to 50 cm keeps its h (without this h
             * fell to the floor sml_min_factor h0, the kernel lost its
             * neighbours and continuity inflated the footprints until the
             * leads over a cell summed to 76-86 cells: docs/ocean.md).
             * Without the mixed layer M0 stays the seeded field's
             * (today's runs unchanged). */
            const int ref = sph_ocean_on(m);
            if (!p->summation_density || ref)
                for (size_t k = 0; k < P->n; k++)
                    if (m->dvel[k] > 0.0) {
                        double f = P->mass[k] / m->dvel[k];
                        if (!p->summation_density)
                            P->dens[k] *= f;
                        if (ref)
                            P->dens0[k] *= f;
                    }
            m->thermo_accum = 0.0;
            if (ocean_dd && (rc = sph_dd_ocean_after(m, tdt, rc, st)) != SPH_STEP_OK)
                return rc; /* every rank's status agreed first */
            if (rc != SPH_STEP_OK)
                return rc;
            if (sph_ocean_on(m) && !ocean_dd && (rc = sph_ocean_after(m, tdt, m->tw, st)) != SPH_STEP_OK)
                return rc;
            for (size_t k = P->n; k-- > 0;)
                if (!(P->mass[k] > 0.0))
                    sph_dd_remove(m, k);
        }
    }
    if (fused && !fused_top && !thermo_ran) { /* the pass's counts are the final state's */
        regime_fractions_from(m, fused_cnt[0], fused_cnt[1], fused_cnt[2], fused_cnt[3]);
        update_budget(m);
        sph_dd_update_sources(m);
        return check_health_from(m, st, fused_first);
    }
    regime_fractions(m);
    update_budget(m);
    sph_dd_update_sources(m);
    return check_health(m, st);
}
int sph_model_diagnose(sph_model *m, sph_status *st)
{
    sph_particles *P = m->P;
    sph_status_clear(st);
    int rc = prepare(m, st);
    if (rc != SPH_STEP_OK)
        return rc;
    sph_ghost_velocity(m, P->u, P->v, 1);
    sph_strain_pass(m, NULL, P->n);
    m->rheo->stress(m, NULL, P->n, P->s11, P->s22, P->s12);
    sph_ghost_stress(m);
    sph_divergence_pass(m, NULL, P->n);
    return SPH_STEP_OK;
}



