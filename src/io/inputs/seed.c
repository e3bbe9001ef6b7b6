/* Particle seeding: see io/seed.h. */
#include "io/seed.h"
#include "raster_impl.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void seed_options_default(seed_options *o)
{
    memset(o, 0, sizeof *o);
    o->threshold = 0.05;
    o->sml_factor = 1.0;
    o->rho_ice = 900.0;
}

static const seed_options *options_or_default(const seed_options *o, seed_options *def)
{
    if (o)
        return o;
    seed_options_default(def);
    return def;
}

static int check_options(const ice_raster *r, const seed_options *o, sph_error *err)
{
    if (!(o->threshold >= 0 && o->threshold < 1))
        return sph_err_set(err, SPH_ERR_CONFIG, "seeding: threshold %g outside 0..1", o->threshold);
    if (!(o->spacing_m >= 0) || !(o->sml_factor > 0) || !(o->rho_ice > 0))
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "seeding: spacing %g m, sml_factor %g, rho_ice %g must be positive",
                           o->spacing_m, o->sml_factor, o->rho_ice);
    if (!r || r->nlon < 1 || r->nlat < 1)
        return sph_err_set(err, SPH_ERR_PARAM, "seeding: empty raster");
    if (o->cell_n < 0 || o->cell_n > SEED_MAX_CELL_N)
        return sph_err_set(err, SPH_ERR_CONFIG, "seeding: %d x %d particles per cell outside 0..%d",
                           o->cell_n, o->cell_n, SEED_MAX_CELL_N);
    return SPH_OK;
}

typedef struct {
    double lon, lat, conc, thick, area;
} seed_point;

/* Calls `emit` for every particle in a deterministic order; returns the
 * count. `emit` NULL only counts. */
typedef int (*emit_fn)(void *ctx, const seed_point *s);

static int is_sea(const landmask *mask, double lon, double lat)
{
    return !mask || landmask_is_land(mask, lon, lat) != 1;
}

/* Sub-cell (a, b) of n x n of cell (i, j): its centre, at the fractions
 * (a + 1/2) / n, (b + 1/2) / n of the cell in the raster's own
 * coordinates (lon/lat, or x/y unprojected by PROJ); on a curvilinear
 * grid interpolated bilinearly (as unit vectors) between the surrounding
 * centres. n = 1: the cell's centre. 0 when it has no position. */
static int sub_lonlat(const ice_raster *r, int i, int j, int n, int a, int b, double *lon, double *lat)
{
    if (n <= 1) {
        ice_raster_cell_lonlat(r, i, j, lon, lat);
        return isfinite(*lon) && isfinite(*lat);
    }
    double f = (a + 0.5) / n - 0.5, g = (b + 0.5) / n - 0.5;
    if (r->kind == ICE_RASTER_LONLAT) {
        *lon = r->lon[i] + f * r->dlon;
        *lat = r->lat[j] + g * r->dlat;
        return 1;
    }
    if (r->kind == ICE_RASTER_PROJECTED)
        return raster_crs_inverse(r->crs, r->x[i] + f * r->dx, r->y[j] + g * r->dy, lon, lat);
    /* curvilinear: between the two nearest centres along each index */
    int i0 = f >= 0 ? i : i - 1, j0 = g >= 0 ? j : j - 1;
    if (i0 + 1 >= r->nlon) i0 = r->nlon - 2;
    if (j0 + 1 >= r->nlat) j0 = r->nlat - 2;
    if (i0 < 0) i0 = 0;
    if (j0 < 0) j0 = 0;
    double t = r->nlon > 1 ? i + f - i0 : 0, u = r->nlat > 1 ? j + g - j0 : 0, v[3] = {0, 0, 0};
    const double deg = M_PI / 180.0;
    for (int q = 0; q < 4; q++) {
        int ii = i0 + (q & 1), jj = j0 + (q >> 1);
        if (ii >= r->nlon) ii = r->nlon - 1;
        if (jj >= r->nlat) jj = r->nlat - 1;
        double w = ((q & 1) ? t : 1 - t) * ((q >> 1) ? u : 1 - u), clon, clat;
        ice_raster_cell_lonlat(r, ii, jj, &clon, &clat);
        if (!isfinite(clon) || !isfinite(clat)) {
            ice_raster_cell_lonlat(r, i, j, lon, lat); /* no neighbour: the centre */
            return isfinite(*lon) && isfinite(*lat);
        }
        v[0] += w * cos(clat * deg) * cos(clon * deg);
        v[1] += w * cos(clat * deg) * sin(clon * deg);
        v[2] += w * sin(clat * deg);
    }
    *lon = atan2(v[1], v[0]) / deg;
    *lat = atan2(v[2], hypot(v[0], v[1])) / deg;
    return 1;
}

