/* The NOAA IMS daily Northern Hemisphere snow and ice analysis (NSIDC
 * G02156) as the initial raster (raster_impl.h), in its ASCII form: a
 * text header, then one row per line, one character per cell, the first
 * row the grid's bottom (y = yll: South America's side), the first column
 * its left (x = xll: the Pacific's side). Classes: 0 outside the Northern
 * Hemisphere, 1 open water, 2 land without snow, 3 sea or lake ice, 4
 * snow-covered land. The grids (NSIDC's user guide, Table 4):
 *   24 km: 1024 x 1024, lower-left corner (-12126597, -12126480) m, 23684.977 m
 *    4 km: 6144 x 6144, (-12288000, -12288000) m, 4000 m
 *    1 km: 24576 x 24576, (-12288000, -12288000) m, 1000 m
 * on the IMS polar stereographic projection (true scale at 60 N, 80 W
 * straight down from the pole, the ellipsoid a = 6378137 m, b = 6356257 m
 * of the IMS files' own proj4 definition). The classes are shared with
 * the IMS GeoTIFF (raster_gdal.c) through raster_ims_fill. */
#include "raster_impl.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "util/log.h"

const raster_ims_grid raster_ims_grids[3] = {
    {1024, -12126597.0, -12126480.0, 23684.977, "24 km"},
    {6144, -12288000.0, -12288000.0, 4000.0, "4 km"},
    {24576, -12288000.0, -12288000.0, 1000.0, "1 km"},
};

const char raster_ims_proj[] = "+proj=stere +lat_0=90 +lat_ts=60 +lon_0=-80 +k=1 +x_0=0 +y_0=0 "
                               "+a=6378137 +b=6356257 +units=m +no_defs";

int raster_ims_check_keys(const char *path, const ice_raster_options *o, sph_error *err)
{
    if (!(o->ims_ice_conc > 0 && o->ims_ice_conc <= 1))
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "ice raster %s: an IMS analysis says only ice or no ice: set "
                           "initial.ims.ice_concentration (the concentration given to an ice "
                           "cell, 0 < A <= 1)", path);
    if (!(o->ims_ice_thick > 0 && o->ims_ice_thick <= ICE_RASTER_MAX_THICKNESS))
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "ice raster %s: an IMS analysis gives no ice thickness: set "
                           "initial.ims.ice_thickness (the thickness given to an ice cell, m)",
                           path);
    return SPH_OK;
}

int raster_ims_fill(ice_raster *r, const unsigned char *cls, const ice_raster_options *o,
                    sph_error *err)
{
    int rc = raster_ims_check_keys(r->path, o, err);
    if (rc)
        return rc;
    size_t n = (size_t)r->nlon * r->nlat, nice = 0;
    if (!(r->land = calloc(n, 1)))
        return sph_err_set(err, SPH_ERR_NOMEM, "ice raster %s: out of memory", r->path);
    r->nland = r->nnoinfo = 0;
    for (size_t k = 0; k < n; k++) {
        r->thick[k] = NAN;
        switch (cls[k]) {
        case 1: /* open water */
            r->conc[k] = 0;
            break;
        case 3: /* sea or lake ice */
            r->conc[k] = o->ims_ice_conc;
            r->thick[k] = o->ims_ice_thick;
            nice++;
            break;
        case 2: /* land without snow */
        case 4: /* snow-covered land */
            r->conc[k] = NAN;
            r->land[k] = 1;
            r->nland++;
            break;
        default: /* 0: outside the Northern Hemisphere */
            r->conc[k] = NAN;
            r->land[k] = 2;
            r->nnoinfo++;
            break;
        }
    }
    r->thickness_kind = ICE_THICK_ICE;
    snprintf(r->thickness_why, sizeof r->thickness_why, "initial.ims.ice_thickness (IMS classes)");
    snprintf(r->assumed, sizeof r->assumed, "IMS ice cells (class 3): concentration %g "
             "(initial.ims.ice_concentration), thickness %g m (initial.ims.ice_thickness)",
             o->ims_ice_conc, o->ims_ice_thick);
    log_info("ice raster %s: IMS classes: %zu ice cells take concentration %g "
             "(initial.ims.ice_concentration) and thickness %g m (initial.ims.ice_thickness); "
             "%zu land, %zu outside the hemisphere", r->path, nice, o->ims_ice_conc,
             o->ims_ice_thick, r->nland, r->nnoinfo);
    return SPH_OK;
}

/* Length of line without its end (newline, carriage return, blanks). */
static size_t trim(const char *line, size_t len)
{
    while (len > 0 && isspace((unsigned char)line[len - 1]))
        len--;
    return len;
}

/* The grid whose data row this line is (one class digit per cell), or NULL. */
static const raster_ims_grid *data_row(const char *line, size_t len)
{
    for (size_t k = 0; k < len; k++)
        if (!isdigit((unsigned char)line[k]))
            return NULL;
    for (int g = 0; g < 3; g++)
        if ((size_t)raster_ims_grids[g].n == len)
            return &raster_ims_grids[g];
    return NULL;
}

