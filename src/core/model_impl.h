/* Private to the model (SQLite-style private header): struct sph_model, the
 * rheology and solver operation tables, and the passes the step driver,
 * the solvers and the rheologies share. Nothing outside src/core includes
 * it; the public API is include/core/model.h.
 *
 * Rooms:
 *   model.c              parameters, create/free/init/resume, step driver,
 *                        budgets and health
 *   coast.c              land mask queries, mirror ghosts, ghost velocity
 *                        and stress, moves blocked by land, outflow
 *   operators.c          SPH passes: ordering, density, diagnosis, active
 *                        set, strain, divergence, gradient correction,
 *                        free drift, continuity, smoothing length,
 *                        interpolation
 *   rheology/<name>.c    one constitutive law each (sph_rheology_ops)
 *   solver/<name>.c      one stress solver each (sph_solver_ops)
 *   registry.c           the rheologies by sph_params.rheology and the
 *                        solvers by sph_params.solver
 *
 * Every pass takes a particle list (NULL: all live particles) and runs
 * over it; operation tables are called once per pass, never per particle,
 * so the per-particle kernels (include/core/rheology.h, momentum below)
 * stay inline in the loops.
 */
#ifndef SPHICE_CORE_MODEL_IMPL_H
#define SPHICE_CORE_MODEL_IMPL_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "core/dd.h"
#include "core/kernel.h"
#include "core/model.h"
#include "core/neighbours.h"
#include "core/ocean.h"

#define OMEGA_EARTH 7.292e-5
/* Bound of lambda_max h^2 / nu of the SPH viscous operator (measured). */
#define SPH_VISCOUS_EIG 1.25
/* Threads pay off only above a few thousand particles: the solver runs
 * thousands of short passes per step, each a fork/join. */
#define SPH_OMP_WORTH(n) ((n) >= 4096)
/* The budget's sums (update_budget): each block of SPH_SUM_BLOCK particles
 * summed in index order, then the blocks' sums in block order, whatever
 * the thread count; with at most one block, the plain sum in index order. */
#define SPH_SUM_BLOCK 16384

/* *x = +0.0, written only where it is not already (pages of a field that
 * stays zero, such as the parcels' strain rates, are never made resident:
 * issue 22's memory at 1e6 particles). */
static inline void sph_set_zero(double *x)
{
    if (*x != 0.0 || signbit(*x))
        *x = 0.0;
}

/* *x = v, written only where its bits differ (a field that a free-drift
 * step leaves as it was is read, not written back) */
static inline void sph_set_bits(double *x, double v)
{
    uint64_t a, b;
    memcpy(&a, x, sizeof a);
    memcpy(&b, &v, sizeof b);
    if (a != b)
        *x = v;
}
#define SPH_SUM_NQ 5
/* Smallest concentration a parcel is diluted to by divergence. */
#define SPH_CONC_MIN 0.05
#define DEG2RAD (M_PI / 180.0)

typedef struct sph_rheology_ops sph_rheology_ops;
typedef struct sph_solver_ops sph_solver_ops;

