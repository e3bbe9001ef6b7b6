/* The mixed layer's thermodynamic step beside the particles' (core/ocean.h,
 * docs/ocean.md): before the particles' step each particle gets the
 * temperature and ice-ocean heat flux of the cells its footprint covers
 * (weighted by the overlap); after it every particle's energy the
 * atmosphere did not explain and its mass change go to those cells; the
 * cells take the atmosphere over their open water with no particle and
 * restoring, form (or melt) frazil below (above) the
 * freezing point; then melted-out particles are removed, new particles
 * are created from the frazil, and thin crowded particles merged.
 * Everything serial and in index order (bit-reproducible), no allocation. */
#include "../model_impl.h"
#include "core/dd.h"
#include "core/ocean.h"

#include <stdlib.h>
#include <string.h>

/* Mean over the layers of the new-ice salinity profile (ppt). */
static double ice_salinity(const sph_thermo_params *tp, int n)
{
    double s = 0.0;
    for (int i = 0; i < n; i++)
        s += sph_bl_salinity(tp, (i + 0.5) / n);
    return s / n;
}

/* Mean enthalpy (J/m^3) of new ice formed at Tf, layer by layer as the
 * particles' leads form it (thermo.c). */
static double new_ice_enthalpy(const sph_thermo_params *tp, int n, double Tf)
{
    double q = 0.0;
    for (int i = 0; i < n; i++) {
        double S = sph_bl_salinity(tp, (i + 0.5) / n);
        double Tm = sph_bl_melting_temperature(tp, S);
        q += sph_bl_enthalpy(tp, S, Tf < Tm ? Tf : Tm);
    }
    return q / n;
}

static double particle_foot(const sph_model *m, size_t k)
{
    const sph_particles *P = m->P;
    double d = m->prm.thermo.rho_i * P->conc[k] * P->thick[k];
    return d > 0.0 ? P->mass[k] / d : 0.0;
}

/* Enthalpy of particle k, J: ice volume x mean layer enthalpy + snow
 * volume x the column's snow enthalpy at its layer temperature,
 * -rho_s (L0 - c0 T_s) per m^3 (sph_snow_enthalpy; T_s 0 without
 * thermo.snow_heat_capacity: -rho_s L0). */
static double particle_enthalpy(const sph_model *m, size_t k)
{
    const sph_particles *P = m->P;
    if (!(P->mass[k] > 0.0))
        return 0.0;
    const double *q = P->enth + k * (size_t)P->nlayers;
    double qb = 0.0;
    for (int i = 0; i < P->nlayers; i++)
        qb += q[i];
    qb /= P->nlayers;
    const sph_thermo_params *tp = &m->prm.thermo;
    double e = P->mass[k] / tp->rho_i * qb;
    if (P->snow[k] > 0.0)
        e += sph_snow_enthalpy(tp, P->tsnow[k]) * P->snow[k] * P->conc[k] * particle_foot(m, k);
    return e;
}

static void ice_totals(const sph_model *m, double *e, double *mass)
{
    if (m->canonical) { /* exact, over every rank (ocean_dd.c) */
        sph_dd_ice_totals(m, particle_enthalpy, e, mass);
        return;
    }
    double se = 0.0, sm = 0.0;
    for (size_t k = 0; k < m->P->n; k++) {
        se += particle_enthalpy(m, k);
        sm += m->P->mass[k];
    }
    *e = se;
    *mass = sm;
}

static double cell_heat_capacity(const sph_model *m, const sph_ocean *o, size_t c)
{
    (void)m;
    return SPH_OCEAN_RHO_WATER * SPH_OCEAN_CP_WATER * o->depth[c] * o->g.dx * o->g.dy *
           fmax(o->seafrac[c], SPH_OCEAN_MIN_SEAFRAC);
}

static double cell_tf(const sph_model *m, const sph_ocean *o, size_t c)
{
    return sph_ocean_freezing_point(m->prm.ocean.freezing, m->prm.thermo.mu, o->sal[c]);
}

/* The cells a particle's footprint covers (docs/ocean.md, "The footprint
 * over the cells"): the footprint is a square of its area centred on the
 * particle, clipped to the grid; the weight of a cell is the square's
 * overlap with the cell times the cell's sea fraction (at least
 * SPH_OCEAN_MIN_SEAFRAC), over their sum. A particle with no footprint,
 * or one that covers no cell of the grid, exchanges with the cell of its
 * centre (clamped to the grid) alone. */
