/* Seeding conserves the raster (issue 19 item 4).
 *
 * The test writes CF lon/lat rasters (sea_ice_area_fraction,
 * sea_ice_thickness with cell_methods "area: mean where sea_ice") over
 * Liaodong Bay: a sharp patch (concentration 0.9, 0.7 m) in open water
 * (0, 0 m), and a smooth Gaussian field. Their ice area sum(A dA) and
 * volume sum(A h dA) are computed here with the spherical cell area
 * R^2 dlon (sin(lat_n) - sin(lat_s)), R = 6371 km. The particles seeded
 * by the lattice (initial.spacing > 0) and per cell must carry the same
 * area (sum mass / (rho h)) and volume (sum mass / rho) within 1 %, and
 * no particle of the sharp patch may take a thickness other than 0.7 m
 * (the open-water zeros must not be mixed in). */
#include "io/raster.h"
#include "io/seed.h"

#include <netcdf.h>
#include <unistd.h>

#include "check.h"

enum { NLON = 60, NLAT = 50 };
static const double LON0 = 120.81, LAT0 = 39.91, D = 0.02, RHO = 900.0;
static const double PATCH_C = 0.9, PATCH_H = 0.7;

static double lon_of(int i) { return LON0 + i * D; }
static double lat_of(int j) { return LAT0 + j * D; }

static int in_patch(int i, int j) { return i >= 17 && i < 41 && j >= 14 && j < 33; }
static double field_conc(int smooth, int i, int j)
{
    if (!smooth)
        return in_patch(i, j) ? PATCH_C : 0.0;
    double v = exp(-pow((lon_of(i) - 121.4) / 0.2, 2) - pow((lat_of(j) - 40.4) / 0.15, 2));
    return v < 0.01 ? 0.0 : v;
}
static double field_thick(int smooth, int i, int j)
{
    if (!smooth)
        return in_patch(i, j) ? PATCH_H : 0.0;
    return field_conc(1, i, j) > 0 ? 0.2 + 0.5 * field_conc(1, i, j) : 0.0;
}

static void write_raster(const char *path, int smooth)
{
    int nc, d[2], vlat, vlon, vc, vh;
    CHECK(nc_create(path, NC_CLOBBER, &nc) == NC_NOERR, "create %s", path);
    nc_def_dim(nc, "lat", NLAT, &d[0]);
    nc_def_dim(nc, "lon", NLON, &d[1]);
    nc_def_var(nc, "lat", NC_DOUBLE, 1, &d[0], &vlat);
    nc_put_att_text(nc, vlat, "units", 13, "degrees_north");
    nc_put_att_text(nc, vlat, "standard_name", 8, "latitude");
    nc_def_var(nc, "lon", NC_DOUBLE, 1, &d[1], &vlon);
    nc_put_att_text(nc, vlon, "units", 12, "degrees_east");
    nc_put_att_text(nc, vlon, "standard_name", 9, "longitude");
    nc_def_var(nc, "siconc", NC_DOUBLE, 2, d, &vc);
    nc_put_att_text(nc, vc, "standard_name", 21, "sea_ice_area_fraction");
    nc_put_att_text(nc, vc, "units", 1, "1");
    nc_def_var(nc, "sithick", NC_DOUBLE, 2, d, &vh);
    nc_put_att_text(nc, vh, "standard_name", 17, "sea_ice_thickness");
    nc_put_att_text(nc, vh, "units", 1, "m");
    nc_put_att_text(nc, vh, "cell_methods", 24, "area: mean where sea_ice");
    nc_enddef(nc);
    double lat[NLAT], lon[NLON];
    static double c[NLAT * NLON], h[NLAT * NLON];
    for (int j = 0; j < NLAT; j++)
        lat[j] = lat_of(j);
    for (int i = 0; i < NLON; i++)
        lon[i] = lon_of(i);
    for (int j = 0; j < NLAT; j++)
        for (int i = 0; i < NLON; i++) {
            c[j * NLON + i] = field_conc(smooth, i, j);
            h[j * NLON + i] = field_thick(smooth, i, j);
        }
    nc_put_var_double(nc, vlat, lat);
    nc_put_var_double(nc, vlon, lon);
    nc_put_var_double(nc, vc, c);
    nc_put_var_double(nc, vh, h);
    nc_close(nc);
}

