/* Fluxes into the ocean on the ocean's grid: see io/ocean_fluxes.h and
 * docs/ocean-coupling.md. One netCDF-4 file per cycle, one record per
 * output interval along an unlimited time with bounds; written to a
 * temporary name and renamed into place by ofx_close. */
#include "io/ocean_fluxes.h"

#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "io/ncfile.h"
#include "ocean_fluxes_impl.h"
#include "util/fileio.h"
#include "util/timeutil.h"

static const struct {
    const char *name, *standard_name, *long_name, *units, *cell_methods, *positive;
} specs[OFX_NFIELDS] = {
    [OFX_HFDS] = {"hfds", "surface_downward_heat_flux_in_sea_water",
                  "net heat flux into the ocean under the ice and through its leads", "W m-2",
                  "area: mean time: mean", "down"},
    [OFX_HFSITHERMDS] = {"hfsithermds", "heat_flux_into_sea_water_due_to_sea_ice_thermodynamics",
                         "heat flux into the ocean under the ice (ice-ocean exchange)", "W m-2",
                         "area: mean time: mean", "down"},
    [OFX_SIFLFWBOT] = {"siflfwbot", "water_flux_into_sea_water_due_to_sea_ice_thermodynamics",
                       "fresh water flux from sea ice (its salt excluded) and snow melt", "kg m-2 s-1",
                       "area: mean time: mean", "down"},
    [OFX_SIFLSALTBOT] = {"siflsaltbot", "downward_sea_ice_basal_salt_flux", "salt flux from sea ice",
                         "kg m-2 s-1", "area: mean time: mean", "down"},
    [OFX_TAUUO] = {"tauuo", "downward_x_stress_at_sea_water_surface",
                   "stress of the ice on the ocean, grid x component", "N m-2", "area: mean time: mean",
                   "down"},
    [OFX_TAUVO] = {"tauvo", "downward_y_stress_at_sea_water_surface",
                   "stress of the ice on the ocean, grid y component", "N m-2", "area: mean time: mean",
                   "down"},
    [OFX_SISTRXUBOT] = {"sistrxubot", "upward_x_stress_at_sea_ice_base",
                        "stress of the ocean on the ice, grid x component (= -tauuo)", "N m-2",
                        "area: mean time: mean", NULL},
    [OFX_SISTRYUBOT] = {"sistryubot", "upward_y_stress_at_sea_ice_base",
                        "stress of the ocean on the ice, grid y component (= -tauvo)", "N m-2",
                        "area: mean time: mean", NULL},
    [OFX_SIFLSWDBOT] = {"siflswdbot", "downwelling_shortwave_flux_in_sea_water_at_sea_ice_base",
                        "shortwave reaching the ice base (already absorbed there: not part of hfds)",
                        "W m-2", "area: mean time: mean", "down"},
    [OFX_SICONC] = {"siconc", "sea_ice_area_fraction",
                    "ice area fraction at the end of the interval (regridded ice area, at most 1)",
                    "1", "area: mean time: point", NULL},
    [OFX_SIVOL] = {"sivol", "sea_ice_thickness",
                   "ice volume per cell area at the end of the interval", "m",
                   "area: mean time: point", NULL},
    [OFX_SITHICK] = {"sithick", "sea_ice_thickness",
                     "ice thickness over the ice-covered part at the end of the interval", "m",
                     "area: mean where sea_ice time: point", NULL},
};


const char *ofx_field_name(int k) { return k >= 0 && k < OFX_NFIELDS ? specs[k].name : NULL; }
size_t ofx_lost(const ofx_writer *w) { return w ? w->lost_record : 0; }
size_t ofx_records(const ofx_writer *w) { return w ? w->nrec : 0; }

static void writer_free(ofx_writer *w)
{
    free(w->cx);
    free(w->cy);
    free(w->area);
    free(w->xaxis);
    free(w->yaxis);
    free(w->land);
    for (int k = 0; k < NACC; k++)
        free(w->acc[k]);
    for (int k = 0; k < OFX_NFIELDS; k++)
        free(w->add[k]);
    free(w->out);
    free(w->bstart);
    free(w->bcell);
    free(w->w);
    free(w->wc);
    ofxc_free(w);
    free(w);
}

void ofx_abort(ofx_writer *w)
{
    if (!w)
        return;
    (void)ncfile_close(&w->nc);
    if (w->tmp[0])
        unlink(w->tmp);
    writer_free(w);
}

static int on_plane(const ofx_writer *w, size_t c) { return isfinite(w->cx[c]) && isfinite(w->cy[c]); }
static int water(const ofx_writer *w, size_t c) { return !(w->land && w->land[c]) && on_plane(w, c); }
int ofx_water_cell(const ofx_writer *w, size_t c) { return water(w, c); }

double ofx_grid_angle(const ofx_writer *w, size_t c)
{
    return w && w->kind == OFX_GRID_CURV && c < w->n ? w->alpha[c] : NAN;
}

int ofx_reserve(ofx_writer *w, size_t n, sph_error *err)
{
    if (n <= w->wcap)
        return SPH_OK;
    size_t nc = w->wcap ? w->wcap : 64;
    while (nc < n)
        nc *= 2;
    double *nw = realloc(w->w, nc * sizeof *nw);
    if (nw)
        w->w = nw;
    size_t *nwc = nw ? realloc(w->wc, nc * sizeof *nwc) : NULL;
    if (!nw || !nwc)
        return sph_err_set(err, SPH_ERR_NOMEM, "ocean fluxes %s: out of memory", w->path);
    w->wc = nwc;
    w->wcap = nc;
    return SPH_OK;
}

