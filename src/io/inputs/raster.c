/* Initial ice field reader (io/raster.h), format-free: the raster's
 * allocation, the checks every format shares, sampling, and the choice of
 * a format driver (raster_impl.h) by the file's first bytes. */
#include "raster_impl.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RASTER_DRIVER_ENTRY(n) &raster_driver_##n,
static const raster_driver *const drivers[] = {RASTER_DRIVERS(RASTER_DRIVER_ENTRY)};
#undef RASTER_DRIVER_ENTRY

void ice_raster_options_default(ice_raster_options *o)
{
    memset(o, 0, sizeof *o);
    o->default_thickness = 0.1;
    o->valid_time = NAN;
    o->ims_ice_conc = o->ims_ice_thick = NAN;
    for (int k = 0; k < 4; k++)
        o->bbox[k] = NAN;
}

void ice_raster_free(ice_raster *r)
{
    if (!r)
        return;
    free(r->lon);
    free(r->lat);
    free(r->x);
    free(r->y);
    free(r->cell_lon);
    free(r->cell_lat);
    free(r->area);
    free(r->land);
    raster_crs_free(r->crs);
    free(r->conc);
    free(r->thick);
    free(r);
}

ice_raster *raster_alloc(const char *path, int nlon, int nlat, sph_error *err)
{
    ice_raster *r = calloc(1, sizeof *r);
    size_t n = (size_t)nlon * (size_t)nlat;
    if (r) {
        r->lon = malloc(sizeof(double) * (size_t)nlon);
        r->lat = malloc(sizeof(double) * (size_t)nlat);
        r->conc = malloc(sizeof(double) * n);
        r->thick = malloc(sizeof(double) * n);
    }
    if (!r || !r->lon || !r->lat || !r->conc || !r->thick) {
        ice_raster_free(r);
        sph_err_set(err, SPH_ERR_NOMEM, "ice raster %s: out of memory for %d x %d cells", path,
                    nlon, nlat);
        return NULL;
    }
    r->nlon = nlon;
    r->nlat = nlat;
    r->valid_time = NAN;
    snprintf(r->path, sizeof r->path, "%s", path);
    return r;
}

int raster_hand_over(ice_raster *r, int rc, ice_raster **out)
{
    if (rc == SPH_OK)
        *out = r;
    else
        ice_raster_free(r);
    return rc;
}

double ice_raster_cell_area(const ice_raster *r, int j)
{
    const double deg = M_PI / 180.0, R = ICE_RASTER_EARTH_RADIUS;
    double s = r->lat[j] - r->dlat / 2, n = r->lat[j] + r->dlat / 2;
    if (s < -90) s = -90;
    if (n > 90) n = 90;
    return R * R * r->dlon * deg * (sin(n * deg) - sin(s * deg));
}

void ice_raster_cell_lonlat(const ice_raster *r, int i, int j, double *lon, double *lat)
{
    if (r->kind == ICE_RASTER_LONLAT) {
        *lon = r->lon[i];
        *lat = r->lat[j];
    } else {
        *lon = r->cell_lon[(size_t)j * r->nlon + i];
        *lat = r->cell_lat[(size_t)j * r->nlon + i];
    }
}

double ice_raster_area(const ice_raster *r, int i, int j)
{
    if (r->kind == ICE_RASTER_LONLAT)
        return ice_raster_cell_area(r, j);
    return r->area[(size_t)j * r->nlon + i];
}

int ice_raster_can_sample(const ice_raster *r)
{
    return r && (r->kind == ICE_RASTER_LONLAT || r->kind == ICE_RASTER_PROJECTED);
}

/* Concentration to fraction and the checks every format shares. `percent`
 * < 0 means decide from the values. Thickness NaN where ice = default. */