static int read_ims(const char *path, const ice_raster_options *o, ice_raster **out,
                    sph_error *err)
{
    int rc = raster_ims_check_keys(path, o, err);
    if (rc)
        return rc;
    FILE *f = fopen(path, "r");
    if (!f)
        return sph_err_set(err, SPH_ERR_IO, "ice raster %s: cannot open: %m", path);
    char *line = NULL;
    size_t cap = 0;
    ssize_t got;
    const raster_ims_grid *g = NULL;
    long lineno = 0;
    enum { MAX_HEADER = 200 };
    while (!g && lineno < MAX_HEADER && (got = getline(&line, &cap, f)) >= 0) {
        lineno++;
        g = data_row(line, trim(line, (size_t)got));
    }
    if (!g) {
        free(line);
        fclose(f);
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "ice raster %s: IMS ASCII without data rows: no line of 1024, 6144 or "
                           "24576 class digits in its first %ld lines (a 24 km file in the "
                           "unpacked form, or not an IMS file)", path, lineno);
    }
    int n = g->n, win[4];
    double x0 = g->xll + g->cell / 2, y0 = g->yll + g->cell / 2;
    rc = raster_window(path, raster_ims_proj, x0, g->cell, n, y0, g->cell, n, o, 3, win, err);
    int nx = win[1] - win[0] + 1, ny = win[3] - win[2] + 1;
    unsigned char *cls = rc ? NULL : malloc((size_t)nx * ny);
    if (!rc && !cls)
        rc = sph_err_set(err, SPH_ERR_NOMEM, "ice raster %s: out of memory", path);
    /* every row is checked (a truncated or damaged file is refused), the
     * window's cells kept */
    long row = 0;
    for (; rc == SPH_OK; row++) {
        if (row > 0) {
            got = getline(&line, &cap, f);
            lineno++;
            if (got < 0)
                break;
        }
        size_t len = trim(line, (size_t)got);
        if (row >= n) {
            if (len > 0)
                rc = sph_err_set(err, SPH_ERR_BAD_DATA,
                                 "ice raster %s: more than the %d rows of the IMS %s grid (line %ld)",
                                 path, n, g->name, lineno);
            continue;
        }
        if (len != (size_t)n) {
            rc = sph_err_set(err, SPH_ERR_BAD_DATA,
                             "ice raster %s: IMS %s row %ld (line %ld) has %zu cells, not %d", path,
                             g->name, row + 1, lineno, len, n);
            break;
        }
        for (int i = 0; i < n; i++) {
            unsigned char c = (unsigned char)line[i];
            if (c < '0' || c > '4') {
                rc = sph_err_set(err, SPH_ERR_BAD_DATA,
                                 "ice raster %s: IMS row %ld column %d: class '%c' is not one of "
                                 "the documented 0 (outside), 1 (water), 2 (land), 3 (ice), 4 "
                                 "(snow)", path, row + 1, i + 1, isprint(c) ? c : '?');
                break;
            }
            if (row >= win[2] && row <= win[3] && i >= win[0] && i <= win[1])
                cls[(size_t)(row - win[2]) * nx + (i - win[0])] = (unsigned char)(c - '0');
        }
    }
    if (rc == SPH_OK && row < n)
        rc = sph_err_set(err, SPH_ERR_BAD_DATA,
                         "ice raster %s: truncated IMS %s file: %ld of %d rows", path, g->name, row,
                         n);
    free(line);
    fclose(f);
    ice_raster *r = NULL;
    if (rc == SPH_OK && !(r = raster_alloc(path, nx, ny, err)))
        rc = err->code;
    if (rc == SPH_OK) {
        r->valid_time = o->valid_time;
        rc = raster_ims_fill(r, cls, o, err);
    }
    if (rc == SPH_OK)
        rc = raster_set_regular_projected(r, raster_ims_proj, "IMS classes", x0 + win[0] * g->cell,
                                          g->cell, y0 + win[2] * g->cell, g->cell, err);
    if (rc == SPH_OK) {
        snprintf(r->grid, sizeof r->grid,
                 "projected, IMS %s ASCII (columns %d..%d, rows %d..%d of %d), %g x %g km cells, "
                 "%s; ice cells: concentration %g, thickness %g m (initial.ims.*)", g->name,
                 win[0] + 1, win[1] + 1, win[2] + 1, win[3] + 1, n, g->cell / 1000,
                 g->cell / 1000, raster_ims_proj, o->ims_ice_conc, o->ims_ice_thick);
        rc = raster_finish(r, 0, o, err);
    }
    free(cls);
    return raster_hand_over(r, rc, out);
}

/* Text whose header names the product (an ESRI grid starts with
 * ncols/nrows, a GeoTIFF is binary: the drivers do not overlap). */
static int probe_ims(const unsigned char *head, size_t got)
{
    char text[RASTER_HEAD + 1];
    size_t n = got < RASTER_HEAD ? got : RASTER_HEAD;
    for (size_t k = 0; k < n; k++) {
        if (!head[k])
            return 0; /* binary */
        text[k] = (char)tolower(head[k]);
    }
    text[n] = '\0';
    const char *t = text + strspn(text, " \t\r\n");
    if (strncmp(t, "ncols", 5) == 0 || strncmp(t, "nrows", 5) == 0)
        return 0;
    /* the product's name, or the "Dim Units" lines of its header */
    return strstr(text, "interactive multisensor snow") != NULL ||
           (strstr(text, "ims") != NULL && strstr(text, "snow and ice") != NULL) ||
           strstr(text, "dim units") != NULL;
}

const raster_driver raster_driver_ims = {"ims-ascii", probe_ims, read_ims};