/* The centre bins within reach of (x, y): [i0, i1] x [j0, j1]. */
static void centre_bins(const ofx_writer *w, double x, double y, double reach, int b[4])
{
    b[0] = (int)floor((x - reach - w->bx0) / w->bin);
    b[1] = (int)floor((x + reach - w->bx0) / w->bin);
    b[2] = (int)floor((y - reach - w->by0) / w->bin);
    b[3] = (int)floor((y + reach - w->by0) / w->bin);
    b[0] = b[0] < 0 ? 0 : b[0];
    b[2] = b[2] < 0 ? 0 : b[2];
    b[1] = b[1] >= w->nbx ? w->nbx - 1 : b[1];
    b[3] = b[3] >= w->nby ? w->nby - 1 : b[3];
}

long ofx_nearest_water(const ofx_writer *w, double x, double y, double reach)
{
    long best = -1;
    double bd = reach * reach;
    int b4[4];
    centre_bins(w, x, y, reach, b4);
    /* a row's bins i0..i1 hold consecutive cells of the index */
    for (int j = b4[2]; j <= b4[3] && b4[0] <= b4[1]; j++) {
        size_t row = (size_t)j * w->nbx, q1 = w->bstart[row + b4[1] + 1];
        for (size_t q = w->bstart[row + b4[0]]; q < q1; q++) {
            size_t c = w->bcell[q];
            double d = (w->cx[c] - x) * (w->cx[c] - x) + (w->cy[c] - y) * (w->cy[c] - y);
            if (water(w, c) && (d < bd || (d == bd && best >= 0 && (long)c < best))) {
                bd = d;
                best = (long)c;
            }
        }
    }
    return best;
}

void ofx_fit_bins(double wx, double wy, size_t n, double *bin, int *nbx, int *nby)
{
    double fx = wx / *bin + 1.0, fy = wy / *bin + 1.0;
    /* at most ~4 bins per cell: a plane far wider than its cells (a grid
     * crossing the projection's edge) gets coarser bins */
    while (fx * fy > 4.0 * (double)n + 16.0) {
        *bin *= 2.0;
        fx = wx / *bin + 1.0;
        fy = wy / *bin + 1.0;
    }
    *nbx = (int)fx;
    *nby = (int)fy;
}

/* Bins over the cells' centres (land too: it tells inside from outside),
 * side ~ the mean cell size. */
static int build_index(ofx_writer *w, sph_error *err)
{
    double x0 = HUGE_VAL, x1 = -HUGE_VAL, y0 = HUGE_VAL, y1 = -HUGE_VAL, side = 0.0;
    size_t nw = 0;
    for (size_t c = 0; c < w->n; c++) {
        if (!on_plane(w, c))
            continue;
        x0 = fmin(x0, w->cx[c]);
        x1 = fmax(x1, w->cx[c]);
        y0 = fmin(y0, w->cy[c]);
        y1 = fmax(y1, w->cy[c]);
        side += sqrt(w->area[c]);
        nw++;
    }
    w->bin = nw ? side / (double)nw : 1.0;
    if (!nw) {
        x0 = x1 = y0 = y1 = 0.0;
    }
    w->bx0 = x0;
    w->by0 = y0;
    ofx_fit_bins(x1 - x0, y1 - y0, w->n, &w->bin, &w->nbx, &w->nby);
    size_t nb = (size_t)w->nbx * (size_t)w->nby;
    w->bstart = calloc(nb + 1, sizeof *w->bstart);
    w->bcell = malloc((nw ? nw : 1) * sizeof *w->bcell);
    if (!w->bstart || !w->bcell)
        return sph_err_set(err, SPH_ERR_NOMEM, "ocean fluxes %s: out of memory (grid index)", w->path);
    for (size_t c = 0; c < w->n; c++)
        if (on_plane(w, c)) {
            int bi = (int)((w->cx[c] - x0) / w->bin), bj = (int)((w->cy[c] - y0) / w->bin);
            w->bstart[(size_t)bj * w->nbx + bi + 1]++;
        }
    for (size_t b = 0; b < nb; b++)
        w->bstart[b + 1] += w->bstart[b];
    size_t *fill = calloc(nb ? nb : 1, sizeof *fill);
    if (!fill)
        return sph_err_set(err, SPH_ERR_NOMEM, "ocean fluxes %s: out of memory (grid index)", w->path);
    for (size_t c = 0; c < w->n; c++) /* cells in index order: deterministic sums */
        if (on_plane(w, c)) {
            int bi = (int)((w->cx[c] - x0) / w->bin), bj = (int)((w->cy[c] - y0) / w->bin);
            size_t b = (size_t)bj * w->nbx + bi;
            w->bcell[w->bstart[b] + fill[b]++] = c;
        }
    free(fill);
    return SPH_OK;
}

#define NCW(call, what)                                                                      \
    do {                                                                                     \
        int st_ = (call);                                                                    \
        if (st_ != NC_NOERR)                                                                 \
            return sph_err_set(err, SPH_ERR_NETCDF, "ocean fluxes %s: %s: %s", w->path, what, \
                               nc_strerror(st_));                                            \
    } while (0)