typedef struct foot_span {
    int i0, i1, j0, j1;      /* cells [i0, i1] x [j0, j1] */
    double xa, xb, ya, yb;   /* the square, clipped */
    double wsum;             /* sum of the raw weights */
    size_t big;              /* the cell of the largest weight (first in index order) */
    int single;              /* 1: the centre cell `big` alone */
} foot_span;

static double overlap_1d(double a, double b, double lo, double hi)
{
    double d = fmin(b, hi) - fmax(a, lo);
    return d > 0.0 ? d : 0.0;
}

static double span_raw(const sph_ocean *o, const foot_span *s, int i, int j)
{
    double xl = o->g.x0 + i * o->g.dx, yl = o->g.y0 + j * o->g.dy;
    size_t c = (size_t)j * (size_t)o->g.nx + (size_t)i;
    return overlap_1d(s->xa, s->xb, xl, xl + o->g.dx) * overlap_1d(s->ya, s->yb, yl, yl + o->g.dy) *
           fmax(o->seafrac[c], SPH_OCEAN_MIN_SEAFRAC);
}

static void span_init(const sph_ocean *o, double x, double y, double foot, foot_span *s)
{
    s->single = 1;
    s->big = sph_ocean_cell(o, x, y);
    s->wsum = 0.0;
    double half = 0.5 * sqrt(foot > 0.0 ? foot : 0.0);
    if (!(half > 0.0) || !isfinite(half) || !isfinite(x) || !isfinite(y))
        return;
    const double gx1 = o->g.x0 + o->g.nx * o->g.dx, gy1 = o->g.y0 + o->g.ny * o->g.dy;
    s->xa = fmax(x - half, o->g.x0);
    s->xb = fmin(x + half, gx1);
    s->ya = fmax(y - half, o->g.y0);
    s->yb = fmin(y + half, gy1);
    if (!(s->xa < s->xb && s->ya < s->yb))
        return;
    s->i0 = (int)fmax(0.0, fmin(floor((s->xa - o->g.x0) / o->g.dx), o->g.nx - 1.0));
    s->i1 = (int)fmax(0.0, fmin(floor((s->xb - o->g.x0) / o->g.dx), o->g.nx - 1.0));
    s->j0 = (int)fmax(0.0, fmin(floor((s->ya - o->g.y0) / o->g.dy), o->g.ny - 1.0));
    s->j1 = (int)fmax(0.0, fmin(floor((s->yb - o->g.y0) / o->g.dy), o->g.ny - 1.0));
    if (s->i0 == s->i1 && s->j0 == s->j1) {
        s->big = (size_t)s->j0 * (size_t)o->g.nx + (size_t)s->i0;
        return;
    }
    double wbig = -1.0;
    for (int j = s->j0; j <= s->j1; j++)
        for (int i = s->i0; i <= s->i1; i++) {
            double w = span_raw(o, s, i, j);
            s->wsum += w;
            if (w > wbig) {
                wbig = w;
                s->big = (size_t)j * (size_t)o->g.nx + (size_t)i;
            }
        }
    s->single = !(s->wsum > 0.0) || !(wbig < s->wsum);
}

/* Adds amount X to a[] over the span: X w to every cell but the largest,
 * which gets the rest, so that the parts sum to X (to one rounding). */
static void span_add(const sph_ocean *o, const foot_span *s, double X, double *a)
{
    if (s->single) {
        a[s->big] += X;
        return;
    }
    double rest = X;
    for (int j = s->j0; j <= s->j1; j++)
        for (int i = s->i0; i <= s->i1; i++) {
            size_t c = (size_t)j * (size_t)o->g.nx + (size_t)i;
            if (c == s->big)
                continue;
            double w = span_raw(o, s, i, j);
            if (w > 0.0) {
                double v = X * (w / s->wsum);
                a[c] += v;
                rest -= v;
            }
        }
    a[s->big] += rest;
}

/* Bins the live particles by the cell of their centre (counting sort,
 * index order kept) and spreads their footprints over the cells they
 * cover (cfoot). */
