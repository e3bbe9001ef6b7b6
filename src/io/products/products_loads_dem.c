/* The station DEM of the ice-load product (issue 25 items 3 and 4; docs/dem.md
 * "The station DEM"): a bonded close-packed ice sheet of the forecast's
 * thickness driven at the forecast's drift speed into the station's
 * vertical structure or cone, with the DEM core's public API (core/dem.h)
 * only; the cycle's cache of its results; a stop at the next step once the
 * cycle's cancel flag is set.
 *
 * The scene (all from the keys, so that a test can build the same run
 * from the core's API and compare bit for bit):
 *   thickness h, speed u: the forecast's, rounded to the cache's
 *     resolution (loads.dem_cache_thickness, loads.dem_cache_speed; 0:
 *     exact), so that a cached result is exactly the run it stands for;
 *   layers nz = max(1, lround((h - d) / (d sqrt(2/3))) + 1) for the
 *     nominal sphere diameter d (loads.dem_particle_diameter), sphere
 *     radius r = h / (2 + (nz - 1) 2 sqrt(2/3)): the close-packed sheet is
 *     exactly h thick (dem_add_sheet_hcp);
 *   nx = ceil(L / 2r) spheres along the drift (L loads.dem_sheet_length),
 *     ny = ceil((W - 2r) / (sqrt(3) r)) + 1 rows across (W =
 *     loads.dem_sheet_width structure diameters), at least 3 and 5;
 *   the rear edge (x < 4r) and both side edges (y < 2r, y > y_max - 2r)
 *     move with the far-field ice at u (translation and rotation fixed),
 *     the rest starts at u;
 *   the ice: bonds of modulus E (K_n = E pi r / 2, Potyondy & Cundall)
 *     and the keys' strengths; a cone's friction for every contact;
 *   the structure: a vertical cylinder of the station's diameter, or its
 *     cone (angle, waterline diameter at z = 0, neck), with its mass,
 *     stiffness and damping ratio, centred across the sheet (y0 = sqrt(3) r
 *     (ny - 1) / 2), touching the sheet without overlap: x0 = max over
 *     the spheres with |y - y0| < reach of x + sqrt(reach^2 - (y - y0)^2),
 *     reach = R + r, or for the cone R - z / tan a + r / sin a at the
 *     sphere's height z (R = w / 2; front + R where none is that close);
 *   step dt = loads.dem_dt, or 0.9 dt_safety dt_critical when 0; the
 *     number of steps ceil(duration / dt) (loads.dem_duration);
 *   the series: the structure's load along the drift (s.fx), its
 *     displacement (s.ux) and acceleration (s.ax) after every step;
 *     mean, max, std (n - 1) of the load over every step; the dominant
 *     frequency by dem_load_stats of the series' means over blocks of
 *     k = max(1, floor(1 ms / dt)) steps (a 1 kHz series: the direct DFT
 *     of every step would cost more than the run; NaN from fewer than two
 *     blocks or block means that do not vary); displacement and
 *     acceleration: max |.| and std. */
#include "products_impl.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/dem.h"
#include "util/log.h"
#include "util/timeutil.h"

void prod_loads_options_default(prod_loads_options *o)
{
    memset(o, 0, sizeof *o);
    o->model = PROD_LOADS_AUTO;
    o->min_speed = 0.05;
    o->min_thickness = 0.1;
    o->duration = 1.0;
    o->particle_diameter = 0.1;
    o->sheet_length = 1.0;
    o->sheet_width = 2.0;
    o->dt = 0.0;
    o->max_particles = 20000;
    o->cache_thickness = 0.02;
    o->cache_speed = 0.02;
    o->map_threshold = 500e3;
    o->elastic_modulus = 1.0e9; /* the seed's E of sea ice (its section 2.1) */
    o->bond_tensile = 0.334e6;  /* calibrated: 0.6 MPa flexural strength at 0.1 m spheres */
    o->bond_shear = 0.558e6;    /* (test_dem_bend, docs/dem.md) */
    o->cancel = NULL;
}

typedef struct prod_dem_cache {
    double w, mass, stiffness, damping, h, u; /* the run's structure and ice */
    double cone_angle, neck, mu;              /* a cone's geometry and friction (0: a vertical leg) */
    prod_dem_result r;
} prod_dem_cache;

static double rounded(double x, double res)
{
    return res > 0.0 ? res * round(x / res) : x;
}

/* max |x| and the sample standard deviation of n values */
static void abs_max_std(const double *x, long n, double *mx, double *sd)
{
    double s = 0.0, m = 0.0, v = 0.0;
    for (long i = 0; i < n; i++) {
        s += x[i];
        m = fmax(m, fabs(x[i]));
    }
    double mu = n > 0 ? s / (double)n : 0.0;
    for (long i = 0; i < n; i++)
        v += (x[i] - mu) * (x[i] - mu);
    *mx = m;
    *sd = n > 1 ? sqrt(v / (double)(n - 1)) : 0.0;
}

