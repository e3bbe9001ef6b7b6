/* Ice-edge scores (io/verify.h) against analytic areas. */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <unistd.h>

#include "check.h"
#include "io/verify.h"
#include "util/fileio.h"

#define R_KM 6371.0

/* Binary disc of radius r_km centred x0_km east of (0, 0) on an
 * equatorial grid, where 1 degree = R pi / 180 km in both directions
 * (cos(lat) differs from 1 by < 2e-4 within 1.2 degrees of the equator). */
static void disc(const prod_grid *g, double x0_km, double r_km, double *c)
{
    double km_per_deg = R_KM * M_PI / 180;
    for (int j = 0; j < g->nlat; j++)
        for (int i = 0; i < g->nlon; i++) {
            double x = (g->lon0 + i * g->dlon) * km_per_deg - x0_km;
            double y = (g->lat0 + j * g->dlat) * km_per_deg;
            c[j * g->nlon + i] = hypot(x, y) < r_km ? 0.9 : 0.05;
        }
}

/* Area of the symmetric difference of two discs of radius r, centres d
 * apart: 2 (pi r^2 - lens). */
static double symdiff_area(double r, double d)
{
    double lens = 2 * r * r * acos(d / (2 * r)) - 0.5 * d * sqrt(4 * r * r - d * d);
    return 2 * (M_PI * r * r - lens);
}

int main(void)
{
    prod_grid g = { 241, 241, -1.2, -1.2, 0.01, 0.01 };
    size_t nn = (size_t)g.nlon * g.nlat;
    double *a = malloc(nn * sizeof *a), *b = malloc(nn * sizeof *b), *p = malloc(nn * sizeof *p);
    double r = 60, d = 30;
    double cell_km2 = prod_grid_cell_area_m2(&g, g.nlat / 2) * 1e-6;
    sph_error err;
    sph_error_clear(&err);
    verify_scores s;

    /* identical fields */
    disc(&g, 0, r, a);
    CHECK(verify_compute(&g, a, a, NULL, NULL, 0.15, &s, &err) == SPH_OK, "%s", err.msg);
    CHECK(s.iiee_km2 == 0 && s.over_km2 == 0 && s.under_km2 == 0, "identical: IIEE %g", s.iiee_km2);
    CHECK(s.conc_bias == 0 && s.conc_rmse == 0, "identical: bias %g rmse %g", s.conc_bias,
          s.conc_rmse);
    CHECK(isnan(s.skill_persistence), "no persistence: skill NaN");
    CHECK_CLOSE(s.edge_length_obs_km, 2 * M_PI * r, 0.1, 0, "disc edge length ~ circumference");

    /* two discs d apart */
    disc(&g, d / 2, r, a);
    disc(&g, -d / 2, r, b);
    CHECK(verify_compute(&g, a, b, NULL, NULL, 0.15, &s, &err) == SPH_OK, "%s", err.msg);
    double want = symdiff_area(r, d);
    /* one cell's area per boundary cell crossed: 2 circles of 2 pi r */
    double boundary_cells = 2 * 2 * M_PI * r / (g.dlon * R_KM * M_PI / 180);
    CHECK_CLOSE(s.iiee_km2, want, 0, 0.5 * boundary_cells * cell_km2, "IIEE of offset discs");
    CHECK_CLOSE(s.over_km2 + s.under_km2, s.iiee_km2, 1e-12, 0, "O + U = IIEE");
    CHECK_CLOSE(s.me_km2 + s.aee_km2, s.iiee_km2, 1e-12, 0, "ME + AEE = IIEE");
    CHECK_CLOSE(s.over_km2, want / 2, 0, 0.5 * boundary_cells * cell_km2, "O is half by symmetry");
    CHECK(s.aee_km2 < 0.05 * want, "equal discs: small extent error %g", s.aee_km2);
    CHECK_CLOSE(s.displacement_km, s.iiee_km2 / s.edge_length_obs_km, 1e-12, 0, "displacement");
    CHECK_CLOSE(s.conc_bias, 0, 0, 0.01, "equal-area discs: bias ~ 0");

    /* persistence: the initial field is 2d away, the forecast d away */
    disc(&g, -d / 2 + 2 * d, r, p);
    CHECK(verify_compute(&g, a, b, p, NULL, 0.15, &s, &err) == SPH_OK, "%s", err.msg);
    double want_skill = 1 - symdiff_area(r, d) / symdiff_area(r, 2 * d);
    CHECK_CLOSE(s.skill_persistence, want_skill, 0.02, 0, "skill against persistence");

    /* bias and RMSE over sea only: land cells carry wild values */
    unsigned char *land = calloc(nn, 1);
    for (size_t k = 0; k < nn; k++) {
        land[k] = k % 7 == 0;
        a[k] = land[k] ? 50.0 : 0.8;
        b[k] = land[k] ? -9.0 : 0.6;
    }
    CHECK(verify_compute(&g, a, b, NULL, land, 0.15, &s, &err) == SPH_OK, "%s", err.msg);
    CHECK_CLOSE(s.conc_bias, 0.2, 1e-9, 0, "uniform bias");
    CHECK_CLOSE(s.conc_rmse, 0.2, 1e-9, 0, "uniform rmse");
    CHECK(s.iiee_km2 == 0, "both all ice: IIEE 0");
    long nsea = 0;
    for (size_t k = 0; k < nn; k++)
        nsea += !land[k];
    CHECK(s.ncells == nsea, "compared %ld sea cells of %ld", s.ncells, nsea);

    /* JSON summary parses and carries the scores */
    char dir[] = "/tmp/sphice-verify-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    char path[256];
    snprintf(path, sizeof path, "%s/scores.json", dir);
    s.valid_time = 86400;
    CHECK(verify_write_json(path, &s, "cycle_time", "1970-01-01T00:00:00Z", &err) == SPH_OK,
          "%s", err.msg);
    char *text = NULL;
    CHECK(read_file(path, &text, NULL, &err) == SPH_OK, "%s", err.msg);
    cJSON *o = text ? cJSON_Parse(text) : NULL;
    CHECK(o != NULL, "scores.json parses");
    if (o) {
        cJSON *v = cJSON_GetObjectItem(o, "concentration_bias");
        CHECK(cJSON_IsNumber(v) && fabs(v->valuedouble - 0.2) < 1e-9, "bias in JSON");
        CHECK(cJSON_IsNull(cJSON_GetObjectItem(o, "skill_vs_persistence")), "NaN as null");
        cJSON *t = cJSON_GetObjectItem(o, "valid_time");
        CHECK(cJSON_IsString(t) && strcmp(t->valuestring, "1970-01-02T00:00:00Z") == 0,
              "valid_time ISO");
        cJSON_Delete(o);
    }
    free(text);
    unlink(path);
    rmdir(dir);
    free(land);
    free(a);
    free(b);
    free(p);
    return check_summary("test_verify");
}