static void bin_particles(sph_model *m)
{
    sph_ocean *o = m->ocean;
    sph_particles *P = m->P;
    memset(o->bin_start, 0, (o->ncell + 1) * sizeof(int));
    memset(o->cfoot, 0, o->ncell * sizeof(double));
    for (size_t k = 0; k < P->n; k++) {
        size_t c = sph_ocean_cell(o, P->x[k], P->y[k]);
        o->pcell[k] = (int)c;
        o->pfoot[k] = particle_foot(m, k);
        foot_span s;
        span_init(o, P->x[k], P->y[k], o->pfoot[k], &s);
        span_add(o, &s, o->pfoot[k], o->cfoot);
        o->bin_start[c + 1]++;
    }
    for (size_t c = 0; c < o->ncell; c++)
        o->bin_start[c + 1] += o->bin_start[c];
    /* acc_w (free between steps) counts each cell's fill */
    for (size_t c = 0; c < o->ncell; c++)
        o->acc_w[c] = 0.0;
    for (size_t k = 0; k < P->n; k++) {
        size_t c = (size_t)o->pcell[k];
        o->bin_list[o->bin_start[c] + (int)o->acc_w[c]] = (int)k;
        o->acc_w[c] += 1.0;
    }
}

void sph_ocean_mark(sph_model *m)
{
    ice_totals(m, &m->ocean->e_last, &m->ocean->m_last);
}

void sph_ocean_account(sph_model *m)
{
    sph_ocean *o = m->ocean;
    double e, ms;
    ice_totals(m, &e, &ms);
    const sph_thermo_params *tp = &m->prm.thermo;
    double sb = ice_salinity(tp, m->P->nlayers) / 1000.0;
    m->budget.energy_outflow += o->e_last - e;
    m->budget.water_outflow += o->m_last - ms;
    m->budget.salt_outflow += (o->m_last - ms) * sb;
    o->e_last = e;
    o->m_last = ms;
}

void sph_ocean_totals(const sph_model *m, double *energy, double *water, double *salt)
{
    const sph_ocean *o = m->ocean;
    double e, ms;
    ice_totals(m, &e, &ms);
    double sb = ice_salinity(&m->prm.thermo, m->P->nlayers) / 1000.0;
    double ew = 0.0, w = 0.0, s = 0.0;
    for (size_t c = 0; c < o->ncell; c++) {
        ew += cell_heat_capacity(m, o, c) * o->temp[c] + o->frazil_enth[c];
        w += o->water[c] + o->frazil[c];
        s += o->salt[c] + o->frazil[c] * sb;
    }
    *energy = e + ew;
    *water = ms + w;
    *salt = ms * sb + s;
}

/* Cell c under the ice: its temperature and ice-ocean heat flux, at most
 * what brings it to freezing in the step over the ice footprint in it. */
static void ocean_under(const sph_model *m, const sph_ocean *o, size_t c, double dt, double *T, double *fw)
{
    double Tc = o->temp[c], Tf = cell_tf(m, o, c);
    double f = m->prm.ocean.heat_transfer * fmax(Tc - Tf, 0.0);
    double ice = o->cfoot[c] > 0.0 ? o->cfoot[c] : 1.0;
    double fmax_ = cell_heat_capacity(m, o, c) * fmax(Tc - Tf, 0.0) / (dt * ice);
    *T = Tc;
    *fw = fmin(f, fmax_);
}

void sph_ocean_before(sph_model *m, double dt)
{
    sph_ocean *o = m->ocean;
    sph_particles *P = m->P;
    sph_ocean_account(m); /* what the dynamics took out since the last look */
    bin_particles(m);
    const sph_thermo_params *tp = &m->prm.thermo;
    for (size_t k = 0; k < P->n; k++) {
        /* the snow that falls on its ice in the step comes from the
         * atmosphere with its enthalpy at 0 C, -rho_s L0 per m^3 of snow
         * (the column adds it, core/thermo.c): booked as if already on
         * the particle, and as a surface flux (sph_ocean_after) */
        double sf = 0.0;
        if (P->mass[k] > 0.0 && P->thick[k] > 0.0 && P->conc[k] > 0.0 && P->snowfall[k] > 0.0)
            sf = sph_snow_enthalpy(tp, 0.0) * (P->snowfall[k] / tp->rho_s) * dt * P->mass[k] /
                 (tp->rho_i * P->thick[k]);
        o->penth[k] = particle_enthalpy(m, k) + sf;
        o->pmass[k] = P->mass[k];
        o->psnowfall[k] = sf;
        foot_span s;
        span_init(o, P->x[k], P->y[k], o->pfoot[k], &s);
        /* the footprint's cells: their mean temperature, and the ice-ocean
         * heat flux of each, at most what brings it to freezing in the step
         * (shared by the ice over it), weighted by the footprint */
        double T = 0.0, fw = 0.0;
        if (s.single) {
            ocean_under(m, o, s.big, dt, &T, &fw);
        } else {
            for (int j = s.j0; j <= s.j1; j++)
                for (int i = s.i0; i <= s.i1; i++) {
                    double w = span_raw(o, &s, i, j) / s.wsum, Tc, fc;
                    if (!(w > 0.0))
                        continue;
                    ocean_under(m, o, (size_t)j * (size_t)o->g.nx + (size_t)i, dt, &Tc, &fc);
                    T += w * Tc;
                    fw += w * fc;
                }
        }
        P->sst[k] = T;
        P->fw[k] = fw;
    }
}