/* The rear (x < 4r) and side (y < 2r, y > y_max - 2r) edges move with the
 * far-field ice at u; returns the sheet's front, max (x + r). */
static double drive_edges(dem *d, double rad, double ymax, double u)
{
    double front = 0.0;
    for (size_t i = 0; i < d->n; i++) {
        const double x = d->x[i], y = d->y[i];
        front = fmax(front, x + rad);
        int edge = x < 4.0 * rad || y < 2.0 * rad || y > ymax - 2.0 * rad;
        if (!edge)
            continue;
        d->flags[i] = DEM_FIX_TRANSLATION | DEM_FIX_ROTATION;
        dem_set_velocity(d, (long)i, u, 0.0, 0.0);
    }
    return front;
}

/* The horizontal distance from the axis at which a sphere of radius rad
 * centred at height z touches the structure: R + r for the cylinder; for
 * the cone (angle a from the horizontal, waterline radius R at z = 0, neck
 * radius R_n from z_n = (R - R_n) tan a up) the face's radius at z,
 * R - z / tan a, plus r / sin a (the normal distance to the face is the
 * horizontal gap times sin a), and R_n + r above z_n. */
static double reach_at(const prod_structure *ps, double rad, double z)
{
    double R = 0.5 * ps->w;
    if (!(ps->cone_angle > 0.0))
        return R + rad;
    double a = ps->cone_angle * M_PI / 180.0, ta = tan(a), rn = 0.5 * ps->neck;
    if (z > (R - rn) * ta)
        return rn + rad;
    return R - z / ta + rad / sin(a);
}

/* The axis x0 at which the structure, centred across at y0, touches the
 * sheet without overlapping it: max over the spheres with |y - y0| < reach
 * (reach_at) of x + sqrt(reach^2 - (y - y0)^2); front + R if none. */
static double touching_x0(const dem *d, const prod_structure *ps, double rad, double y0, double front)
{
    double x0 = -HUGE_VAL;
    for (size_t i = 0; i < d->n; i++) {
        double dy = d->y[i] - y0, reach = reach_at(ps, rad, d->z[i]);
        if (fabs(dy) < reach)
            x0 = fmax(x0, d->x[i] + sqrt(reach * reach - dy * dy));
    }
    return x0 > -HUGE_VAL ? x0 : front + 0.5 * ps->w;
}

static int dem_fail(sph_error *err, int code, const char *station, const char *key, const char *fmt, ...)
    __attribute__((format(printf, 5, 6)));
