/* Initial ice rasters on projected and curvilinear grids (issue 19 item 1).
 *
 * Each file is written here in the grid shape its provider documents:
 *  - NOAA/NSIDC sea-ice CDR (G02202): 25 km polar stereographic north,
 *    x/y in metres, y from north to south, grid mapping variable `crs`
 *    (polar_stereographic, straight_vertical_longitude_from_pole -45,
 *    standard_parallel 70, Hughes 1980 ellipsoid a 6378273 m, b
 *    6356889.449 m; EPSG:3411), dimensions (time, y, x);
 *  - OSI SAF EASE2 (OSI-450/430): `Lambert_Azimuthal_Grid`
 *    (lambert_azimuthal_equal_area, origin (0 E, 90 N), WGS84 given by
 *    semi_major_axis and inverse_flattening), xc/yc in km, ice_conc in %;
 *  - a GRIB-derived Lambert conformal file (two standard parallels,
 *    spherical earth_radius 6371229 m, x/y in km);
 *  - transverse Mercator on a sphere, given only as a proj4 attribute;
 *  - a curvilinear ocean-model grid (2-D nav_lat/nav_lon, with and
 *    without a cell-area variable named by cell_measures).
 * Checked against formulas computed here (Snyder 1987, "Map projections,
 * a working manual"): the PROJECTED forward formula at the reader's cell
 * lon/lat must give the file's x/y within 0.01 m (1e-7 degrees); the
 * cell area must be dx dy / k^2 with the scale factor k of the formula
 * (1 for the equal-area EASE2 grid); per-cell seeding must carry the
 * raster's ice area and volume within 1 %; bad grids fail with one line
 * naming file and variable. */
#include <unistd.h>

#include "raster_provider.h"

static const double DEG = M_PI / 180;

/* ---------------------------------------------------- Snyder formulas */
/* polar stereographic and polar LAEA: raster_provider.h */

/* Lambert conformal conic, sphere R, two standard parallels (eq. 15-1..15-5, 15-4 for k) */
static void lcc_forward(double R, double p1, double p2, double lat0, double lon0, double lon,
                        double lat, double *x, double *y, double *k)
{
    p1 *= DEG, p2 *= DEG;
    double n = log(cos(p1) / cos(p2)) / log(tan(M_PI / 4 + p2 / 2) / tan(M_PI / 4 + p1 / 2));
    double F = cos(p1) * pow(tan(M_PI / 4 + p1 / 2), n) / n;
    double rho = R * F / pow(tan(M_PI / 4 + lat * DEG / 2), n);
    double rho0 = R * F / pow(tan(M_PI / 4 + lat0 * DEG / 2), n);
    double th = n * remainder(lon - lon0, 360) * DEG;
    *x = rho * sin(th);
    *y = rho0 - rho * cos(th);
    *k = n * rho / (R * cos(lat * DEG));
}

/* transverse Mercator, sphere (eq. 8-1..8-3) */
static void tm_forward(double R, double k0, double lat0, double lon0, double lon, double lat,
                       double *x, double *y, double *k)
{
    double phi = lat * DEG, dl = (lon - lon0) * DEG, B = cos(phi) * sin(dl);
    *x = 0.5 * R * k0 * log((1 + B) / (1 - B));
    *y = R * k0 * (atan2(tan(phi), cos(dl)) - lat0 * DEG);
    *k = k0 / sqrt(1 - B * B);
}

/* area of a lon/lat cell on the ellipsoid (a, e): authalic q (eq. 3-12) */
static double ll_area(double a, double e, double dlon, double s, double n)
{
    return a * a * dlon * DEG * (rp_q(n * DEG, e) - rp_q(s * DEG, e)) / 2;
}

/* ---------------------------------------------------------- writers */