/* 1 where the model's plane land (o->plane_land) holds (x, y). */
static int plane_is_land(const seed_options *o, double x, double y)
{
    if (!o->plane_land)
        return 0;
    long i = (long)floor((x - o->plane_x0) / o->plane_dx), j = (long)floor((y - o->plane_y0) / o->plane_dy);
    return i >= 0 && j >= 0 && i < o->plane_nx && j < o->plane_ny && o->plane_land[(size_t)j * o->plane_nx + i];
}

/* The same for a point given in lon/lat (projected with p; no p or a point
 * that does not project: not land by the plane). */
static int lonlat_plane_land(const seed_options *o, const geo_proj *p, double lon, double lat)
{
    double x, y;
    if (!o->plane_land || !p || geo_forward(p, 1, &lon, &lat, &x, &y, NULL) != SPH_OK)
        return 0;
    return plane_is_land(o, x, y);
}

/* Per cell (spacing_m == 0): cell_n x cell_n particles (at least one) per
 * cell above the threshold, each with the cell's concentration and
 * thickness and 1 / cell_n^2 of its area; a sub-cell whose centre is land
 * (mask) is left out. */
static int walk_cells(const ice_raster *r, const geo_proj *p, const landmask *mask, const seed_options *o,
                      emit_fn emit, void *ctx, size_t *count)
{
    *count = 0;
    const int n = o->cell_n > 1 ? o->cell_n : 1;
    for (int j = 0; j < r->nlat; j++) {
        for (int i = 0; i < r->nlon; i++) {
            size_t k = (size_t)j * r->nlon + i;
            double c = r->conc[k], lon, lat;
            if (!(c > o->threshold) || !(r->thick[k] > 0))
                continue;
            double a = ice_raster_area(r, i, j) / ((double)n * n);
            for (int b = 0; b < n; b++)
                for (int q = 0; q < n; q++) {
                    if (!sub_lonlat(r, i, j, n, q, b, &lon, &lat) || !is_sea(mask, lon, lat) ||
                        lonlat_plane_land(o, p, lon, lat))
                        continue;
                    seed_point s = {lon, lat, c, r->thick[k], a};
                    if (emit) {
                        int rc = emit(ctx, &s);
                        if (rc != SPH_OK)
                            return rc;
                    }
                    (*count)++;
                }
        }
    }
    return SPH_OK;
}

/* Plane lattice bounds: the projected corners and edge midpoints of the
 * raster (enough for the small regional domains sphice runs on). */