/* 1 when (x, y) is within the footprint of a live particle (the binned ones). */
static int inside_ice(const sph_model *m, double x, double y, double reach)
{
    const sph_ocean *o = m->ocean;
    const sph_particles *P = m->P;
    double ds = o->g.ds;
    int ri = (int)ceil(reach / o->g.dx), rj = (int)ceil(reach / o->g.dy);
    size_t c = sph_ocean_cell(o, x, y);
    int ci = (int)(c % (size_t)o->g.nx), cj = (int)(c / (size_t)o->g.nx);
    for (int j = cj - rj; j <= cj + rj; j++) {
        if (j < 0 || j >= o->g.ny)
            continue;
        for (int i = ci - ri; i <= ci + ri; i++) {
            if (i < 0 || i >= o->g.nx)
                continue;
            size_t b = (size_t)j * (size_t)o->g.nx + (size_t)i;
            for (int q = o->bin_start[b]; q < o->bin_start[b + 1]; q++) {
                int k = o->bin_list[q];
                double r = 0.45 * (sqrt(o->pfoot[k]) + ds);
                double dx = P->x[k] - x, dy = P->y[k] - y;
                if (dx * dx + dy * dy < r * r)
                    return 1;
            }
        }
    }
    return 0;
}

/* Lattice points of cell c: index range [a0, a1) x [b0, b1). */
static void cell_lattice(const sph_ocean *o, size_t c, long *a0, long *a1, long *b0, long *b1)
{
    int i = (int)(c % (size_t)o->g.nx), j = (int)(c / (size_t)o->g.nx);
    double xa = o->g.x0 + i * o->g.dx, ya = o->g.y0 + j * o->g.dy;
    *a0 = (long)ceil((xa - o->g.lx0) / o->g.ds);
    *a1 = (long)ceil((xa + o->g.dx - o->g.lx0) / o->g.ds);
    *b0 = (long)ceil((ya - o->g.ly0) / o->g.ds);
    *b1 = (long)ceil((ya + o->g.dy - o->g.ly0) / o->g.ds);
}

static long max_id(const sph_particles *P)
{
    long id = -1;
    for (size_t k = 0; k < P->n; k++)
        id = P->id[k] > id ? P->id[k] : id;
    return id;
}

/* New particles in cell c from its frazil; SPH_STEP_FATAL when the model
 * is full. */
