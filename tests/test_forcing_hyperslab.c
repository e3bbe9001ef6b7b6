/* Read windows (issue 19 item 10, docs/forcing.md "Large files"): a source
 * opened with a read window (forcing_source_spec.window, margin_km) reads
 * only the hyperslab of each grid that covers the domain plus the margin.
 * For three grids a regional domain is sampled through the window and
 * through a whole-file read of the same file; the values must be equal bit
 * for bit at many points (inside the domain and margin, across the seam of
 * a global grid, and near the window's edge, where a point is either
 * sampled exactly as the whole file would or refused as outside the read
 * window), and the bytes the reader holds must follow the window:
 *
 *  - a global regular file shaped like the CMEMS global analysis
 *    (GLOBAL_ANALYSISFORECAST_PHY_001_024: dimensions time, depth,
 *    latitude, longitude; float uo/vo with _FillValue, standard names
 *    eastward/northward_sea_water_velocity, "hours since 1950-01-01",
 *    longitude -180 .. 180 - step, latitude -80 .. 90, chunked and
 *    deflated) at 1/2 degree instead of 1/12 to stay fast, with zos for
 *    the SSH gradient, and a domain across the 180th meridian;
 *  - an NSIDC-style polar stereographic 25 km grid (x/y in m, grid_mapping
 *    polar_stereographic, no latitude/longitude in the file) with
 *    grid-relative currents;
 *  - a curvilinear grid with 2-D latitude/longitude and an angle variable.
 * Fields are analytic and have land (fill) patches, so the nearest-valid
 * fallback and one-sided gradients are exercised inside the window too.
 */
#include "check.h"
#include "io/forcing.h"
#include "io/geo.h"
#include "service/check.h"
#include "service/config.h"
#include "service/coupling.h"
#include "service/forecast.h"
#include "core/particles.h"
#include "util/err.h"
#include "cmems_nc.h"