typedef struct {
    const char *xname, *yname, *units; /* units NULL: none written */
    double to_unit;                    /* file units per metre */
    int nx, ny, descending;
    double x0, y0, d;                  /* first centre (m) and spacing (m) */
    const char *conc_name, *conc_units;
    double conc_scale;                 /* file value per fraction (1 or 100) */
    int with_gm;
    const char *gm_name;
} grid_spec;

static double conc_of(int i, int j, int nx, int ny)
{
    /* a smooth patch with open water around, and a sharp edge */
    double u = (i + 0.5) / nx - 0.5, v = (j + 0.5) / ny - 0.5;
    double c = 0.95 * exp(-(u * u + v * v) / 0.08);
    return c < 0.1 ? 0 : round(c * 100) / 100;
}
static double thick_of(int i, int j) { return 0.5 + 0.01 * i + 0.02 * j; }

typedef void (*gm_writer)(int ncid, int gm);



/* Writes the raster; conc[j][i] with j counted from y0 upward. */
static void write_projected(const char *path, const grid_spec *g, gm_writer gmw)
{
    int ncid, d[3], vx, vy, vc, vh, vt, gm = -1;
    CHECK(nc_create(path, NC_CLOBBER | NC_NETCDF4, &ncid) == NC_NOERR, "create %s", path);
    nc_def_dim(ncid, "time", 1, &d[0]);
    nc_def_dim(ncid, g->yname, (size_t)g->ny, &d[1]);
    nc_def_dim(ncid, g->xname, (size_t)g->nx, &d[2]);
    nc_def_var(ncid, "time", NC_DOUBLE, 1, &d[0], &vt);
    nc_put_att_text(ncid, vt, "units", 31, "days since 1978-01-01 00:00:00");
    nc_def_var(ncid, g->xname, NC_DOUBLE, 1, &d[2], &vx);
    nc_def_var(ncid, g->yname, NC_DOUBLE, 1, &d[1], &vy);
    nc_put_att_text(ncid, vx, "standard_name", 23, "projection_x_coordinate");
    nc_put_att_text(ncid, vy, "standard_name", 23, "projection_y_coordinate");
    if (g->units) {
        nc_put_att_text(ncid, vx, "units", strlen(g->units), g->units);
        nc_put_att_text(ncid, vy, "units", strlen(g->units), g->units);
    }
    if (g->with_gm) {
        nc_def_var(ncid, g->gm_name, NC_INT, 0, NULL, &gm);
        gmw(ncid, gm);
    }
    nc_def_var(ncid, g->conc_name, NC_FLOAT, 3, d, &vc);
    nc_def_var(ncid, "sea_ice_thickness", NC_FLOAT, 3, d, &vh);
    nc_put_att_text(ncid, vc, "units", strlen(g->conc_units), g->conc_units);
    rp_text(ncid, vc, "standard_name", "sea_ice_area_fraction");
    nc_put_att_text(ncid, vh, "standard_name", 17, "sea_ice_thickness");
    nc_put_att_text(ncid, vh, "units", 1, "m");
    if (g->with_gm) {
        nc_put_att_text(ncid, vc, "grid_mapping", strlen(g->gm_name), g->gm_name);
        nc_put_att_text(ncid, vh, "grid_mapping", strlen(g->gm_name), g->gm_name);
    }
    float fill = -999;
    nc_put_att_float(ncid, vc, "_FillValue", NC_FLOAT, 1, &fill);
    nc_enddef(ncid);
    double t = 16000;
    nc_put_var_double(ncid, vt, &t);
    double *ax = malloc(sizeof(double) * (size_t)(g->nx > g->ny ? g->nx : g->ny));
    for (int i = 0; i < g->nx; i++)
        ax[i] = (g->x0 + i * g->d) * g->to_unit;
    nc_put_var_double(ncid, vx, ax);
    for (int j = 0; j < g->ny; j++) {
        int jj = g->descending ? g->ny - 1 - j : j;
        ax[j] = (g->y0 + jj * g->d) * g->to_unit;
    }
    nc_put_var_double(ncid, vy, ax);
    free(ax);
    float *c = malloc(sizeof(float) * (size_t)(g->nx * g->ny)), *h = malloc(sizeof(float) * (size_t)(g->nx * g->ny));
    for (int j = 0; j < g->ny; j++)
        for (int i = 0; i < g->nx; i++) {
            int jj = g->descending ? g->ny - 1 - j : j;
            c[j * g->nx + i] = (float)(conc_of(i, jj, g->nx, g->ny) * g->conc_scale);
            h[j * g->nx + i] = (float)thick_of(i, jj);
        }
    c[0] = fill; /* one missing cell */
    nc_put_var_float(ncid, vc, c);
    nc_put_var_float(ncid, vh, h);
    free(c);
    free(h);
    nc_close(ncid);
}



