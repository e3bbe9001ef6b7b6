/* The DEM driver: particles, bonds, the cell search, the step. */
#include "dem_impl.h"

#include <stdlib.h>
#include <string.h>
#include <omp.h>

#include "core/neighbours.h"

void dem_params_default(dem_params *p)
{
    memset(p, 0, sizeof *p);
    p->density = 900.0;
    p->kn = 0.0; /* 0: from the bond modulus, K_n = E_b pi r / 2 (dem_create) */
    p->ks_ratio = 0.6;          /* the seed: k_t is 60 % of k_n */
    p->restitution = 0.3;
    p->friction = 0.15;         /* ice on steel / ice on ice, ~0.1-0.2 */
    p->bond_modulus = 1.0e9;    /* E of sea ice, ~1 GPa (the seed's value) */
    p->bond_shear_ratio = 0.6;
    p->bond_radius = 1.0;
    /* calibrated (test_dem_bend, docs/dem.md): a close-packed specimen of three
     * layers of 0.1 m spheres (0.263 m) in three-point bending (span 16 depths,
     * a roller nose) reaches the measured 0.6 MPa flexural strength of Bohai
     * ice (Xiu et al. 2022) with these bonds; shear at session 6's ratio
     * 0.222 / 0.133 of tension (not calibrated) */
    p->bond_tensile = 0.334e6;
    p->bond_shear = 0.558e6;
    p->water_density = 1025.0;
    p->gravity = 9.81;
    p->drag = 0.5;
    p->local_damping = 0.0;
    p->dt_safety = 0.8;
    p->max_contacts = 16;
}

dem *dem_create(size_t cap, size_t cap_bonds, const dem_params *p)
{
    if (cap == 0 || !p || p->max_contacts < 1)
        return NULL;
    dem *d = calloc(1, sizeof *d);
    if (!d)
        return NULL;
    d->p = *p;
    d->cap = cap;
    d->cap_bonds = cap_bonds;
    double **dv[] = {&d->x,  &d->y,  &d->z,  &d->vx, &d->vy, &d->vz, &d->wx, &d->wy,
                     &d->wz, &d->r,  &d->m,  &d->inertia, &d->fx, &d->fy, &d->fz,
                     &d->tx, &d->ty, &d->tz};
    int ok = 1;
    for (size_t k = 0; k < sizeof dv / sizeof dv[0]; k++)
        ok &= (*dv[k] = calloc(cap, sizeof(double))) != NULL;
    size_t slots = cap * (size_t)p->max_contacts;
    d->ext = calloc(3 * cap, sizeof(double));
    d->s_fs = calloc(3 * cap, sizeof(double));
    d->s_f = calloc(3 * cap, sizeof(double));
    d->flags = calloc(cap, sizeof(int));
    for (int b = 0; b < 2; b++) {
        d->c_id[b] = malloc(slots * sizeof(int));
        d->c_us[b] = calloc(3 * slots, sizeof(double));
        d->c_n[b] = calloc(cap, sizeof(int));
        ok &= d->c_id[b] && d->c_us[b] && d->c_n[b];
    }
    d->bonds = calloc(cap_bonds ? cap_bonds : 1, sizeof(dem_bond));
    d->b_start = calloc(cap + 1, sizeof(int));
    d->b_list = calloc(2 * cap_bonds + 1, sizeof(int));
    d->grid = sph_nbr_create(1, cap, 1);
    ok &= d->ext && d->s_fs && d->s_f && d->flags && d->bonds && d->b_start && d->b_list &&
          d->grid;
    if (!ok) {
        dem_free(d);
        return NULL;
    }
    return d;
}

void dem_free(dem *d)
{
    if (!d)
        return;
    double *dv[] = {d->x,  d->y,  d->z,  d->vx, d->vy, d->vz, d->wx, d->wy, d->wz,
                    d->r,  d->m,  d->inertia, d->fx, d->fy, d->fz, d->tx, d->ty, d->tz};
    for (size_t k = 0; k < sizeof dv / sizeof dv[0]; k++)
        free(dv[k]);
    free(d->ext);
    free(d->s_fs);
    free(d->s_f);
    free(d->flags);
    for (int b = 0; b < 2; b++) {
        free(d->c_id[b]);
        free(d->c_us[b]);
        free(d->c_n[b]);
    }
    free(d->bonds);
    free(d->b_start);
    free(d->b_list);
    sph_nbr_free(d->grid);
    free(d);
}