static int dem_fail(sph_error *err, int code, const char *station, const char *key, const char *fmt, ...)
{
    char what[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    return sph_err_set(err, code, "loads: station \"%s\": %s: set %s", station, what, key);
}

int products_loads_dem_run(const prod_loads_options *o, const prod_structure *ps, const char *station, double h,
                           double u, prod_dem_result *r, sph_error *err)
{
    memset(r, 0, sizeof *r);
    r->thickness = h;
    r->speed = u;
    if (!(h > 0.0) || !(u >= 0.0) || !isfinite(h) || !isfinite(u))
        return dem_fail(err, SPH_ERR_PARAM, station, "loads.dem_cache_thickness",
                        "the DEM's ice (thickness %g m, speed %g m/s) is not a sheet that can be built", h, u);
    const double q = sqrt(2.0 / 3.0), dn = o->particle_diameter;
    long nz = lround((h - dn) / (dn * q)) + 1;
    if (nz < 1)
        nz = 1;
    double rad = h / (2.0 + (double)(nz - 1) * 2.0 * q);
    double width = o->sheet_width * ps->w;
    long nx = (long)ceil(o->sheet_length / (2.0 * rad));
    long ny = (long)ceil((width - 2.0 * rad) / (sqrt(3.0) * rad)) + 1;
    if (nx < 3 || ny < 5)
        return dem_fail(err, SPH_ERR_CONFIG, station, nx < 3 ? "loads.dem_sheet_length" : "loads.dem_sheet_width",
                        "the DEM's ice sheet cannot be built: %.0f spheres along the drift and %.0f rows across "
                        "(at least 3 and 5)", (double)nx, (double)ny);
    double np = (double)nx * (double)ny * (double)nz;
    if (np > (double)o->max_particles)
        return dem_fail(err, SPH_ERR_CONFIG, station, "loads.dem_max_particles",
                        "the DEM's ice sheet cannot be built: it needs %.0f spheres, more than the %.0f allowed", np,
                        (double)o->max_particles);
    dem_params p;
    dem_params_default(&p);
    /* Potyondy & Cundall's deformability: K_n = E pi r / 2 (dem_create, K_n
     * 0), bonds E / (r_i + r_j); a cone's ice-structure friction is the
     * contacts' mu (one mu in the seed's Fig. 18), as Ralston's load has it */
    p.bond_modulus = o->elastic_modulus;
    p.bond_tensile = o->bond_tensile;
    p.bond_shear = o->bond_shear;
    if (ps->cone_angle > 0.0)
        p.friction = ps->mu;
    size_t n = (size_t)np;
    dem *d = dem_create(n, 8 * n, &p);
    if (!d)
        return sph_err_set(err, SPH_ERR_NOMEM, "loads: station \"%s\": the DEM: out of memory (%zu spheres)",
                           station, n);
    double t0 = time_monotonic();
    if (dem_add_sheet_hcp(d, 0.0, 0.0, (int)nx, (int)ny, (int)nz, rad, u, 0.0) != 0) {
        dem_free(d);
        return dem_fail(err, SPH_ERR_CONFIG, station, "loads.dem_max_particles",
                        "the DEM's ice sheet cannot be built (%.0f spheres, bond capacity %.0f)", np, 8.0 * np);
    }
    double front = drive_edges(d, rad, sqrt(3.0) * rad * (double)(ny - 1) + rad, u);
    d->s.kind = ps->cone_angle > 0.0 ? DEM_STRUCT_CONE : DEM_STRUCT_CYLINDER;
    d->s.diameter = ps->w;
    if (ps->cone_angle > 0.0) {
        d->s.cone_angle = ps->cone_angle;
        d->s.neck_diameter = ps->neck;
        d->s.z_waterline = 0.0;
    }
    d->s.y0 = 0.5 * sqrt(3.0) * rad * (double)(ny - 1);
    d->s.x0 = touching_x0(d, ps, rad, d->s.y0, front);
    d->s.mass = ps->mass;
    d->s.stiffness = ps->stiffness;
    d->s.damping_ratio = ps->damping;
    sph_status st;
    if (dem_check(d, &st) != 0) {
        dem_free(d);
        const char *key = strstr(st.quantity, "neck")    ? "stations[].structure.neck_diameter"
                          : strstr(st.quantity, "angle") ? "stations[].structure.cone_angle"
                          : strstr(st.quantity, "structure") ? "stations[].structure.mass, .stiffness or .damping"
                                                             : "loads.dem_elastic_modulus, loads.dem_bond_tensile "
                                                               "or loads.dem_bond_shear";
        return sph_err_set(err, SPH_ERR_CONFIG, "loads: station \"%s\": the DEM cannot be built: %s %g %s: set %s",
                           station, st.quantity, st.value, st.what, key);
    }
    double dt = o->dt > 0.0 ? o->dt : 0.9 * p.dt_safety * dem_dt_critical(d);
    long steps = (long)ceil(o->duration / dt);
    if (steps < 1)
        steps = 1;
    double *f = malloc(3 * (size_t)steps * sizeof *f);
    if (!f) {
        dem_free(d);
        return sph_err_set(err, SPH_ERR_NOMEM, "loads: station \"%s\": the DEM: out of memory (%ld steps)", station,
                           steps);
    }
    double *ux = f + steps, *ax = ux + steps;
    for (long s = 0; s < steps; s++) {
        if (o->cancel && *o->cancel) { /* the cycle was cancelled: nothing of this run is kept */
            free(f);
            dem_free(d);
            return sph_err_set(err, SPH_ERR_CANCELLED, "loads: station \"%s\": the DEM cancelled after %.3g of %.3g s",
                               station, (double)s * dt, o->duration);
        }
        int rc = dem_step(d, dt, &st);
        if (rc != SPH_STEP_OK) {
            int tstep = st.kind == SPH_FAULT_TIMESTEP;
            free(f);
            dem_free(d);
            if (tstep)
                return dem_fail(err, SPH_ERR_CONFIG, station, "loads.dem_dt",
                                "the DEM step %g s is beyond the contact's stability limit %g s", st.value, st.limit);
            return sph_err_set(err, SPH_ERR_NUMERICS, "loads: station \"%s\": the DEM failed at step %ld: %s %s",
                               station, s, st.quantity, st.what);
        }
        f[s] = d->s.fx;
        ux[s] = d->s.ux;
        ax[s] = d->s.ax;
    }
    double sum = 0.0, mx = -HUGE_VAL, var = 0.0;
    for (long s = 0; s < steps; s++) {
        sum += f[s];
        mx = fmax(mx, f[s]);
    }
    double mu = sum / (double)steps;
    for (long s = 0; s < steps; s++)
        var += (f[s] - mu) * (f[s] - mu);
    r->mean = mu;
    r->max = mx;
    r->std = steps > 1 ? sqrt(var / (double)(steps - 1)) : 0.0;
    long k = (long)floor(1e-3 / dt);
    if (k < 1)
        k = 1;
    long nd = steps / k;
    double *fd = ux; /* the block means overwrite nothing still needed: computed after ux and ax */
    abs_max_std(ux, steps, &r->disp_max, &r->disp_std);
    abs_max_std(ax, steps, &r->acc_max, &r->acc_std);
    for (long b = 0; b < nd; b++) {
        double bs = 0.0;
        for (long j = 0; j < k; j++)
            bs += f[b * k + j];
        fd[b] = bs / (double)k;
    }
    /* no spectrum (NaN, fill in the file) from fewer than two blocks or a
     * load that does not vary (a sheet at rest: no dominant frequency) */
    double m2, x2, s2 = 0.0;
    r->freq = NAN;
    if (nd > 1)
        dem_load_stats(fd, (size_t)nd, dt * (double)k, &m2, &x2, &s2, &r->freq);
    if (!(s2 > 0.0))
        r->freq = NAN;
    r->particles = (long)d->n;
    r->bonds = (long)d->nbonds;
    r->steps = steps;
    r->dt = dt;
    free(f);
    dem_free(d);
    r->seconds = time_monotonic() - t0;
    return SPH_OK;
}

static int cache_grow(prod_writer *p)
{
    size_t cap = p->ld_capcache ? 2 * p->ld_capcache : 16;
    prod_dem_cache *grown = realloc(p->ld_cache, cap * sizeof *grown);
    if (grown) {
        p->ld_cache = grown;
        p->ld_capcache = cap;
    }
    return grown ? 0 : -1;
}

int prod_loads_dem(prod_writer *p, int s, double h, double u, prod_dem_result *r, int *cached, sph_error *err)
{
    const prod_loads_options *o = &p->opts.loads;
    const prod_structure *ps = &p->ld_st[s];
    double hr = rounded(h, o->cache_thickness), ur = rounded(u, o->cache_speed);
    *cached = 0;
    for (size_t c = 0; c < p->ld_ncache; c++) {
        const prod_dem_cache *e = &p->ld_cache[c];
        if (e->h == hr && e->u == ur && e->w == ps->w && e->mass == ps->mass && e->stiffness == ps->stiffness &&
            e->damping == ps->damping && e->cone_angle == ps->cone_angle && e->neck == ps->neck && e->mu == ps->mu) {
            *r = e->r;
            *cached = 1;
            p->ld_sum.dem_cached++;
            return SPH_OK;
        }
    }
    int rc = products_loads_dem_run(o, ps, p->stations[s].name, hr, ur, r, err);
    if (rc != SPH_OK)
        return rc;
    log_info("loads: station \"%s\": DEM of %.3g m ice at %.3g m/s: %ld spheres, %ld steps of %.3g s, load mean %.4g kN, "
             "max %.4g kN (%.1f s)", p->stations[s].name, hr, ur, r->particles, r->steps, r->dt, r->mean * 1e-3,
             r->max * 1e-3, r->seconds);
    p->ld_sum.dem_runs++;
    p->ld_sum.dem_seconds += r->seconds;
    p->ld_sum.dem_steps += r->steps;
    p->ld_sum.dem_particle_steps += r->steps * r->particles;
    if (p->ld_ncache == p->ld_capcache && cache_grow(p) != 0)
        return sph_err_set(err, SPH_ERR_NOMEM, "loads: out of memory (DEM cache)");
    prod_dem_cache *e = &p->ld_cache[p->ld_ncache++];
    e->w = ps->w;
    e->mass = ps->mass;
    e->stiffness = ps->stiffness;
    e->damping = ps->damping;
    e->cone_angle = ps->cone_angle;
    e->neck = ps->neck;
    e->mu = ps->mu;
    e->h = hr;
    e->u = ur;
    e->r = *r;
    return SPH_OK;
}

void prod_loads_dem_free(prod_writer *p)
{
    free(p->ld_cache);
    p->ld_cache = NULL;
    p->ld_ncache = p->ld_capcache = 0;
}

int prod_loads_alert(const prod_writer *p, int s)
{
    double thr = p->opts.loads.map_threshold;
    if (!(thr > 0.0))
        return 0;
    for (int k = 0; k < p->ld_sum.nstations; k++)
        if (p->ld_sum_station[k] == s)
            return p->ld_sum.st[k].load > thr;
    return 0;
}
