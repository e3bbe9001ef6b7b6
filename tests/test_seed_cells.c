/* Per-cell seeding of n x n particles per raster cell (issue 19 item 4)
 * and the raster's own land flags (item 6).
 *
 * The test writes two CF rasters with the netCDF API: a regular lon/lat
 * one over Liaodong Bay and a polar-stereographic one north of Svalbard
 * (CF grid_mapping polar_stereographic, WGS84, true scale at 70 N,
 * straight vertical longitude -45 E, x/y in km), each with a sharp patch
 * (A = 0.9, h = 0.7 m) in open water and a smooth Gaussian field. Their
 * ice area sum(A dA) and volume sum(A h dA) are computed here: dA on the
 * sphere R^2 dlon (sin(lat_n) - sin(lat_s)) for lon/lat, and dx dy / k^2
 * for the projection (k: Snyder's polar-stereographic scale, eq. 21-32,
 * at the cell's centre, whose position is checked against his forward
 * formula). For n = 1, 2, 3 every cell with ice gets exactly n^2
 * particles at the centres of its n x n sub-cells, each with the cell's
 * thickness (0.7 m in the patch: no open-water zero mixed in), and the
 * seeded area and volume equal the raster's within 1 %. With a land mask
 * cutting through cells, no particle is on land and the seeded ice equals
 * the raster's over the sea sub-cells (counted here).
 *
 * Raster flags: an NSIDC-CDR-shaped file (cdr_seaice_conc ubyte, scale
 * 0.01, flag_values 251..255 "pole_hole_mask lakes coastal land_mask
 * missing_data", crs polar_stereographic Hughes 1980, xgrid/ygrid in
 * metres, rows north to south; NSIDC G02202 user guide) with a land and
 * coast strip where a separate land mask has its coastline elsewhere:
 * landmask_from_raster is land exactly at the flagged cells, the union
 * with the other mask is land where either is, and neither the lattice
 * nor per-cell seeding places a particle in a flagged cell (the lattice
 * used to: its bilinear sample leaves the flagged corners out and seeded
 * the coast cell next to ice). */
#include <stdlib.h>
#include <unistd.h>

#include "io/landmask.h"
#include "raster_provider.h"
#include "seed_cdr.h"

static char dir[] = "/tmp/sphice-seedcells-XXXXXX";
static const double RHO = 900.0, PATCH_C = 0.9, PATCH_H = 0.7;

/* ------------------------------------------------------------ fields */

enum { NI = 30, NJ = 24 };
static int in_patch(int i, int j) { return i >= 8 && i < 20 && j >= 6 && j < 16; }
static double conc_of(int smooth, int i, int j)
{
    if (!smooth)
        return in_patch(i, j) ? PATCH_C : 0.0;
    double v = exp(-pow((i - 14.5) / 7.0, 2) - pow((j - 11.5) / 5.0, 2));
    return v < 0.02 ? 0.0 : v;
}
static double thick_of(int smooth, int i, int j)
{
    if (!smooth)
        return in_patch(i, j) ? PATCH_H : 0.0;
    return conc_of(1, i, j) > 0 ? 0.2 + 0.6 * conc_of(1, i, j) : 0.0;
}

/* ------------------------------------------------------------ lon/lat */

static const double LL_LON0 = 120.81, LL_LAT0 = 39.91, LL_D = 0.02;

static double lonlat_area(int j)
{
    const double R = 6371000.0, lat = LL_LAT0 + j * LL_D;
    return R * R * LL_D * RP_DEG * (sin((lat + LL_D / 2) * RP_DEG) - sin((lat - LL_D / 2) * RP_DEG));
}

/* ------------------------------------------------------------ polar stereographic */

static const double PA = 6378137.0, PRF = 298.257223563, PD = 10000.0; /* m */
static double px0, py0; /* first centre, m */
static double pb(void) { return PA * (1 - 1 / PRF); }

/* The field on the lon/lat grid (siconc, sithick) or the polar
 * stereographic one (aice, hi, x/y in km, grid_mapping). */