static int put_text(int nc, int var, const char *name, const char *text)
{
    return text ? nc_put_att_text(nc, var, name, strlen(text), text) : NC_NOERR;
}

static int def_coord(int nc, const char *name, int ndims, const int *dims, const char *std, const char *units,
                     const char *axis, int *v)
{
    int st;
    if ((st = nc_def_var(nc, name, NC_DOUBLE, ndims, dims, v)) || (st = put_text(nc, *v, "standard_name", std)) ||
        (st = put_text(nc, *v, "units", units)))
        return st;
    return put_text(nc, *v, "axis", axis);
}

static int define_file(ofx_writer *w, const ofx_grid *g, const ofx_meta *m, sph_error *err)
{
    int nc = w->nc, d_t, d_nv, d_y, d_x, v_x, v_y, v_area, v_lon = -1, v_lat = -1;
    int lonlat = g->kind == OFX_GRID_LONLAT, curv = g->kind == OFX_GRID_CURV;
    int d_v4 = -1, v_blon = -1, v_blat = -1, v_ang = -1;
    NCW(nc_def_dim(nc, "time", NC_UNLIMITED, &d_t), "define dimension");
    NCW(nc_def_dim(nc, "nv", 2, &d_nv), "define dimension");
    NCW(nc_def_dim(nc, lonlat ? "lat" : "y", (size_t)g->ny, &d_y), "define dimension");
    NCW(nc_def_dim(nc, lonlat ? "lon" : "x", (size_t)g->nx, &d_x), "define dimension");
    NCW(nc_def_var(nc, "time", NC_DOUBLE, 1, &d_t, &w->v_time), "define variable");
    NCW(put_text(nc, w->v_time, "standard_name", "time"), "write attribute");
    NCW(put_text(nc, w->v_time, "long_name", "end of the averaging interval"), "write attribute");
    NCW(put_text(nc, w->v_time, "units", "seconds since 1970-01-01 00:00:00"), "write attribute");
    NCW(put_text(nc, w->v_time, "calendar", "standard"), "write attribute");
    NCW(put_text(nc, w->v_time, "axis", "T"), "write attribute");
    NCW(put_text(nc, w->v_time, "bounds", "time_bnds"), "write attribute");
    int dtb[2] = {d_t, d_nv};
    NCW(nc_def_var(nc, "time_bnds", NC_DOUBLE, 2, dtb, &w->v_bnds), "define variable");
    NCW(put_text(nc, w->v_bnds, "units", "seconds since 1970-01-01 00:00:00"), "write attribute");
    int d2[2] = {d_y, d_x}, d3[3] = {d_t, d_y, d_x};
    /* lon/lat axes, or x/y axes with 2-D lat/lon auxiliary coordinates;
     * a curvilinear grid: index dimensions y, x, 2-D lat/lon with bounds */
    if (!curv) {
        NCW(def_coord(nc, lonlat ? "lat" : "y", 1, &d_y, lonlat ? "latitude" : "projection_y_coordinate",
                      lonlat ? "degrees_north" : "m", "Y", &v_y), "define variable");
        NCW(def_coord(nc, lonlat ? "lon" : "x", 1, &d_x, lonlat ? "longitude" : "projection_x_coordinate",
                      lonlat ? "degrees_east" : "m", "X", &v_x), "define variable");
    }
    if (!lonlat) {
        NCW(def_coord(nc, "lat", 2, d2, "latitude", "degrees_north", NULL, &v_lat), "define variable");
        NCW(def_coord(nc, "lon", 2, d2, "longitude", "degrees_east", NULL, &v_lon), "define variable");
    }
    if (curv) {
        NCW(nc_def_dim(nc, "nv4", 4, &d_v4), "define dimension");
        int d4[3] = {d_y, d_x, d_v4};
        NCW(put_text(nc, v_lat, "bounds", "lat_bnds"), "write attribute");
        NCW(put_text(nc, v_lon, "bounds", "lon_bnds"), "write attribute");
        NCW(nc_def_var(nc, "lat_bnds", NC_DOUBLE, 3, d4, &v_blat), "define variable");
        NCW(nc_def_var(nc, "lon_bnds", NC_DOUBLE, 3, d4, &v_blon), "define variable");
        NCW(put_text(nc, v_blat, "units", "degrees_north"), "write attribute");
        NCW(put_text(nc, v_blon, "units", "degrees_east"), "write attribute");
        NCW(put_text(nc, v_blon, "comment", g->corners), "write attribute");
        NCW(nc_def_var(nc, "angle", NC_DOUBLE, 2, d2, &v_ang), "define variable");
        NCW(put_text(nc, v_ang, "standard_name", "angle_of_rotation_from_east_to_x"), "write attribute");
        NCW(put_text(nc, v_ang, "long_name", "angle between the grid's i (x) axis and east, anticlockwise, "
                                             "computed from the grid's cell centres"), "write attribute");
        NCW(put_text(nc, v_ang, "units", "radians"), "write attribute");
        NCW(put_text(nc, v_ang, "coordinates", "lat lon"), "write attribute");
    }
    NCW(nc_def_var(nc, "areacello", NC_DOUBLE, 2, d2, &v_area), "define variable");
    NCW(put_text(nc, v_area, "standard_name", "cell_area"), "write attribute");
    NCW(put_text(nc, v_area, "long_name", "true area of the cell"), "write attribute");
    NCW(put_text(nc, v_area, "units", "m2"), "write attribute");
    if (!lonlat)
        NCW(put_text(nc, v_area, "coordinates", "lat lon"), "write attribute");
    NCW(nc_def_var(nc, "particles_lost", NC_INT64, 1, &d_t, &w->v_lost), "define variable");
    NCW(put_text(nc, w->v_lost, "long_name", "particles farther from every water cell than their "
                                             "radius: their fluxes are not in this record"), "write attribute");
    NCW(put_text(nc, w->v_lost, "units", "1"), "write attribute");
    for (int k = 0; k < OFX_NFIELDS; k++) {
        int v;
        NCW(nc_def_var(nc, specs[k].name, NC_DOUBLE, 3, d3, &v), "define variable");
        size_t chunk[3] = {1, (size_t)g->ny, (size_t)g->nx};
        NCW(nc_def_var_chunking(nc, v, NC_CHUNKED, chunk), "define chunking");
        NCW(nc_def_var_deflate(nc, v, 1, 1, 4), "define compression");
        double fill = OFX_FILL;
        NCW(nc_def_var_fill(nc, v, 0, &fill), "define fill value");
        NCW(put_text(nc, v, "standard_name", specs[k].standard_name), "write attribute");
        NCW(put_text(nc, v, "long_name", specs[k].long_name), "write attribute");
        NCW(put_text(nc, v, "units", specs[k].units), "write attribute");
        NCW(put_text(nc, v, "cell_methods", specs[k].cell_methods), "write attribute");
        NCW(put_text(nc, v, "cell_measures", "area: areacello"), "write attribute");
        NCW(put_text(nc, v, "positive", specs[k].positive), "write attribute");
        if (!lonlat)
            NCW(put_text(nc, v, "coordinates", "lat lon"), "write attribute");
        if (curv && k >= OFX_TAUUO && k <= OFX_SISTRYUBOT)
            NCW(put_text(nc, v, "comment",
                         k == OFX_TAUUO || k == OFX_SISTRXUBOT
                             ? "grid-relative: the component along the grid's i (x) axis, which points `angle` "
                               "anticlockwise from east; eastward = x cos(angle) - y sin(angle)"
                             : "grid-relative: the component along the grid's j (y) axis, `angle` + 90 degrees "
                               "anticlockwise from east; northward = x sin(angle) + y cos(angle)"),
                "write attribute");
        w->v_data[k] = v;
    }
    char iso[32];
    time_format_iso(m->cycle_time, iso, sizeof iso);
    NCW(put_text(nc, NC_GLOBAL, "Conventions", "CF-1.8"), "write attribute");
    NCW(put_text(nc, NC_GLOBAL, "title", m->title ? m->title : "sphice fluxes into the ocean"),
        "write attribute");
    NCW(put_text(nc, NC_GLOBAL, "institution", m->institution), "write attribute");
    NCW(put_text(nc, NC_GLOBAL, "source", "sphice SPH sea-ice model"), "write attribute");
    NCW(put_text(nc, NC_GLOBAL, "sphice_version", m->model_version), "write attribute");
    NCW(put_text(nc, NC_GLOBAL, "git_revision", m->git_revision), "write attribute");
    NCW(put_text(nc, NC_GLOBAL, "cycle_time", iso), "write attribute");
    NCW(put_text(nc, NC_GLOBAL, "comment",
                 "Fluxes into the ocean, positive down, means over each record's time_bnds; "
                 "siconc, sivol, sithick at the record's end. Layout, signs and formulas: "
                 "docs/ocean-coupling.md."), "write attribute");
    if (g->projection)
        NCW(put_text(nc, NC_GLOBAL, "model_plane_projection", g->projection), "write attribute");
    if (g->grid_source)
        NCW(put_text(nc, NC_GLOBAL, "grid_source", g->grid_source), "write attribute");
    if (curv) {
        NCW(put_text(nc, NC_GLOBAL, "cell_corners", g->corners), "write attribute");
        NCW(put_text(nc, NC_GLOBAL, "stress_orientation",
                     "grid: tauuo, tauvo, sistrxubot, sistryubot are along the grid's i (x) and j (y) axes "
                     "(ROMS xi/eta), turned from east/north by the variable angle"), "write attribute");
        NCW(put_text(nc, NC_GLOBAL, "regridding",
                     "each particle's footprint (a disc, as a regular 32-gon of its area) clipped to the cell "
                     "polygons on the model plane; weights normalised to 1 over the water cells"),
            "write attribute");
    } else {
        NCW(put_text(nc, NC_GLOBAL, "stress_orientation",
                     lonlat ? "east/north: tauuo, tauvo, sistrxubot, sistryubot are eastward and northward"
                            : "the model plane's x/y axes"), "write attribute");
    }
    NCW(nc_enddef(nc), "end definitions");
    if (!curv) {
        NCW(nc_put_var_double(nc, v_x, g->xaxis), "write");
        NCW(nc_put_var_double(nc, v_y, g->yaxis), "write");
    } else {
        NCW(nc_put_var_double(nc, v_blat, g->blat), "write");
        NCW(nc_put_var_double(nc, v_blon, g->blon), "write");
        NCW(nc_put_var_double(nc, v_ang, w->alpha), "write");
    }
    if (!lonlat) {
        NCW(nc_put_var_double(nc, v_lat, g->lat), "write");
        NCW(nc_put_var_double(nc, v_lon, g->lon), "write");
    }
    NCW(nc_put_var_double(nc, v_area, g->area), "write");
    return SPH_OK;
}