/* NSIDC CDR `crs` (G02202 user guide, EPSG:3411): the CF attributes */
static const double HA = 6378273.0, HB = 6356889.449;
static void gm_cdr_cf(int ncid, int gm)
{
    rp_text(ncid, gm, "grid_mapping_name", "polar_stereographic");
    rp_num(ncid, gm, "straight_vertical_longitude_from_pole", -45);
    rp_num(ncid, gm, "latitude_of_projection_origin", 90);
    rp_num(ncid, gm, "standard_parallel", 70);
    rp_num(ncid, gm, "false_easting", 0);
    rp_num(ncid, gm, "false_northing", 0);
    rp_num(ncid, gm, "semi_major_axis", HA);
    rp_num(ncid, gm, "semi_minor_axis", HB);
}
/* the same with its EPSG code, which the reader takes first */
static void gm_cdr(int ncid, int gm)
{
    gm_cdr_cf(ncid, gm);
    rp_text(ncid, gm, "srid", "urn:ogc:def:crs:EPSG::3411");
}
/* OSI SAF EASE2 north */
static const double WA = 6378137.0, WRF = 298.257223563;
static void gm_ease2(int ncid, int gm)
{
    rp_text(ncid, gm, "grid_mapping_name", "lambert_azimuthal_equal_area");
    rp_num(ncid, gm, "longitude_of_projection_origin", 0);
    rp_num(ncid, gm, "latitude_of_projection_origin", 90);
    rp_num(ncid, gm, "false_easting", 0);
    rp_num(ncid, gm, "false_northing", 0);
    rp_num(ncid, gm, "semi_major_axis", WA);
    rp_num(ncid, gm, "inverse_flattening", WRF);
}
/* the same as a proj4 string whose CRS unit is km */
static void gm_ease2_km(int ncid, int gm)
{
    rp_text(ncid, gm, "proj4_string", "+proj=laea +lat_0=90 +lon_0=0 +x_0=0 +y_0=0 +a=6378137 "
                                       "+rf=298.257223563 +units=km +no_defs");
}
static const double GR = 6371229.0;
static void gm_lcc(int ncid, int gm)
{
    rp_text(ncid, gm, "grid_mapping_name", "lambert_conformal_conic");
    double sp[2] = {60, 75};
    nc_put_att_double(ncid, gm, "standard_parallel", NC_DOUBLE, 2, sp);
    rp_num(ncid, gm, "longitude_of_central_meridian", 20);
    rp_num(ncid, gm, "latitude_of_projection_origin", 70);
    rp_num(ncid, gm, "earth_radius", GR);
}
static void gm_tm(int ncid, int gm)
{
    rp_text(ncid, gm, "proj4", "+proj=tmerc +lat_0=60 +lon_0=25 +k_0=0.9996 +x_0=0 +y_0=0 "
                                "+R=6371000 +units=m +no_defs");
}
static void gm_noellps(int ncid, int gm)
{
    gm_cdr_cf(ncid, gm);
    nc_del_att(ncid, gm, "semi_major_axis");
    nc_del_att(ncid, gm, "semi_minor_axis");
}
static void gm_rotated(int ncid, int gm)
{
    rp_text(ncid, gm, "grid_mapping_name", "rotated_latitude_longitude");
    rp_num(ncid, gm, "grid_north_pole_latitude", 30);
    rp_num(ncid, gm, "grid_north_pole_longitude", -160);
}
static void gm_badproj(int ncid, int gm) { rp_text(ncid, gm, "proj4text", "+proj=nosuchprojection +R=6371000"); }