static void write_raster(const char *path, int stereo, int smooth)
{
    double cx, cy, k;
    rp_ps_forward(PA, pb(), 70, -45, 15.0, 80.5, &cx, &cy, &k);
    px0 = round(cx / PD) * PD - (NI / 2) * PD;
    py0 = round(cy / PD) * PD - (NJ / 2) * PD;
    int nc, d[2], vx, vy, vc, vh;
    CHECK(nc_create(path, NC_CLOBBER | NC_NETCDF4, &nc) == NC_NOERR, "create %s", path);
    nc_def_dim(nc, stereo ? "y" : "lat", NJ, &d[0]);
    nc_def_dim(nc, stereo ? "x" : "lon", NI, &d[1]);
    if (stereo) {
        vx = sc_axis(nc, "x", d[1], "projection_x_coordinate", "km");
        vy = sc_axis(nc, "y", d[0], "projection_y_coordinate", "km");
        sc_ps_crs(nc, "polar_stereographic", PA, "inverse_flattening", PRF);
    } else {
        vy = sc_axis(nc, "lat", d[0], "latitude", "degrees_north");
        vx = sc_axis(nc, "lon", d[1], "longitude", "degrees_east");
    }
    nc_def_var(nc, stereo ? "aice" : "siconc", NC_DOUBLE, 2, d, &vc);
    rp_text(nc, vc, "standard_name", "sea_ice_area_fraction");
    rp_text(nc, vc, "units", "1");
    nc_def_var(nc, stereo ? "hi" : "sithick", NC_DOUBLE, 2, d, &vh);
    rp_text(nc, vh, "standard_name", "sea_ice_thickness");
    rp_text(nc, vh, "units", "m");
    rp_text(nc, vh, "cell_methods", "area: mean where sea_ice");
    if (stereo) {
        rp_text(nc, vc, "grid_mapping", "polar_stereographic");
        rp_text(nc, vh, "grid_mapping", "polar_stereographic");
    }
    nc_enddef(nc);
    double xs[NI], ys[NJ];
    static double c[NJ * NI], h[NJ * NI];
    for (int i = 0; i < NI; i++)
        xs[i] = stereo ? (px0 + i * PD) / 1000 : LL_LON0 + i * LL_D;
    for (int j = 0; j < NJ; j++)
        ys[j] = stereo ? (py0 + j * PD) / 1000 : LL_LAT0 + j * LL_D;
    for (int q = 0; q < NJ * NI; q++) {
        c[q] = conc_of(smooth, q % NI, q / NI);
        h[q] = thick_of(smooth, q % NI, q / NI);
    }
    nc_put_var_double(nc, vx, xs);
    nc_put_var_double(nc, vy, ys);
    nc_put_var_double(nc, vc, c);
    nc_put_var_double(nc, vh, h);
    nc_close(nc);
}

/* ------------------------------------------------------------ checks */

/* The raster's area of cell (i, j), computed here; for the projection
 * also how far the reader's centre is from Snyder's (m). */
static double cell_area(const ice_raster *r, int stereo, int i, int j, double *off)
{
    *off = 0;
    if (!stereo)
        return lonlat_area(j);
    double lon, lat, x, y, k;
    ice_raster_cell_lonlat(r, i, j, &lon, &lat);
    rp_ps_forward(PA, pb(), 70, -45, lon, lat, &x, &y, &k);
    *off = fmax(fabs(x - (px0 + i * PD)), fabs(y - (py0 + j * PD)));
    return PD * PD / (k * k);
}

/* Where a seeded particle lies in the raster's own coordinates: cell
 * (i, j), sub-cell (a, b) of n, and its distance from that sub-cell's
 * centre (degrees for lon/lat, m for the projection). */
static double locate(const geo_proj *p, int stereo, int n, double px, double py, int *ci, int *cj, int *sub)
{
    double lon, lat;
    geo_inverse(p, 1, &px, &py, &lon, &lat, NULL);
    double u, v, d;
    if (stereo) {
        double x, y, k;
        rp_ps_forward(PA, pb(), 70, -45, lon, lat, &x, &y, &k);
        u = (x - px0) / PD, v = (y - py0) / PD, d = PD;
    } else {
        u = (lon - LL_LON0) / LL_D, v = (lat - LL_LAT0) / LL_D, d = LL_D;
    }
    *ci = (int)floor(u + 0.5), *cj = (int)floor(v + 0.5);
    double fu = u - *ci + 0.5, fv = v - *cj + 0.5; /* 0..1 across the cell */
    int a = (int)floor(fu * n), b = (int)floor(fv * n);
    a = a < 0 ? 0 : a >= n ? n - 1 : a;
    b = b < 0 ? 0 : b >= n ? n - 1 : b;
    *sub = b * n + a;
    return hypot(fu - (a + 0.5) / n, fv - (b + 0.5) / n) * d;
}

