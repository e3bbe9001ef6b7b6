/* Ice-model output as the initial raster (issue 19 items 2 and 3):
 *  - CMIP6 / CMOR sea-ice variables (Notz et al. 2016, SIMIP): siconc in
 *    %, sithick with cell_methods "area: mean where sea_ice" (the ice
 *    itself), sivol with "area: mean where sea" (volume per cell area);
 *  - a ROMS-style file on its curvilinear rho grid (lat_rho/lon_rho),
 *    aice as a packed short with an add_offset (so zero is stored as a
 *    few 1e-6 below 0) and hice with long_name "average ice thickness in
 *    cell" (a cell mean);
 *  - fice / hice without metadata that says what hice is.
 * Asserts: the thickness kind decided from the metadata, a cell mean
 * divided by the concentration (seeded volume = sum of the cell-mean
 * thickness x cell area, seeded area = sum A x cell area, within 1 %),
 * the packing artefact read as 0 and a real negative value refused, and
 * an undecidable thickness refused in one line naming
 * initial.thickness_kind. Cell areas: the ellipsoidal (WGS84) lon/lat
 * cell, Snyder eq. 3-12. */
#include <unistd.h>

#include "raster_provider.h"

enum { NX = 24, NY = 18 };
static const double LON0 = 30.05, LAT0 = 75.05, D = 0.1, WA = 6378137.0, WRF = 298.257223563;

static double conc(int i, int j) { return i < 4 ? 0 : fmin(1, 0.3 + 0.03 * i + 0.01 * j); }
static double hice_ice(int i, int j) { return 0.4 + 0.05 * j + 0.01 * i; } /* per ice area */

static double cell_area(int j)
{
    double f = 1 / WRF, e = sqrt(2 * f - f * f), lat = LAT0 + j * D;
    return WA * WA * D * RP_DEG * (rp_q((lat + D / 2) * RP_DEG, e) - rp_q((lat - D / 2) * RP_DEG, e)) / 2;
}

static void write_cmip(const char *path)
{
    int ncid, d[3], vt, vlat, vlon, vc, vh, vv;
    CHECK(nc_create(path, NC_CLOBBER | NC_NETCDF4, &ncid) == NC_NOERR, "create %s", path);
    nc_def_dim(ncid, "time", 1, &d[0]);
    nc_def_dim(ncid, "lat", NY, &d[1]);
    nc_def_dim(ncid, "lon", NX, &d[2]);
    nc_def_var(ncid, "time", NC_DOUBLE, 1, &d[0], &vt);
    rp_text(ncid, vt, "units", "days since 1850-01-01");
    nc_def_var(ncid, "lat", NC_DOUBLE, 1, &d[1], &vlat);
    rp_text(ncid, vlat, "units", "degrees_north");
    rp_text(ncid, vlat, "standard_name", "latitude");
    nc_def_var(ncid, "lon", NC_DOUBLE, 1, &d[2], &vlon);
    rp_text(ncid, vlon, "units", "degrees_east");
    rp_text(ncid, vlon, "standard_name", "longitude");
    nc_def_var(ncid, "siconc", NC_FLOAT, 3, d, &vc);
    rp_text(ncid, vc, "standard_name", "sea_ice_area_fraction");
    rp_text(ncid, vc, "units", "%");
    rp_text(ncid, vc, "cell_methods", "area: mean where sea time: mean");
    nc_def_var(ncid, "sithick", NC_FLOAT, 3, d, &vh);
    rp_text(ncid, vh, "standard_name", "sea_ice_thickness");
    rp_text(ncid, vh, "units", "m");
    rp_text(ncid, vh, "cell_methods", "area: time: mean where sea_ice (comment: mask=siconc)");
    nc_def_var(ncid, "sivol", NC_FLOAT, 3, d, &vv);
    rp_text(ncid, vv, "standard_name", "sea_ice_thickness");
    rp_text(ncid, vv, "long_name", "Sea-Ice Volume per Area");
    rp_text(ncid, vv, "units", "m");
    rp_text(ncid, vv, "cell_methods", "area: mean where sea time: mean");
    nc_enddef(ncid);
    double t = 54000, la[NY], lo[NX];
    nc_put_var_double(ncid, vt, &t);
    for (int j = 0; j < NY; j++)
        la[j] = LAT0 + j * D;
    for (int i = 0; i < NX; i++)
        lo[i] = LON0 + i * D;
    nc_put_var_double(ncid, vlat, la);
    nc_put_var_double(ncid, vlon, lo);
    static float c[NY * NX], h[NY * NX], v[NY * NX];
    for (int j = 0; j < NY; j++)
        for (int i = 0; i < NX; i++) {
            c[j * NX + i] = (float)(100 * conc(i, j));
            h[j * NX + i] = conc(i, j) > 0 ? (float)hice_ice(i, j) : 0.f;
            v[j * NX + i] = (float)(conc(i, j) * hice_ice(i, j));
        }
    nc_put_var_float(ncid, vc, c);
    nc_put_var_float(ncid, vh, h);
    nc_put_var_float(ncid, vv, v);
    nc_close(ncid);
}