static int lattice_bounds(const ice_raster *r, const geo_proj *p, const seed_options *o,
                          double b[4], sph_error *err)
{
    if (o->xmin != 0 || o->xmax != 0 || o->ymin != 0 || o->ymax != 0) {
        b[0] = o->xmin, b[1] = o->xmax, b[2] = o->ymin, b[3] = o->ymax;
        return SPH_OK;
    }
    if (r->kind != ICE_RASTER_LONLAT) {
        /* every cell centre, widened by the largest half cell */
        size_t n = (size_t)r->nlon * r->nlat;
        double *xy = malloc(sizeof(double) * 2 * n), half = 0;
        if (!xy)
            return sph_err_set(err, SPH_ERR_NOMEM, "seeding: out of memory");
        int rc = geo_forward(p, n, r->cell_lon, r->cell_lat, xy, xy + n, err);
        b[0] = b[2] = INFINITY;
        b[1] = b[3] = -INFINITY;
        for (size_t k = 0; rc == SPH_OK && k < n; k++) {
            b[0] = fmin(b[0], xy[k]), b[1] = fmax(b[1], xy[k]);
            b[2] = fmin(b[2], xy[n + k]), b[3] = fmax(b[3], xy[n + k]);
            half = fmax(half, sqrt(r->area[k]) / 2);
        }
        free(xy);
        b[0] -= half, b[1] += half, b[2] -= half, b[3] += half;
        return rc;
    }
    enum { NS = 9 };
    double lon[4 * NS], lat[4 * NS], x[4 * NS], y[4 * NS];
    double w = r->lon[0] - r->dlon / 2, e = r->lon[r->nlon - 1] + r->dlon / 2;
    double s = r->lat[0] - r->dlat / 2, n = r->lat[r->nlat - 1] + r->dlat / 2;
    for (int k = 0; k < NS; k++) {
        double f = k / (double)(NS - 1);
        lon[k] = w + f * (e - w), lat[k] = s;
        lon[NS + k] = w + f * (e - w), lat[NS + k] = n;
        lon[2 * NS + k] = w, lat[2 * NS + k] = s + f * (n - s);
        lon[3 * NS + k] = e, lat[3 * NS + k] = s + f * (n - s);
    }
    int rc = geo_forward(p, 4 * NS, lon, lat, x, y, err);
    if (rc != SPH_OK)
        return rc;
    b[0] = b[2] = INFINITY;
    b[1] = b[3] = -INFINITY;
    for (int k = 0; k < 4 * NS; k++) {
        b[0] = fmin(b[0], x[k]), b[1] = fmax(b[1], x[k]);
        b[2] = fmin(b[2], y[k]), b[3] = fmax(b[3], y[k]);
    }
    return SPH_OK;
}

/* A shallow copy of r for the lattice's sampling: one more row and
 * column of centres on every side repeating the edge cells, so that a
 * point in the outer half of an edge cell (beyond the centres' hull, still
 * inside the raster) takes that cell's values; thick holds the ice volume
 * per cell area (conc * thick), so that ice_raster_sample gives
 * sum w A h / sum w beside sum w A / sum w, and their ratio is a thickness
 * that open-water corners (A = 0) do not dilute. Free with free(q->conc). */
static int sample_raster(const ice_raster *r, ice_raster *q, sph_error *err)
{
    const int nx = r->nlon + 2, ny = r->nlat + 2;
    size_t n = (size_t)nx * ny;
    *q = *r;
    q->nlon = nx, q->nlat = ny;
    q->cell_lon = q->cell_lat = q->area = NULL;
    q->land = NULL;
    double *buf = malloc(sizeof(double) * (2 * n + (size_t)nx + (size_t)ny));
    if (!buf)
        return sph_err_set(err, SPH_ERR_NOMEM, "seeding: out of memory");
    q->conc = buf, q->thick = buf + n;
    double *cx = buf + 2 * n, *cy = cx + nx;
    const double *rx = r->kind == ICE_RASTER_LONLAT ? r->lon : r->x;
    const double *ry = r->kind == ICE_RASTER_LONLAT ? r->lat : r->y;
    double ddx = r->kind == ICE_RASTER_LONLAT ? r->dlon : r->dx;
    double ddy = r->kind == ICE_RASTER_LONLAT ? r->dlat : r->dy;
    for (int i = 0; i < nx; i++)
        cx[i] = rx[0] + (i - 1) * ddx;
    for (int j = 0; j < ny; j++)
        cy[j] = ry[0] + (j - 1) * ddy;
    if (r->kind == ICE_RASTER_LONLAT)
        q->lon = cx, q->lat = cy;
    else
        q->x = cx, q->y = cy;
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            int si = i < 1 ? 0 : i > r->nlon ? r->nlon - 1 : i - 1;
            int sj = j < 1 ? 0 : j > r->nlat ? r->nlat - 1 : j - 1;
            size_t k = (size_t)sj * r->nlon + si, kq = (size_t)j * nx + i;
            q->conc[kq] = r->conc[k];
            q->thick[kq] = r->conc[k] > 0 && r->thick[k] > 0 ? r->conc[k] * r->thick[k] : 0.0;
        }
    return SPH_OK;
}