/* The contact stiffness: K_n, or E_b pi r / 2 of the first particle
 * (k_n A of a bond of radius r between equal particles). */
static double contact_kn(const dem *d)
{
    if (d->p.kn > 0.0)
        return d->p.kn;
    double r = d->n ? d->r[0] : 0.05;
    return d->p.bond_modulus * M_PI * r / 2.0;
}

long dem_add_particle(dem *d, double x, double y, double z, double r)
{
    if (d->n >= d->cap || !(r > 0.0) || !isfinite(x) || !isfinite(y) || !isfinite(z))
        return -1;
    size_t i = d->n++;
    d->x[i] = x;
    d->y[i] = y;
    d->z[i] = z;
    d->r[i] = r;
    d->m[i] = d->p.density * 4.0 / 3.0 * M_PI * r * r * r;
    d->inertia[i] = 0.4 * d->m[i] * r * r;
    d->c_n[0][i] = d->c_n[1][i] = 0;
    if (d->p.kn <= 0.0 && i == 0)
        d->p.kn = contact_kn(d);
    return (long)i;
}

long dem_add_bond(dem *d, long i, long j)
{
    if (d->nbonds >= d->cap_bonds || i < 0 || j < 0 || (size_t)i >= d->n || (size_t)j >= d->n ||
        i == j)
        return -1;
    dem_bond *b = &d->bonds[d->nbonds];
    memset(b, 0, sizeof *b);
    b->i = (int)i;
    b->j = (int)j;
    b->radius = d->p.bond_radius * fmin(d->r[i], d->r[j]);
    b->kn = d->p.bond_modulus / (d->r[i] + d->r[j]);
    b->ks = b->kn * d->p.bond_shear_ratio;
    b->sigma_t = d->p.bond_tensile;
    b->tau_c = d->p.bond_shear;
    d->bonds_indexed = 0;
    return (long)d->nbonds++;
}

long dem_bond_touching(dem *d, double tol)
{
    long made = 0;
    for (size_t i = 0; i < d->n; i++)
        for (size_t j = i + 1; j < d->n; j++) {
            double dx = d->x[j] - d->x[i], dy = d->y[j] - d->y[i], dz = d->z[j] - d->z[i];
            double gap = sqrt(dx * dx + dy * dy + dz * dz) - d->r[i] - d->r[j];
            if (gap < tol * (d->r[i] + d->r[j]) && dem_add_bond(d, (long)i, (long)j) >= 0)
                made++;
        }
    return made;
}

long dem_add_sheet(dem *d, double x0, double y0, int nx, int ny, int nz, double r, double u,
                   double v)
{
    if (nx < 1 || ny < 1 || nz < 1 || d->n + (size_t)nx * ny * nz > d->cap)
        return -1;
    double h = 2.0 * r * nz;
    double draft = d->p.water_density > 0.0 ? h * d->p.density / d->p.water_density : 0.5 * h;
    long first = (long)d->n;
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                long q = dem_add_particle(d, x0 + 2.0 * r * i, y0 + 2.0 * r * j,
                                          -draft + r + 2.0 * r * k, r);
                d->vx[q] = u;
                d->vy[q] = v;
            }
#define SHEET_ID(i, j, k) (first + ((long)(k) * ny + (j)) * nx + (i))
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                long q = SHEET_ID(i, j, k);
                if (i + 1 < nx && dem_add_bond(d, q, SHEET_ID(i + 1, j, k)) < 0) return -1;
                if (j + 1 < ny && dem_add_bond(d, q, SHEET_ID(i, j + 1, k)) < 0) return -1;
                if (k + 1 < nz && dem_add_bond(d, q, SHEET_ID(i, j, k + 1)) < 0) return -1;
            }
#undef SHEET_ID
    return first;
}