#include <math.h>
#include <netcdf.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define NCW(call)                                                                            \
    do {                                                                                     \
        int rc_ = (call);                                                                    \
        if (rc_ != NC_NOERR) {                                                               \
            fprintf(stderr, "%s:%d: %s: %s\n", __FILE__, __LINE__, #call, nc_strerror(rc_)); \
            exit(2);                                                                         \
        }                                                                                    \
    } while (0)

#define DEG (M_PI / 180.0)
#define T0 1700006400.0      /* 2023-11-15T00:00:00Z */
#define NT 3                 /* 6-hourly */
#define FILL CMEMS_FILL
#define KM_PER_DEG 111.19492664455873 /* 6371 km sphere */

enum { REGULAR = 0, PROJECTED, CURVILINEAR };

/* Analytic fields with land: fill where the "land" function is positive (islands of
 * one or two nodes, so a valid node is always within the stencil's reach). */
static double land(double a, double b)
{
    return sin(a * 1.7) * cos(b * 1.3) - 0.97;
}

static float field(int q, double a, double b, size_t k)
{
    if (land(a, b) > 0)
        return FILL;
    double t = (double)k;
    switch (q) {
    case 0: return (float)(0.4 * sin(a * 0.07 + t) * cos(b * 0.05) + 0.05 * t);
    case 1: return (float)(0.3 * cos(a * 0.05 - t) * sin(b * 0.09 + 0.2));
    default: return (float)(0.8 * sin(a * 0.04) * sin(b * 0.06 + t) + 0.1);
    }
}

typedef struct shape {
    int kind;
    size_t nx, ny;
    /* regular */
    double lon0, dlon, lat0, dlat; /* dlat < 0: latitudes descending (ERA5) */
    int swap;                      /* data dimensions (..., longitude, latitude) */
    /* projected */
    double x0, dx, y0, dy;
    /* curvilinear */
    double clon, clat, step, rot;
} shape;

static void curv_node(const shape *s, size_t i, size_t j, double *lon, double *lat)
{
    double a = s->rot * DEG;
    double x = ((double)i - (double)(s->nx - 1) / 2) * s->step;
    double y = ((double)j - (double)(s->ny - 1) / 2) * s->step;
    double E = x * cos(a) - y * sin(a), N = x * sin(a) + y * cos(a);
    *lat = s->clat + N;
    *lon = s->clon + E / cos(*lat * DEG);
}

static const char *const proj_y_atts[] = {"standard_name", "projection_y_coordinate", "units", "m",
                                          "axis", "Y", NULL};
static const char *const proj_x_atts[] = {"standard_name", "projection_x_coordinate", "units", "m",
                                          "axis", "X", NULL};
static const char *const lat2_atts[] = {"standard_name", "latitude", "units", "degrees_north", NULL};
static const char *const lon2_atts[] = {"standard_name", "longitude", "units", "degrees_east", NULL};
static const char *const angle_atts[] = {"long_name", "angle between XI-axis and EAST", "units",
                                         "radians", NULL};

/* NSIDC polar stereographic north (Hughes 1980 ellipsoid, true at 70 N) */
static void def_crs(int nc)
{
    static const char *const atts[] = {"grid_mapping_name", "polar_stereographic", NULL};
    static const struct { const char *name; double v; } num[] = {
        {"latitude_of_projection_origin", 90}, {"standard_parallel", 70},
        {"straight_vertical_longitude_from_pole", -45}, {"false_easting", 0}, {"false_northing", 0},
        {"semi_major_axis", 6378273.0}, {"inverse_flattening", 298.279411123064}};
    int crs = cmems_var(nc, "crs", NC_INT, 0, NULL, atts);
    for (size_t k = 0; k < sizeof num / sizeof num[0]; k++)
        NCW(nc_put_att_double(nc, crs, num[k].name, NC_DOUBLE, 1, &num[k].v));
}

static void write_file(const char *path, const shape *s)
{
    int nc, d[4] = {-1, -1, -1, -1}, c[4] = {-1, -1, -1, -1}, lat2 = -1, lon2 = -1, ang = -1;
    NCW(nc_create(path, NC_CLOBBER | NC_NETCDF4, &nc));
    if (s->kind == REGULAR) {
        cmems_coords(nc, NT, s->ny, s->nx, d, c);
    } else {
        NCW(nc_def_dim(nc, "time", NT, &d[0]));
        NCW(nc_def_dim(nc, "y", s->ny, &d[2]));
        NCW(nc_def_dim(nc, "x", s->nx, &d[3]));
        c[0] = cmems_var(nc, "time", NC_FLOAT, 1, &d[0], cmems_time_atts);
    }
    if (s->kind == PROJECTED) {
        c[2] = cmems_var(nc, "y", NC_DOUBLE, 1, &d[2], proj_y_atts);
        c[3] = cmems_var(nc, "x", NC_DOUBLE, 1, &d[3], proj_x_atts);
        def_crs(nc);
    } else if (s->kind == CURVILINEAR) {
        lat2 = cmems_var(nc, "lat", NC_DOUBLE, 2, &d[2], lat2_atts);
        lon2 = cmems_var(nc, "lon", NC_DOUBLE, 2, &d[2], lon2_atts);
        ang = cmems_var(nc, "angle", NC_DOUBLE, 2, &d[2], angle_atts);
    }
    static const char *const names[3] = {"uo", "vo", "zos"};
    const char *std[3] = {"eastward_sea_water_velocity", "northward_sea_water_velocity",
                          "sea_surface_height_above_geoid"};
    if (s->kind != REGULAR) {
        std[0] = "sea_water_x_velocity";
        std[1] = "sea_water_y_velocity";
    }
    int vv[3];
    for (int q = 0; q < 3; q++) {
        int dims[4], nd = 0;
        dims[nd++] = d[0];
        if (s->kind == REGULAR && q < 2)
            dims[nd++] = d[1];
        dims[nd++] = d[s->swap ? 3 : 2];
        dims[nd++] = d[s->swap ? 2 : 3];
        size_t ch[4] = {1, 1, 1, 1};
        ch[nd - 2] = s->ny < 64 ? s->ny : 64;
        ch[nd - 1] = s->nx < 128 ? s->nx : 128;
        if (s->swap) {
            ch[nd - 2] = s->nx < 128 ? s->nx : 128;
            ch[nd - 1] = s->ny < 64 ? s->ny : 64;
        }
        const char *atts[9] = {"standard_name", std[q], "units", q < 2 ? "m s-1" : "m", NULL, NULL,
                               NULL, NULL, NULL};
        if (s->kind == PROJECTED)
            atts[4] = "grid_mapping", atts[5] = "crs";
        if (s->kind == CURVILINEAR)
            atts[4] = "coordinates", atts[5] = "lon lat";
        vv[q] = cmems_data(nc, names[q], nd, dims, ch, atts);
    }
    NCW(nc_enddef(nc));
    size_t n = s->nx * s->ny;
    double *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
    float *buf = malloc(n * sizeof *buf);
    if (s->kind == REGULAR) {
        cmems_coord_values(nc, c, NT, T0 / 3600.0 + CMEMS_H1970, s->ny, s->lat0, s->nx, s->lon0,
                           s->dlon);
        for (size_t j = 0; j < s->ny; j++)
            buf[j] = (float)(s->lat0 + (double)j * s->dlat);
        NCW(nc_put_var_float(nc, c[2], buf));
    } else {
        for (size_t k = 0; k < NT; k++)
            buf[k] = (float)(T0 / 3600.0 + CMEMS_H1970 + 6.0 * (double)k);
        NCW(nc_put_var_float(nc, c[0], buf));
    }
    if (s->kind == PROJECTED) {
        for (size_t j = 0; j < s->ny; j++)
            a[j] = s->y0 + (double)j * s->dy;
        NCW(nc_put_var_double(nc, c[2], a));
        for (size_t i = 0; i < s->nx; i++)
            a[i] = s->x0 + (double)i * s->dx;
        NCW(nc_put_var_double(nc, c[3], a));
    } else if (s->kind == CURVILINEAR) {
        double *an = malloc(n * sizeof *an);
        for (size_t j = 0; j < s->ny; j++)
            for (size_t i = 0; i < s->nx; i++) {
                curv_node(s, i, j, &a[j * s->nx + i], &b[j * s->nx + i]);
                an[j * s->nx + i] = s->rot * DEG;
            }
        NCW(nc_put_var_double(nc, lon2, a));
        NCW(nc_put_var_double(nc, lat2, b));
        NCW(nc_put_var_double(nc, ang, an));
        free(an);
    }
    for (size_t k = 0; k < NT; k++)
        for (int q = 0; q < 3; q++) {
            for (size_t j = 0; j < s->ny; j++)
                for (size_t i = 0; i < s->nx; i++)
                    buf[s->swap ? i * s->ny + j : j * s->nx + i] = field(q, (double)i, (double)j, k);
            size_t start[4] = {k, 0, 0, 0}, count[4] = {1, 1, s->ny, s->nx};
            if (s->swap)
                count[2] = s->nx, count[3] = s->ny;
            if (!(s->kind == REGULAR && q < 2)) {
                count[1] = count[2];
                count[2] = count[3];
            }
            NCW(nc_put_vara_float(nc, vv[q], start, count, buf));
        }
    free(a);
    free(b);
    free(buf);
    NCW(nc_close(nc));
}

static int open_one(forcing **f, const char *path, const double box[4], int window,
                    double margin_km, sph_error *e)
{
    const char *files[1] = {path};
    forcing_source_spec sp = cmems_spec(files, FQ_CURRENT | FQ_SSH, window, margin_km);
    sph_error_clear(e);
    return forcing_open(f, &sp, 1, T0, T0 + 12 * 3600.0, box[0], box[1], box[2], box[3], e);
}

/* Samples currents, SSH and its gradient at n points. */
typedef struct vals {
    double *q[5];
} vals;

static int sample(forcing *f, double t, size_t n, const double *lon, const double *lat, vals *v,
                  sph_error *e)
{
    forcing_sample s;
    memset(&s, 0, sizeof s);
    s.uw_east = v->q[0];
    s.vw_north = v->q[1];
    s.ssh = v->q[2];
    s.ssh_dx_east = v->q[3];
    s.ssh_dy_north = v->q[4];
    for (int k = 0; k < 5; k++)
        memset(v->q[k], 0, n * sizeof(double));
    sph_error_clear(e);
    return forcing_sample_at(f, t, n, lon, lat, &s, e);
}

static void vals_alloc(vals *v, size_t n)
{
    for (int k = 0; k < 5; k++)
        v->q[k] = calloc(n, sizeof(double));
}

static void vals_free(vals *v)
{
    for (int k = 0; k < 5; k++)
        free(v->q[k]);
}

static uint64_t rng = 88172645463325252ull;
static double urand(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return (double)(rng >> 11) / 9007199254740992.0;
}

/* The box plus margin in degrees (as docs/forcing.md gives it). */
static void margin_box(const double box[4], double margin_km, double out[4])
{
    double dlat = margin_km / KM_PER_DEG;
    double phi = fmax(fabs(box[2] - dlat), fabs(box[3] + dlat));
    double dlon = dlat / cos(phi * DEG);
    out[0] = box[0] - dlon;
    out[1] = box[1] + dlon;
    out[2] = box[2] - dlat;
    out[3] = box[3] + dlat;
}

static int bits_equal(double a, double b)
{
    return memcmp(&a, &b, sizeof a) == 0;
}

typedef struct kase {
    const char *name;
    shape s;
    double box[4];
    double margin_km;
    double seam;       /* regular global grid: the meridian where its columns wrap */
    /* window cells expected from the box, the margin and the spacing (test's own
     * arithmetic): an upper bound on the window's nodes */
    double cells_max;
} kase;

static void run_case(const char *dir, const kase *c)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s.nc", dir, c->name);
    write_file(path, &c->s);
    forcing *fw = NULL, *ff = NULL;
    sph_error e;
    int rc = open_one(&fw, path, c->box, 1, c->margin_km, &e);
    CHECK(rc == 0, "%s: open with a read window: %s", c->name, e.msg);
    rc = open_one(&ff, path, c->box, 0, 0, &e);
    CHECK(rc == 0, "%s: open whole: %s", c->name, e.msg);
    if (!fw || !ff) {
        forcing_close(fw);
        forcing_close(ff);
        return;
    }
    double mb[4];
    margin_box(c->box, c->margin_km, mb);

    /* 1. points inside the domain plus margin: all sampled, equal bit for bit, at a
     * time between two file times (both slices) and on one */
    const size_t n = 4000;
    double *lon = malloc(n * sizeof *lon), *lat = malloc(n * sizeof *lat);
    for (size_t p = 0; p < n; p++) {
        lon[p] = mb[0] + (mb[1] - mb[0]) * urand();
        lat[p] = mb[2] + (mb[3] - mb[2]) * urand();
    }
    if (c->s.kind == REGULAR && c->box[0] < c->seam && c->box[1] > c->seam) {
        /* across the seam: its nodes, between them, and on it (given either way) */
        static const double seam[] = {-0.5, -0.25, -0.000001, 0.0, 0.000001, 0.25, 0.5, -360.0,
                                      -359.75, -0.1, 360.0, 359.9};
        for (size_t k = 0; k < sizeof seam / sizeof seam[0]; k++) {
            lon[k] = c->seam + seam[k];
            lat[k] = 0.5 * (c->box[2] + c->box[3]) + 0.31 * (double)k;
        }
    }
    vals a, b;
    vals_alloc(&a, n);
    vals_alloc(&b, n);
    static const double tt[] = {T0 + 2.5 * 3600.0, T0 + 6 * 3600.0, T0 + 10 * 3600.0};
    for (size_t it = 0; it < sizeof tt / sizeof tt[0]; it++) {
        int ra = sample(fw, tt[it], n, lon, lat, &a, &e);
        CHECK(ra == 0, "%s: window sample: %s", c->name, e.msg);
        int rb = sample(ff, tt[it], n, lon, lat, &b, &e);
        CHECK(rb == 0, "%s: whole sample: %s", c->name, e.msg);
        size_t diff = 0, finite = 0;
        for (int q = 0; q < 5; q++)
            for (size_t p = 0; p < n; p++) {
                diff += !bits_equal(a.q[q][p], b.q[q][p]);
                finite += isfinite(a.q[q][p]) && a.q[q][p] != 0;
            }
        CHECK(ra == 0 && rb == 0 && diff == 0, "%s: %zu of %zu values differ from the whole file's",
              c->name, diff, 5 * n);
        if (diff)
            fprintf(stderr, "  e.g. %.17g %.17g | %.17g %.17g | %.17g %.17g\n", a.q[0][0], b.q[0][0],
                    a.q[2][0], b.q[2][0], a.q[3][0], b.q[3][0]);
        CHECK(finite > 4 * n, "%s: values are non-trivial (%zu of %zu finite, non-zero)", c->name,
              finite, 5 * n);
    }

    /* 2. near and beyond the window's edge: one point at a time; sampled exactly
     * as the whole file, or refused as outside the read window (never garbage) */
    size_t ok = 0, refused = 0, wrong = 0, bad_msg = 0;
    double wx = mb[1] - mb[0], wy = mb[3] - mb[2];
    const size_t nring = 2000;
    for (size_t p = 0; p < nring; p++) {
        /* a ring from the margin box to some cells beyond it, walked around (so that
         * the curvilinear search walks from the previous point) */
        double gx = fmax(0.15 * wx, 2.5), gy = fmax(0.15 * wy, 2.5);
        double u = urand(), t = 4.0 * (double)p / (double)nring, x, y;
        int side = (int)t;
        double v = t - side;
        double bx0 = mb[0] - gx * u, bx1 = mb[1] + gx * u, by0 = mb[2] - gy * u, by1 = mb[3] + gy * u;
        if (side == 0) {
            x = bx0 + (bx1 - bx0) * v;
            y = by0;
        } else if (side == 1) {
            x = bx1;
            y = by0 + (by1 - by0) * v;
        } else if (side == 2) {
            x = bx1 - (bx1 - bx0) * v;
            y = by1;
        } else {
            x = bx0;
            y = by1 - (by1 - by0) * v;
        }
        sph_error e1, e2;
        int ra = sample(fw, tt[0], 1, &x, &y, &a, &e1);
        int rb = sample(ff, tt[0], 1, &x, &y, &b, &e2);
        if (ra == 0) {
            ok++;
            for (int q = 0; q < 5; q++)
                wrong += rb != 0 || !bits_equal(a.q[q][0], b.q[q][0]);
        } else {
            refused++;
            wrong += ra != SPH_ERR_COVERAGE;
            if (rb == 0)
                bad_msg += !strstr(e1.msg, "read window") || !strstr(e1.msg, "margin_km");
        }
    }
    CHECK(wrong == 0, "%s: %zu edge points sampled differently from the whole file", c->name, wrong);
    CHECK(bad_msg == 0, "%s: %zu refusals do not name the read window and forcing[].margin_km",
          c->name, bad_msg);
    CHECK(ok > 0 && refused > 0, "%s: the ring crosses the window's edge (%zu sampled, %zu refused)",
          c->name, ok, refused);

    /* 3. far outside the window, inside the file: refused with the one line */
    double fx = c->s.kind == REGULAR ? 0.0 : c->box[0], fy = c->s.kind == REGULAR ? 0.0 : mb[2] - 0.6 * wy;
    if (c->s.kind == PROJECTED) {
        fx = -135.0; /* across the pole from the domain */
        fy = 80.0;
    }
    rc = sample(fw, tt[0], 1, &fx, &fy, &a, &e);
    CHECK(rc == SPH_ERR_COVERAGE && strstr(e.msg, "outside the read window") &&
              strstr(e.msg, "forcing[].margin_km"),
          "%s: far point: rc %d '%s'", c->name, rc, e.msg);
    if (rc == SPH_ERR_COVERAGE)
        printf("%s: %s\n", c->name, e.msg);
    CHECK(sample(ff, tt[0], 1, &fx, &fy, &b, &e) == 0, "%s: the far point is in the file: %s",
          c->name, e.msg);

    /* 4. at nodes of the polar stereographic grid (positions by PROJ's inverse of the
     * file's own x/y and ellipsoid), SSH is the node's value (the whole-file read used
     * to locate these points in a cell on the far side of the pole) */
    if (c->s.kind == PROJECTED) {
        geo_proj *pj = geo_proj_create("+proj=stere +lat_0=90 +lat_ts=70 +lon_0=-45 +x_0=0 +y_0=0 "
                                       "+a=6378273 +rf=298.279411123064 +units=m +no_defs +type=crs",
                                       0.0, 0.0, &e);
        CHECK(pj != NULL, "PROJ: %s", e.msg);
        size_t nodes = 0, near = 0;
        for (size_t j = 0; pj && j < c->s.ny; j += 3)
            for (size_t i = 0; i < c->s.nx; i += 3) {
                double X = c->s.x0 + (double)i * c->s.dx, Y = c->s.y0 + (double)j * c->s.dy, lo, la;
                if (geo_inverse(pj, 1, &X, &Y, &lo, &la, &e) != 0 || !(lo >= mb[0] && lo <= mb[1] &&
                                                                      la >= mb[2] && la <= mb[3]))
                    continue;
                double want = field(2, (double)i, (double)j, 0);
                if (want == FILL)
                    continue;
                for (int r = 0; r < 2; r++) {
                    int rr = sample(r ? ff : fw, T0, 1, &lo, &la, &a, &e);
                    nodes++;
                    near += rr == 0 && fabs(a.q[2][0] - want) < 1e-6;
                }
            }
        geo_proj_free(pj);
        CHECK(nodes > 20 && near == nodes, "%s: %zu of %zu node samples are the node's value",
              c->name, near, nodes);
    }

    /* 5. memory follows the window: the same samples, the bytes held */
    sample(fw, tt[0], n, lon, lat, &a, &e);
    sample(ff, tt[0], n, lon, lat, &b, &e);
    size_t bw = forcing_debug_bytes(fw), bf = forcing_debug_bytes(ff);
    double cells = (double)(c->s.nx * c->s.ny);
    /* what does not grow with the nodes held: point stencils and work arrays (n
     * points), the regular grid's 1-D axes and the structures */
    double fixed = (double)n * (6 * 8 + 3 * 80) + 8.0 * (double)(c->s.nx + c->s.ny) + 32768.0;
    double bound = fixed + ((double)bf - fixed) * c->cells_max / cells;
    printf("%s: bytes held %zu with the window, %zu whole (%.2f %%); bound %.0f (window <= %.0f "
           "of %.0f nodes)\n",
           c->name, bw, bf, 100.0 * (double)bw / (double)bf, bound, c->cells_max, cells);
    CHECK((double)bw <= bound, "%s: %zu bytes with the window, more than %.0f", c->name, bw, bound);
    CHECK(bw * 10 < bf, "%s: the window holds %zu bytes of %zu", c->name, bw, bf);
    vals_free(&a);
    vals_free(&b);
    free(lon);
    free(lat);
    forcing_close(fw);
    forcing_close(ff);
    if (!getenv("SPHICE_KEEP"))
        unlink(path);
}

