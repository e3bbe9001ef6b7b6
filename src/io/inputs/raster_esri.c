/* The ESRI ASCII grid driver of the initial ice raster (raster_impl.h):
 * header keys ncols, nrows, xllcorner|xllcenter, yllcorner|yllcenter,
 * cellsize, NODATA_value, then rows from north to south; thickness from a
 * second grid of the same geometry. */
#include "raster_impl.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "util/fileio.h"

typedef struct {
    long ncols, nrows;
    double ncols_v, nrows_v; /* as written in the header */
    double x, y, cellsize, nodata;
    int x_is_centre, y_is_centre, has_nodata;
    const char *data; /* first value */
} esri_header;

static int parse_esri_header(const char *path, const char *text, esri_header *h, sph_error *err)
{
    memset(h, 0, sizeof *h);
    h->nodata = NAN;
    int seen = 0; /* bits: ncols nrows x y cellsize */
    const char *p = text;
    for (;;) {
        while (isspace((unsigned char)*p))
            p++;
        if (!isalpha((unsigned char)*p))
            break;
        char key[32];
        size_t n = 0;
        while (isalpha((unsigned char)*p) || *p == '_') {
            if (n < sizeof key - 1)
                key[n++] = (char)tolower((unsigned char)*p);
            p++;
        }
        key[n] = '\0';
        char *end;
        double v = strtod(p, &end);
        if (end == p)
            return sph_err_set(err, SPH_ERR_BAD_DATA, "ice raster %s: header key %s has no number",
                               path, key);
        p = end;
        /* found by tests/fuzz/fuzz_raster: a count beyond long's range (the
         * cast would be undefined behaviour), NaN, or not whole is refused */
        if ((strcmp(key, "ncols") == 0 || strcmp(key, "nrows") == 0) &&
            !(v >= 2 && v <= 100000 && v == floor(v)))
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: header key %s %g: not a whole number of "
                               "cells from 2 to 100000", path, key, v);
        if (strcmp(key, "ncols") == 0) h->ncols = (long)v, h->ncols_v = v, seen |= 1;
        else if (strcmp(key, "nrows") == 0) h->nrows = (long)v, h->nrows_v = v, seen |= 2;
        else if (strcmp(key, "xllcorner") == 0) h->x = v, seen |= 4;
        else if (strcmp(key, "xllcenter") == 0) h->x = v, h->x_is_centre = 1, seen |= 4;
        else if (strcmp(key, "yllcorner") == 0) h->y = v, seen |= 8;
        else if (strcmp(key, "yllcenter") == 0) h->y = v, h->y_is_centre = 1, seen |= 8;
        else if (strcmp(key, "cellsize") == 0) h->cellsize = v, seen |= 16;
        else if (strcmp(key, "nodata_value") == 0) h->nodata = v, h->has_nodata = 1;
        else
            return sph_err_set(err, SPH_ERR_BAD_DATA, "ice raster %s: unknown header key \"%s\"",
                               path, key);
    }
    if (seen != 31)
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "ice raster %s: ESRI header lacks %s", path,
                           !(seen & 1) ? "ncols" : !(seen & 2) ? "nrows" : !(seen & 4) ? "xllcorner"
                           : !(seen & 8) ? "yllcorner" : "cellsize");
    if (h->ncols < 2 || h->nrows < 2 || h->ncols > 100000 || h->nrows > 100000 ||
        !(h->cellsize > 0))
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "ice raster %s: bad ESRI geometry: ncols %g, nrows %g, cellsize %g "
                           "(need 2..100000 cells each way, cellsize > 0)", path, h->ncols_v,
                           h->nrows_v, h->cellsize);
    h->data = p;
    return SPH_OK;
}

/* Reads the values into out[j * ncols + i] with j counted from the south. */
static int parse_esri_values(const char *path, const esri_header *h, double *out, sph_error *err)
{
    const char *p = h->data;
    size_t total = (size_t)h->ncols * h->nrows;
    for (size_t k = 0; k < total; k++) {
        while (isspace((unsigned char)*p))
            p++;
        long row = (long)(k / h->ncols), col = (long)(k % h->ncols);
        if (!*p)
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: truncated: %zu of %zu values (%ld rows x %ld "
                               "columns)", path, k, total, h->nrows, h->ncols);
        char *end;
        double v = strtod(p, &end);
        if (end == p || (*end && !isspace((unsigned char)*end)))
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: bad value \"%.20s\" at row %ld column %ld", path, p,
                               row + 1, col + 1);
        p = end;
        int missing = h->has_nodata && (v == h->nodata || (isnan(v) && isnan(h->nodata)));
        if (isnan(v) && !missing)
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: NaN at row %ld column %ld (not the NODATA_value)",
                               path, row + 1, col + 1);
        out[(size_t)(h->nrows - 1 - row) * h->ncols + col] = missing ? NAN : v;
    }
    while (isspace((unsigned char)*p))
        p++;
    if (*p)
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "ice raster %s: more values than %ld rows x %ld columns", path, h->nrows,
                           h->ncols);
    return SPH_OK;
}