long dem_add_sheet_hcp(dem *d, double x0, double y0, int nx, int ny, int nz, double r, double u,
                       double v)
{
    if (nx < 1 || ny < 1 || nz < 1 || d->n + (size_t)nx * ny * nz > d->cap)
        return -1;
    double dz = 2.0 * r * sqrt(2.0 / 3.0), dy = sqrt(3.0) * r;
    double h = 2.0 * r + (nz - 1) * dz;
    double draft = d->p.water_density > 0.0 ? h * d->p.density / d->p.water_density : 0.5 * h;
    long first = (long)d->n;
    for (int k = 0; k < nz; k++) {
        /* B layers sit over the A layer's triangle centres */
        double ox = (k % 2) ? r : 0.0, oy = (k % 2) ? dy / 3.0 : 0.0;
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                double xo = (j % 2) ? r : 0.0;
                long q = dem_add_particle(d, x0 + ox + xo + 2.0 * r * i, y0 + oy + dy * j,
                                          -draft + r + dz * k, r);
                d->vx[q] = u;
                d->vy[q] = v;
            }
    }
    /* bond the touching pairs (centre distance 2r) among the new spheres */
    long last = (long)d->n;
    double lim = 2.0 * r * (1.0 + 1e-6);
    for (long a = first; a < last; a++)
        for (long b = a + 1; b < last; b++) {
            double ddx = d->x[b] - d->x[a], ddy = d->y[b] - d->y[a], ddz = d->z[b] - d->z[a];
            if (fabs(ddx) > lim || fabs(ddy) > lim || fabs(ddz) > lim)
                continue;
            if (ddx * ddx + ddy * ddy + ddz * ddz <= lim * lim && dem_add_bond(d, a, b) < 0)
                return -1;
        }
    return first;
}

void dem_set_velocity(dem *d, long i, double vx, double vy, double vz)
{
    d->vx[i] = vx;
    d->vy[i] = vy;
    d->vz[i] = vz;
}

/* The stable step of the stiffest mode, bounded as for a particle with
 * DEM_COORDINATION springs of the stiffest kind (the kissing number of
 * equal spheres: bonds and contacts together cannot exceed it):
 * translation omega^2 <= 2 z K_t / m, rotation omega^2 <= 2 z K_r / I
 * with K_r = max(k_n I, k_s J) + 4 k_s A r^2 (bending and twisting, and
 * the shear spring's lever on both spheres; the factor 2 bounds the
 * coupling to the neighbours, Gerschgorin's row sum), dt = 2 / omega
 * reduced by sqrt(1 + zeta^2) - zeta for the dashpots. Measured limits
 * (docs/dem.md): a cubic bonded sheet 2.0x, a close-packed one 1.1x this
 * estimate. */
#define DEM_COORDINATION 12.0

double dem_dt_critical(const dem *d)
{
    double mmin = HUGE_VAL, imin = HUGE_VAL, rmax = 0.0;
    for (size_t i = 0; i < d->n; i++) {
        mmin = fmin(mmin, d->m[i]);
        imin = fmin(imin, d->inertia[i]);
        rmax = fmax(rmax, d->r[i]);
    }
    if (d->n == 0)
        return HUGE_VAL;
    double kn = d->p.kn, ks = d->p.kn * d->p.ks_ratio;
    double kt = fmax(kn, ks);
    double kr = 4.0 * ks * rmax * rmax;
    for (size_t b = 0; b < d->nbonds; b++) {
        const dem_bond *q = &d->bonds[b];
        double R = q->radius, A = M_PI * R * R, I = 0.25 * M_PI * R * R * R * R;
        kt = fmax(kt, fmax(q->kn, q->ks) * A);
        kr = fmax(kr, fmax(q->kn * I, q->ks * 2.0 * I) + 4.0 * q->ks * A * rmax * rmax);
    }
    double z2 = 2.0 * DEM_COORDINATION;
    double dt = 2.0 * sqrt(mmin / (z2 * kt));
    if (kr > 0.0)
        dt = fmin(dt, 2.0 * sqrt(imin / (z2 * kr)));
    double zeta = dem_zeta(d->p.restitution);
    return dt * (sqrt(1.0 + zeta * zeta) - zeta);
}

static int status_set(sph_status *st, int code, sph_fault kind, long particle, const char *q,
                      double v, double lim, const char *what, long step)
{
    st->step = step;
    return sph_status_set(st, code, kind, particle, q, v, lim, what);
}