int ofx_open(ofx_writer **out, const ofx_grid *g, const ofx_meta *m, const char *path, sph_error *err)
{
    *out = NULL;
    int curv = g && g->kind == OFX_GRID_CURV;
    if (!g || !m || !path || g->nx < 1 || g->ny < 1 || (!curv && (!g->xaxis || !g->yaxis)) || !g->cx || !g->cy ||
        !g->area || (g->kind != OFX_GRID_LONLAT && (!g->lon || !g->lat)) ||
        (curv && (!g->blon || !g->blat || !g->bx || !g->by || !g->corners)))
        return sph_err_set(err, SPH_ERR_PARAM, "ocean fluxes %s: incomplete grid", path ? path : "(no path)");
    ofx_writer *w = calloc(1, sizeof *w);
    if (!w)
        return sph_err_set(err, SPH_ERR_NOMEM, "ocean fluxes %s: out of memory", path);
    w->nc = -1;
    w->kind = g->kind;
    w->nx = g->nx;
    w->ny = g->ny;
    w->n = (size_t)g->nx * (size_t)g->ny;
    if (snprintf(w->path, sizeof w->path, "%s", path) >= (int)sizeof w->path) {
        writer_free(w);
        return sph_err_set(err, SPH_ERR_PARAM, "ocean fluxes: path too long: %s", path);
    }
    for (size_t c = 0; c < w->n; c++)
        if (!(g->area[c] > 0.0) || !isfinite(g->area[c])) {
            int rc = sph_err_set(err, SPH_ERR_PARAM, "ocean fluxes %s: cell %zu has area %g m2 (must be > 0)",
                                 path, c, g->area[c]);
            writer_free(w);
            return rc;
        }
    int ok = 1;
    size_t bytes = w->n * sizeof(double);
    ok &= (w->cx = malloc(bytes)) != NULL;
    ok &= (w->cy = malloc(bytes)) != NULL;
    ok &= (w->area = malloc(bytes)) != NULL;
    ok &= (w->out = malloc(bytes)) != NULL;
    ok &= (w->xaxis = malloc((size_t)g->nx * sizeof(double))) != NULL;
    ok &= (w->yaxis = malloc((size_t)g->ny * sizeof(double))) != NULL;
    for (int k = 0; k < NACC; k++)
        ok &= (w->acc[k] = calloc(w->n, sizeof(double))) != NULL;
    for (int k = 0; k < OFX_NFIELDS; k++)
        ok &= (w->add[k] = calloc(w->n, sizeof(double))) != NULL;
    if (g->land)
        ok &= (w->land = malloc(w->n)) != NULL;
    if (!ok) {
        writer_free(w);
        return sph_err_set(err, SPH_ERR_NOMEM, "ocean fluxes %s: out of memory (%zu cells)", path, w->n);
    }
    memcpy(w->cx, g->cx, bytes);
    memcpy(w->cy, g->cy, bytes);
    memcpy(w->area, g->area, bytes);
    if (!curv) {
        memcpy(w->xaxis, g->xaxis, (size_t)g->nx * sizeof(double));
        memcpy(w->yaxis, g->yaxis, (size_t)g->ny * sizeof(double));
    }
    if (g->land)
        memcpy(w->land, g->land, w->n);
    int rc = build_index(w, err);
    if (!rc && curv)
        rc = ofxc_setup(w, g, err);
    if (rc) {
        writer_free(w);
        return rc;
    }
    atomic_tmp_name(path, w->tmp, sizeof w->tmp);
    int st = nc_create(w->tmp, NC_NETCDF4 | NC_CLOBBER, &w->nc);
    if (st != NC_NOERR) {
        w->nc = -1;
        w->tmp[0] = '\0';
        rc = sph_err_set(err, SPH_ERR_NETCDF, "ocean fluxes %s: create: %s", path, nc_strerror(st));
        writer_free(w);
        return rc;
    }
    if ((rc = define_file(w, g, m, err))) {
        ofx_abort(w);
        return rc;
    }
    *out = w;
    return SPH_OK;
}