/* land east of this longitude (lon/lat case): through the patch's cells,
 * on an edge of the mask's 0.002 degree cells */
static const double CUT_LON = 120.7 + 187 * 0.002;

static void seed_case(const char *path, int stereo, int smooth, int n, const landmask *mask)
{
    char what[160];
    snprintf(what, sizeof what, "%s, %s, %d x %d per cell%s", stereo ? "polar stereographic" : "lon/lat",
             smooth ? "smooth field" : "sharp 0.7 m patch", n, n, mask ? ", land cutting cells" : "");
    sph_error err;
    sph_error_clear(&err);
    ice_raster *r = NULL;
    CHECK(ice_raster_read(path, NULL, &r, &err) == SPH_OK && r, "%s: read: %s", what, err.msg);
    if (!r)
        return;
    geo_proj *p = stereo ? geo_proj_create("auto", 15.0, 80.5, &err)
                         : geo_proj_create("auto", LL_LON0 + NI / 2 * LL_D, LL_LAT0 + NJ / 2 * LL_D, &err);
    seed_options so;
    seed_options_default(&so);
    so.threshold = 0;
    so.rho_ice = RHO;
    so.cell_n = n;
    /* the raster's ice, computed here, over the sea sub-cells */
    double want_a = 0, want_v = 0, worst_pos = 0;
    size_t want_n = 0;
    for (int j = 0; j < NJ; j++)
        for (int i = 0; i < NI; i++) {
            double off, a = cell_area(r, stereo, i, j, &off), c = conc_of(smooth, i, j);
            worst_pos = fmax(worst_pos, off);
            if (!(c > 0))
                continue;
            int sea = 0;
            for (int q = 0; q < n; q++) /* sub-cell centres west of the cut */
                sea += !mask || LL_LON0 + (i - 0.5 + (q + 0.5) / n) * LL_D < CUT_LON;
            sea *= n;
            want_n += (size_t)sea;
            want_a += c * a * sea / (n * n);
            want_v += c * thick_of(smooth, i, j) * a * sea / (n * n);
        }
    if (stereo)
        CHECK(worst_pos < 0.01, "%s: cell centres within 0.01 m of Snyder's formula (%g m)", what, worst_pos);
    size_t cnt = 0;
    CHECK(seed_count(r, p, mask, &so, &cnt, &err) == SPH_OK, "%s: count: %s", what, err.msg);
    CHECK(cnt == want_n, "%s: %zu particles, want %zu (n^2 per cell with ice, sea sub-cells)", what, cnt,
          want_n);
    sph_particles *P = sph_particles_create(cnt ? cnt : 1, 1);
    seed_totals t;
    CHECK(seed_from_raster_totals(r, p, mask, &so, P, &t, &err) == SPH_OK && P->n == cnt, "%s: seed: %s", what,
          err.msg);
    double area = 0, vol = 0, worst_sub = 0, worst_h = 0;
    static int seen[NJ * NI * 9];
    memset(seen, 0, sizeof seen);
    size_t bad_cell = 0, twice = 0, on_land = 0;
    for (size_t k = 0; k < P->n; k++) {
        vol += P->mass[k] / RHO;
        area += P->mass[k] / (RHO * P->thick[k]);
        int ci, cj, sub;
        worst_sub = fmax(worst_sub, locate(p, stereo, n, P->x[k], P->y[k], &ci, &cj, &sub));
        if (ci < 0 || cj < 0 || ci >= NI || cj >= NJ || !(conc_of(smooth, ci, cj) > 0)) {
            bad_cell++;
            continue;
        }
        if (seen[(cj * NI + ci) * 9 + sub]++)
            twice++;
        /* the cell's own thickness and concentration */
        worst_h = fmax(worst_h, fabs(P->thick[k] - thick_of(smooth, ci, cj)) + fabs(P->conc[k] - conc_of(smooth, ci, cj)));
        double lon, lat;
        geo_inverse(p, 1, &P->x[k], &P->y[k], &lon, &lat, NULL);
        on_land += mask && landmask_is_land(mask, lon, lat) == 1;
    }
    printf("%s: raster %.6g km2 %.6g km3; seeded %zu particles %.6g km2 (%+.2e) %.6g km3 (%+.2e); "
           "sub-cell centres within %.3g %s\n", what, want_a / 1e6, want_v / 1e9, P->n, area / 1e6,
           area / want_a - 1, vol / 1e9, vol / want_v - 1, worst_sub, stereo ? "m" : "deg");
    CHECK(fabs(area / want_a - 1) <= 0.01, "%s: seeded ice area within 1 %% of the raster's", what);
    CHECK(fabs(vol / want_v - 1) <= 0.01, "%s: seeded ice volume within 1 %% of the raster's", what);
    CHECK(fabs(t.raster_area_m2 / want_a - 1) <= 1e-3, "%s: totals: the raster's area %g", what, t.raster_area_m2);
    CHECK(fabs(t.raster_volume_m3 / want_v - 1) <= 1e-3, "%s: totals: the raster's volume %g", what,
          t.raster_volume_m3);
    CHECK(!t.rescaled, "%s: per cell is not rescaled", what);
    CHECK(bad_cell == 0 && twice == 0, "%s: every particle in a cell with ice, one per sub-cell (%zu outside, "
          "%zu twice)", what, bad_cell, twice);
    CHECK(worst_sub < (stereo ? 0.5 : 1e-6), "%s: at the sub-cells' centres (%g)", what, worst_sub);
    CHECK(worst_h < 1e-12, "%s: each particle has its cell's thickness and concentration (%g)", what, worst_h);
    CHECK(on_land == 0, "%s: %zu particles on land", what, on_land);
    sph_particles_free(P);
    geo_proj_free(p);
    ice_raster_free(r);
}

