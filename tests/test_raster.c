/* Initial ice raster and seeding.
 *
 * A synthetic field over Liaodong Bay (analytic concentration and
 * thickness, a land strip, one missing cell) is written by this test as
 * NetCDF fraction, NetCDF percent (packed short, descending latitude, a
 * time axis) and ESRI ASCII (concentration + thickness grids). All three
 * must give the same particles; the seeded mass must equal the field's ice
 * mass computed here from the analytic functions and the spherical cell
 * area R^2 dlon (sin(lat_n) - sin(lat_s)) within 0.1 %; no particle may lie
 * on land. Bad inputs must fail with a message naming file and problem. */
#include "io/raster.h"
#include "io/seed.h"

#include <netcdf.h>
#include <unistd.h>

#include "util/fileio.h"

#include "check.h"

enum { NLON = 50, NLAT = 45 };
static const double LON0 = 120.91, LAT0 = 40.01, D = 0.02; /* cell centres */
static const double RHO = 900.0, THRESH = 0.05;

static double lon_of(int i) { return LON0 + i * D; }
static double lat_of(int j) { return LAT0 + j * D; }
/* land: a coastal strip east of 121.7 E (cells i >= 40) */
static int land_cell(int i, int j) { (void)j; return i >= 40; }
static int missing_cell(int i, int j) { return i == 3 && j == 4; }
/* concentration in percent, two decimals (exact in every format) */
static double conc_pct(int i, int j)
{
    double v = 100.0 * exp(-pow((lon_of(i) - 121.4) / 0.3, 2) - pow((lat_of(j) - 40.45) / 0.25, 2));
    return round(v * 100) / 100;
}
static double thick_m(int i, int j) { return round(100 * (0.05 + 0.3 * (lat_of(j) - 40.0))) / 100; }

/* thickness as written by write_nc: units and the factor from metres */
static const char *thick_units = "m";
static double thick_factor = 1.0;

static void write_nc(const char *path, int percent, int descending, int with_thick, int fmt)
{
    int ncid, d[3], vlat, vlon, vt, vc, vh;
    CHECK(nc_create(path, NC_CLOBBER | fmt, &ncid) == NC_NOERR, "create %s", path);
    nc_def_dim(ncid, "time", 1, &d[0]);
    nc_def_dim(ncid, "lat", NLAT, &d[1]);
    nc_def_dim(ncid, "lon", NLON, &d[2]);
    nc_def_var(ncid, "time", NC_DOUBLE, 1, &d[0], &vt);
    nc_put_att_text(ncid, vt, "units", 31, "hours since 1999-02-08 00:00:00");
    nc_def_var(ncid, "lat", NC_DOUBLE, 1, &d[1], &vlat);
    nc_def_var(ncid, "lon", NC_DOUBLE, 1, &d[2], &vlon);
    nc_def_var(ncid, "ice", percent ? NC_SHORT : NC_FLOAT, 3, d, &vc);
    nc_put_att_text(ncid, vc, "standard_name", 21, "sea_ice_area_fraction");
    if (percent) {
        nc_put_att_text(ncid, vc, "units", 1, "%");
        double sf = 0.01;
        short fill = -32767;
        nc_put_att_double(ncid, vc, "scale_factor", NC_DOUBLE, 1, &sf);
        nc_put_att_short(ncid, vc, "_FillValue", NC_SHORT, 1, &fill);
    } else {
        float fill = NAN; /* NaN declared as the fill value */
        nc_put_att_float(ncid, vc, "_FillValue", NC_FLOAT, 1, &fill);
        nc_put_att_text(ncid, vc, "units", 1, "1");
    }
    if (with_thick) {
        nc_def_var(ncid, "sithick", NC_FLOAT, 3, d, &vh);
        nc_put_att_text(ncid, vh, "units", strlen(thick_units), thick_units);
    }
    nc_enddef(ncid);
    double t = 6, lat[NLAT], lon[NLON];
    for (int j = 0; j < NLAT; j++)
        lat[j] = lat_of(descending ? NLAT - 1 - j : j);
    for (int i = 0; i < NLON; i++)
        lon[i] = lon_of(i);
    nc_put_var_double(ncid, vt, &t);
    nc_put_var_double(ncid, vlat, lat);
    nc_put_var_double(ncid, vlon, lon);
    static short cs[NLAT * NLON];
    static float cf[NLAT * NLON], hf[NLAT * NLON];
    for (int jj = 0; jj < NLAT; jj++) {
        int j = descending ? NLAT - 1 - jj : jj;
        for (int i = 0; i < NLON; i++) {
            int k = jj * NLON + i;
            cs[k] = missing_cell(i, j) ? -32767 : (short)lround(conc_pct(i, j) * 100);
            cf[k] = missing_cell(i, j) ? NAN : (float)(conc_pct(i, j) / 100);
            hf[k] = (float)(thick_m(i, j) * thick_factor);
        }
    }
    if (percent)
        nc_put_var_short(ncid, vc, cs);
    else
        nc_put_var_float(ncid, vc, cf);
    if (with_thick)
        nc_put_var_float(ncid, vh, hf);
    nc_close(ncid);
}