struct sph_model {
    sph_params prm;
    sph_kernel kern;
    const sph_rheology_ops *rheo; /* prm.rheology's table */
    const sph_solver_ops *solver; /* prm.solver's table */
    void *solver_ws;              /* the solver's own workspace (solver->create) */
    sph_particles *P; /* capacity 2*cap: live particles then ghosts */
    size_t cap;
    size_t ng;        /* ghosts this step, at indices [n, n + ng) */
    int *ghost_src;
    double *ghost_nx, *ghost_ny, *ghost_n2x, *ghost_n2y;
    /* [ng] the mass of the reflections a ghost stands for (its source's,
     * plus those of the ghosts merged into it, coast.c): the summation
     * density's land share; P->mass of a merged ghost carries their volume
     * at its source's density instead (the operators' sums m / rho) */
    double *ghost_mass;
    /* the ghosts placed so far in a hash of square cells (coast.c): heads
     * [gh_size, a power of two], chains [2*cap] */
    int *gh_head, *gh_next;
    size_t gh_size;
    double gh_cell;
    size_t ghosts_thinned; /* ghosts merged into others by the last build (coast.c) */
    int ghost_merge;       /* 1 once a neighbour list overflowed: crowded ghosts are merged */
    sph_nbr *nb;
    int has_mask;
    sph_landmask mask;
    unsigned char *land;
    unsigned char *near_land; /* sea cells within the ghost radius of land */
    double near_radius;
    /* workspaces, [2*cap] */
    double *un, *vn;     /* velocity at the start of the step */
    double *zeta;        /* last bulk viscosity */
    double *vfluct;      /* fluctuating velocity (SPH_RHEO_FIELD_VFLUCT; else NULL) */
    double *dvel;        /* per-particle velocity change of the last iteration */
    double *scratch;     /* permutation and misc, [2*cap*SPH_MAX_LAYERS] */
    int *order;
    int *active;         /* particles iterated by the stress solver */
    size_t nactive;
    unsigned char *loose; /* per particle: free drift in auto mode */
    double dens_scale;   /* lattice calibration of the truncated kernel */
    double *fcor;        /* Coriolis parameter per particle, set each step */
    double *sum_part;    /* the budget's partial sums, SPH_SUM_NQ per block of SPH_SUM_BLOCK particles */
    double cos_air, sin_air, cos_water, sin_water; /* turning angles */
    sph_thermo_work *tw;
    double *binv;    /* [6*c2] gradient correction per particle: B^-1 of the strain
                        rates (b11, b12, b22), then of the stress divergence */
    sph_ocean *ocean;  /* the mixed layer (sph_model_ocean_create); NULL: none */
    size_t binv_ident;  /* slots [0, binv_ident) hold the identity or the correction;
                           beyond, untouched zero pages (memory: model.c) */
    size_t memory_bound; /* model.compact_gradients auto: the factor form from this
                            particle count (SPH_MEMORY_BOUND_PARTICLES; tests lower it) */
    /* 1 / M_j^2 per slot for the divergence's records (pack_stress_slot):
     * M does not change within a stress solve, so a solver that owns such
     * an array points here for the solve (NULL otherwise); div_imd2_ready:
     * filled by this solve's first divergence pass (operators.c) */
    double *div_imd2;
    int div_imd2_ready;
    /* 1 / M_k per particle for the strain pass (strain_finish): filled for
     * the active set by a solver before its iterations, the same division
     * the pass makes (NULL otherwise: the pass divides) */
    double *strain_im;
    /* the pairs a list of the strain and divergence passes visits (the sum
     * of its particles' neighbour counts), kept for up to three lists while
     * pass_pairs_on (a solve: lists and neighbour counts fixed); operators.c */
    int pass_pairs_on, pass_pairs_n;
    const int *pass_pairs_list[3];
    size_t pass_pairs_count[3], pass_pairs_sum[3];
    /* within a solve (pass_pairs_on): m_j already in nb->pk's records
     * (operators.c: set by the solve's first packing, cleared with it) */
    int pk_mass_ready;
    /* 1: mEVP's per-particle passes in four lanes (lanes.h; the CPU has
     * AVX2, checked at create); 0: two. The same bits either way. */
    int lanes4;
    sph_budget budget;
    sph_step_stats stats;
    double time, thermo_accum;
    long steps;
    /* domain decomposition (core/dd.h, dd.c): driver hooks (NULL: serial),
     * canonical mode, the neighbour sort keys [2*cap], owned flags [2*cap] */
    const struct sph_dd_hooks *dd;
    int canonical;
    long *dd_key;
    unsigned char *dd_owned;
    /* canonical mode: the budget's exact sources over the owned particles
     * (core/dd.h), on top of dd_base (the budget at init or resume) */
    sph_xsum dd_src[SPH_DD_NSRC];
    sph_budget dd_base;
    /* canonical mode with the mixed layer (ocean/ocean_dd.c): the ocean's
     * step runs on a global view of the particles, every rank's owned ones
     * in id order (the driver's SPH_DD_OCEAN gathers them), allocated with
     * capacity cap by sph_dd_ocean_alloc: og_ea the atmospheric energy of
     * each (the thermodynamic step's), og_lea the same per local slot,
     * og_mine the ids this rank owned when the view was gathered (sorted),
     * og_maxid the largest id of the view then; og_on 1 while m->P is the
     * view; og_rc the worst step status over the ranks (the gather's) */
    sph_particles *og;
    double *og_ea, *og_lea, *og_scratch;
    long *og_pair, *og_mine;
    int *og_order;
    size_t og_nmine;
    long og_maxid;
    int og_on, og_rc;
    /* the particles that left at an open boundary in this step with
     * output.ocean_fluxes on (sph_ocean_stash_particle's rows, capacity
     * cap): og_out this rank's owned ones, og_outg every rank's (the
     * driver's SPH_DD_OUTFLOW gathers them), booked in id order */
    double *og_out, *og_outg;
    size_t og_nout, og_noutg;
};