/* ----------------------------------------------------------- checks */

typedef void (*fwd_fn)(double lon, double lat, double *x, double *y, double *k);
static void f_cdr(double lon, double lat, double *x, double *y, double *k)
{
    rp_ps_forward(HA, HB, 70, -45, lon, lat, x, y, k);
}
static void f_ease2(double lon, double lat, double *x, double *y, double *k)
{
    rp_laea_forward(WA, WRF, 0, lon, lat, x, y);
    *k = 1; /* equal area: areal scale 1 */
}
static void f_lcc(double lon, double lat, double *x, double *y, double *k)
{
    lcc_forward(GR, 60, 75, 70, 20, lon, lat, x, y, k);
}
static void f_tm(double lon, double lat, double *x, double *y, double *k)
{
    tm_forward(6371000, 0.9996, 60, 25, lon, lat, x, y, k);
}


/* Reads `path`, checks positions and areas against fwd, seeds per cell
 * and checks the seeded ice area and volume. */
static void check_projected(const char *what, const char *path, const grid_spec *g, fwd_fn fwd)
{
    ice_raster *r = NULL;
    sph_error err;
    sph_error_clear(&err);
    int rc = ice_raster_read(path, NULL, &r, &err);
    CHECK(rc == SPH_OK && r, "%s: read: %s", what, err.msg);
    if (!r)
        return;
    CHECK(r->kind == ICE_RASTER_PROJECTED && r->nlon == g->nx && r->nlat == g->ny,
          "%s: kind %d, %d x %d", what, r->kind, r->nlon, r->nlat);
    double worst_xy = 0, worst_area = 0, want_area = 0, want_vol = 0;
    for (int j = 0; j < g->ny; j++)
        for (int i = 0; i < g->nx; i++) {
            double lon, lat, x, y, k;
            ice_raster_cell_lonlat(r, i, j, &lon, &lat);
            fwd(lon, lat, &x, &y, &k);
            double ex = g->x0 + i * g->d, ey = g->y0 + j * g->d; /* j from y0 upward */
            worst_xy = fmax(worst_xy, fmax(fabs(x - ex), fabs(y - ey)));
            double area = g->d * g->d / (k * k);
            worst_area = fmax(worst_area, fabs(ice_raster_area(r, i, j) / area - 1));
            double c = conc_of(i, j, g->nx, g->ny);
            if ((i == 0 && j == (g->descending ? g->ny - 1 : 0)) || !(c > 0.05))
                continue; /* the missing cell; below the threshold */
            want_area += c * area;
            want_vol += c * thick_of(i, j) * area;
        }
    /* 0.01 m on the map is about 1e-7 degrees */
    CHECK(worst_xy < 0.01, "%s: cell centre off the projection formula by %g m", what, worst_xy);
    CHECK(worst_area < 1e-6, "%s: cell area off dx dy / k^2 by %g (relative)", what, worst_area);
    /* per-cell seeding carries the raster's ice */
    rp_check_seeded(what, r, want_area, want_vol, 0.05);
    /* sampling in the native coordinates: at a cell centre, that cell */
    int ci = g->nx / 2 + 1, cj = g->ny / 2 - 1;
    double lon, lat, c, h;
    ice_raster_cell_lonlat(r, ci, cj, &lon, &lat);
    CHECK(ice_raster_sample(r, lon, lat, &c, &h) && fabs(c - conc_of(ci, cj, g->nx, g->ny)) < 1e-6 &&
              fabs(h - thick_of(ci, cj)) < 1e-6,
          "%s: sample at cell (%d, %d): %g, %g m", what, ci, cj, c, h);
    ice_raster_free(r);
}