static void write_esri(const char *path, int thick)
{
    FILE *f = fopen(path, "w");
    fprintf(f, "ncols %d\nNROWS %d\nxllcorner %.10g\nyllcorner %.10g\ncellsize %g\nNODATA_value -9999\n",
            NLON, NLAT, LON0 - D / 2, LAT0 - D / 2, D);
    for (int j = NLAT - 1; j >= 0; j--) { /* north to south */
        for (int i = 0; i < NLON; i++)
            fprintf(f, "%s%.10g", i ? " " : "",
                    missing_cell(i, j) ? -9999.0 : thick ? thick_m(i, j) : conc_pct(i, j));
        fputc('\n', f);
    }
    fclose(f);
}

static landmask *test_mask(void)
{
    static unsigned char land[NLAT * NLON];
    for (int j = 0; j < NLAT; j++)
        for (int i = 0; i < NLON; i++)
            land[j * NLON + i] = (unsigned char)land_cell(i, j);
    return landmask_create_array(NLON, NLAT, LON0 - D / 2, LAT0 - D / 2, D, D, land, NULL);
}

/* The field's ice mass, from the analytic functions (not the reader). */
static double expected_mass(double thresh)
{
    const double deg = M_PI / 180, R = 6371000.0;
    double m = 0;
    for (int j = 0; j < NLAT; j++) {
        double area = R * R * D * deg * (sin((lat_of(j) + D / 2) * deg) - sin((lat_of(j) - D / 2) * deg));
        for (int i = 0; i < NLON; i++) {
            double c = conc_pct(i, j) / 100;
            if (land_cell(i, j) || missing_cell(i, j) || !(c > thresh))
                continue;
            m += RHO * c * thick_m(i, j) * area;
        }
    }
    return m;
}

static sph_particles *seed_file(const char *path, const ice_raster_options *ro, const geo_proj *p,
                                const landmask *mask, const seed_options *so, ice_raster **keep)
{
    sph_error err;
    sph_error_clear(&err);
    ice_raster *r = NULL;
    CHECK(ice_raster_read(path, ro, &r, &err) == SPH_OK, "read %s: %s", path, err.msg);
    if (!r)
        return NULL;
    size_t n = 0;
    CHECK(seed_count(r, p, mask, so, &n, &err) == SPH_OK, "%s", err.msg);
    sph_particles *P = sph_particles_create(n + 1, 1);
    CHECK(seed_from_raster(r, p, mask, so, P, &err) == SPH_OK, "seed %s: %s", path, err.msg);
    CHECK(P->n == n, "seed_count %zu == seeded %zu", n, P->n);
    if (keep)
        *keep = r;
    else
        ice_raster_free(r);
    return P;
}

static char last_error[1024];

static void expect_error(const char *path, const ice_raster_options *o, const char *what1,
                         const char *what2)
{
    sph_error err;
    sph_error_clear(&err);
    ice_raster *r = NULL;
    CHECK(ice_raster_read(path, o, &r, &err) != SPH_OK && r == NULL, "%s must fail", path);
    CHECK(strstr(err.msg, path) != NULL || (o && o->thickness_path && strstr(err.msg, o->thickness_path)),
          "message names the file: %s", err.msg);
    if (getenv("SPHICE_TEST_VERBOSE"))
        fprintf(stderr, "expected error: %s\n", err.msg);
    snprintf(last_error, sizeof last_error, "%s", err.msg);
    CHECK(strstr(err.msg, what1) != NULL && (!what2 || strstr(err.msg, what2) != NULL),
          "message says \"%s\": %s", what1, err.msg);
}