static int create_in_cell(sph_model *m, size_t c, double reach, long *next_id, sph_status *st)
{
    sph_ocean *o = m->ocean;
    sph_particles *P = m->P;
    const sph_thermo_params *tp = &m->prm.thermo;
    double ds = o->g.ds;
    long a0, a1, b0, b1;
    cell_lattice(o, c, &a0, &a1, &b0, &b1);
    size_t nfree = 0;
    for (int pass = 0; pass < 2; pass++) {
        size_t made = 0;
        for (long b = b0; b < b1; b++)
            for (long a = a0; a < a1; a++) {
                double x = o->g.lx0 + a * ds, y = o->g.ly0 + b * ds;
                if (!sph_is_domain_sea(m, x, y) || inside_ice(m, x, y, reach))
                    continue;
                if (pass == 0) {
                    nfree++;
                    continue;
                }
                size_t k = P->n + made++;
                double mass = o->frazil[c] / (double)nfree;
                double foot = ds * ds;
                /* every field of core/particles.h's list: zero, then set */
                sph_particles_clear_one(P, k);
                P->x[k] = x;
                P->y[k] = y;
                P->u[k] = P->v[k] = 0.0;
                P->mass[k] = mass;
                P->conc[k] = 1.0;
                P->thick[k] = mass / (tp->rho_i * foot);
                P->sml[k] = P->sml0[k] = m->prm.sml_factor * ds;
                P->dens[k] = P->dens0[k] = mass / foot;
                P->snow[k] = 0.0;
                P->tsurf[k] = cell_tf(m, o, c);
                P->s11[k] = P->s22[k] = P->s12[k] = 0.0;
                P->coastc[k] = 0.0;
                double *q = P->enth + k * (size_t)P->nlayers;
                double qv = o->frazil_enth[c] / (o->frazil[c] / tp->rho_i);
                for (int i = 0; i < P->nlayers; i++)
                    q[i] = qv;
                P->id[k] = (*next_id)++;
                P->regime[k] = 0;
                P->e11[k] = P->e22[k] = P->e12[k] = P->pres[k] = P->ax[k] = P->ay[k] = 0.0;
                P->lat[k] = o->lat[c];
                P->ua[k] = o->ua[c];
                P->va[k] = o->va[c];
                P->uw[k] = P->vw[k] = P->sshx[k] = P->sshy[k] = 0.0;
                P->tair[k] = o->tair[c];
                P->qair[k] = o->qair[c];
                P->swdn[k] = o->swdn[c];
                P->lwdn[k] = o->lwdn[c];
                P->sst[k] = o->temp[c];
                P->fw[k] = NAN;
                P->fsens[k] = P->flat[k] = NAN;
            }
        if (pass == 0) {
            if (nfree == 0)
                return SPH_STEP_OK; /* no room in this cell: the frazil waits */
            if (P->n + nfree > m->cap)
                return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_CAPACITY, -1, "particle count",
                                      (double)(P->n + nfree), (double)m->cap,
                                      "new ice in open water needs more particles than the model "
                                      "capacity (raise it or merge thin particles)");
        } else {
            P->n += made;
        }
    }
    m->budget.new_ice += o->frazil[c];
    if (m->canonical && (!m->dd || m->dd->lead)) /* the sources, once over the ranks (ocean_dd.c) */
        sph_xsum_add(&m->dd_src[SPH_DD_SRC_NEW_ICE], o->frazil[c]);
    m->budget.created_particles += (long)nfree;
    o->frazil[c] = 0.0;
    o->frazil_enth[c] = 0.0;
    return SPH_STEP_OK;
}

/* Hands particle k's accumulators to the cells of a footprint `foot`. */
static void take_particle_foot(sph_model *m, size_t k, double foot)
{
    sph_ocean *o = m->ocean;
    sph_particles *P = m->P;
    foot_span s;
    span_init(o, P->x[k], P->y[k], foot, &s);
    double *const from[7] = {P->ofx_heat_lead, P->ofx_water, P->ofx_salt, P->ofx_heat_ice,
                             P->ofx_taux, P->ofx_tauy, P->ofx_swbase};
    double *const to[7] = {o->ofx_heat, o->ofx_water, o->ofx_salt, o->ofx_heat_ice,
                           o->ofx_taux, o->ofx_tauy, o->ofx_swbase};
    for (int q = 0; q < 7; q++) {
        span_add(o, &s, from[q][k], to[q]);
        from[q][k] = 0.0;
    }
}

void sph_ocean_take_particle(sph_model *m, size_t k)
{
    take_particle_foot(m, k, particle_foot(m, k));
}

void sph_ocean_stash_particle(sph_model *m, size_t k, double rec[SPH_OCEAN_OUT_ROW])
{
    sph_particles *P = m->P;
    double *const from[7] = {P->ofx_heat_lead, P->ofx_water, P->ofx_salt, P->ofx_heat_ice,
                             P->ofx_taux, P->ofx_tauy, P->ofx_swbase};
    rec[0] = (double)P->id[k];
    rec[1] = P->x[k];
    rec[2] = P->y[k];
    rec[3] = particle_foot(m, k);
    for (int q = 0; q < 7; q++) {
        rec[4 + q] = from[q][k];
        from[q][k] = 0.0;
    }
}

void sph_ocean_book_stashed(sph_model *m, const double rec[SPH_OCEAN_OUT_ROW])
{
    sph_ocean *o = m->ocean;
    double *const to[7] = {o->ofx_heat, o->ofx_water, o->ofx_salt, o->ofx_heat_ice,
                           o->ofx_taux, o->ofx_tauy, o->ofx_swbase};
    foot_span s;
    span_init(o, rec[1], rec[2], rec[3], &s);
    for (int q = 0; q < 7; q++)
        span_add(o, &s, rec[4 + q], to[q]);
}