/* 1 when (lon, lat) lies inside r's cells (its centres' hull widened by
 * half a cell), in r's own coordinates. */
static int inside_raster(const ice_raster *r, double lon, double lat)
{
    double x = lon, y = lat;
    const double *rx = r->lon, *ry = r->lat;
    double hx = r->dlon / 2, hy = r->dlat / 2;
    if (r->kind == ICE_RASTER_PROJECTED) {
        if (!raster_crs_forward(r->crs, lon, lat, &x, &y))
            return 0;
        rx = r->x, ry = r->y, hx = r->dx / 2, hy = r->dy / 2;
    }
    return x >= rx[0] - hx && x <= rx[r->nlon - 1] + hx && y >= ry[0] - hy && y <= ry[r->nlat - 1] + hy;
}

/* 1 when (lon, lat) lies in a cell the raster flags as land (ice_raster.land 1). */
static int raster_flags_land(const ice_raster *r, double lon, double lat)
{
    if (!r->land)
        return 0;
    double x = lon, y = lat, x0 = r->kind == ICE_RASTER_LONLAT ? r->lon[0] : r->x[0];
    double y0 = r->kind == ICE_RASTER_LONLAT ? r->lat[0] : r->y[0];
    double dx = r->kind == ICE_RASTER_LONLAT ? r->dlon : r->dx, dy = r->kind == ICE_RASTER_LONLAT ? r->dlat : r->dy;
    if (r->kind == ICE_RASTER_PROJECTED && !raster_crs_forward(r->crs, lon, lat, &x, &y))
        return 0;
    double fi = floor((x - x0) / dx + 0.5), fj = floor((y - y0) / dy + 0.5);
    if (!(fi >= 0 && fj >= 0 && fi < r->nlon && fj < r->nlat))
        return 0;
    return r->land[(size_t)fj * r->nlon + (size_t)fi] == 1;
}

static int walk_lattice(const ice_raster *r, const geo_proj *p, const landmask *mask,
                        const seed_options *o, emit_fn emit, void *ctx, size_t *count,
                        double box[4], sph_error *err)
{
    *count = 0;
    if (!ice_raster_can_sample(r))
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "seeding %s: initial.spacing: a lattice cannot be sampled on this "
                           "raster's grid (%s); set initial.spacing to 0 (a particle per cell)",
                           r->path, r->grid);
    double b[4] = {0, 0, 0, 0};
    int rc = lattice_bounds(r, p, o, b, err);
    if (rc != SPH_OK)
        return rc;
    const double d = o->spacing_m;
    long i0 = (long)ceil(b[0] / d - 0.5), i1 = (long)floor(b[1] / d - 0.5);
    long j0 = (long)ceil(b[2] / d - 0.5), j1 = (long)floor(b[3] / d - 0.5);
    if (box) { /* the plane area the lattice's footprints tile, within the bounds */
        box[0] = fmax(b[0], (double)i0 * d), box[1] = fmin(b[1], (double)(i1 + 1) * d);
        box[2] = fmax(b[2], (double)j0 * d), box[3] = fmin(b[3], (double)(j1 + 1) * d);
    }
    if (i1 < i0 || j1 < j0)
        return SPH_OK;
    if ((double)(i1 - i0 + 1) * (double)(j1 - j0 + 1) > 1e9)
        return sph_err_set(err, SPH_ERR_CONFIG, "seeding: spacing %g m gives over 1e9 lattice points", d);
    ice_raster vol;
    if ((rc = sample_raster(r, &vol, err)) != SPH_OK)
        return rc;
    size_t nx = (size_t)(i1 - i0 + 1);
    double *x = malloc(sizeof(double) * nx * 4);
    if (!x) {
        free(vol.conc);
        return sph_err_set(err, SPH_ERR_NOMEM, "seeding: out of memory");
    }
    double *y = x + nx, *lon = y + nx, *lat = lon + nx;
    for (long j = j0; j <= j1 && rc == SPH_OK; j++) {
        for (size_t i = 0; i < nx; i++) {
            x[i] = ((double)(i0 + (long)i) + 0.5) * d;
            y[i] = ((double)j + 0.5) * d;
        }
        geo_inverse(p, nx, x, y, lon, lat, NULL); /* NaN where it fails: skipped */
        for (size_t i = 0; i < nx && rc == SPH_OK; i++) {
            seed_point s = {lon[i], lat[i], 0, 0, d * d};
            double ah;
            if (!isfinite(lon[i]) || !inside_raster(r, lon[i], lat[i]) ||
                !ice_raster_sample(&vol, lon[i], lat[i], &s.conc, &ah))
                continue;
            if (!(s.conc > o->threshold) || !(ah > 0) || !is_sea(mask, lon[i], lat[i]) ||
                raster_flags_land(r, lon[i], lat[i]) || plane_is_land(o, x[i], y[i]))
                continue;
            s.thick = ah / s.conc; /* thickness of the ice, not of ice and water */
            if (emit)
                rc = emit(ctx, &s);
            (*count)++;
        }
    }
    free(x);
    free(vol.conc);
    return rc;
}