/* ------------------------------------------------------------ NSIDC CDR flags */

/* Cells of r where m's land is not the CDR's land, coast and lake (not
 * missing) or, with_coast, also north of the coastline mask's 40.45 N;
 * *nflag: the CDR's flagged land cells. */
static size_t wrong_land(const ice_raster *r, const landmask *m, int with_coast, size_t *nflag)
{
    size_t wrong = 0;
    *nflag = 0;
    for (int j = 0; j < r->nlat; j++)
        for (int i = 0; i < r->nlon; i++) {
            double lon, lat;
            ice_raster_cell_lonlat(r, i, j, &lon, &lat);
            int ii, jn;
            cdr_cell(lon, lat, &ii, &jn);
            int raw = cdr_raw(ii, jn), flag = raw == 254 || raw == 253 || raw == 252;
            *nflag += flag;
            wrong += landmask_is_land(m, lon, lat) != (flag || (with_coast && lat > 40.45 && lon < 122.1));
        }
    return wrong;
}

static void flags_case(const char *path)
{
    ice_raster_options o;
    ice_raster_options_default(&o);
    o.default_thickness = 0.5;
    ice_raster *r = NULL;
    sph_error err;
    sph_error_clear(&err);
    CHECK(ice_raster_read(path, &o, &r, &err) == SPH_OK && r, "CDR: read: %s", err.msg);
    if (!r)
        return;
    landmask *fl = landmask_from_raster(r, "landmask.source raster", &err);
    CHECK(fl != NULL, "CDR: land from its flags: %s", err.msg);
    /* a coastline elsewhere: land north of 40.45 N on a 0.01 deg grid */
    static unsigned char coast[120 * 100];
    for (int j = 0; j < 100; j++)
        for (int i = 0; i < 120; i++)
            coast[j * 120 + i] = 40.0 + (j + 0.5) * 0.01 > 40.45;
    landmask *un = landmask_create_array(120, 100, 120.9, 40.0, 0.01, 0.01, coast, &err);
    size_t nflag = 0, wrong = fl ? wrong_land(r, fl, 0, &nflag) : 1, wrong_union = 1;
    CHECK(nflag > 0 && wrong == 0, "CDR: landmask_from_raster land exactly at the %zu land/coast/lake cells "
          "(%zu wrong)", nflag, wrong);
    if (fl && un) {
        landmask_add(un, fl);
        fl = NULL; /* owned by un */
        wrong_union = wrong_land(r, un, 1, &nflag);
        CHECK(wrong_union == 0, "CDR: the union with a coastline mask is land where either is (%zu wrong)",
              wrong_union);
    }
    /* seeding: never in a flagged cell, with no mask at all, the lattice and per cell */
    geo_proj *p = geo_proj_create("auto", 121.5, 40.3, &err);
    for (int mode = 0; p && mode < 3; mode++) {
        seed_options so;
        seed_options_default(&so);
        so.threshold = 0.15;
        so.spacing_m = mode == 0 ? 700.0 : 0.0; /* a lattice finer than the cells: points in every cell */
        so.cell_n = mode;
        const landmask *m = mode == 2 ? un : NULL;
        size_t n = 0, in_flag = 0, on_mask = 0;
        CHECK(seed_count(r, p, m, &so, &n, &err) == SPH_OK && n > 0, "CDR mode %d: count: %s", mode, err.msg);
        sph_particles *P = sph_particles_create(n ? n : 1, 1);
        CHECK(seed_from_raster(r, p, m, &so, P, &err) == SPH_OK, "CDR mode %d: seed: %s", mode, err.msg);
        for (size_t k = 0; k < P->n; k++) {
            double lon, lat;
            geo_inverse(p, 1, &P->x[k], &P->y[k], &lon, &lat, NULL);
            int ii, jn;
            cdr_cell(lon, lat, &ii, &jn);
            int raw = ii >= 0 && jn >= 0 && ii < CX && jn < CY ? cdr_raw(ii, jn) : 0;
            in_flag += raw > 250;
            on_mask += m && landmask_is_land(m, lon, lat) == 1;
        }
        printf("CDR, %s: %zu particles, %zu in flagged cells, %zu on the union's land\n",
               mode == 0 ? "lattice 700 m" : mode == 1 ? "per cell" : "2 x 2 per cell with the union mask", P->n,
               in_flag, on_mask);
        CHECK(in_flag == 0, "CDR mode %d: no particle in a cell the raster flags (%zu)", mode, in_flag);
        CHECK(on_mask == 0, "CDR mode %d: no particle on the union's land (%zu)", mode, on_mask);
        sph_particles_free(P);
    }
    geo_proj_free(p);
    landmask_free(fl);
    landmask_free(un);
    /* a raster without flags: refused in one line naming the key */
    ice_raster_free(r);
}