/* Merges particle j into k: mass, momentum, ice volume, enthalpy, snow
 * volume and footprint are summed; position mass-weighted. */
static void merge_into(sph_model *m, size_t k, size_t j)
{
    sph_particles *P = m->P;
    const sph_thermo_params *tp = &m->prm.thermo;
    double mk = P->mass[k], mj = P->mass[j], ms = mk + mj;
    double fk = particle_foot(m, k), fj = particle_foot(m, j), fs = fk + fj;
    double ak = P->conc[k] * fk, aj = P->conc[j] * fj; /* ice areas */
    double vk = mk / tp->rho_i, vj = mj / tp->rho_i;
    double *qk = P->enth + k * (size_t)P->nlayers, *qj = P->enth + j * (size_t)P->nlayers;
    for (int i = 0; i < P->nlayers; i++)
        qk[i] = (vk * qk[i] + vj * qj[i]) / (vk + vj);
    double snow = P->snow[k] * ak + P->snow[j] * aj;
    /* the snow's enthalpy -rho_s (L0 - c0 T) is linear in T: the
     * volume-weighted temperature keeps it */
    double sk = P->snow[k] > 0.0 ? P->snow[k] * ak : 0.0, sj = P->snow[j] > 0.0 ? P->snow[j] * aj : 0.0;
    double tsnow = sk + sj > 0.0 ? (sk * fmin(P->tsnow[k], 0.0) + sj * fmin(P->tsnow[j], 0.0)) / (sk + sj) : 0.0;
    P->x[k] = (mk * P->x[k] + mj * P->x[j]) / ms;
    P->y[k] = (mk * P->y[k] + mj * P->y[j]) / ms;
    P->u[k] = (mk * P->u[k] + mj * P->u[j]) / ms;
    P->v[k] = (mk * P->v[k] + mj * P->v[j]) / ms;
    P->tsurf[k] = (mk * P->tsurf[k] + mj * P->tsurf[j]) / ms;
    P->s11[k] = (fk * P->s11[k] + fj * P->s11[j]) / fs;
    P->s22[k] = (fk * P->s22[k] + fj * P->s22[j]) / fs;
    P->s12[k] = (fk * P->s12[k] + fj * P->s12[j]) / fs;
    /* the reference footprints m / M0 add, as the reference lengths
     * sml0 below do (h = sml0 sqrt(M0 / M) = sml0 sqrt(a / a0); M0
     * follows the mass through thermodynamics, model.c) */
    P->dens0[k] = ms / (mk / P->dens0[k] + mj / P->dens0[j]);
    P->dens[k] = ms / fs;
    P->coastc[k] = fmax(P->coastc[k], P->coastc[j]);
    /* the smoothing length scales with the side of the footprint */
    P->sml0[k] = sqrt(P->sml0[k] * P->sml0[k] + P->sml0[j] * P->sml0[j]);
    P->sml[k] = sqrt(P->sml[k] * P->sml[k] + P->sml[j] * P->sml[j]);
    double area = ak + aj;
    P->conc[k] = fmin(area / fs, 1.0);
    P->mass[k] = ms;
    P->thick[k] = ms / (tp->rho_i * P->conc[k] * fs);
    P->snow[k] = snow / (P->conc[k] * fs);
    P->tsnow[k] = tsnow;
    /* the fluxes into the ocean the two gathered this record stay in it */
    P->ofx_heat_ice[k] += P->ofx_heat_ice[j];
    P->ofx_heat_lead[k] += P->ofx_heat_lead[j];
    P->ofx_water[k] += P->ofx_water[j];
    P->ofx_salt[k] += P->ofx_salt[j];
    P->ofx_taux[k] += P->ofx_taux[j];
    P->ofx_tauy[k] += P->ofx_tauy[j];
    P->ofx_swbase[k] += P->ofx_swbase[j];
    if (mj > mk)
        P->id[k] = P->id[j];
    P->mass[j] = 0.0;
}