int seed_raster_totals(const ice_raster *r, const geo_proj *p, const landmask *mask,
                       const seed_options *o, const double box[4], double *area,
                       double *volume, sph_error *err)
{
    *area = *volume = 0;
    seed_options def;
    o = options_or_default(o, &def);
    int rc = check_options(r, o, err);
    if (rc != SPH_OK)
        return rc;
    for (int j = 0; j < r->nlat; j++)
        for (int i = 0; i < r->nlon; i++) {
            size_t k = (size_t)j * r->nlon + i;
            double c = r->conc[k], lon, lat;
            if (!(c > o->threshold) || !(r->thick[k] > 0))
                continue;
            /* the lattice: by the cell's centre, or, for a cell more than
             * twice the lattice spacing across, by the fraction of it inside
             * the box (a coarse cell at the box's edge is partly sampled,
             * and the centre alone would count it whole or not at all);
             * per cell: by its sub-cells' */
            int sub = o->spacing_m > 0 || o->cell_n <= 1 ? 1 : o->cell_n, in = 0;
            if (o->spacing_m > 0 && box) {
                double size = sqrt(ice_raster_area(r, i, j));
                if (size > 2.0 * o->spacing_m)
                    sub = (int)fmin(16.0, ceil(size / o->spacing_m));
            }
            for (int b = 0; b < sub; b++)
                for (int q = 0; q < sub; q++) {
                    if (!sub_lonlat(r, i, j, sub, q, b, &lon, &lat) || !is_sea(mask, lon, lat) ||
                        lonlat_plane_land(o, p, lon, lat))
                        continue;
                    if (box) {
                        double x, y;
                        if (!p || geo_forward(p, 1, &lon, &lat, &x, &y, NULL) != SPH_OK ||
                            !(x >= box[0] && x < box[1] && y >= box[2] && y < box[3]))
                            continue;
                    }
                    in++;
                }
            if (!in)
                continue;
            double a = ice_raster_area(r, i, j) * (in / ((double)sub * sub));
            *area += c * a;
            *volume += c * r->thick[k] * a;
        }
    return SPH_OK;
}

int seed_count(const ice_raster *r, const geo_proj *p, const landmask *mask,
               const seed_options *o, size_t *count, sph_error *err)
{
    seed_options def;
    o = options_or_default(o, &def);
    int rc = check_options(r, o, err);
    if (rc != SPH_OK)
        return rc;
    if (o->spacing_m > 0)
        return walk_lattice(r, p, mask, o, NULL, NULL, count, NULL, err);
    return walk_cells(r, p, mask, o, NULL, NULL, count);
}