/* The water cells within radius R of (x, y) and their normalised weights
 * into w->wc / w->w; the nearest water cell within R + 2 bins when none
 * is. A point farther than 0.75 sqrt(area) from the nearest cell centre
 * (land or water) is outside the grid (a square cell's corner is at
 * 0.707). Returns the count (0: outside or lost). */
static size_t place(ofx_writer *w, double x, double y, double R, sph_error *err, int *rc)
{
    size_t cnt = 0;
    double sum = 0.0, reach = R + 2.0 * w->bin, best = HUGE_VAL, best_any = HUGE_VAL;
    size_t bestc = 0, bestc_any = 0;
    int b4[4];
    centre_bins(w, x, y, reach, b4);
    int i0 = b4[0], i1 = b4[1], j0 = b4[2], j1 = b4[3];
    for (int j = j0; j <= j1; j++)
        for (int i = i0; i <= i1; i++) {
            size_t b = (size_t)j * w->nbx + i;
            for (size_t q = w->bstart[b]; q < w->bstart[b + 1]; q++) {
                size_t c = w->bcell[q];
                double dx = w->cx[c] - x, dy = w->cy[c] - y, d2 = dx * dx + dy * dy;
                if (d2 < best_any) {
                    best_any = d2;
                    bestc_any = c;
                }
                if (!water(w, c))
                    continue;
                if (d2 < best) {
                    best = d2;
                    bestc = c;
                }
                if (d2 >= R * R)
                    continue;
                if (cnt == w->wcap) {
                    size_t nc = w->wcap ? 2 * w->wcap : 64;
                    double *nw = realloc(w->w, nc * sizeof *nw);
                    if (nw)
                        w->w = nw;
                    size_t *nwc = nw ? realloc(w->wc, nc * sizeof *nwc) : NULL;
                    if (!nw || !nwc) {
                        *rc = sph_err_set(err, SPH_ERR_NOMEM, "ocean fluxes %s: out of memory", w->path);
                        return 0;
                    }
                    w->wc = nwc;
                    w->wcap = nc;
                }
                double s = 1.0 - d2 / (R * R);
                w->w[cnt] = s * s * w->area[c];
                w->wc[cnt++] = c;
                sum += w->w[cnt - 1];
            }
        }
    if (!(best_any <= 0.5625 * w->area[bestc_any])) /* 0.75^2 */
        return 0;
    if (cnt == 0 || !(sum > 0.0)) {
        if (best > reach * reach)
            return 0;
        if (w->wcap == 0) {
            w->w = malloc(64 * sizeof *w->w);
            w->wc = malloc(64 * sizeof *w->wc);
            if (!w->w || !w->wc) {
                *rc = sph_err_set(err, SPH_ERR_NOMEM, "ocean fluxes %s: out of memory", w->path);
                return 0;
            }
            w->wcap = 64;
        }
        w->w[0] = 1.0;
        w->wc[0] = bestc;
        return 1;
    }
    for (size_t q = 0; q < cnt; q++)
        w->w[q] /= sum;
    return cnt;
}

