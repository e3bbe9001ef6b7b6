/* The GeoTIFF driver of the initial raster (raster_impl.h), through GDAL:
 * any georeferenced band. The file says its CRS (WKT handed to PROJ, as
 * the NetCDF path does), geotransform (north-up, not rotated), nodata and
 * scale/offset; the band metadata GDAL exposes (standard_name, long_name,
 * cell_methods, units or the band's unit type, flag_values/flag_meanings,
 * the band description as a variable name) say which band is the
 * concentration and which the thickness, the concentration's unit and the
 * thickness kind; where they do not, the keys initial.gdal.conc_band,
 * initial.gdal.thick_band, initial.gdal.conc_units and
 * initial.thickness_kind do, and where neither does the file is refused
 * in one line naming the band and the key. A single byte band on one of
 * the IMS grids (raster_ims.c) is the IMS GeoTIFF: its values are the IMS
 * classes.
 *
 * GDALAllRegister is called as gis.c does; the driver manager is left to
 * the process's end (main.c: destroying it from an exit handler crashed). */
#include "raster_impl.h"

#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal.h>
#include <math.h>
#include <ogr_srs_api.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "io/cf.h"
#include "util/log.h"

enum { ROLE_NONE = 0, ROLE_CONC, ROLE_THICK };

static const char *item(GDALRasterBandH b, const char *key)
{
    const char *v = GDALGetMetadataItem(b, key, NULL);
    return v && *v ? v : NULL;
}

static int in_list(const char *name, const char *const *names)
{
    for (; *names; names++)
        if (strcmp(name, *names) == 0)
            return 1;
    return 0;
}

/* What the band's metadata says it is. */
static int band_role(GDALRasterBandH b)
{
    const char *sn = item(b, "standard_name"), *d = GDALGetDescription(b);
    if (sn && strcmp(sn, "sea_ice_area_fraction") == 0)
        return ROLE_CONC;
    if (sn && strcmp(sn, "sea_ice_thickness") == 0)
        return ROLE_THICK;
    const char *nm = d && *d ? d : item(b, "NETCDF_VARNAME");
    if (nm && in_list(nm, raster_conc_names))
        return ROLE_CONC;
    static const char *const volume_names[] = {"sivol", "vice", NULL};
    if (nm && (in_list(nm, raster_thick_names) || in_list(nm, volume_names)))
        return ROLE_THICK;
    return ROLE_NONE;
}

static const char *band_name(GDALRasterBandH b)
{
    const char *d = GDALGetDescription(b);
    return d && *d ? d : item(b, "NETCDF_VARNAME") ? item(b, "NETCDF_VARNAME") : "";
}

/* The band's unit: its unit type, else its "units" item; NULL: none. */
static const char *band_units(GDALRasterBandH b)
{
    const char *u = GDALGetRasterUnitType(b);
    return u && *u ? u : item(b, "units");
}

/* Raw values of the window (file rows top-down or bottom-up) into out
 * [j * nx + i], j ascending in y. */
static int read_window(GDALRasterBandH b, const char *path, int band, const int win[4],
                       int ny_file, int top_down, double *out, sph_error *err)
{
    int nx = win[1] - win[0] + 1, ny = win[3] - win[2] + 1;
    int yoff = top_down ? ny_file - 1 - win[3] : win[2];
    if (GDALRasterIO(b, GF_Read, win[0], yoff, nx, ny, out, nx, ny, GDT_Float64, 0, 0) != CE_None) {
        const char *m = CPLGetLastErrorMsg();
        return sph_err_set(err, SPH_ERR_BAD_DATA, "ice raster %s: reading band %d: %s (truncated "
                           "or corrupt file?)", path, band, m && *m ? m : "GDAL error");
    }
    if (top_down) /* first buffer row is the window's top: flip to ascending y */
        for (int j = 0; j < ny / 2; j++)
            for (int i = 0; i < nx; i++) {
                double t = out[(size_t)j * nx + i];
                out[(size_t)j * nx + i] = out[(size_t)(ny - 1 - j) * nx + i];
                out[(size_t)(ny - 1 - j) * nx + i] = t;
            }
    return SPH_OK;
}

/* Numbers of a metadata list such as "{251,252}" or "251 252". */
static size_t parse_list(const char *s, double *v, size_t max)
{
    size_t n = 0;
    while (s && *s && n < max) {
        char *end;
        double x = strtod(s, &end);
        if (end == s) {
            s++;
            continue;
        }
        v[n++] = x;
        s = end;
    }
    return n;
}