typedef struct {
    sph_particles *P;
    const geo_proj *p;
    const seed_options *o;
    sph_error *err;
} emit_ctx;

static int emit_particle(void *vctx, const seed_point *s)
{
    emit_ctx *c = vctx;
    sph_particles *P = c->P;
    size_t k = P->n;
    double x, y;
    int rc = geo_forward(c->p, 1, &s->lon, &s->lat, &x, &y, c->err);
    if (rc != SPH_OK)
        return rc;
    P->x[k] = x;
    P->y[k] = y;
    P->lat[k] = s->lat;
    P->u[k] = P->v[k] = 0;
    P->conc[k] = s->conc;
    P->thick[k] = s->thick;
    P->mass[k] = c->o->rho_ice * s->conc * s->thick * s->area;
    P->sml[k] = c->o->sml_factor * sqrt(s->area);
    P->id[k] = c->o->first_id + (long)k;
    P->n = k + 1;
    return SPH_OK;
}

int seed_from_raster_totals(const ice_raster *r, const geo_proj *p, const landmask *mask,
                            const seed_options *o, sph_particles *P, seed_totals *tot,
                            sph_error *err)
{
    seed_options def;
    o = options_or_default(o, &def);
    seed_totals t;
    memset(&t, 0, sizeof t);
    size_t need;
    int rc = seed_count(r, p, mask, o, &need, err);
    if (rc != SPH_OK)
        return rc;
    if (!p)
        return sph_err_set(err, SPH_ERR_PARAM, "seeding %s: no projection", r->path);
    if (need > P->cap - P->n)
        return sph_err_set(err, SPH_ERR_PARAM,
                           "seeding %s: %zu particles needed but only %zu of %zu free", r->path,
                           need, P->cap - P->n, P->cap);
    size_t n0 = P->n, got;
    /* ids count from first_id for this call's first particle */
    seed_options local = *o;
    local.first_id = o->first_id - (long)n0;
    emit_ctx c = {P, p, &local, err};
    double box[4] = {0, 0, 0, 0};
    if (o->spacing_m > 0)
        rc = walk_lattice(r, p, mask, o, emit_particle, &c, &got, box, err);
    else
        rc = walk_cells(r, p, mask, o, emit_particle, &c, &got);
    if (rc == SPH_OK)
        rc = seed_raster_totals(r, p, mask, o, o->spacing_m > 0 ? box : NULL, &t.raster_area_m2,
                                &t.raster_volume_m3, err);
    if (rc != SPH_OK) {
        P->n = n0;
        return rc;
    }
    for (size_t k = n0; k < P->n; k++) {
        t.raw_volume_m3 += P->mass[k] / o->rho_ice;
        t.raw_area_m2 += P->mass[k] / (o->rho_ice * P->thick[k]);
    }
    /* the lattice's footprints are plane areas and its edge is sampled:
     * scale its area and volume to the raster's over the same region */
    double fa = t.raster_area_m2 / t.raw_area_m2, fv = t.raster_volume_m3 / t.raw_volume_m3;
    if (o->spacing_m > 0 && isfinite(fa) && isfinite(fv) && fa > 0 && fv > 0) {
        t.rescaled = 1;
        for (size_t k = n0; k < P->n; k++) {
            P->mass[k] *= fv;
            P->thick[k] *= fv / fa;
        }
    }
    for (size_t k = n0; k < P->n; k++) {
        t.seeded_volume_m3 += P->mass[k] / o->rho_ice;
        t.seeded_area_m2 += P->mass[k] / (o->rho_ice * P->thick[k]);
    }
    t.n = P->n - n0;
    if (tot)
        *tot = t;
    return SPH_OK;
}

int seed_from_raster(const ice_raster *r, const geo_proj *p, const landmask *mask,
                     const seed_options *o, sph_particles *P, sph_error *err)
{
    return seed_from_raster_totals(r, p, mask, o, P, NULL, err);
}