/* the raster's ice area (m^2) and volume (m^3), from the functions above */
static void raster_totals(int smooth, double *area, double *vol)
{
    const double deg = M_PI / 180, R = 6371000.0;
    *area = *vol = 0;
    for (int j = 0; j < NLAT; j++)
        for (int i = 0; i < NLON; i++) {
            double a = R * R * D * deg * (sin((lat_of(j) + D / 2) * deg) - sin((lat_of(j) - D / 2) * deg));
            *area += field_conc(smooth, i, j) * a;
            *vol += field_conc(smooth, i, j) * field_thick(smooth, i, j) * a;
        }
}

static void seed_case(const char *path, int smooth, double spacing, const geo_proj *p)
{
    const char *what = smooth ? "smooth field" : "sharp 0.7 m patch";
    sph_error err;
    sph_error_clear(&err);
    ice_raster *r = NULL;
    CHECK(ice_raster_read(path, NULL, &r, &err) == SPH_OK, "read %s: %s", path, err.msg);
    if (!r)
        return;
    seed_options so;
    seed_options_default(&so);
    so.threshold = 0;
    so.spacing_m = spacing;
    so.rho_ice = RHO;
    size_t n = 0;
    CHECK(seed_count(r, p, NULL, &so, &n, &err) == SPH_OK && n > 50, "%s: count %zu %s", what, n, err.msg);
    sph_particles *P = sph_particles_create(n ? n : 1, 1);
    seed_totals t;
    CHECK(seed_from_raster_totals(r, p, NULL, &so, P, &t, &err) == SPH_OK && P->n == n, "%s: seed: %s",
          what, err.msg);
    double area = 0, vol = 0, want_a, want_v, hmin = INFINITY, hmax = -INFINITY;
    for (size_t k = 0; k < P->n; k++) {
        vol += P->mass[k] / RHO;
        area += P->mass[k] / (RHO * P->thick[k]);
        hmin = fmin(hmin, P->thick[k]);
        hmax = fmax(hmax, P->thick[k]);
    }
    raster_totals(smooth, &want_a, &want_v);
    printf("%s, %s: raster %.6g km2 %.6g km3; seeded %.6g km2 (%+.3f %%) %.6g km3 (%+.3f %%); "
           "lattice before scaling %+.3f %% area, %+.3f %% volume; thickness %.4g..%.4g m\n",
           what, spacing > 0 ? "lattice" : "per cell", want_a / 1e6, want_v / 1e9, area / 1e6,
           100 * (area / want_a - 1), vol / 1e9, 100 * (vol / want_v - 1),
           100 * (t.raw_area_m2 / want_a - 1), 100 * (t.raw_volume_m3 / want_v - 1), hmin, hmax);
    CHECK_CLOSE(area, want_a, 0.01, 0, "seeded ice area within 1 % of the raster's");
    CHECK_CLOSE(vol, want_v, 0.01, 0, "seeded ice volume within 1 % of the raster's");
    CHECK_CLOSE(t.seeded_area_m2, area, 1e-9, 0, "totals: seeded area");
    CHECK_CLOSE(t.seeded_volume_m3, vol, 1e-9, 0, "totals: seeded volume");
    CHECK_CLOSE(t.raster_area_m2, want_a, 0.002, 0, "totals: the raster's area");
    CHECK_CLOSE(t.raster_volume_m3, want_v, 0.002, 0, "totals: the raster's volume");
    if (!smooth) {
        /* every particle is 0.7 m ice: no open-water zero mixed in */
        CHECK(hmin > PATCH_H * 0.99 && hmax < PATCH_H * 1.01, "%s: thickness %.4g..%.4g m, want %.2g",
              what, hmin, hmax, PATCH_H);
    }
    sph_particles_free(P);
    ice_raster_free(r);
}

int main(void)
{
    char dir[] = "/tmp/sphice_seedcons_XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    char sharp[600], smooth[600];
    snprintf(sharp, sizeof sharp, "%s/sharp.nc", dir);
    snprintf(smooth, sizeof smooth, "%s/smooth.nc", dir);
    write_raster(sharp, 0);
    write_raster(smooth, 1);
    sph_error err;
    sph_error_clear(&err);
    geo_proj *p = geo_proj_create("auto", 121.4, 40.4, &err);
    CHECK(p != NULL, "projection: %s", err.msg);
    const double spacings[] = {0, 2222.4, 1500, 3000};
    for (size_t s = 0; p && s < sizeof spacings / sizeof spacings[0]; s++) {
        seed_case(sharp, 0, spacings[s], p);
        seed_case(smooth, 1, spacings[s], p);
    }
    geo_proj_free(p);
    unlink(sharp);
    unlink(smooth);
    rmdir(dir);
    return check_summary("test_seed_conserve");
}