/* nodata and flags to NaN (land[k] 1 or 2 at flags), scale/offset
 * applied; an undeclared NaN refused. */
static int unpack(GDALRasterBandH b, const char *path, int band, size_t n, double *v,
                  unsigned char *land, double *halfstep, sph_error *err)
{
    int has_nd = 0, ok_s = 0, ok_o = 0;
    double nd = GDALGetRasterNoDataValue(b, &has_nd);
    double scale = GDALGetRasterScale(b, &ok_s), offset = GDALGetRasterOffset(b, &ok_o);
    if (!ok_s)
        scale = 1;
    if (!ok_o)
        offset = 0;
    GDALDataType t = GDALGetRasterDataType(b);
    if (halfstep)
        *halfstep = t != GDT_Float32 && t != GDT_Float64 ? 0.5 * fabs(scale) : 0;
    double fv[RASTER_MAX_FLAGS];
    int fk[RASTER_MAX_FLAGS];
    size_t nf = parse_list(item(b, "flag_values"), fv, RASTER_MAX_FLAGS);
    if (nf) {
        char label[64], meanings[4096];
        snprintf(label, sizeof label, "band %d", band);
        const char *m = item(b, "flag_meanings");
        if (!m)
            return sph_err_set(err, SPH_ERR_BAD_DATA, "ice raster %s: %s has flag_values but no "
                               "flag_meanings", path, label);
        snprintf(meanings, sizeof meanings, "%s", m);
        if (raster_flag_meanings(path, label, "flag_values", nf, meanings, fk, err) < 0)
            return err->code;
    }
    for (size_t k = 0; k < n; k++) {
        double x = v[k];
        size_t f = 0;
        while (f < nf && x != fv[f])
            f++;
        if (f < nf) {
            v[k] = NAN;
            if (land)
                land[k] = fk[f] == 1 ? 1 : 2;
            continue;
        }
        if (isnan(x) && !(has_nd && isnan(nd)))
            return sph_err_set(err, SPH_ERR_BAD_DATA,
                               "ice raster %s: band %d is NaN at index %zu and NaN is not its "
                               "nodata value", path, band, k);
        v[k] = isnan(x) || (has_nd && x == nd) ? NAN : x * scale + offset;
    }
    return SPH_OK;
}

/* The IMS grid this single byte band lies on, or NULL. */
static const raster_ims_grid *ims_grid(GDALDatasetH ds, const double *gt)
{
    if (GDALGetRasterCount(ds) != 1 ||
        GDALGetRasterDataType(GDALGetRasterBand(ds, 1)) != GDT_Byte)
        return NULL;
    int nx = GDALGetRasterXSize(ds), ny = GDALGetRasterYSize(ds);
    for (int g = 0; g < 3; g++) {
        const raster_ims_grid *G = &raster_ims_grids[g];
        if (nx == G->n && ny == G->n && fabs(gt[1] - G->cell) < 1e-3 &&
            fabs(gt[5] + G->cell) < 1e-3 && fabs(gt[0] - G->xll) < 1 &&
            fabs(gt[3] - (G->yll + G->n * G->cell)) < 1)
            return G;
    }
    return NULL;
}