int ofx_add_particles(ofx_writer *w, const ofx_particles *p, sph_error *err)
{
    if (!w || !p)
        return sph_err_set(err, SPH_ERR_PARAM, "ocean fluxes: no writer or particles");
    if (p->n == 0)
        return SPH_OK;
    const double *src[NACC] = {p->heat_ice, p->heat_lead, p->water, p->salt, p->taux, p->tauy,
                               p->swbase, p->ice_area, p->ice_volume};
    if (!p->x || !p->y || !p->radius)
        return sph_err_set(err, SPH_ERR_PARAM, "ocean fluxes %s: particles without positions", w->path);
    for (int a = 0; a < NACC; a++)
        if (!src[a])
            return sph_err_set(err, SPH_ERR_PARAM, "ocean fluxes %s: particle amount %d missing", w->path, a);
    for (size_t k = 0; k < p->n; k++) {
        for (int a = 0; a < NACC; a++)
            if (!isfinite(src[a][k]))
                return sph_err_set(err, SPH_ERR_NUMERICS, "ocean fluxes %s: particle %zu: amount %d is not finite",
                                   w->path, k, a);
        int rc = SPH_OK;
        double R = p->radius[k] > 0.0 && isfinite(p->radius[k]) ? p->radius[k] : 0.0;
        size_t cnt = !(isfinite(p->x[k]) && isfinite(p->y[k])) ? 0
                   : w->kind == OFX_GRID_CURV ? ofxc_place(w, p->x[k], p->y[k], R, err, &rc)
                   : place(w, p->x[k], p->y[k], R, err, &rc);
        if (rc)
            return rc;
        if (cnt == 0) {
            w->lost++;
            continue;
        }
        for (size_t q = 0; q < cnt; q++) {
            size_t c = w->wc[q];
            double wt = w->w[q];
            for (int a = 0; a < NACC; a++)
                w->acc[a][c] += wt * src[a][k];
        }
    }
    return SPH_OK;
}

int ofx_add_cells(ofx_writer *w, int k, const double *flux, sph_error *err)
{
    if (!w || !flux)
        return sph_err_set(err, SPH_ERR_PARAM, "ocean fluxes: no writer or cell fluxes");
    if (k < OFX_HFDS || k > OFX_SIFLSWDBOT)
        return sph_err_set(err, SPH_ERR_PARAM, "ocean fluxes %s: field %d is not a flux that cells may add to",
                           w->path, k);
    for (size_t c = 0; c < w->n; c++) {
        if (!isfinite(flux[c]))
            return sph_err_set(err, SPH_ERR_NUMERICS, "ocean fluxes %s: %s of cell %zu is not finite", w->path,
                               specs[k].name, c);
        if (flux[c] != 0.0 && !water(w, c))
            return sph_err_set(err, SPH_ERR_PARAM, "ocean fluxes %s: %s of cell %zu is %g on land", w->path,
                               specs[k].name, c, flux[c]);
    }
    /* the stress pairs stay opposite */
    int twin = k == OFX_TAUUO ? OFX_SISTRXUBOT : k == OFX_TAUVO ? OFX_SISTRYUBOT
             : k == OFX_SISTRXUBOT ? OFX_TAUUO : k == OFX_SISTRYUBOT ? OFX_TAUVO : -1;
    for (size_t c = 0; c < w->n; c++) {
        w->add[k][c] += flux[c];
        if (twin >= 0)
            w->add[twin][c] -= flux[c];
    }
    /* hfsithermds is part of hfds: heat under the ice adds to both */
    if (k == OFX_HFSITHERMDS)
        for (size_t c = 0; c < w->n; c++)
            w->add[OFX_HFDS][c] += flux[c];
    return SPH_OK;
}