static void chop_file(const char *src, const char *dst, double frac)
{
    char *data = NULL;
    size_t len = 0;
    sph_error err;
    sph_error_clear(&err);
    read_file(src, &data, &len, &err);
    FILE *f = fopen(dst, "wb");
    fwrite(data, 1, (size_t)(len * frac), f);
    fclose(f);
    free(data);
}

int main(void)
{
    sph_error err;
    sph_error_clear(&err);
    char dir[] = "/tmp/sphice_raster_XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    char nc_frac[512], nc_pct[512], esri_c[512], esri_h[512], p4[512];
    snprintf(nc_frac, sizeof nc_frac, "%s/frac.nc", dir);
    snprintf(nc_pct, sizeof nc_pct, "%s/pct.nc", dir);
    snprintf(esri_c, sizeof esri_c, "%s/conc.asc", dir);
    snprintf(esri_h, sizeof esri_h, "%s/thick.asc", dir);
    snprintf(p4, sizeof p4, "%s/nc4.nc", dir);
    write_nc(nc_frac, 0, 0, 1, 0);
    write_nc(nc_pct, 1, 1, 1, NC_NETCDF4);
    write_esri(esri_c, 0);
    write_esri(esri_h, 1);

    geo_proj *p = geo_proj_create("auto", 121.4, 40.45, &err);
    landmask *mask = test_mask();
    seed_options so;
    seed_options_default(&so);
    CHECK(so.threshold == THRESH, "default threshold 0.05");
    ice_raster_options ro;
    ice_raster_options_default(&ro);

    ice_raster *r = NULL;
    sph_particles *A = seed_file(nc_frac, &ro, p, mask, &so, &r);
    sph_particles *B = seed_file(nc_pct, &ro, p, mask, &so, NULL);
    ro.thickness_path = esri_h;
    ro.thickness_kind = ICE_THICK_ICE; /* an ESRI grid cannot say (issue 19 item 3) */
    sph_particles *C = seed_file(esri_c, &ro, p, mask, &so, NULL);
    ro.thickness_path = NULL;

    /* Raster contents against the analytic field. */
    if (r) {
        CHECK(r->nlon == NLON && r->nlat == NLAT, "size %d x %d", r->nlon, r->nlat);
        CHECK_CLOSE(r->lon[7], lon_of(7), 0, 1e-9, "lon");
        CHECK_CLOSE(r->lat[9], lat_of(9), 0, 1e-9, "lat");
        CHECK_CLOSE(r->conc[9 * NLON + 20], conc_pct(20, 9) / 100, 1e-6, 0, "conc fraction");
        CHECK_CLOSE(r->thick[9 * NLON + 20], thick_m(20, 9), 1e-6, 0, "thick");
        CHECK(isnan(r->conc[4 * NLON + 3]), "declared NaN fill is missing");
        CHECK_CLOSE(r->valid_time, 918453600.0, 0, 1e-6, "valid time 1999-02-08T06:00Z");
        ice_raster_free(r);
    }

    /* Thickness in other length units (udunits2), and in a unit that is
     * not a length: one line naming the file and the units. */
    {
        static const struct { const char *units; double factor; } tu[] = {
            {"cm", 100.0}, {"mm", 1000.0}, {"inch", 1.0 / 0.0254}};
        char pth[512];
        snprintf(pth, sizeof pth, "%s/thick_units.nc", dir);
        for (int q = 0; q < 3; q++) {
            thick_units = tu[q].units;
            thick_factor = tu[q].factor;
            write_nc(pth, 0, 0, 1, 0);
            ice_raster *ru = NULL;
            sph_error_clear(&err);
            CHECK(ice_raster_read(pth, NULL, &ru, &err) == SPH_OK, "%s: %s", tu[q].units, err.msg);
            if (ru)
                CHECK_CLOSE(ru->thick[9 * NLON + 20], thick_m(20, 9), 1e-6, 0, tu[q].units);
            ice_raster_free(ru);
        }
        thick_units = "K";
        thick_factor = 1.0;
        write_nc(pth, 0, 0, 1, 0);
        ice_raster *ru = NULL;
        sph_error_clear(&err);
        CHECK(ice_raster_read(pth, NULL, &ru, &err) == SPH_ERR_UNITS && ru == NULL &&
                  strstr(err.msg, pth) && strstr(err.msg, "thickness units 'K' are not a length"),
              "thickness in K: %s", err.msg);
        ice_raster_free(ru);
        thick_units = "m";
        unlink(pth);
    }

    double want = expected_mass(THRESH);
    sph_particles *sets[3] = {A, B, C};
    const char *names[3] = {"NetCDF fraction", "NetCDF percent", "ESRI ASCII"};
    for (int s = 0; s < 3; s++) {
        sph_particles *P = sets[s];
        if (!P)
            continue;
        double total = 0;
        int on_land = 0, bad = 0;
        for (size_t k = 0; k < P->n; k++) {
            total += P->mass[k];
            double lon, lat;
            geo_inverse(p, 1, &P->x[k], &P->y[k], &lon, &lat, NULL);
            int i = (int)floor((lon - (LON0 - D / 2)) / D), j = (int)floor((lat - (LAT0 - D / 2)) / D);
            on_land += land_cell(i, j);
            bad += !(P->conc[k] > THRESH && P->conc[k] <= 1 && P->thick[k] > 0 && P->sml[k] > 1000 &&
                     P->sml[k] < 3000 && P->u[k] == 0 && P->v[k] == 0 && P->id[k] == (long)k &&
                     fabs(P->lat[k] - lat) < 1e-9);
        }
        CHECK_CLOSE(total, want, 1e-3, 0, names[s]);
        CHECK(on_land == 0, "%s: %d particles on land", names[s], on_land);
        CHECK(bad == 0, "%s: %d particles with bad fields", names[s], bad);
        if (s > 0 && A && P->n == A->n) {
            double dx = 0, dm = 0;
            for (size_t k = 0; k < P->n; k++) {
                dx = fmax(dx, hypot(P->x[k] - A->x[k], P->y[k] - A->y[k]));
                dm = fmax(dm, fabs(P->mass[k] / A->mass[k] - 1));
            }
            CHECK(dx < 1e-6 && dm < 1e-6, "%s vs NetCDF fraction: position %g m, mass %g", names[s], dx, dm);
        } else if (s > 0) {
            CHECK(0, "%s gives %zu particles, NetCDF fraction %zu", names[s], P->n, A ? A->n : 0);
        }
    }

    /* Capacity: appending fails cleanly; a second raster appends with ids
     * continuing from first_id. */
    if (A) {
        ice_raster *r2 = NULL;
        ice_raster_read(nc_frac, NULL, &r2, &err);
        size_t n0 = A->n;
        sph_error_clear(&err);
        CHECK(seed_from_raster(r2, p, mask, &so, A, &err) == SPH_ERR_PARAM && A->n == n0,
              "capacity exceeded refused");
        CHECK(strstr(err.msg, "needed") != NULL, "message: %s", err.msg);
        sph_particles *Q = sph_particles_create(2 * n0, 1);
        seed_options s2 = so;
        CHECK(seed_from_raster(r2, p, mask, &so, Q, &err) == SPH_OK, "first");
        s2.first_id = 100000;
        CHECK(seed_from_raster(r2, p, mask, &s2, Q, &err) == SPH_OK, "append");
        CHECK(Q->n == 2 * n0 && Q->id[n0] == 100000 && Q->id[2 * n0 - 1] == 100000 + (long)n0 - 1,
              "ids of the appended set");
        sph_particles_free(Q);

        /* Plane lattice at 1.5 km: bilinear sampling conserves to ~1 %
         * (no mask, the field's edge is nearly ice-free; the plane is
         * ellipsoidal, the cell areas spherical: another 0.1 %). */
        seed_options sl = so;
        sl.spacing_m = 1500;
        sl.threshold = 0;
        size_t nl = 0;
        CHECK(seed_count(r2, p, NULL, &sl, &nl, &err) == SPH_OK && nl > 1000, "lattice count %zu", nl);
        sph_particles *L = sph_particles_create(nl, 1);
        CHECK(seed_from_raster(r2, p, NULL, &sl, L, &err) == SPH_OK, "%s", err.msg);
        double tl = 0;
        for (size_t k = 0; k < L->n; k++)
            tl += L->mass[k];
        /* expected: all cells, no land, threshold 0 */
        double all = 0;
        const double deg = M_PI / 180, R = 6371000.0;
        for (int j = 0; j < NLAT; j++)
            for (int i = 0; i < NLON; i++)
                if (!missing_cell(i, j))
                    all += RHO * conc_pct(i, j) / 100 * thick_m(i, j) * R * R * D * deg *
                           (sin((lat_of(j) + D / 2) * deg) - sin((lat_of(j) - D / 2) * deg));
        CHECK_CLOSE(tl, all, 0.03, 0, "lattice seeding mass within 3 %");
        CHECK_CLOSE(L->sml[0], 1500, 1e-12, 0, "lattice sml = spacing");
        sph_particles_free(L);
        ice_raster_free(r2);
    }

    /* Missing thickness: the default applies. */
    write_nc(p4, 0, 0, 0, NC_NETCDF4);
    ro.default_thickness = 0.25;
    ice_raster *r3 = NULL;
    CHECK(ice_raster_read(p4, &ro, &r3, &err) == SPH_OK, "%s", err.msg);
    if (r3)
        CHECK_CLOSE(r3->thick[10 * NLON + 10], 0.25, 0, 1e-12, "default thickness");
    ice_raster_free(r3);
    ro.default_thickness = 0.1;

    /* Bad input. */
    char bad[512];
    snprintf(bad, sizeof bad, "%s/chopped.nc", dir);
    chop_file(nc_frac, bad, 0.6);
    expect_error(bad, NULL, "NetCDF", NULL);
    snprintf(bad, sizeof bad, "%s/chopped4.nc", dir);
    chop_file(nc_pct, bad, 0.5);
    expect_error(bad, NULL, "NetCDF", NULL);
    /* missing variable: the thickness-only file is the percent file without "ice" */
    {
        snprintf(bad, sizeof bad, "%s/nothick.nc", dir);
        int ncid, dd[2], v;
        nc_create(bad, NC_CLOBBER, &ncid);
        nc_def_dim(ncid, "lat", 3, &dd[0]);
        nc_def_dim(ncid, "lon", 3, &dd[1]);
        nc_def_var(ncid, "sithick", NC_FLOAT, 2, dd, &v);
        nc_close(ncid);
        expect_error(bad, NULL, "missing variable", "sea_ice_area_fraction");
    }
    /* NaN not declared as fill; 150 %; negative thickness (ESRI) */
    {
        snprintf(bad, sizeof bad, "%s/nan.nc", dir);
        int ncid, dd[2], vla, vlo, v;
        nc_create(bad, NC_CLOBBER, &ncid);
        nc_def_dim(ncid, "lat", 2, &dd[0]);
        nc_def_dim(ncid, "lon", 2, &dd[1]);
        nc_def_var(ncid, "lat", NC_DOUBLE, 1, &dd[0], &vla);
        nc_def_var(ncid, "lon", NC_DOUBLE, 1, &dd[1], &vlo);
        nc_def_var(ncid, "siconc", NC_DOUBLE, 2, dd, &v);
        double fill = -1;
        nc_put_att_double(ncid, v, "_FillValue", NC_DOUBLE, 1, &fill);
        nc_enddef(ncid);
        double la[2] = {40, 40.1}, lo[2] = {121, 121.1}, val[4] = {0.5, NAN, 0.2, 0.3};
        nc_put_var_double(ncid, vla, la);
        nc_put_var_double(ncid, vlo, lo);
        nc_put_var_double(ncid, v, val);
        nc_close(ncid);
        expect_error(bad, NULL, "NaN", NULL);
    }
    snprintf(bad, sizeof bad, "%s/c150.asc", dir);
    FILE *f = fopen(bad, "w");
    fprintf(f, "ncols 2\nnrows 2\nxllcenter 121\nyllcenter 40\ncellsize 0.1\nNODATA_value -9999\n"
               "50 150\n20 30\n");
    fclose(f);
    expect_error(bad, NULL, "concentration 150 %", "outside 0..100 %");
    snprintf(bad, sizeof bad, "%s/trunc.asc", dir);
    f = fopen(bad, "w");
    fprintf(f, "ncols 3\nnrows 2\nxllcenter 121\nyllcenter 40\ncellsize 0.1\n50 60 70\n20\n");
    fclose(f);
    expect_error(bad, NULL, "truncated", "4 of 6");
    snprintf(bad, sizeof bad, "%s/nanesri.asc", dir);
    f = fopen(bad, "w");
    fprintf(f, "ncols 2\nnrows 2\nxllcenter 121\nyllcenter 40\ncellsize 0.1\nNODATA_value -9999\n"
               "50 nan\n20 30\n");
    fclose(f);
    expect_error(bad, NULL, "NaN", "row 1 column 2");
    {
        char th[512];
        snprintf(th, sizeof th, "%s/neg.asc", dir);
        f = fopen(th, "w");
        fprintf(f, "ncols 2\nnrows 2\nxllcenter 121\nyllcenter 40\ncellsize 0.1\n0.1 -0.2\n0.3 0.3\n");
        fclose(f);
        snprintf(bad, sizeof bad, "%s/ok.asc", dir);
        f = fopen(bad, "w");
        fprintf(f, "ncols 2\nnrows 2\nxllcenter 121\nyllcenter 40\ncellsize 0.1\n50 60\n20 30\n");
        fclose(f);
        ice_raster_options o2;
        ice_raster_options_default(&o2);
        o2.thickness_path = th;
        o2.thickness_kind = ICE_THICK_ICE;
        expect_error(bad, &o2, "negative thickness", "-0.2");
        CHECK(strstr(last_error, th) != NULL, "names the thickness file: %s", last_error);
        /* issue 21 item 8: a 1e6 m thickness is bad input, refused at reading */
        f = fopen(th, "w");
        fprintf(f, "ncols 2\nnrows 2\nxllcenter 121\nyllcenter 40\ncellsize 0.1\n0.1 1e6\n0.3 0.3\n");
        fclose(f);
        expect_error(bad, &o2, "not sea ice", "1e+06 m");
        CHECK(strstr(last_error, th) != NULL, "names the thickness file: %s", last_error);
    }
    /* found by tests/fuzz/fuzz_raster: a header count beyond long (undefined
     * behaviour of the cast) or not whole (silently truncated) is refused
     * naming the key and the value */
    static const struct { const char *file, *text, *key, *value; } counts[] = {
        {"hugecols.asc", "ncols 4.4e20\nnrows 2\n", "ncols", "4.4e+20"},
        {"halfrows.asc", "ncols 2\nnrows 2.5\n", "nrows", "2.5"},
    };
    for (size_t k = 0; k < sizeof counts / sizeof counts[0]; k++) {
        char text[256];
        int len = snprintf(text, sizeof text, "%sxllcenter 121\nyllcenter 40\ncellsize 0.1\n50 60\n20 30\n",
                           counts[k].text);
        sph_error werr;
        sph_error_clear(&werr);
        snprintf(bad, sizeof bad, "%s/%s", dir, counts[k].file);
        CHECK(atomic_write_file(bad, text, (size_t)len, &werr) == SPH_OK, "%s", werr.msg);
        expect_error(bad, NULL, counts[k].key, counts[k].value);
    }
    snprintf(bad, sizeof bad, "%s/junk.txt", dir);
    f = fopen(bad, "w");
    fprintf(f, "hello\n");
    fclose(f);
    expect_error(bad, NULL, "neither NetCDF nor", NULL);

    sph_particles_free(A);
    sph_particles_free(B);
    sph_particles_free(C);
    landmask_free(mask);
    geo_proj_free(p);
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    CHECK(system(cmd) == 0, "cleanup");
    return check_summary("test_raster");
}