/* ROMS: packed aice, hice a cell mean, curvilinear rho grid. bad_raw: put
 * a truly negative concentration (-0.01) in one cell. */
static const double SCALE = 3.0518e-05, OFFSET = 0.9;
static void write_roms(const char *path, int bad_raw, int hice_meta)
{
    int ncid, d[3], vt, vlat, vlon, vc, vh;
    CHECK(nc_create(path, NC_CLOBBER | NC_NETCDF4, &ncid) == NC_NOERR, "create %s", path);
    nc_def_dim(ncid, "ocean_time", 1, &d[0]);
    nc_def_dim(ncid, "eta_rho", NY, &d[1]);
    nc_def_dim(ncid, "xi_rho", NX, &d[2]);
    nc_def_var(ncid, "ocean_time", NC_DOUBLE, 1, &d[0], &vt);
    rp_text(ncid, vt, "units", "seconds since 1970-01-01 00:00:00");
    nc_def_var(ncid, "lat_rho", NC_DOUBLE, 2, &d[1], &vlat);
    rp_text(ncid, vlat, "long_name", "latitude of RHO-points");
    rp_text(ncid, vlat, "units", "degree_north");
    rp_text(ncid, vlat, "standard_name", "latitude");
    nc_def_var(ncid, "lon_rho", NC_DOUBLE, 2, &d[1], &vlon);
    rp_text(ncid, vlon, "long_name", "longitude of RHO-points");
    rp_text(ncid, vlon, "units", "degree_east");
    rp_text(ncid, vlon, "standard_name", "longitude");
    nc_def_var(ncid, "aice", NC_SHORT, 3, d, &vc);
    rp_text(ncid, vc, "long_name", "fraction of cell covered by ice");
    rp_text(ncid, vc, "coordinates", "lon_rho lat_rho ocean_time");
    rp_num(ncid, vc, "scale_factor", SCALE);
    rp_num(ncid, vc, "add_offset", OFFSET);
    short fill = -32767;
    nc_put_att_short(ncid, vc, "_FillValue", NC_SHORT, 1, &fill);
    nc_def_var(ncid, "hice", NC_FLOAT, 3, d, &vh);
    if (hice_meta)
        rp_text(ncid, vh, "long_name", "average ice thickness in cell");
    rp_text(ncid, vh, "units", "meter");
    rp_text(ncid, vh, "coordinates", "lon_rho lat_rho ocean_time");
    nc_enddef(ncid);
    double t = 9.18e8;
    nc_put_var_double(ncid, vt, &t);
    static double la[NY * NX], lo[NY * NX];
    static short c[NY * NX];
    static float h[NY * NX];
    for (int j = 0; j < NY; j++)
        for (int i = 0; i < NX; i++) {
            la[j * NX + i] = LAT0 + j * D;
            lo[j * NX + i] = LON0 + i * D;
            c[j * NX + i] = (short)lround((conc(i, j) - OFFSET) / SCALE);
            h[j * NX + i] = (float)(conc(i, j) * hice_ice(i, j)); /* the cell mean */
        }
    if (bad_raw)
        c[5 * NX + 2] = (short)lround((-0.01 - OFFSET) / SCALE);
    nc_put_var_double(ncid, vlat, la);
    nc_put_var_double(ncid, vlon, lo);
    nc_put_var_short(ncid, vc, c);
    nc_put_var_float(ncid, vh, h);
    nc_close(ncid);
}

static ice_raster *read_ok(const char *what, const char *path, const char *thick_var, int kind)
{
    ice_raster_options o;
    ice_raster_options_default(&o);
    o.thick_variable = thick_var;
    o.thickness_kind = kind;
    ice_raster *r = NULL;
    sph_error err;
    sph_error_clear(&err);
    CHECK(ice_raster_read(path, &o, &r, &err) == SPH_OK && r, "%s: %s", what, err.msg);
    return r;
}

static void expect_refused(const char *what, const char *path, const char *thick_var,
                           const char *want)
{
    ice_raster_options o;
    ice_raster_options_default(&o);
    o.thick_variable = thick_var;
    ice_raster *r = NULL;
    sph_error err;
    sph_error_clear(&err);
    CHECK(ice_raster_read(path, &o, &r, &err) != SPH_OK && !r && strstr(err.msg, path) &&
              strstr(err.msg, want) && !strchr(err.msg, '\n'),
          "%s: \"%s\" (want one line with \"%s\")", what, err.msg, want);
    ice_raster_free(r);
}