static void merge_thin(sph_model *m)
{
    sph_ocean *o = m->ocean;
    sph_particles *P = m->P;
    const sph_ocean_params *op = &m->prm.ocean;
    bin_particles(m);
    double fmx = 0.0;
    for (size_t k = 0; k < P->n; k++)
        fmx = fmax(fmx, o->pfoot[k]);
    double reach = op->merge_distance * sqrt(fmx);
    int ri = (int)ceil(reach / o->g.dx), rj = (int)ceil(reach / o->g.dy);
    /* the merged particle's size cap: a merged particle stays thin, so
     * without it it would merge again and again (docs/ocean.md) */
    const double side = op->merge_max_size * o->g.ds, foot_cap = side * side;
    const double sml_cap = op->merge_max_size * m->prm.sml_factor * o->g.ds;
    for (size_t k = 0; k < P->n; k++) {
        if (!(P->mass[k] > 0.0) || !(P->thick[k] < op->merge_thickness))
            continue;
        size_t c = (size_t)o->pcell[k];
        int ci = (int)(c % (size_t)o->g.nx), cj = (int)(c / (size_t)o->g.nx);
        long best = -1;
        for (int j = cj - rj; j <= cj + rj && best < 0; j++) {
            if (j < 0 || j >= o->g.ny)
                continue;
            for (int i = ci - ri; i <= ci + ri && best < 0; i++) {
                if (i < 0 || i >= o->g.nx)
                    continue;
                size_t b = (size_t)j * (size_t)o->g.nx + (size_t)i;
                for (int q = o->bin_start[b]; q < o->bin_start[b + 1]; q++) {
                    size_t l = (size_t)o->bin_list[q];
                    if (l <= k || !(P->mass[l] > 0.0) || !(P->thick[l] < op->merge_thickness))
                        continue;
                    if (o->pfoot[k] + o->pfoot[l] > foot_cap ||
                        P->sml[k] * P->sml[k] + P->sml[l] * P->sml[l] > sml_cap * sml_cap * (1.0 + 1e-12) ||
                        P->sml0[k] * P->sml0[k] + P->sml0[l] * P->sml0[l] > sml_cap * sml_cap * (1.0 + 1e-12))
                        continue;
                    double r = op->merge_distance * 0.5 * (sqrt(o->pfoot[k]) + sqrt(o->pfoot[l]));
                    double dx = P->x[l] - P->x[k], dy = P->y[l] - P->y[k];
                    if (dx * dx + dy * dy < r * r) {
                        best = (long)l;
                        break;
                    }
                }
            }
        }
        if (best >= 0) {
            merge_into(m, k, (size_t)best);
            m->budget.merged_particles++;
        }
    }
    for (size_t k = P->n; k-- > 0;)
        if (!(P->mass[k] > 0.0))
            sph_particles_remove(P, k);
}

int sph_ocean_after(sph_model *m, double dt, const sph_thermo_work *tw, sph_status *st)
{
    return sph_ocean_after_ea(m, dt, tw, NULL, st);
}