/* Array length of the per-particle workspaces: live particles and ghosts. */
static inline size_t sph_model_slots(const sph_model *m) { return m->P->cap; }

/* ------------------------------------------------------------------ */
/* rheologies (src/core/rheology/)                                     */

/* Fields a rheology needs beside the common ones. */
#define SPH_RHEO_FIELD_VFLUCT 1u /* m->vfluct: kernel-weighted RMS velocity
                                    deviation, filled by the strain pass */

struct sph_rheology_ops {
    const char *name;     /* the configuration's name (model.rheology) */
    unsigned fields;      /* SPH_RHEO_FIELD_* the model allocates and fills */
    /* Constitutive stress of the listed particles (NULL: all live) from
     * their strain rates into s11/s22/s12[k], the bulk viscosity into
     * m->zeta[k]; loose particles (m->loose) get zero stress. */
    void (*stress)(sph_model *m, const int *list, size_t count, double *s11, double *s22,
                   double *s12);
    /* Upper bound of the bulk viscosity of the listed particles into
     * out[k], for the explicit solver's stability limit. */
    void (*zeta_bound)(const sph_model *m, const int *list, size_t count, double *out);
    /* Projects the EVP stress memory of every live particle back onto what
     * the current strength allows; NULL: no projection. */
    void (*project_memory)(sph_model *m);
    /* The measured stable dynamic step this rheology imposes at initial
     * spacing `spacing`, with the refusal's message in *why; HUGE_VAL
     * where it imposes none. */
    double (*stable_dt)(const sph_params *p, double spacing, const char **why);
    /* 1: stress is sph_vp_stress per particle (zeta into m->zeta, loose
     * particles zero), which a solver may evaluate inline instead of
     * calling stress (mEVP's fused stress and relaxation) */
    int vp_law;
};

/* For a rheology's stress pass: a loose particle (free drift) carries no
 * stress; 1 if k is one (its stress and zeta zeroed). */
static inline int sph_stress_loose(sph_model *m, size_t k, double *s11, double *s22, double *s12)
{
    if (!m->loose[k])
        return 0;
    s11[k] = s22[k] = s12[k] = 0.0;
    m->zeta[k] = 0.0;
    return 1;
}

/* The table for sph_params.rheology; NULL when out of range. */
const sph_rheology_ops *sph_rheology_ops_of(int kind);

/* ------------------------------------------------------------------ */
/* stress solvers (src/core/solver/)                                   */

struct sph_solver_ops {
    const char *name; /* the configuration's name (model.solver) */
    /* Allocates the solver's workspace for m into *ws (NULL: none needed);
     * 0 on success. Called outside a step (create, set_params). */
    int (*create)(const sph_model *m, void **ws);
    void (*free)(void *ws);
    /* Internal stress and momentum of the active set m->active for one
     * dynamic step; fills m->stats. */
    int (*solve)(sph_model *m, void *ws, sph_status *st);
    /* The measured stable dynamic step (docs/bench.md) at initial spacing
     * `spacing`, with the refusal's message in *why; HUGE_VAL where
     * nothing bounds it (a solver that sub-steps itself or is implicit). */
    double (*stable_dt)(const sph_params *p, double spacing, const char **why);
    /* 1: reads m->binv with the gradient correction off too (its identity,
     * model.c prepare_lists); 0: only with the correction on */
    int binv_always;
};