int main(void)
{
    char dir[] = "/tmp/sphice-test-raster-models-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    char path[512];
    double want_area = 0, want_vol = 0;
    for (int j = 0; j < NY; j++)
        for (int i = 0; i < NX; i++)
            if (conc(i, j) > 0.05) {
                want_area += conc(i, j) * cell_area(j);
                want_vol += conc(i, j) * hice_ice(i, j) * cell_area(j);
            }

    /* CMIP6: sithick per ice area, sivol a cell mean: the same ice */
    snprintf(path, sizeof path, "%s/siconc_SImon_model_historical_r1i1p1f1_gn_199902.nc", dir);
    write_cmip(path);
    ice_raster *r = read_ok("CMIP6 sithick", path, "sithick", ICE_THICK_AUTO);
    if (r) {
        CHECK(r->thickness_kind == ICE_THICK_ICE, "sithick: kind %d (%s)", r->thickness_kind,
              r->thickness_why);
        /* the reader's lon/lat cell area is on the sphere (6371 km): compare
         * against that for the regular grid, which is unchanged */
        double sa = 0, sv = 0;
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++)
                if (conc(i, j) > 0.05) {
                    double s = ICE_RASTER_EARTH_RADIUS * ICE_RASTER_EARTH_RADIUS * D * RP_DEG *
                               (sin((LAT0 + j * D + D / 2) * RP_DEG) - sin((LAT0 + j * D - D / 2) * RP_DEG));
                    sa += conc(i, j) * s;
                    sv += conc(i, j) * hice_ice(i, j) * s;
                }
        rp_check_seeded("CMIP6 sithick", r, sa, sv, 0.05);
        ice_raster_free(r);
        r = read_ok("CMIP6 sivol", path, "sivol", ICE_THICK_AUTO);
        if (r) {
            CHECK(r->thickness_kind == ICE_THICK_CELL_MEAN, "sivol: kind %d (%s)", r->thickness_kind,
                  r->thickness_why);
            rp_check_seeded("CMIP6 sivol (cell mean)", r, sa, sv, 0.05);
        }
        ice_raster_free(r);
    }

    /* ROMS: curvilinear, packed aice with the artefact, hice a cell mean */
    snprintf(path, sizeof path, "%s/ocean_his_arctic.nc", dir);
    write_roms(path, 0, 1);
    {
        /* the artefact is there: zero stored below 0, within half a step */
        short raw = (short)lround((0 - OFFSET) / SCALE);
        double stored = OFFSET + raw * SCALE;
        CHECK(stored < -1e-6 && stored > -SCALE / 2, "test setup: zero stored as %g", stored);
    }
    r = read_ok("ROMS aice/hice", path, NULL, ICE_THICK_AUTO);
    if (r) {
        CHECK(r->kind == ICE_RASTER_CURVILINEAR, "ROMS: kind %d", r->kind);
        CHECK(r->thickness_kind == ICE_THICK_CELL_MEAN, "ROMS hice: kind %d (%s)", r->thickness_kind,
              r->thickness_why);
        CHECK(r->conc[0] == 0, "packing artefact read as %g, want 0", r->conc[0]);
        CHECK(fabs(r->thick[5 * NX + 10] - hice_ice(10, 5)) < 1e-5,
              "cell mean / A: %g m, want %g m", r->thick[5 * NX + 10], hice_ice(10, 5));
        rp_check_seeded("ROMS aice/hice (cell mean)", r, want_area, want_vol, 0.05);
    }
    ice_raster_free(r);
    snprintf(path, sizeof path, "%s/ocean_his_bad.nc", dir);
    write_roms(path, 1, 1);
    expect_refused("a real negative concentration", path, NULL, "outside 0..1");

    /* fice/hice-style: hice without metadata cannot be decided */
    snprintf(path, sizeof path, "%s/ocean_his_nometa.nc", dir);
    write_roms(path, 0, 0);
    expect_refused("hice without metadata", path, NULL, "initial.thickness_kind");
    r = read_ok("hice with initial.thickness_kind cell_mean", path, NULL, ICE_THICK_CELL_MEAN);
    if (r)
        CHECK(fabs(r->thick[5 * NX + 10] - hice_ice(10, 5)) < 1e-5, "cell_mean by key: %g m",
              r->thick[5 * NX + 10]);
    ice_raster_free(r);

    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    CHECK(system(cmd) == 0, "cleanup");
    return check_summary("test_raster_models");
}