static int read_esri(const char *path, const char *text, const ice_raster_options *o,
                     ice_raster **out, sph_error *err)
{
    esri_header h;
    int rc = parse_esri_header(path, text, &h, err);
    if (rc != SPH_OK)
        return rc;
    ice_raster *r = raster_alloc(path, (int)h.ncols, (int)h.nrows, err);
    if (!r)
        return err ? err->code : SPH_ERR_NOMEM;
    double x0 = h.x + (h.x_is_centre ? 0 : h.cellsize / 2);
    double y0 = h.y + (h.y_is_centre ? 0 : h.cellsize / 2);
    for (int i = 0; i < r->nlon; i++)
        r->lon[i] = x0 + i * h.cellsize;
    for (int j = 0; j < r->nlat; j++)
        r->lat[j] = y0 + j * h.cellsize;
    r->dlon = r->dlat = h.cellsize;
    r->valid_time = o->valid_time;
    rc = parse_esri_values(path, &h, r->conc, err);
    size_t n = (size_t)r->nlon * r->nlat;
    for (size_t k = 0; k < n; k++)
        r->thick[k] = NAN;
    if (rc == SPH_OK && o->thickness_path && *o->thickness_path &&
        o->thickness_kind == ICE_THICK_AUTO)
        rc = sph_err_set(err, SPH_ERR_CONFIG,
                         "ice raster %s: an ESRI grid cannot say whether thickness is per ice "
                         "area or a cell mean: set initial.thickness_kind to \"ice\" or "
                         "\"cell_mean\"", o->thickness_path);
    if (rc == SPH_OK && o->thickness_path && *o->thickness_path) {
        r->thickness_kind = o->thickness_kind;
        snprintf(r->thickness_why, sizeof r->thickness_why, "initial.thickness_kind");
        char *ttext = NULL;
        esri_header th;
        rc = read_file(o->thickness_path, &ttext, NULL, err);
        if (rc == SPH_OK)
            rc = parse_esri_header(o->thickness_path, ttext, &th, err);
        if (rc == SPH_OK &&
            (th.ncols != h.ncols || th.nrows != h.nrows ||
             fabs(th.x + (th.x_is_centre ? 0 : th.cellsize / 2) - x0) > 1e-6 * h.cellsize ||
             fabs(th.y + (th.y_is_centre ? 0 : th.cellsize / 2) - y0) > 1e-6 * h.cellsize ||
             fabs(th.cellsize - h.cellsize) > 1e-9 * h.cellsize))
            rc = sph_err_set(err, SPH_ERR_BAD_DATA,
                             "ice raster %s: thickness grid does not match concentration grid %s",
                             o->thickness_path, path);
        if (rc == SPH_OK)
            rc = parse_esri_values(o->thickness_path, &th, r->thick, err);
        for (size_t k = 0; rc == SPH_OK && k < n; k++)
            if (r->thick[k] < 0)
                rc = sph_err_set(err, SPH_ERR_BAD_DATA,
                                 "ice raster %s: negative thickness %g m at (%g E, %g N)",
                                 o->thickness_path, r->thick[k], r->lon[k % r->nlon],
                                 r->lat[k / r->nlon]);
        free(ttext);
    }
    if (rc == SPH_OK)
        rc = raster_finish(r, -1, o, err);
    if (rc != SPH_OK) {
        ice_raster_free(r);
        return rc;
    }
    *out = r;
    return SPH_OK;
}


/* The whole file is read again here: the probe saw only its head. */
static int read_esri_file(const char *path, const ice_raster_options *o, ice_raster **out,
                          sph_error *err)
{
    char *text = NULL;
    int rc = read_file(path, &text, NULL, err);
    if (rc != SPH_OK)
        return rc;
    rc = read_esri(path, text, o, out, err);
    free(text);
    return rc;
}

static int probe_esri(const unsigned char *head, size_t got)
{
    size_t i = 0;
    while (i < got && isspace(head[i]))
        i++;
    return got - i >= 5 && (strncasecmp((const char *)head + i, "ncols", 5) == 0 ||
                            strncasecmp((const char *)head + i, "nrows", 5) == 0);
}

const raster_driver raster_driver_esri = {"esri-ascii", probe_esri, read_esri_file};