static int read_gdal(const char *path, const ice_raster_options *o, ice_raster **out,
                     sph_error *err)
{
    GDALAllRegister();
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErrorReset();
    GDALDatasetH ds = GDALOpen(path, GA_ReadOnly);
    ice_raster *r = NULL;
    char *wkt = NULL, *p4 = NULL;
    double *tmp = NULL;
    unsigned char *flags = NULL, *cls = NULL;
    int rc = SPH_OK;
    const char *m;
    if (!ds) {
        m = CPLGetLastErrorMsg();
        rc = sph_err_set(err, SPH_ERR_BAD_DATA, "ice raster %s: GDAL cannot open it: %s", path,
                         m && *m ? m : "unknown error");
        goto done;
    }
    int nb = GDALGetRasterCount(ds), nxf = GDALGetRasterXSize(ds), nyf = GDALGetRasterYSize(ds);
    double gt[6];
    if (nb < 1 || nxf < 2 || nyf < 2) {
        rc = sph_err_set(err, SPH_ERR_BAD_DATA, "ice raster %s: %d band(s) of %d x %d cells "
                         "(need a band of 2 x 2 cells at least)", path, nb, nxf, nyf);
        goto done;
    }
    if (GDALGetGeoTransform(ds, gt) != CE_None) {
        rc = sph_err_set(err, SPH_ERR_BAD_DATA, "ice raster %s: not georeferenced (no "
                         "geotransform)", path);
        goto done;
    }
    if (gt[2] != 0 || gt[4] != 0 || !(gt[1] > 0) || gt[5] == 0) {
        rc = sph_err_set(err, SPH_ERR_BAD_DATA, "ice raster %s: geotransform (%g, %g, %g, %g, "
                         "%g, %g) is rotated or flipped in x: not a regular grid", path, gt[0],
                         gt[1], gt[2], gt[3], gt[4], gt[5]);
        goto done;
    }
    OGRSpatialReferenceH srs = GDALGetSpatialRef(ds);
    if (!srs) {
        rc = sph_err_set(err, SPH_ERR_BAD_DATA, "ice raster %s: no CRS: the file does not say "
                         "which projection its x/y are in", path);
        goto done;
    }
    const char *wopt[] = {"FORMAT=WKT2_2019", NULL};
    OSRExportToWktEx(srs, &wkt, wopt);
    OSRExportToProj4(srs, &p4);
    int geographic = OSRIsGeographic(srs), projected = OSRIsProjected(srs);
    if ((!geographic && !projected) || !wkt) {
        rc = sph_err_set(err, SPH_ERR_BAD_DATA, "ice raster %s: CRS \"%.200s\" is neither "
                         "geographic nor projected: unknown on the earth", path,
                         OSRGetName(srs) ? OSRGetName(srs) : "?");
        goto done;
    }
    double unit = projected ? OSRGetLinearUnits(srs, NULL) : 1;
    if (geographic && fabs(OSRGetAngularUnits(srs, NULL) - M_PI / 180) > 1e-12) {
        rc = sph_err_set(err, SPH_ERR_BAD_DATA, "ice raster %s: geographic CRS not in degrees",
                         path);
        goto done;
    }
    int top_down = gt[5] < 0;
    double dx = gt[1] * unit, dy = fabs(gt[5]) * unit;
    double x0 = (gt[0] + 0.5 * gt[1]) * unit;                       /* left column's centre */
    double y0 = (gt[3] + (top_down ? nyf - 0.5 : 0.5) * gt[5]) * unit; /* bottom row's centre */
    int win[4] = {0, nxf - 1, 0, nyf - 1};
    if (projected && (rc = raster_window(path, wkt, x0, dx, nxf, y0, dy, nyf, o, 3, win, err)))
        goto done;
    int nx = win[1] - win[0] + 1, ny = win[3] - win[2] + 1;
    size_t n = (size_t)nx * ny;

    /* the roles of the bands */
    const raster_ims_grid *ims = NULL;
    int conc = o->gdal_conc_band, thick = o->gdal_thick_band;
    if (conc > nb || thick > nb) {
        rc = sph_err_set(err, SPH_ERR_CONFIG, "ice raster %s: has %d band(s): %s %d does not exist",
                         path, nb, conc > nb ? "initial.gdal.conc_band" : "initial.gdal.thick_band",
                         conc > nb ? conc : thick);
        goto done;
    }
    /* bands the metadata name, where the key leaves it to them */
    int *slot[3] = {NULL, &conc, &thick};
    const int keyed[3] = {1, o->gdal_conc_band != 0, o->gdal_thick_band != 0};
    static const char *const what[3] = {"", "concentration", "thickness"};
    static const char *const key[3] = {"", "conc_band", "thick_band"};
    for (int b = 1; b <= nb; b++) {
        int role = band_role(GDALGetRasterBand(ds, b));
        if (b == conc || b == thick || keyed[role])
            continue;
        if (*slot[role] > 0) {
            rc = sph_err_set(err, SPH_ERR_CONFIG, "ice raster %s: bands %d and %d both say they "
                             "are the %s: set initial.gdal.%s", path, *slot[role], b, what[role],
                             key[role]);
            goto done;
        }
        *slot[role] = b;
    }
    if (conc == 0 && (ims = ims_grid(ds, gt)) != NULL) {
        if ((rc = raster_ims_check_keys(path, o, err)))
            goto done;
    } else {
        if (conc == 0) {
            GDALRasterBandH h = GDALGetRasterBand(ds, 1);
            rc = sph_err_set(err, SPH_ERR_CONFIG, "ice raster %s: no band says it is the sea-ice "
                             "concentration (band metadata standard_name sea_ice_area_fraction or "
                             "a name such as siconc; band 1 is \"%.40s\"): set "
                             "initial.gdal.conc_band", path, band_name(h));
            goto done;
        }
        for (int b = 1; b <= nb; b++)
            if (b != conc && b != thick && o->gdal_thick_band == 0 &&
                band_role(GDALGetRasterBand(ds, b)) == ROLE_NONE) {
                GDALRasterBandH h = GDALGetRasterBand(ds, b);
                rc = sph_err_set(err, SPH_ERR_CONFIG, "ice raster %s: band %d (\"%.40s\") has a "
                                 "role sphice does not know (it may be the thickness): set "
                                 "initial.gdal.thick_band to its number, or -1 for none", path, b,
                                 band_name(h));
                goto done;
            }
    }

    if (!(r = raster_alloc(path, nx, ny, err))) {
        rc = err->code;
        goto done;
    }
    if (!(tmp = malloc(sizeof(double) * n)) || !(flags = calloc(n, 1))) {
        rc = sph_err_set(err, SPH_ERR_NOMEM, "ice raster %s: out of memory", path);
        goto done;
    }
    r->valid_time = o->valid_time;
    int percent = 0;
    if (ims) {
        if ((rc = read_window(GDALGetRasterBand(ds, 1), path, 1, win, nyf, top_down, tmp, err)))
            goto done;
        if (!(cls = malloc(n))) {
            rc = sph_err_set(err, SPH_ERR_NOMEM, "ice raster %s: out of memory", path);
            goto done;
        }
        for (size_t k = 0; k < n; k++) {
            if (!(tmp[k] >= 0 && tmp[k] <= 4)) {
                rc = sph_err_set(err, SPH_ERR_BAD_DATA, "ice raster %s: IMS GeoTIFF (%s grid) "
                                 "value %g at column %d, row %zu from the bottom is not one of the "
                                 "documented classes 0..4", path, ims->name, tmp[k],
                                 win[0] + (int)(k % nx) + 1, win[2] + k / nx + 1);
                goto done;
            }
            cls[k] = (unsigned char)tmp[k];
        }
        if ((rc = raster_ims_fill(r, cls, o, err)))
            goto done;
    } else {
        GDALRasterBandH hc = GDALGetRasterBand(ds, conc);
        if (o->gdal_conc_units != ICE_CONC_UNITS_AUTO) {
            percent = o->gdal_conc_units == ICE_CONC_UNITS_PERCENT;
        } else {
            const char *u = band_units(hc);
            if (u && (strcmp(u, "%") == 0 || strcasecmp(u, "percent") == 0))
                percent = 1;
            else if (u && (strcmp(u, "1") == 0 || strcasecmp(u, "fraction") == 0))
                percent = 0;
            else {
                rc = sph_err_set(err, SPH_ERR_CONFIG, "ice raster %s: concentration band %d says "
                                 "%s%s%s: set initial.gdal.conc_units to \"fraction\" or "
                                 "\"percent\"", path, conc, u ? "unit \"" : "no unit",
                                 u ? u : "", u ? "\"" : "");
                goto done;
            }
        }
        if ((rc = read_window(hc, path, conc, win, nyf, top_down, r->conc, err)) ||
            (rc = unpack(hc, path, conc, n, r->conc, flags, &r->conc_halfstep, err)))
            goto done;
        for (size_t k = 0; k < n; k++) {
            r->nland += flags[k] == 1;
            r->nnoinfo += flags[k] == 2;
        }
        if (r->nland || r->nnoinfo) {
            r->land = flags;
            flags = NULL;
            log_info("ice raster %s: band %d flags: %zu land/coast/lake cells, %zu cells without "
                     "information (not open water)", path, conc, r->nland, r->nnoinfo);
        }
        if (thick > 0) {
            GDALRasterBandH ht = GDALGetRasterBand(ds, thick);
            char label[64], name[64];
            snprintf(label, sizeof label, "thickness band %d", thick);
            snprintf(name, sizeof name, "%.40s", *band_name(ht) ? band_name(ht) : label);
            if ((rc = raster_thickness_kind(path, label, name, item(ht, "cell_methods"),
                                            item(ht, "long_name"), item(ht, "standard_name"),
                                            o->thickness_kind, &r->thickness_kind,
                                            r->thickness_why, sizeof r->thickness_why, err)))
                goto done;
            if ((rc = read_window(ht, path, thick, win, nyf, top_down, r->thick, err)) ||
                (rc = unpack(ht, path, thick, n, r->thick, NULL, NULL, err)))
                goto done;
            /* any length unit (udunits2: cm, mm, ...); none means m */
            const char *u = band_units(ht);
            if (u && strcmp(u, "m") != 0) {
                cf_units *cu = NULL;
                double a = 1, bb = 0;
                rc = cf_units_create(&cu, err);
                if (rc == SPH_OK && (cf_units_linear(cu, u, "m", &a, &bb) != 0 || bb != 0.0 ||
                                     !(a > 0.0)))
                    rc = sph_err_set(err, SPH_ERR_UNITS, "ice raster %s: thickness band %d units "
                                     "'%s' are not a length", path, thick, u);
                cf_units_free(cu);
                if (rc)
                    goto done;
                for (size_t k = 0; k < n; k++)
                    r->thick[k] *= a;
            }
        } else {
            log_info("ice raster %s: no thickness band, using %g m", path, o->default_thickness);
            for (size_t k = 0; k < n; k++)
                r->thick[k] = NAN;
        }
        for (size_t k = 0; r->land && k < n; k++)
            if (r->land[k])
                r->conc[k] = NAN;
    }
    if (projected) {
        char label[64];
        snprintf(label, sizeof label, "band %d", ims ? 1 : conc);
        if ((rc = raster_set_regular_projected(r, wkt, label, x0 + win[0] * dx, dx,
                                               y0 + win[2] * dy, dy, err)))
            goto done;
    } else {
        for (int i = 0; i < nx; i++)
            r->lon[i] = x0 + i * dx;
        for (int j = 0; j < ny; j++)
            r->lat[j] = y0 + j * dy;
        r->dlon = dx;
        r->dlat = dy;
    }
    if (ims)
        snprintf(r->grid, sizeof r->grid, "projected, IMS %s GeoTIFF (columns %d..%d, rows %d..%d "
                 "from the bottom), %g x %g km cells, %.200s; ice cells: concentration %g, "
                 "thickness %g m (initial.ims.*)", ims->name, win[0] + 1, win[1] + 1, win[2] + 1,
                 win[3] + 1, dx / 1000, dy / 1000, p4 ? p4 : "?", o->ims_ice_conc,
                 o->ims_ice_thick);
    else if (projected)
        snprintf(r->grid, sizeof r->grid, "projected, GeoTIFF band %d, %g x %g km cells, %.400s",
                 conc, dx / 1000, dy / 1000, p4 ? p4 : "?");
    else
        snprintf(r->grid, sizeof r->grid, "regular lon/lat, GeoTIFF band %d, %g x %g degrees",
                 conc, r->dlon, r->dlat);
    if (!ims && (o->gdal_conc_band || o->gdal_thick_band || o->gdal_conc_units))
        snprintf(r->assumed, sizeof r->assumed, "GeoTIFF concentration band %d%s, thickness "
                 "band %d%s, concentration in %s%s", conc,
                 o->gdal_conc_band ? " (initial.gdal.conc_band)" : "", thick > 0 ? thick : 0,
                 o->gdal_thick_band ? " (initial.gdal.thick_band)" : "",
                 percent ? "percent" : "fraction",
                 o->gdal_conc_units ? " (initial.gdal.conc_units)" : "");
    rc = raster_finish(r, percent, o, err);
done:
    if (ds)
        GDALClose(ds);
    CPLFree(wkt);
    CPLFree(p4);
    CPLPopErrorHandler();
    free(tmp);
    free(flags);
    free(cls);
    return raster_hand_over(r, rc, out);
}

static int probe_gdal(const unsigned char *head, size_t got)
{
    return got >= 4 && (memcmp(head, "II*\0", 4) == 0 || memcmp(head, "MM\0*", 4) == 0 ||
                        memcmp(head, "II+\0", 4) == 0 || memcmp(head, "MM\0+", 4) == 0);
}

const raster_driver raster_driver_gdal = {"geotiff", probe_gdal, read_gdal};