static void no_flags_case(const char *path)
{
    ice_raster *r = NULL;
    sph_error err;
    sph_error_clear(&err);
    CHECK(ice_raster_read(path, NULL, &r, &err) == SPH_OK && r, "read: %s", err.msg);
    if (!r)
        return;
    sph_error_clear(&err);
    landmask *m = landmask_from_raster(r, "landmask.raster_land", &err);
    CHECK(m == NULL && strstr(err.msg, "landmask.raster_land") && strstr(err.msg, path) && !strchr(err.msg, '\n'),
          "a raster without flags: one line naming the key and the file: %s", err.msg);
    printf("  no flags -> %s\n", err.msg);
    landmask_free(m);
    ice_raster_free(r);
}

int main(void)
{
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    char ll[2][600], ps[2][600], cdr[600];
    sph_error err;
    sph_error_clear(&err);
    for (int s = 0; s < 2; s++) {
        snprintf(ll[s], sizeof ll[s], "%s/lonlat%d.nc", dir, s);
        snprintf(ps[s], sizeof ps[s], "%s/stereo%d.nc", dir, s);
        write_raster(ll[s], 0, s);
        write_raster(ps[s], 1, s);
    }
    static unsigned char cut[400 * 100]; /* 120.7-121.5 E, 39.85-40.85 N */
    for (int j = 0; j < 100; j++)
        for (int i = 0; i < 400; i++)
            cut[j * 400 + i] = 120.7 + (i + 0.5) * 0.002 > CUT_LON;
    landmask *mask = landmask_create_array(400, 100, 120.7, 39.85, 0.002, 0.01, cut, &err);
    CHECK(mask != NULL, "mask: %s", err.msg);
    for (int n = 1; n <= 3; n++)
        for (int s = 0; s < 2; s++) {
            seed_case(ll[s], 0, s, n, NULL);
            seed_case(ps[s], 1, s, n, NULL);
            seed_case(ll[s], 0, s, n, mask);
        }
    landmask_free(mask);
    snprintf(cdr, sizeof cdr, "%s/cdr.nc", dir);
    write_cdr(cdr);
    flags_case(cdr);
    no_flags_case(ll[0]);
    for (int s = 0; s < 2; s++) {
        unlink(ll[s]);
        unlink(ps[s]);
    }
    unlink(cdr);
    rmdir(dir);
    return check_summary("test_seed_cells");
}