/* The table for sph_params.solver; NULL when out of range. */
const sph_solver_ops *sph_solver_ops_of(int kind);

/* Explicit viscous step limit at the current state (solver/explicit.c). */
double sph_explicit_limit(sph_model *m);

/* ------------------------------------------------------------------ */
/* coasts (coast.c)                                                    */

int sph_is_land(const sph_model *m, double x, double y);
int sph_is_domain_sea(const sph_model *m, double x, double y);
/* Marks sea cells within `radius` of a land cell (done once, at init). */
void sph_mark_near_land(sph_model *m, double radius);
/* The same marking into nl (nx * ny bytes of the mask): 1 where a land
 * cell (outside a closed domain counts as land) lies within the window of
 * `radius` around the cell (core/dd.c: the halo's coast zone). */
void sph_mark_land_within(const sph_model *m, double radius, unsigned char *nl);
void sph_build_ghosts(sph_model *m);
void sph_ghost_velocity(sph_model *m, double *u, double *v, int mirror);
void sph_ghost_stress(sph_model *m);
/* The air stress on each ghost's source into air[2 g], air[2 g + 1] (m->ng
 * ghosts), and sph_ghost_stress with it (NULL: computed there): for a
 * solver that calls the ghost stress many times in a step. */
void sph_ghost_air_setup(sph_model *m, double *air);
void sph_ghost_stress_air(sph_model *m, const double *air);
void sph_move_and_constrain(sph_model *m);
void sph_remove_outflow(sph_model *m);
/* sph_move_and_constrain for particle k alone; returns 1 when its new
 * position is one sph_remove_outflow removes (the same test) */
int sph_move_one(sph_model *m, size_t k);

/* S' = R S R with R = I - 2 n n^T; S = [[a, b], [b, c]] (a mirror). */
static inline void sph_reflect_tensor(double nx, double ny, double *a, double *b, double *c)
{
    if (nx == 0.0 && ny == 0.0)
        return;
    double r11 = 1 - 2 * nx * nx, r12 = -2 * nx * ny, r22 = 1 - 2 * ny * ny;
    double t11 = r11 * *a + r12 * *b, t12 = r11 * *b + r12 * *c;
    double t21 = r12 * *a + r22 * *b, t22 = r12 * *b + r22 * *c;
    double s11 = t11 * r11 + t12 * r12, s12 = t11 * r12 + t12 * r22;
    double s22 = t21 * r12 + t22 * r22;
    *a = s11;
    *b = s12;
    *c = s22;
}

/* The stress a mirror ghost takes from its source (before the normal
 * stress extrapolation of sph_ghost_stress): free slip, the mirror image
 * R S R per wall, whose shear stress sigma_nt is odd, so the pair with its
 * source carries no shear traction across the coast (a slip wall); no
 * slip, the source's stress unreflected: the no-slip extension of the
 * velocity (u -> -u) makes the wall shear strain d u_t / d n even across
 * the coast, so sigma_nt is even and the coast takes the shear traction
 * (docs/dynamics.md, "box2001": with R S R a no-slip coast raised the
 * wall's shear strain but transmitted no shear stress, and packed ice slid
 * along it). a, b, c = S11, S12, S22. */
static inline void sph_ghost_stress_image(int no_slip, double n1x, double n1y, double n2x, double n2y,
                                          double *a, double *b, double *c)
{
    if (no_slip)
        return;
    sph_reflect_tensor(n1x, n1y, a, b, c);
    sph_reflect_tensor(n2x, n2y, a, b, c);
}

/* ------------------------------------------------------------------ */
/* the ocean mixed layer and new ice (ocean/new_ice.c)                 */

/* Active when the model has a mixed layer and ocean.mixed_layer is on. */
static inline int sph_ocean_on(const sph_model *m) { return m->ocean && m->prm.ocean.mixed_layer; }
/* Records the particles' ice enthalpy and mass as the last look. */
void sph_ocean_mark(sph_model *m);
/* Books what the particles lost since the last look (open boundaries). */
void sph_ocean_account(sph_model *m);
/* Totals of ice (particles, frazil) plus ocean: energy J, water kg, salt kg. */
void sph_ocean_totals(const sph_model *m, double *energy, double *water, double *salt);
/* Before the particles' thermodynamic step: cells' SST and ice-ocean flux. */
void sph_ocean_before(sph_model *m, double dt);
/* After it: cells, frazil, removal, creation, merging. */
int sph_ocean_after(sph_model *m, double dt, const sph_thermo_work *tw, sph_status *st);
/* Hands particle k's accumulated fluxes into the ocean (ofx_*) to its
 * cell's accumulators and zeroes them, before k is removed mid-record. */