static void expect_error(const char *what, const char *path, const char *want1, const char *want2)
{
    ice_raster *r = NULL;
    sph_error err;
    sph_error_clear(&err);
    int rc = ice_raster_read(path, NULL, &r, &err);
    CHECK(rc != SPH_OK && !r, "%s: accepted", what);
    CHECK(strstr(err.msg, path) && strstr(err.msg, want1) && strstr(err.msg, want2) &&
              !strchr(err.msg, '\n'),
          "%s: message \"%s\" lacks \"%s\"/\"%s\" or is not one line", what, err.msg, want1, want2);
    ice_raster_free(r);
}

/* curvilinear: 2-D nav_lat/nav_lon of a 0.1 degree grid; area optional (km2) */
static void write_curvilinear(const char *path, int with_area)
{
    enum { NX = 30, NY = 20 };
    int ncid, d[2], vlat, vlon, vc, va;
    CHECK(nc_create(path, NC_CLOBBER | NC_NETCDF4, &ncid) == NC_NOERR, "create %s", path);
    nc_def_dim(ncid, "y", NY, &d[0]);
    nc_def_dim(ncid, "x", NX, &d[1]);
    nc_def_var(ncid, "nav_lat", NC_DOUBLE, 2, d, &vlat);
    nc_def_var(ncid, "nav_lon", NC_DOUBLE, 2, d, &vlon);
    rp_text(ncid, vlat, "units", "degrees_north");
    rp_text(ncid, vlon, "units", "degrees_east");
    rp_text(ncid, vlat, "standard_name", "latitude");
    rp_text(ncid, vlon, "standard_name", "longitude");
    nc_def_var(ncid, "siconc", NC_DOUBLE, 2, d, &vc);
    rp_text(ncid, vc, "coordinates", "nav_lat nav_lon");
    rp_text(ncid, vc, "units", "1");
    if (with_area) {
        nc_def_var(ncid, "areacello", NC_DOUBLE, 2, d, &va);
        rp_text(ncid, va, "units", "km2");
        rp_text(ncid, vc, "cell_measures", "area: areacello");
    }
    nc_enddef(ncid);
    static double la[NY * NX], lo[NY * NX], c[NY * NX], a[NY * NX];
    double f = 1 / WRF, e = sqrt(2 * f - f * f);
    for (int j = 0; j < NY; j++)
        for (int i = 0; i < NX; i++) {
            la[j * NX + i] = 72.05 + 0.1 * j;
            lo[j * NX + i] = 178.55 + 0.1 * i; /* crosses the date line */
            if (lo[j * NX + i] > 180)
                lo[j * NX + i] -= 360;
            c[j * NX + i] = 0.8;
            a[j * NX + i] = 2.5 * (1 + 0.001 * i); /* km2, the file's own */
        }
    (void)e;
    nc_put_var_double(ncid, vlat, la);
    nc_put_var_double(ncid, vlon, lo);
    nc_put_var_double(ncid, vc, c);
    if (with_area)
        nc_put_var_double(ncid, va, a);
    nc_close(ncid);
}