/* Index of the axis cell (bounded by the midpoints between centres, half a
 * spacing beyond the ends) holding v; -1 outside. */
static long axis_cell(const double *a, int n, double v)
{
    if (!isfinite(v))
        return -1;
    if (n == 1)
        return 0;
    int up = a[n - 1] > a[0];
    double lo = a[0] - 0.5 * (a[1] - a[0]), hi = a[n - 1] + 0.5 * (a[n - 1] - a[n - 2]);
    if (up ? (v < lo || v >= hi) : (v > lo || v <= hi))
        return -1;
    long i = 0, j = n - 1; /* the last centre on v's lower side, then the nearer of it and the next */
    while (j - i > 1) {
        long mid = (i + j) / 2;
        if (up ? a[mid] <= v : a[mid] >= v)
            i = mid;
        else
            j = mid;
    }
    return fabs(v - a[i]) <= fabs(a[j] - v) ? i : j;
}

long ofx_locate(const ofx_writer *w, double lon, double lat, double x, double y, double reach)
{
    if (!w)
        return -1;
    if (w->kind == OFX_GRID_CURV) { /* the cell polygon holding (x, y), else the nearest water */
        long c = isfinite(x) && isfinite(y) ? ofxc_cell_at(w, x, y) : -1;
        if (c >= 0 && water(w, (size_t)c))
            return c;
        return isfinite(x) && isfinite(y) && reach > 0.0 ? ofx_nearest_water(w, x, y, reach) : -1;
    }
    double u = w->kind == OFX_GRID_LONLAT ? lon : x, v = w->kind == OFX_GRID_LONLAT ? lat : y;
    if (w->kind == OFX_GRID_LONLAT && isfinite(u) && w->nx > 1 && w->xaxis[1] > w->xaxis[0]) {
        /* the longitude on the axis' side of the seam: [first west edge, + 360) */
        double west = w->xaxis[0] - 0.5 * (w->xaxis[1] - w->xaxis[0]);
        u = west + fmod(fmod(u - west, 360.0) + 360.0, 360.0);
    }
    long i = axis_cell(w->xaxis, w->nx, u), j = axis_cell(w->yaxis, w->ny, v);
    if (i >= 0 && j >= 0) {
        size_t c = (size_t)j * (size_t)w->nx + (size_t)i;
        if (water(w, c))
            return (long)c;
    }
    if (!isfinite(x) || !isfinite(y) || !(reach > 0.0))
        return -1;
    long best = -1;
    double bd = reach * reach;
    for (size_t c = 0; c < w->n; c++) {
        if (!water(w, c))
            continue;
        double dx = w->cx[c] - x, dy = w->cy[c] - y, d = dx * dx + dy * dy;
        if (d <= bd) {
            bd = d;
            best = (long)c;
        }
    }
    return best;
}

int ofx_add_cell_amounts(ofx_writer *w, int k, size_t n, const long *to, const double *amount, double dt,
                         double *lost, sph_error *err)
{
    if (!w || (n > 0 && (!to || !amount)) || !(dt > 0.0))
        return sph_err_set(err, SPH_ERR_PARAM, "ocean fluxes: no writer, cells or interval");
    double *flux = calloc(w->n, sizeof(double));
    if (!flux)
        return sph_err_set(err, SPH_ERR_NOMEM, "ocean fluxes %s: out of memory", w->path);
    double miss = 0.0;
    for (size_t c = 0; c < n; c++) {
        if (amount[c] == 0.0)
            continue;
        if (to[c] < 0 || (size_t)to[c] >= w->n) {
            miss += amount[c];
            continue;
        }
        flux[to[c]] += amount[c] / (w->area[to[c]] * dt);
    }
    int rc = ofx_add_cells(w, k, flux, err);
    free(flux);
    if (lost)
        *lost = miss;
    return rc;
}

int ofx_add_ocean_cells(ofx_writer *w, size_t n, const long *to, const double *rot, const double *heat,
                        const double *water, const double *salt, const double *heat_ice, const double *taux,
                        const double *tauy, const double *swbase, double dt, double lost[3], sph_error *err)
{
    double *tx = calloc(2 * (n > 0 ? n : 1), sizeof(double));
    if (!tx)
        return sph_err_set(err, SPH_ERR_NOMEM, "ocean fluxes: out of memory (%zu cells)", n);
    double *ty = tx + n;
    for (size_t c = 0; c < n; c++) {
        double cs = rot ? rot[c] : 1.0, sn = rot ? rot[n + c] : 0.0;
        if (w && w->kind == OFX_GRID_CURV) { /* plane x/y -> the target cell's i/j */
            double b = to && to[c] >= 0 && (size_t)to[c] < w->n ? w->beta[to[c]] : 0.0;
            cs = cos(b);
            sn = -sin(b);
        }
        tx[c] = taux[c] * cs - tauy[c] * sn;
        ty[c] = taux[c] * sn + tauy[c] * cs;
    }
    const double *amt[7] = {heat, water, salt, heat_ice, tx, ty, swbase};
    const int field[7] = {OFX_HFDS, OFX_SIFLFWBOT, OFX_SIFLSALTBOT, OFX_HFSITHERMDS, OFX_TAUUO, OFX_TAUVO,
                          OFX_SIFLSWDBOT};
    double miss[3] = {0.0, 0.0, 0.0};
    int rc = SPH_OK;
    for (int q = 0; q < 7 && rc == SPH_OK; q++) {
        double l = 0.0;
        rc = ofx_add_cell_amounts(w, field[q], n, to, amt[q], dt, &l, err);
        if (q < 4)
            miss[q == 3 ? 0 : q] += l;
    }
    free(tx);
    if (lost)
        for (int q = 0; q < 3; q++)
            lost[q] = miss[q];
    return rc;
}