void sph_ocean_take_particle(sph_model *m, size_t k);
/* Canonical mode (ocean/ocean_dd.c): a particle leaving at an open
 * boundary is stashed instead (a row: id, x, y, footprint, then its seven
 * accumulators in take_particle's order, which it zeroes), and the rows of
 * every rank are booked into the cells in id order (sph_ocean_book_stashed,
 * exactly what take_particle adds for that particle). */
#define SPH_OCEAN_OUT_ROW 11
void sph_ocean_stash_particle(sph_model *m, size_t k, double rec[SPH_OCEAN_OUT_ROW]);
void sph_ocean_book_stashed(sph_model *m, const double rec[SPH_OCEAN_OUT_ROW]);
/* sph_ocean_after with the particles' atmospheric energy from ea[k]
 * instead of tw (the canonical view's, ocean_dd.c). */
int sph_ocean_after_ea(sph_model *m, double dt, const sph_thermo_work *tw, const double *ea, sph_status *st);

/* Canonical mode with the mixed layer (ocean/ocean_dd.c, docs/domain.md):
 * the view's workspace (outside a step; 0 on success, also when not
 * needed), and the ocean's two halves of a thermodynamic step on the view
 * of every rank's owned particles in id order. before: sets sst and fw of
 * every local slot; after: the cells, removal, creation and merging on the
 * view, then the local particles become this rank's share of the view (the
 * ids it owned; the new ones on the lead rank); rc_in: this rank's status
 * of the thermodynamic step, agreed over the ranks first. */
int sph_dd_ocean_alloc(sph_model *m);
void sph_dd_ocean_free(sph_model *m);
int sph_dd_ocean_before(sph_model *m, double dt, sph_status *st);
int sph_dd_ocean_after(sph_model *m, double dt, int rc_in, sph_status *st);
/* Stashes owned particle k that leaves at an open boundary (canonical
 * mode with the mixed layer and thermo.ocean_fluxes). */
void sph_dd_ocean_stash_outflow(sph_model *m, size_t k);
/* After the removals of a step, on every rank: gathers every rank's
 * stashed rows and books them into the cells in id order. */
void sph_dd_ocean_book_outflow(sph_model *m);
/* 1 where the leaving particles' accumulators go through the stash. */
static inline int sph_dd_ocean_stashes(const sph_model *m)
{
    return m->canonical && m->og && m->prm.thermo.ocean_fluxes && sph_ocean_on(m);
}
/* Canonical mode: the ice enthalpy (J) and mass (kg) of the particles as
 * exact sums, over the view, or over the owned particles summed over the
 * ranks (the driver's reduce). */
void sph_dd_ice_totals(const sph_model *m, double (*enth)(const sph_model *, size_t), double *e, double *mass);

/* ------------------------------------------------------------------ */
/* canonical mode for domain decomposition (dd.c, core/dd.h)          */

/* Removes live particle k (sph_particles_remove), keeping the owned flags
 * of canonical mode with their particles. */
void sph_dd_remove(sph_model *m, size_t k);
/* Canonical mode: the budget's source terms from the exact accumulators. */
void sph_dd_update_sources(sph_model *m);

/* Sorts every neighbour list by the particles' global keys. */
void sph_dd_sort_lists(sph_model *m);
/* After the lists, density and active set: the driver maps its particles
 * (serial: all owned). */
void sph_dd_lists_ready(sph_model *m);
/* The mEVP norms over the owned active particles, exact and reduced over
 * the ranks: max |du|, sum du^2, sum res2, sum |u|^2, the count. */
void sph_dd_mevp_norms(sph_model *m, const int *act, size_t na, const double *res2, double *r,
                       double *s2, double *q2, double *u2, double *nact);