int main(void)
{
    char dir[] = "/tmp/sphice-test-raster-grid-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    char path[512];

    /* NSIDC CDR: 25 km, x/y in metres, y north to south, a window of the
     * 304 x 448 grid (x from -3850 km, y from 5850 km at its top edge) */
    grid_spec cdr = {"x", "y", "meters", 1.0, 40, 30, 1, -1500e3 + 12.5e3, -1000e3 + 12.5e3,
                     25e3, "cdr_seaice_conc", "1", 1.0, 1, "crs"};
    snprintf(path, sizeof path, "%s/cdr.nc", dir);
    write_projected(path, &cdr, gm_cdr_cf);
    check_projected("CDR polar stereographic (CF attributes)", path, &cdr, f_cdr);
    /* the same grid through its EPSG code (srid) */
    snprintf(path, sizeof path, "%s/cdr_epsg.nc", dir);
    write_projected(path, &cdr, gm_cdr);
    check_projected("CDR polar stereographic (EPSG:3411)", path, &cdr, f_cdr);
    /* the same with x/y in km */
    grid_spec cdrkm = cdr;
    cdrkm.units = "km";
    cdrkm.to_unit = 1e-3;
    snprintf(path, sizeof path, "%s/cdr_km.nc", dir);
    write_projected(path, &cdrkm, gm_cdr_cf);
    check_projected("CDR polar stereographic, x/y in km", path, &cdrkm, f_cdr);

    /* OSI SAF EASE2 north: xc/yc in km, ice_conc in percent */
    grid_spec ease = {"xc", "yc", "km", 1e-3, 36, 28, 1, 500e3 + 12.5e3, -2000e3 + 12.5e3, 25e3,
                      "ice_conc", "%", 100.0, 1, "Lambert_Azimuthal_Grid"};
    snprintf(path, sizeof path, "%s/osisaf_ease2.nc", dir);
    write_projected(path, &ease, gm_ease2);
    check_projected("OSI SAF EASE2 (lambert_azimuthal_equal_area)", path, &ease, f_ease2);

    snprintf(path, sizeof path, "%s/osisaf_ease2_km.nc", dir);
    write_projected(path, &ease, gm_ease2_km);
    check_projected("EASE2 from a proj4 string in km", path, &ease, f_ease2);

    /* Lambert conformal conic, spherical, x/y in km */
    grid_spec lcc = {"x", "y", "km", 1e-3, 30, 30, 0, -300e3, -200e3, 10e3, "aice", "1", 1.0, 1,
                     "Lambert_Conformal"};
    snprintf(path, sizeof path, "%s/lcc.nc", dir);
    write_projected(path, &lcc, gm_lcc);
    check_projected("Lambert conformal conic", path, &lcc, f_lcc);

    /* transverse Mercator from a proj4 attribute alone */
    grid_spec tm = {"x", "y", "m", 1.0, 25, 25, 0, 100e3, -150e3, 5e3, "siconc", "1", 1.0, 1,
                    "transverse_mercator"};
    snprintf(path, sizeof path, "%s/tm.nc", dir);
    write_projected(path, &tm, gm_tm);
    check_projected("transverse Mercator (proj4)", path, &tm, f_tm);

    /* curvilinear, geodesic areas: the lon/lat cell area on WGS84 */
    snprintf(path, sizeof path, "%s/curv.nc", dir);
    write_curvilinear(path, 0);
    {
        ice_raster *r = NULL;
        sph_error err;
        sph_error_clear(&err);
        CHECK(ice_raster_read(path, NULL, &r, &err) == SPH_OK && r, "curvilinear: %s", err.msg);
        if (r) {
            double f = 1 / WRF, e = sqrt(2 * f - f * f), worst = 0;
            for (int j = 0; j < r->nlat; j++)
                for (int i = 0; i < r->nlon; i++) {
                    double lat = 72.05 + 0.1 * j;
                    double want = ll_area(WA, e, 0.1, lat - 0.05, lat + 0.05);
                    worst = fmax(worst, fabs(ice_raster_area(r, i, j) / want - 1));
                }
            CHECK(r->kind == ICE_RASTER_CURVILINEAR && worst < 1e-4,
                  "curvilinear: kind %d, area off the ellipsoidal cell area by %g", r->kind, worst);
            double lon, lat;
            ice_raster_cell_lonlat(r, 29, 19, &lon, &lat);
            CHECK(fabs(lat - (72.05 + 1.9)) < 1e-9 && fabs(remainder(lon - (178.55 + 2.9), 360)) < 1e-9,
                  "curvilinear: cell (29, 19) at %g E %g N", lon, lat);
            /* a lattice cannot sample it: one line naming initial.spacing */
            geo_proj *p = geo_proj_create("auto", 180, 73, &err);
            seed_options so;
            seed_options_default(&so);
            so.spacing_m = 5000;
            size_t n;
            sph_error_clear(&err);
            CHECK(seed_count(r, p, NULL, &so, &n, &err) != SPH_OK &&
                      strstr(err.msg, "initial.spacing") && !strchr(err.msg, '\n'),
                  "curvilinear lattice: \"%s\"", err.msg);
            /* per cell: area = sum conc * area */
            so.spacing_m = 0;
            double want = 0;
            for (int j = 0; j < r->nlat; j++)
                for (int i = 0; i < r->nlon; i++) {
                    double la = 72.05 + 0.1 * j;
                    want += 0.8 * ll_area(WA, e, 0.1, la - 0.05, la + 0.05);
                }
            CHECK(seed_count(r, p, NULL, &so, &n, &err) == SPH_OK, "%s", err.msg);
            sph_particles *P = sph_particles_create(n + 1, 1);
            CHECK(seed_from_raster(r, p, NULL, &so, P, &err) == SPH_OK, "%s", err.msg);
            double got = 0;
            for (size_t q = 0; q < P->n; q++)
                got += P->mass[q] / (so.rho_ice * P->thick[q]);
            CHECK(fabs(got / want - 1) < 0.01, "curvilinear seeded area %g km2, raster %g km2",
                  got / 1e6, want / 1e6);
            sph_particles_free(P);
            geo_proj_free(p);
        }
        ice_raster_free(r);
    }
    snprintf(path, sizeof path, "%s/curv_area.nc", dir);
    write_curvilinear(path, 1);
    {
        ice_raster *r = NULL;
        sph_error err;
        sph_error_clear(&err);
        CHECK(ice_raster_read(path, NULL, &r, &err) == SPH_OK && r, "curvilinear+area: %s", err.msg);
        if (r)
            CHECK(fabs(ice_raster_area(r, 10, 3) - 2.5e6 * 1.01) < 1e-3,
                  "cell area variable in km2: %g m2, want %g", ice_raster_area(r, 10, 3), 2.525e6);
        ice_raster_free(r);
    }

    /* bad grids: one line naming file, variable and problem */
    grid_spec bad = cdr;
    bad.with_gm = 0;
    snprintf(path, sizeof path, "%s/nogm.nc", dir);
    write_projected(path, &bad, gm_cdr);
    expect_error("x/y in metres, no grid_mapping", path, "cdr_seaice_conc", "grid_mapping");
    bad = cdr;
    bad.units = NULL;
    snprintf(path, sizeof path, "%s/nounits.nc", dir);
    write_projected(path, &bad, gm_cdr);
    expect_error("projected x/y without units", path, "cdr_seaice_conc", "units");
    bad = cdr;
    snprintf(path, sizeof path, "%s/noellps.nc", dir);
    write_projected(path, &bad, gm_noellps);
    expect_error("no ellipsoid", path, "cdr_seaice_conc", "ellipsoid");
    snprintf(path, sizeof path, "%s/rotated.nc", dir);
    write_projected(path, &bad, gm_rotated);
    expect_error("unsupported grid mapping", path, "cdr_seaice_conc", "rotated_latitude_longitude");
    snprintf(path, sizeof path, "%s/badproj.nc", dir);
    write_projected(path, &bad, gm_badproj);
    expect_error("projection PROJ cannot build", path, "cdr_seaice_conc", "PROJ cannot build");
    bad.units = "kg";
    snprintf(path, sizeof path, "%s/kg.nc", dir);
    write_projected(path, &bad, gm_cdr);
    expect_error("x/y not a length", path, "cdr_seaice_conc", "kg");

    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    CHECK(system(cmd) == 0, "cleanup");
    return check_summary("test_raster_grid");
}