int dem_check(const dem *d, sph_status *st)
{
    sph_status_clear(st);
    const dem_params *p = &d->p;
    if (!(p->density > 0.0))
        return status_set(st, SPH_STEP_FATAL, SPH_FAULT_INVALID, -1, "density", p->density, 0,
                          "must be positive", -1);
    if (!(p->restitution > 0.0 && p->restitution <= 1.0))
        return status_set(st, SPH_STEP_FATAL, SPH_FAULT_INVALID, -1, "restitution",
                          p->restitution, 0, "must lie in (0, 1]", -1);
    if (!(p->friction >= 0.0) || !(p->bond_modulus > 0.0) || !(p->bond_radius > 0.0) ||
        !(p->bond_tensile > 0.0) || !(p->bond_shear > 0.0))
        return status_set(st, SPH_STEP_FATAL, SPH_FAULT_INVALID, -1, "bond parameters", 0, 0,
                          "must be positive", -1);
    if (!(p->dt_safety > 0.0 && p->dt_safety <= 1.0))
        return status_set(st, SPH_STEP_FATAL, SPH_FAULT_INVALID, -1, "dt safety", p->dt_safety,
                          0, "must lie in (0, 1]", -1);
    return dem_structure_check(&d->s, st);
}

/* Per particle its bonds, in bond order (CSR), rebuilt when bonds were added. */
static void index_bonds(dem *d)
{
    int *start = d->b_start;
    memset(start, 0, (d->n + 1) * sizeof(int));
    for (size_t b = 0; b < d->nbonds; b++) {
        start[d->bonds[b].i + 1]++;
        start[d->bonds[b].j + 1]++;
    }
    for (size_t i = 0; i < d->n; i++)
        start[i + 1] += start[i];
    /* fill with a cursor per particle: reuse the torque array's slot count */
    for (size_t b = 0; b < d->nbonds; b++) {
        int i = d->bonds[b].i, j = d->bonds[b].j;
        d->b_list[start[i]++] = (int)b;
        d->b_list[start[j]++] = (int)b;
    }
    for (size_t i = d->n; i > 0; i--)
        start[i] = start[i - 1];
    start[0] = 0;
    d->bonds_indexed = 1;
}

static int bonded_intact(const dem *d, long i, long j)
{
    for (int q = d->b_start[i]; q < d->b_start[i + 1]; q++) {
        const dem_bond *b = &d->bonds[d->b_list[q]];
        if (!b->broken && (b->i == j || b->j == j))
            return 1;
    }
    return 0;
}

/* Forces on particle i: contacts (new list into buffer nxt), bonds,
 * structure, water, gravity. Returns -1 on contact overflow. */