int sph_ocean_after_ea(sph_model *m, double dt, const sph_thermo_work *tw, const double *eav, sph_status *st)
{
    sph_ocean *o = m->ocean;
    sph_particles *P = m->P;
    const sph_params *p = &m->prm;
    const sph_thermo_params *tp = &p->thermo;
    const int nl = P->nlayers;
    const double sb = ice_salinity(tp, nl) / 1000.0;
    /* 1. each particle's unexplained energy and its mass change to its cell */
    memset(o->acc_e, 0, o->ncell * sizeof(double));
    memset(o->acc_w, 0, o->ncell * sizeof(double));
    for (size_t k = 0; k < P->n; k++) {
        double ea = eav ? eav[k] : sph_thermo_energy_atm(tw, k);
        double de = particle_enthalpy(m, k) - o->penth[k];
        m->budget.energy_surface += ea + o->psnowfall[k];
        foot_span s; /* the footprint before the step, as cfoot */
        span_init(o, P->x[k], P->y[k], o->pfoot[k], &s);
        span_add(o, &s, ea - de, o->acc_e);
        span_add(o, &s, -((P->mass[k] > 0.0 ? P->mass[k] : 0.0) - o->pmass[k]), o->acc_w);
    }
    /* 2. the cells */
    const double area = o->g.dx * o->g.dy;
    const double tau = p->ocean.restore_days * 86400.0;
    for (size_t c = 0; c < o->ncell; c++) {
        double H = cell_heat_capacity(m, o, c); /* J/K */
        double T = o->temp[c];
        double aopen = fmax(0.0, o->seafrac[c] - o->cfoot[c] / area);
        double e_ow = 0.0;
        if (aopen > 0.0) {
            sph_thermo_params q = *tp;
            double Tf = cell_tf(m, o, c);
            q.ocean_salinity = -Tf / (tp->mu > 0.0 ? tp->mu : 1.0);
            sph_column_forcing f;
            sph_column_forcing_default(&f);
            f.tair = o->tair[c];
            f.qair = o->qair[c];
            f.wind = hypot(o->ua[c], o->va[c]);
            f.swdn = o->swdn[c];
            f.lwdn = o->lwdn[c];
            f.sst = T;
            e_ow = sph_open_water_flux(&q, &f) * aopen * area * dt;
        }
        m->budget.energy_surface += e_ow;
        double e_r = 0.0;
        if (tau > 0.0) {
            double g = 1.0 - exp(-dt / tau);
            if (isfinite(o->sst_restore[c]))
                e_r = H * (o->sst_restore[c] - T) * g;
            if (isfinite(o->sss_restore[c])) {
                double ds_ = (o->water[c] * o->sss_restore[c] / 1000.0 - o->salt[c]) * g;
                o->salt[c] += ds_;
                m->budget.salt_restoring += ds_;
            }
        }
        m->budget.energy_restoring += e_r;
        T += (e_ow + e_r + o->acc_e[c]) / H;
        o->water[c] += o->acc_w[c];
        o->salt[c] += o->acc_w[c] * sb;
        o->sal[c] = 1000.0 * o->salt[c] / o->water[c];
        double Tf = cell_tf(m, o, c);
        double dmf = 0.0, elat = 0.0; /* latent heat the frazil gave (> 0) or took the liquid */
        if (T < Tf) { /* frazil: the heat deficit freezes ice at Tf */
            double D = H * (Tf - T);
            elat = D;
            double qn = new_ice_enthalpy(tp, nl, Tf);
            dmf = tp->rho_i * D / -qn;
            o->frazil[c] += dmf;
            o->frazil_enth[c] -= D;
            T = Tf;
        } else if (T > Tf && o->frazil[c] > 0.0) { /* warm water melts waiting frazil */
            double avail = H * (T - Tf), need = -o->frazil_enth[c];
            double use = avail < need ? avail : need;
            dmf = -o->frazil[c] * (use < need ? use / need : 1.0);
            o->frazil[c] += dmf;
            o->frazil_enth[c] = use < need ? o->frazil_enth[c] + use : 0.0;
            if (use >= need)
                o->frazil[c] = 0.0;
            T -= use / H;
            elat = -use;
        }
        o->water[c] -= dmf;
        o->salt[c] -= dmf * sb;
        o->sal[c] = 1000.0 * o->salt[c] / o->water[c];
        o->temp[c] = T;
        o->ow_heat[c] = e_ow / (area * dt);
        o->ow_fresh[c] = -dmf / (area * dt);
        o->ow_salt[c] = -dmf * sb / (area * dt);
        o->ofx_heat[c] += e_ow + elat;
        o->ofx_water[c] -= dmf;
        o->ofx_salt[c] -= dmf * sb;
    }
    /* 3. particles whose ice melted away (their water is already in the
     * cell; what they gave the ocean since the last record goes to the
     * cell's accumulators) */
    for (size_t k = P->n; k-- > 0;)
        if (!(P->mass[k] > 0.0)) {
            take_particle_foot(m, k, o->pfoot[k]); /* its footprint before it melted */
            sph_particles_remove(P, k);
        }
    /* 4. new particles from the frazil */
    int rc = SPH_STEP_OK;
    if (p->ocean.create) {
        bin_particles(m);
        double fmx = 0.0;
        for (size_t k = 0; k < P->n; k++)
            fmx = fmax(fmx, o->pfoot[k]);
        double reach = 0.45 * (sqrt(fmx) + o->g.ds);
        long next = max_id(P) + 1;
        for (size_t c = 0; c < o->ncell && rc == SPH_STEP_OK; c++) {
            if (!(o->frazil[c] > 0.0))
                continue;
            double open = fmax(0.0, o->seafrac[c] * area - o->cfoot[c]);
            double h = open > 0.0 ? o->frazil[c] / (tp->rho_i * open) : HUGE_VAL;
            if (h >= p->ocean.new_thickness)
                rc = create_in_cell(m, c, reach, &next, st);
        }
    }
    /* 5. thin crowded particles merge */
    if (rc == SPH_STEP_OK && p->ocean.merge)
        merge_thin(m);
    sph_ocean_mark(m);
    return rc;
}