int raster_finish(ice_raster *r, int percent, const ice_raster_options *o, sph_error *err)
{
    size_t n = (size_t)r->nlon * r->nlat;
    if (percent < 0) {
        percent = 0;
        for (size_t k = 0; k < n; k++)
            if (r->conc[k] > 1.5)
                percent = 1;
    }
    for (size_t k = 0; k < n; k++) {
        double c = r->conc[k];
        int i = (int)(k % r->nlon), j = (int)(k / r->nlon);
        double lon, lat;
        if (isnan(c)) {
            r->thick[k] = NAN;
            continue;
        }
        /* a packed value within half a packing step of a bound is that
         * bound (a packed short with an offset stores 0 as -6.4e-6) */
        double tol = fmax(percent ? 1e-4 : 1e-6, r->conc_halfstep);
        if (c < -tol || c > (percent ? 100.0 : 1.0) + tol) {
            ice_raster_cell_lonlat(r, i, j, &lon, &lat);
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: concentration %g %s at (%g E, %g N) outside 0..%s",
                               r->path, c, percent ? "%" : "(fraction)", lon, lat,
                               percent ? "100 %" : "1");
        }
        c = percent ? c / 100.0 : c;
        r->conc[k] = c < 0 ? 0 : c > 1 ? 1 : c;
        double h = r->thick[k];
        if (h > ICE_RASTER_MAX_THICKNESS) {
            ice_raster_cell_lonlat(r, i, j, &lon, &lat);
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: thickness %g m at (%g E, %g N) above %g m: not sea ice "
                               "(check the variable's units or fill value)",
                               o->thickness_path ? o->thickness_path : r->path, h, lon, lat,
                               ICE_RASTER_MAX_THICKNESS);
        }
        if (r->thickness_kind == ICE_THICK_CELL_MEAN && r->conc[k] > 0 && !isnan(h))
            r->thick[k] = h = h / r->conc[k]; /* volume per cell area -> per ice area */
        if (h < 0) {
            ice_raster_cell_lonlat(r, i, j, &lon, &lat);
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: negative thickness %g m at (%g E, %g N)", r->path, h,
                               lon, lat);
        }
        if (isnan(h) || (h == 0 && r->conc[k] > 0))
            r->thick[k] = o->default_thickness;
    }
    return SPH_OK;
}

int ice_raster_read(const char *path, const ice_raster_options *opt, ice_raster **out,
                    sph_error *err)
{
    ice_raster_options defaults;
    if (!opt) {
        ice_raster_options_default(&defaults);
        opt = &defaults;
    }
    *out = NULL;
    if (!(opt->default_thickness > 0))
        return sph_err_set(err, SPH_ERR_CONFIG, "ice raster %s: default thickness %g m must be > 0",
                           path, opt->default_thickness);
    FILE *f = fopen(path, "rb");
    if (!f)
        return sph_err_set(err, SPH_ERR_IO, "ice raster %s: cannot open: %m", path);
    unsigned char head[RASTER_HEAD];
    size_t got = fread(head, 1, sizeof head, f);
    fclose(f);
    for (size_t i = 0; i < sizeof drivers / sizeof drivers[0]; i++)
        if (drivers[i]->probe(head, got))
            return drivers[i]->read(path, opt, out, err);
    return sph_err_set(err, SPH_ERR_BAD_DATA,
                       "ice raster %s: neither NetCDF nor an ESRI ASCII grid, IMS ASCII or GeoTIFF (%zu bytes)", path,
                       got < 8 ? got : (size_t)8);
}

int ice_raster_sample(const ice_raster *r, double lon, double lat, double *conc, double *thick)
{
    *conc = *thick = NAN;
    double fi, fj;
    if (r->kind == ICE_RASTER_LONLAT) {
        fi = (lon - r->lon[0]) / r->dlon;
        fj = (lat - r->lat[0]) / r->dlat;
    } else if (r->kind == ICE_RASTER_PROJECTED) {
        double x, y;
        if (!raster_crs_forward(r->crs, lon, lat, &x, &y))
            return 0;
        fi = (x - r->x[0]) / r->dx;
        fj = (y - r->y[0]) / r->dy;
    } else {
        return 0;
    }
    if (!(fi >= 0 && fj >= 0 && fi <= r->nlon - 1 && fj <= r->nlat - 1))
        return 0;
    int i = (int)fi, j = (int)fj;
    if (i > r->nlon - 2) i = r->nlon - 2;
    if (j > r->nlat - 2) j = r->nlat - 2;
    double a = fi - i, b = fj - j, sw = 0, sc = 0, st = 0;
    for (int dj = 0; dj <= 1; dj++)
        for (int di = 0; di <= 1; di++) {
            double w = (di ? a : 1 - a) * (dj ? b : 1 - b);
            size_t k = (size_t)(j + dj) * r->nlon + (i + di);
            if (w <= 0 || isnan(r->conc[k]))
                continue;
            sw += w;
            sc += w * r->conc[k];
            st += w * r->thick[k];
        }
    if (sw <= 0)
        return 0;
    *conc = sc / sw;
    *thick = st / sw;
    return 1;
}