static int particle_forces(dem *d, long i, double dt, int cur, int nxt, double zeta)
{
    (void)zeta;
    const sph_nbr *g = d->grid;
    const dem_params *p = &d->p;
    int mc = p->max_contacts;
    double f[3] = {d->ext[3 * i], d->ext[3 * i + 1], d->ext[3 * i + 2]}, t[3] = {0, 0, 0};
    double ri = d->r[i];
    double wi[3] = {d->wx[i], d->wy[i], d->wz[i]};
    int *oid = d->c_id[cur] + (size_t)i * mc, *nid = d->c_id[nxt] + (size_t)i * mc;
    double *ous = d->c_us[cur] + (size_t)i * mc * 3, *nus = d->c_us[nxt] + (size_t)i * mc * 3;
    int on = d->c_n[cur][i], nn = 0;
    int cx = (int)((d->x[i] - g->x0) / g->cell), cy = (int)((d->y[i] - g->y0) / g->cell);
    if (cx >= g->ncx) cx = g->ncx - 1;
    if (cy >= g->ncy) cy = g->ncy - 1;
    for (int jy = cy - 1; jy <= cy + 1; jy++) {
        if (jy < 0 || jy >= g->ncy)
            continue;
        for (int jx = cx - 1; jx <= cx + 1; jx++) {
            if (jx < 0 || jx >= g->ncx)
                continue;
            int c = jy * g->ncx + jx;
            for (int s = g->cell_start[c]; s < g->cell_start[c + 1]; s++) {
                long j = g->sorted[s];
                if (j == i)
                    continue;
                double dx[3] = {d->x[j] - d->x[i], d->y[j] - d->y[i], d->z[j] - d->z[i]};
                double rs = ri + d->r[j];
                double d2 = v3dot(dx, dx);
                if (d2 >= rs * rs || d2 == 0.0)
                    continue;
                if (bonded_intact(d, i, j))
                    continue;
                if (nn >= mc)
                    return -1;
                double len = sqrt(d2), delta = rs - len;
                double n[3] = {dx[0] / len, dx[1] / len, dx[2] / len};
                double ai = ri - 0.5 * delta, aj = d->r[j] - 0.5 * delta;
                double wj[3] = {d->wx[j], d->wy[j], d->wz[j]};
                double rai[3] = {ai * n[0], ai * n[1], ai * n[2]};
                double raj[3] = {-aj * n[0], -aj * n[1], -aj * n[2]};
                double ci[3], cj[3];
                v3cross(wi, rai, ci);
                v3cross(wj, raj, cj);
                double vc[3] = {d->vx[j] + cj[0] - d->vx[i] - ci[0],
                                d->vy[j] + cj[1] - d->vy[i] - ci[1],
                                d->vz[j] + cj[2] - d->vz[i] - ci[2]};
                double *fs = nus + 3 * nn;
                fs[0] = fs[1] = fs[2] = 0.0;
                for (int q = 0; q < on; q++)
                    if (oid[q] == j) {
                        fs[0] = ous[3 * q];
                        fs[1] = ous[3 * q + 1];
                        fs[2] = ous[3 * q + 2];
                        break;
                    }
                nid[nn++] = (int)j;
                double me = d->m[i] * d->m[j] / (d->m[i] + d->m[j]);
                double fc[3], ft[3], tq[3];
                dem_contact_force(p, n, delta, vc, me, dt, fs, fc, ft);
                v3cross(rai, ft, tq);
                for (int k = 0; k < 3; k++) {
                    f[k] += fc[k];
                    t[k] += tq[k];
                }
            }
        }
    }
    d->c_n[nxt][i] = nn;
    /* bonds, in bond order */
    for (int q = d->b_start[i]; q < d->b_start[i + 1]; q++) {
        const dem_bond *b = &d->bonds[d->b_list[q]];
        double sg = b->i == i ? 1.0 : -1.0;
        const double *tb = b->i == i ? b->t_i : b->t_j;
        for (int k = 0; k < 3; k++) {
            f[k] += sg * b->f_i[k];
            t[k] += tb[k];
        }
    }
    /* structure */
    double *sf = d->s_f + 3 * i;
    sf[0] = sf[1] = sf[2] = 0.0;
    if (d->s.kind != DEM_STRUCT_NONE) {
        double fw[3], tw[3];
        if (dem_structure_contact(d, i, dt, d->s_fs + 3 * i, fw, tw)) {
            for (int k = 0; k < 3; k++) {
                f[k] += fw[k];
                t[k] += tw[k];
                sf[k] = -fw[k];
            }
        } else {
            d->s_fs[3 * i] = d->s_fs[3 * i + 1] = d->s_fs[3 * i + 2] = 0.0;
        }
    }
    /* gravity, buoyancy and drag of the submerged cap under z = 0 */
    f[2] -= d->m[i] * p->gravity;
    if (p->water_density > 0.0) {
        double sub = ri - d->z[i];
        if (sub > 2.0 * ri) sub = 2.0 * ri;
        if (sub > 0.0) {
            double vsub = M_PI * sub * sub * (3.0 * ri - sub) / 3.0;
            double frac = vsub / (4.0 / 3.0 * M_PI * ri * ri * ri);
            f[2] += p->water_density * p->gravity * vsub;
            double du[3] = {p->current[0] - d->vx[i], p->current[1] - d->vy[i],
                            p->current[2] - d->vz[i]};
            double sp = sqrt(v3dot(du, du));
            double cd = 0.5 * p->water_density * p->drag * M_PI * ri * ri * frac * sp;
            for (int k = 0; k < 3; k++)
                f[k] += cd * du[k];
        }
    }
    d->fx[i] = f[0];
    d->fy[i] = f[1];
    d->fz[i] = f[2];
    d->tx[i] = t[0];
    d->ty[i] = t[1];
    d->tz[i] = t[2];
    return 0;
}

static double local_damp(double f, double v, double alpha)
{
    return alpha > 0.0 && v != 0.0 ? f - alpha * fabs(f) * (v > 0.0 ? 1.0 : -1.0) : f;
}