/* Field k of the current record into w->out. */
static void record_field(ofx_writer *w, int k, double dt)
{
    for (size_t c = 0; c < w->n; c++) {
        if (!water(w, c)) {
            w->out[c] = OFX_FILL;
            continue;
        }
        double r = 1.0 / (w->area[c] * dt), v, tx = w->acc[ACC_TAUX][c], ty = w->acc[ACC_TAUY][c];
        if (w->kind == OFX_GRID_CURV) { /* plane x/y -> the cell's i/j axes */
            double cb = cos(w->beta[c]), sb = sin(w->beta[c]), ti = tx * cb + ty * sb;
            ty = -tx * sb + ty * cb;
            tx = ti;
        }
        switch (k) {
        case OFX_HFDS: v = (w->acc[ACC_HEAT_ICE][c] + w->acc[ACC_HEAT_LEAD][c]) * r; break;
        case OFX_HFSITHERMDS: v = w->acc[ACC_HEAT_ICE][c] * r; break;
        case OFX_SIFLFWBOT: v = w->acc[ACC_WATER][c] * r; break;
        case OFX_SIFLSALTBOT: v = w->acc[ACC_SALT][c] * r; break;
        case OFX_TAUUO: v = tx * r; break;
        case OFX_TAUVO: v = ty * r; break;
        case OFX_SISTRXUBOT: v = -tx * r; break;
        case OFX_SISTRYUBOT: v = -ty * r; break;
        case OFX_SIFLSWDBOT: v = w->acc[ACC_SWBASE][c] * r; break;
        /* the particles' footprints m/M need not tile the plane exactly, so
         * the regridded ice area may exceed a cell: the fraction is capped
         * at 1 (volume and fluxes are not: they conserve) */
        case OFX_SICONC: v = fmin(1.0, w->acc[ACC_ICE_AREA][c] / w->area[c]); break;
        case OFX_SIVOL: v = w->acc[ACC_ICE_VOLUME][c] / w->area[c]; break;
        default: { /* OFX_SITHICK = sivol / siconc */
            double a = fmin(w->acc[ACC_ICE_AREA][c], w->area[c]);
            v = a > 0.0 ? w->acc[ACC_ICE_VOLUME][c] / a : OFX_FILL;
            break;
        }
        }
        w->out[c] = k <= OFX_SIFLSWDBOT ? v + w->add[k][c] : v;
    }
}

int ofx_write_record(ofx_writer *w, double t_start, double t_end, sph_error *err)
{
    if (!w)
        return sph_err_set(err, SPH_ERR_PARAM, "ocean fluxes: no writer");
    double dt = t_end - t_start;
    if (!(dt > 0.0) || !isfinite(dt))
        return sph_err_set(err, SPH_ERR_PARAM, "ocean fluxes %s: interval [%g, %g] is empty", w->path, t_start,
                           t_end);
    size_t r = w->nrec;
    size_t s1 = r, one = 1, s2[2] = {r, 0}, c2[2] = {1, 2};
    double bnds[2] = {t_start, t_end};
    long long lost = (long long)w->lost;
    NCW(nc_put_var1_double(w->nc, w->v_time, &s1, &t_end), "write");
    NCW(nc_put_vara_double(w->nc, w->v_bnds, s2, c2, bnds), "write");
    NCW(nc_put_vara_longlong(w->nc, w->v_lost, &s1, &one, &lost), "write");
    size_t s3[3] = {r, 0, 0}, c3[3] = {1, (size_t)w->ny, (size_t)w->nx};
    for (int k = 0; k < OFX_NFIELDS; k++) {
        record_field(w, k, dt);
        NCW(nc_put_vara_double(w->nc, w->v_data[k], s3, c3, w->out), "write");
    }
    for (int a = 0; a < NACC; a++)
        memset(w->acc[a], 0, w->n * sizeof(double));
    for (int k = 0; k < OFX_NFIELDS; k++)
        memset(w->add[k], 0, w->n * sizeof(double));
    w->lost_record = w->lost;
    w->lost = 0;
    w->nrec++;
    return SPH_OK;
}

int ofx_close(ofx_writer *w, sph_error *err)
{
    if (!w)
        return sph_err_set(err, SPH_ERR_PARAM, "ocean fluxes: no writer");
    int st = ncfile_close(&w->nc);
    if (st != NC_NOERR) {
        int rc = sph_err_set(err, SPH_ERR_NETCDF, "ocean fluxes %s: close: %s", w->path, nc_strerror(st));
        ofx_abort(w);
        return rc;
    }
    int rc = atomic_commit(w->tmp, w->path, err);
    if (rc) {
        ofx_abort(w);
        return rc;
    }
    w->tmp[0] = '\0';
    writer_free(w);
    return SPH_OK;
}