/* Nodes of a window over a regular axis: the span / spacing, the two nodes of the
 * cells at either end, and 3 guard nodes each side. */
static double axis_nodes(double span, double step)
{
    return ceil(span / step) + 2 + 2 * 3 + 1;
}

int main(void)
{
    char dir[] = "/tmp/sphice-hyperslab-XXXXXX";
    if (!mkdtemp(dir)) {
        perror("mkdtemp");
        return 2;
    }
    /* Global, 1/2 degree, CMEMS layout; a Bering Sea domain across 180 E. */
    kase g = {.name = "cmems_global",
              .s = {.kind = REGULAR, .nx = 720, .ny = 341, .lon0 = -180, .dlon = 0.5, .lat0 = -80,
                    .dlat = 0.5},
              .box = {176.0, 186.0, 58.0, 62.0},
              .margin_km = 150.0,
              .seam = 180.0};
    double mb[4];
    margin_box(g.box, g.margin_km, mb);
    g.cells_max = axis_nodes(mb[1] - mb[0], 0.5) * axis_nodes(mb[3] - mb[2], 0.5);
    run_case(dir, &g);

    /* Global 0 .. 360 (as GFS and ERA5 write it), latitudes descending 90 .. -90, data
     * dimensions (time, depth, longitude, latitude): a North Sea domain across the 0
     * meridian, two slabs read x before y. */
    kase z = {.name = "global_0_360",
              .s = {.kind = REGULAR, .nx = 720, .ny = 361, .lon0 = 0, .dlon = 0.5, .lat0 = 90,
                    .dlat = -0.5, .swap = 1},
              .box = {-4.0, 4.0, 54.0, 58.0},
              .margin_km = 100.0,
              .seam = 0.0};
    margin_box(z.box, z.margin_km, mb);
    z.cells_max = axis_nodes(mb[1] - mb[0], 0.5) * axis_nodes(mb[3] - mb[2], 0.5);
    run_case(dir, &z);

    /* The same file, domain away from the seam, margin 0: only the cells the domain
     * touches and the guard. */
    kase g0 = g;
    g0.name = "cmems_global_m0";
    g0.box[0] = 20.0;
    g0.box[1] = 24.0;
    g0.margin_km = 0.0;
    g0.cells_max = axis_nodes(4.0, 0.5) * axis_nodes(4.0, 0.5);
    run_case(dir, &g0);

    /* NSIDC polar stereographic north, 25 km (304 x 448; x from -3850 km, y from
     * 5850 km down); Fram Strait. The window's nodes: the margin box's extent in
     * the plane, from the projection's formula (spherical, to 2 %) over its
     * corners and edges. */
    kase p = {.name = "nsidc_polar",
              .s = {.kind = PROJECTED, .nx = 304, .ny = 448, .x0 = -3837500.0, .dx = 25000.0,
                    .y0 = 5837500.0, .dy = -25000.0},
              .box = {-10.0, 10.0, 76.0, 80.0},
              .margin_km = 100.0};
    {
        double m[4], x0 = 1e30, x1 = -1e30, y0 = 1e30, y1 = -1e30;
        margin_box(p.box, p.margin_km, m);
        for (int a = 0; a <= 40; a++)
            for (int b = 0; b <= 40; b++) {
                double lo = (m[0] + (m[1] - m[0]) * a / 40.0) * DEG, la = (m[2] + (m[3] - m[2]) * b / 40.0) * DEG;
                /* polar stereographic true at 70 N, lon0 -45 (sphere): rho = R k t */
                double k70 = (1 + sin(70 * DEG)) / 1.0;
                double r = 6378.273 * cos(la) * k70 / (1 + sin(la));
                double x = r * sin(lo + 45 * DEG), y = -r * cos(lo + 45 * DEG);
                x0 = fmin(x0, x), x1 = fmax(x1, x), y0 = fmin(y0, y), y1 = fmax(y1, y);
            }
        p.cells_max = axis_nodes(1.02 * (x1 - x0), 25.0) * axis_nodes(1.02 * (y1 - y0), 25.0);
    }
    run_case(dir, &p);

    /* Curvilinear: 0.1 degree of latitude, rotated 25 degrees, 400 x 300 nodes around
     * 72 N, 20 E. The window's nodes: the margin box's diagonal in grid steps. */
    kase c = {.name = "curvilinear",
              .s = {.kind = CURVILINEAR, .nx = 400, .ny = 300, .clon = 20.0, .clat = 72.0,
                    .step = 0.1, .rot = 25.0},
              .box = {18.0, 22.0, 71.0, 72.5},
              .margin_km = 40.0};
    {
        double m[4];
        margin_box(c.box, c.margin_km, m);
        double ex = (m[1] - m[0]) * cos(m[2] * DEG), ey = m[3] - m[2];
        double span = (ex + ey) / 0.1; /* a rotated box's index extent is below |dx| + |dy| */
        c.cells_max = (span + 12) * (span + 12);
    }
    run_case(dir, &c);
    /* The service: forcing[].margin_km reaches the reader (default 300 km; 20040 km,
     * half the circumference, reads whole grids), sphice check shows the window. */
    {
        char path[512];
        snprintf(path, sizeof path, "%s/service.nc", dir);
        write_file(path, &g.s);
        static const char *const margins[] = {"", ", \"margin_km\": 150", ", \"margin_km\": 20040"};
        static const double want_margin[] = {300.0, 150.0, 20040.0};
        for (int k = 0; k < 3; k++) {
            char text[2048];
            snprintf(text, sizeof text,
                     "{\"domain\": {\"lon_min\": 176, \"lon_max\": 186, \"lat_min\": 58, "
                     "\"lat_max\": 62}, \"schedule\": {\"forecast_hours\": 6},"
                     " \"forcing\": [{\"name\": \"cmems\", \"kind\": \"ocean\", \"urls\": \"%s\","
                     " \"required\": [\"current\"]%s}], \"output\": {\"dir\": \"%s/out\"}}",
                     path, margins[k], dir);
            struct sph_config *cfg = NULL;
            sph_error e;
            sph_error_clear(&e);
            int rc = sph_config_parse(text, "hyperslab.json", &cfg, &e);
            CHECK(rc == 0, "config with forcing[].margin_km: %s", e.msg);
            if (rc)
                continue;
            CHECK(cfg->forcing[0].margin_km == want_margin[k], "margin_km %g, want %g",
                  cfg->forcing[0].margin_km, want_margin[k]);
            const char *files[2] = {path, NULL};
            forcing_source_spec sp;
            forcing_name_map *map = NULL;
            rc = forecast_source_spec(cfg, 0, files, &sp, &map, &e);
            CHECK(rc == 0 && sp.window == (k < 2) && sp.margin_km == want_margin[k],
                  "spec: window %d margin %g", sp.window, sp.margin_km);
            char *out = NULL;
            size_t outlen = 0;
            FILE *mf = open_memstream(&out, &outlen);
            service_check(cfg, T0, 0, mf);
            fclose(mf);
            CHECK((strstr(out, ", window ") != NULL) == (k < 2), "sphice check and the window:\n%s",
                  out);
            free(out);
            if (k == 1) {
                /* a particle that drifted out of the window is outside the forcing: an
                 * ocean source serves the others and counts it as a coast fallback (no
                 * current), as for a point outside the file's grid */
                forecast_request req;
                memset(&req, 0, sizeof req);
                req.cycle_time = T0;
                req.forcing_files[0] = files;
                fc_coupling cp;
                memset(&cp, 0, sizeof cp);
                rc = coupling_open(&cp, cfg, &req, T0, T0 + 6 * 3600.0, "test", &e);
                CHECK(rc == 0, "coupling_open: %s", e.msg);
                geo_proj *proj = geo_proj_create("aeqd", 181.0, 60.0, &e);
                sph_particles *P = sph_particles_create(3, 1);
                double plon[3] = {180.1, 177.3, 150.0}, plat[3] = {60.2, 58.6, 60.0};
                CHECK(proj && P && geo_forward(proj, 3, plon, plat, P->x, P->y, &e) == 0,
                      "particles: %s", e.msg);
                P->n = 3;
                for (size_t q = 0; q < 3; q++)
                    P->id[q] = (long)q;
                CHECK(coupling_alloc(&cp, 3, &e) == 0, "alloc");
                if (rc == 0)
                    rc = coupling_fill(&cp, proj, &cfg->model.thermo, 0, P, T0 + 3600.0, &e);
                CHECK(rc == 0 && cp.coast_fallbacks == 1, "fill: rc %d, %ld fallbacks: %s", rc,
                      cp.coast_fallbacks, e.msg);
                CHECK(P->uw[2] == 0 && P->vw[2] == 0, "the particle outside the window got no current");
                CHECK(hypot(P->uw[0], P->vw[0]) > 0 && hypot(P->uw[1], P->vw[1]) > 0,
                      "the particles inside got currents");
                coupling_free(&cp);
                sph_particles_free(P);
                geo_proj_free(proj);
            }
            free(map);
            sph_config_free(cfg);
        }
        unlink(path);
    }
    rmdir(dir);
    return check_summary("test_forcing_hyperslab");
}