int dem_step(dem *d, double dt, sph_status *st)
{
    sph_status_clear(st);
    if (dem_check(d, st) != 0)
        return st->code;
    /* the bound depends on the particles and bonds only: cached (its
     * serial loop over every bond would cost a second thread's gain) */
    if (d->dt_crit <= 0.0 || d->dt_n != d->n || d->dt_nbonds != d->nbonds) {
        d->dt_crit = dem_dt_critical(d);
        d->dt_n = d->n;
        d->dt_nbonds = d->nbonds;
    }
    double dtc = d->dt_crit, lim = d->p.dt_safety * dtc;
    if (!(dt > 0.0) || !(dt <= lim))
        return status_set(st, SPH_STEP_RECOVERABLE, SPH_FAULT_TIMESTEP, -1, "DEM step", dt, lim,
                          "is beyond the contact's stability limit", d->step);
    if (!d->bonds_indexed)
        index_bonds(d);
    double rmax = 0.0;
    for (size_t i = 0; i < d->n; i++)
        rmax = fmax(rmax, d->r[i]);
    sph_nbr_grid(d->grid, d->n, d->x, d->y, 2.0 * rmax);
    double zeta = dem_zeta(d->p.restitution);
    int cur = d->cur, nxt = 1 - cur;
    long nb = (long)d->nbonds, n = (long)d->n;
    long overflow = n, badp = n;
    long intact = 0, bt = 0, bs = 0;
#pragma omp parallel if (n >= 256)
    {
#pragma omp for schedule(static) reduction(+ : intact, bt, bs)
        for (long b = 0; b < nb; b++) {
            dem_bond_update(d, &d->bonds[b], dt, zeta);
            int k = d->bonds[b].broken;
            intact += k == 0;
            bt += k == 1;
            bs += k == 2;
        }
#pragma omp for schedule(static) reduction(min : overflow)
        for (long i = 0; i < n; i++)
            if (particle_forces(d, i, dt, cur, nxt, zeta) != 0 && i < overflow)
                overflow = i;
    }
    if (overflow < n)
        return status_set(st, SPH_STEP_FATAL, SPH_FAULT_CAPACITY, overflow, "contacts",
                          d->p.max_contacts, d->p.max_contacts,
                          "exceed the contact slots of a particle", d->step);
    d->cur = nxt;
    d->bonds_intact = intact;
    d->bonds_broken_tension = bt;
    d->bonds_broken_shear = bs;
    long contacts = 0;
    /* The structure's load, summed in index order. */
    double sfx = 0.0, sfy = 0.0, sfz = 0.0;
    for (long i = 0; i < n; i++) {
        sfx += d->s_f[3 * i];
        sfy += d->s_f[3 * i + 1];
        sfz += d->s_f[3 * i + 2];
        contacts += d->c_n[nxt][i];
    }
    d->contacts = contacts;
    d->s.fx = sfx;
    d->s.fy = sfy;
    d->s.fz = sfz;
    double alpha = d->p.local_damping;
#pragma omp parallel for schedule(static) reduction(min : badp) if (n >= 256)
    for (long i = 0; i < n; i++) {
        int fl = d->flags[i];
        if (!(fl & DEM_FIX_TRANSLATION)) {
            double im = 1.0 / d->m[i];
            if (!(fl & DEM_FIX_X))
                d->vx[i] += local_damp(d->fx[i], d->vx[i], alpha) * im * dt;
            if (!(fl & DEM_FIX_Y))
                d->vy[i] += local_damp(d->fy[i], d->vy[i], alpha) * im * dt;
            if (!(fl & DEM_FIX_Z))
                d->vz[i] += local_damp(d->fz[i], d->vz[i], alpha) * im * dt;
        }
        if (!(fl & DEM_FIX_ROTATION)) {
            double ii = 1.0 / d->inertia[i];
            d->wx[i] += local_damp(d->tx[i], d->wx[i], alpha) * ii * dt;
            d->wy[i] += local_damp(d->ty[i], d->wy[i], alpha) * ii * dt;
            d->wz[i] += local_damp(d->tz[i], d->wz[i], alpha) * ii * dt;
        }
        d->x[i] += d->vx[i] * dt;
        d->y[i] += d->vy[i] * dt;
        d->z[i] += d->vz[i] * dt;
        if (!(isfinite(d->x[i]) && isfinite(d->y[i]) && isfinite(d->z[i]) &&
              isfinite(d->wx[i] + d->wy[i] + d->wz[i])) && i < badp)
            badp = i;
    }
    dem_structure_advance(&d->s, dt);
    d->step++;
    d->time += dt;
    if (badp < n)
        return status_set(st, SPH_STEP_FATAL, SPH_FAULT_NONFINITE, badp, "position", NAN, 0,
                          "is not finite", d->step);
    if (!isfinite(d->s.ux + d->s.uy))
        return status_set(st, SPH_STEP_FATAL, SPH_FAULT_NONFINITE, -1, "structure displacement",
                          NAN, 0, "is not finite", d->step);
    return SPH_STEP_OK;
}