/* ------------------------------------------------------------------ */
/* SPH passes (operators.c)                                            */

double sph_max_sml(const sph_particles *P, size_t n);
void sph_reorder(sph_model *m);
void sph_density_pass(sph_model *m);
/* One particle of sph_diagnose_pass (ridging at A > 1 done on P): its
 * concentration *A, ice strength *pres; returns the strength's factor
 * exp(-C (1 - A)) (the auto regime's loose test). Shared with the parcels'
 * one-pass step (model.c) so both make the same operations. */
static inline double sph_diagnose_one(sph_particles *P, const sph_params *p, size_t k, double *A, double *pres)
{
    double hbar = P->dens[k] / p->rho_i;
    double a = hbar / P->thick[k];
    if (a > 1.0) { /* ridging: A = 1, the ice thickens at constant volume */
        P->snow[k] *= P->thick[k] / hbar; /* the snow piles up with it: snow mass kept */
        P->thick[k] = hbar;
        a = 1.0;
    }
    /* sph_ice_strength's factor, computed once (same operations) */
    double factor = exp(-p->C * (1.0 - a));
    *A = a;
    *pres = p->P0 * hbar * factor;
    return factor;
}

/* One particle of sph_update_sml (model.variable_sml): the new smoothing
 * length from its mass per area and its divergence, within the bounds. */
static inline double sph_sml_one(const sph_particles *P, const sph_params *p, size_t k)
{
    double div = P->e11[k] + P->e22[k];
    double h = P->sml0[k] * sqrt(P->dens0[k] / P->dens[k]) * (1.0 + 0.5 * p->dt * div);
    double lo = p->sml_min_factor * P->sml0[k], hi = p->sml_max_factor * P->sml0[k];
    return fmin(fmax(h, lo), hi);
}

void sph_diagnose_pass(sph_model *m);
void sph_select_active(sph_model *m);
void sph_strain_pass(sph_model *m, const int *list, size_t count);
void sph_divergence_pass(sph_model *m, const int *list, size_t count);
void sph_gradient_correction_pass(sph_model *m);
void sph_free_drift_pass(sph_model *m);
void sph_parcels_drift_pass(sph_model *m);
/* sph_parcels_drift_pass's solve for particles [k0, k1), on the calling
 * thread (the same bits: each parcel's result is its own) */
void sph_parcels_drift_range(sph_model *m, size_t k0, size_t k1);
void sph_continuity_pass(sph_model *m);
void sph_update_sml(sph_model *m);

/* The factor of the air and water stress of particle k: 1 (Hibler 1979,
 * the default) or its concentration A (model.momentum.drag_scaling =
 * concentration, CICE's form). */
static inline double sph_drag_factor(const sph_model *m, size_t k)
{
    return m->prm.drag_scaling == SPH_DRAG_CONCENTRATION ? m->P->conc[k] : 1.0;
}

/* Momentum for particle k with implicit water drag (lagged speed) and
 * trapezoidal Coriolis, solved as a 2x2 system:
 *   (1+beta) u' = beta u_p + u_n + dt [a_int + tau_a/(rho h) - g grad xi
 *                 + c R_w (U_w - u') - f k x (u' + u_n)/2]
 * c = rho_w C_w |U_w - u_p| / M. beta = 0 is a plain implicit
 * step; beta > 0 is the mEVP pseudo-time iteration (Kimmritz et al. 2015),
 * whose fixed point is the same time-discrete equation. */
static inline void sph_momentum(const sph_model *m, size_t k, double beta, double up, double vp,
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
    /* model.momentum.drag_scaling = concentration (a comparison option):
     * CICE's air and water stress, both times A */
    double dA = sph_drag_factor(m, k);
    double tax = dA * p->rho_a * p->Ca * sa * (ua * ca - va * sna);
    double tay = dA * p->rho_a * p->Ca * sa * (ua * sna + va * ca);
    double uw = P->uw[k], vw = P->vw[k];
    double dux = uw - up, duy = vw - vp;
    double c = dA * p->rho_w * p->Cw * sqrt(dux * dux + duy * duy) / rho_h;
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

#endif
