/* gen_liaodong: writes the synthetic Liaodong Bay 1999 demo scene.
 *
 * Usage: gen_liaodong OUTDIR [GSHHG_BINNED_FILE]
 *
 * The seed paper's case (PHYSICS.md section 6: 1999-02-08 06:00 to
 * 1999-02-12 06:00 local time, UTC+8) was driven by observations that are
 * not public. This program synthesises a scene with the same documented
 * properties so that the forecast can run end to end:
 *
 *   landmask_liaodong.nc   land_binary_mask at 0.01 deg, rasterised from
 *                          the GSHHG high-resolution binned shoreline
 *   ice_19990208T06.nc     initial ice raster at 0.01 deg: a 35 cm rafted
 *                          patch of ~100 km^2 in thin (< 10 cm) ice
 *   atmos_199902.nc        hourly atmosphere on a 0.25 deg grid
 *   tide_bohai_harmonic.nc M2, S2, K1, O1 elevation and current
 *                          constituents ("harmonic-1" format)
 *   stations.json          approximate platform positions, edge reference
 *
 * Everything random comes from one gsl_rng (mt19937) with a fixed seed, so
 * two runs on the same libraries write the same numbers. Times are UTC,
 * "hours since 1999-02-07 00:00:00": the scene is 22 h .. 118 h, forcing
 * covers 19 h .. 121 h (3 h margin each side).
 */
#include <errno.h>
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_randist.h>
#include <gsl/gsl_rng.h>

#include "util/err.h"
#include "util/fileio.h"
#include "util/log.h"

#define GEN_SEED 19990208UL
#define EARTH_RADIUS_KM 6371.0
#define DEG2RAD (M_PI / 180.0)

/* Scene domain and the fine (0.01 deg) raster shared by mask and ice. */
#define FINE_LON0 120.80
#define FINE_LAT0 39.60
#define FINE_NLON 181 /* 120.80 .. 122.60 */
#define FINE_NLAT 151 /* 39.60 .. 41.10 */
#define FINE_STEP 0.01

/* Scene time axis, hours since 1999-02-07 00:00:00 UTC. */
#define SCENE_T0 22.0   /* 1999-02-08 06:00 local */
#define SCENE_T1 118.0  /* 1999-02-12 06:00 local */
#define FORCING_MARGIN 3.0
#define TIME_UNITS "hours since 1999-02-07 00:00:00"
#define LOCAL_UTC_OFFSET 8.0

/* The seed's rafted patch: box corners (121.75 E, 40.69 N), (121.89 E, 40.55 N). */
#define PATCH_LON_W 121.75
#define PATCH_LON_E 121.89
#define PATCH_LAT_S 40.55
#define PATCH_LAT_N 40.69
#define PATCH_AREA_KM2 100.0
#define PATCH_MEAN_H 0.35

/* Bay axis (NNE-SSW) from the mouth to the head, used by the tide. */
#define AXIS_LON0 121.2
#define AXIS_LAT0 40.0
#define AXIS_LON1 122.0
#define AXIS_LAT1 40.9

static const char *const REFERENCES =
    "Ji Shunying et al., SPH simulation of local drifting sea ice in Liaodong Bay "
    "(the seed paper of sphice; the scene imitates its 1999-02-08..12 case); "
    "Wessel P. and Smith W.H.F. (1996), A global, self-consistent, hierarchical, "
    "high-resolution shoreline database, J. Geophys. Res. 101(B4), 8741-8743 "
    "(GSHHG 2.3.7, coastline of the land mask)";

/* ------------------------------------------------------------------ */
/* Small helpers                                                       */

static double fine_lon(int i) { return (FINE_LON0 * 100.0 + i) / 100.0; }
static double fine_lat(int j) { return (FINE_LAT0 * 100.0 + j) / 100.0; }

/* Area of a lon/lat cell of the given size centred at lat, on the sphere. */
static double cell_area_km2(double lat, double dlon, double dlat)
{
    double s = sin((lat + 0.5 * dlat) * DEG2RAD) - sin((lat - 0.5 * dlat) * DEG2RAD);
    return EARTH_RADIUS_KM * EARTH_RADIUS_KM * dlon * DEG2RAD * s;
}

/* Local km coordinates around the bay (equirectangular at 40.35 N): the
 * random textures are defined in km so that their scales are isotropic. */
static void local_km(double lon, double lat, double *x, double *y)
{
    const double km_per_deg = EARTH_RADIUS_KM * DEG2RAD;
    *x = (lon - 121.7) * cos(40.35 * DEG2RAD) * km_per_deg;
    *y = (lat - 40.35) * km_per_deg;
}

static double clampd(double v, double lo, double hi) { return v < lo ? lo : v > hi ? hi : v; }

static double smoothstep01(double x)
{
    x = clampd(x, 0.0, 1.0);
    return x * x * (3.0 - 2.0 * x);
}

static double bump(double x, double centre, double width)
{
    double z = (x - centre) / width;
    return exp(-z * z);
}

/* A smooth random texture: a sum of NMODES plane waves with random
 * direction, wavelength in [lmin, lmax] km and phase, scaled to unit
 * variance (so values are mostly within +-2). */
#define NOISE_MODES 24
typedef struct {
    double kx[NOISE_MODES], ky[NOISE_MODES], ph[NOISE_MODES], amp[NOISE_MODES];
} noise2d;

static void noise_init(noise2d *n, gsl_rng *rng, double lmin_km, double lmax_km)
{
    double var = 0.0;
    for (int m = 0; m < NOISE_MODES; m++) {
        double lambda = lmin_km + (lmax_km - lmin_km) * gsl_rng_uniform(rng);
        double dir = 2.0 * M_PI * gsl_rng_uniform(rng);
        double k = 2.0 * M_PI / lambda;
        n->kx[m] = k * cos(dir);
        n->ky[m] = k * sin(dir);
        n->ph[m] = 2.0 * M_PI * gsl_rng_uniform(rng);
        n->amp[m] = lambda / lmax_km; /* redder spectrum: long waves dominate */
        var += 0.5 * n->amp[m] * n->amp[m];
    }
    for (int m = 0; m < NOISE_MODES; m++)
        n->amp[m] /= sqrt(var);
}

static double noise_eval(const noise2d *n, double x, double y)
{
    double s = 0.0;
    for (int m = 0; m < NOISE_MODES; m++)
        s += n->amp[m] * cos(n->kx[m] * x + n->ky[m] * y + n->ph[m]);
    return s;
}

/* ------------------------------------------------------------------ */
/* NetCDF writing: one output file at a time, written to a temporary name
 * and renamed into place, so a reader never sees half a file.          */

typedef struct {
    int ncid;
    const char *path;
    char tmp[4096];
    sph_error *err;
} ncw;

static int ncw_fail(ncw *w, int status, const char *what)
{
    return sph_err_set(w->err, SPH_ERR_NETCDF, "%s: %s: %s", w->path, what, nc_strerror(status));
}

#define NCW(w, call)                                   \
    do {                                               \
        int st_ = (call);                              \
        if (st_ != NC_NOERR) {                         \
            ncw_fail((w), st_, #call);                 \
            goto fail;                                 \
        }                                              \
    } while (0)

static int put_text(ncw *w, int varid, const char *name, const char *text)
{
    int st = nc_put_att_text(w->ncid, varid, name, strlen(text), text);
    return st == NC_NOERR ? 0 : ncw_fail(w, st, name);
}

static int ncw_create(ncw *w, const char *path, const char *title, const char *comment,
                      sph_error *err)
{
    w->path = path;
    w->err = err;
    w->ncid = -1;
    atomic_tmp_name(path, w->tmp, sizeof w->tmp);
    int st = nc_create(w->tmp, NC_NETCDF4 | NC_CLOBBER, &w->ncid);
    if (st != NC_NOERR) {
        w->ncid = -1;
        return ncw_fail(w, st, "create");
    }
    char full_comment[2048];
    snprintf(full_comment, sizeof full_comment,
             "%s Synthetic scene: the observations of the seed paper (NOAA AVHRR ice "
             "raster corrected with icebreaker and platform reports, JZ20-2 platform "
             "wind and air temperature, a Bohai tide model) are not public, so every "
             "field here is made up to have their documented properties. Random "
             "textures from GSL mt19937 with seed %lu.",
             comment, GEN_SEED);
    if (put_text(w, NC_GLOBAL, "title", title) || put_text(w, NC_GLOBAL, "source", "synthetic") ||
        put_text(w, NC_GLOBAL, "comment", full_comment) ||
        put_text(w, NC_GLOBAL, "history",
                 "created by tools/gen_liaodong.c (make demo-forcing); deterministic, "
                 "no creation date recorded so that regeneration is reproducible") ||
        put_text(w, NC_GLOBAL, "references", REFERENCES) ||
        put_text(w, NC_GLOBAL, "Conventions", "CF-1.8") ||
        put_text(w, NC_GLOBAL, "sphice_generator", "tools/gen_liaodong.c") ||
        put_text(w, NC_GLOBAL, "institution", "sphice project (synthetic demo data)")) {
        nc_close(w->ncid);
        w->ncid = -1;
        remove(w->tmp);
        return -1;
    }
    return 0;
}

static int ncw_commit(ncw *w)
{
    int st = nc_close(w->ncid);
    w->ncid = -1;
    if (st != NC_NOERR) {
        remove(w->tmp);
        return ncw_fail(w, st, "close");
    }
    return atomic_commit(w->tmp, w->path, w->err) == SPH_OK ? 0 : -1;
}

static void ncw_abort(ncw *w)
{
    if (w->ncid >= 0)
        nc_close(w->ncid);
    w->ncid = -1;
    remove(w->tmp);
}

/* A 1-D coordinate variable with its own dimension. */
static int def_coord(ncw *w, const char *name, size_t n, const double *values,
                     const char *standard_name, const char *long_name, const char *units,
                     const char *axis, int *dimid)
{
    int varid;
    NCW(w, nc_def_dim(w->ncid, name, n, dimid));
    NCW(w, nc_def_var(w->ncid, name, NC_DOUBLE, 1, dimid, &varid));
    if (put_text(w, varid, "standard_name", standard_name) ||
        put_text(w, varid, "long_name", long_name) || put_text(w, varid, "units", units) ||
        put_text(w, varid, "axis", axis))
        return -1;
    if (strcmp(name, "time") == 0 && put_text(w, varid, "calendar", "standard"))
        return -1;
    NCW(w, nc_put_var_double(w->ncid, varid, values));
    return 0;
fail:
    return -1;
}

/* A compressed float data variable. standard_name may be NULL where CF has
 * no name for the quantity (tidal phases); long_name is always set. */
static int def_float(ncw *w, const char *name, int ndims, const int *dimids,
                     const char *standard_name, const char *long_name, const char *units,
                     const float *fill, int *varid)
{
    NCW(w, nc_def_var(w->ncid, name, NC_FLOAT, ndims, dimids, varid));
    NCW(w, nc_def_var_deflate(w->ncid, *varid, 1, 1, 5));
    if (fill)
        NCW(w, nc_def_var_fill(w->ncid, *varid, 0, fill));
    if ((standard_name && put_text(w, *varid, "standard_name", standard_name)) ||
        put_text(w, *varid, "long_name", long_name) || put_text(w, *varid, "units", units))
        return -1;
    return 0;
fail:
    return -1;
}

/* ------------------------------------------------------------------ */
/* GSHHG binned shoreline -> land/sea level at points.
 *
 * The binned file cuts every shoreline polygon into segments per bin
 * (Bin_size_in_minutes; 2 degrees for the high resolution). Point
 * coordinates are unsigned 16-bit offsets from the bin's south-west
 * corner in units of bin_size/65535. Each bin stores the GSHHG level
 * (0 ocean, 1 land, 2 lake, 3 island in lake, 4 pond) of its four corners
 * in Embedded_node_levels_in_a_bin: bits 9-11 SW, 6-8 SE, 3-5 NE, 0-2 NW.
 * Each segment packs npts << 9 | level << 6 | entry << 3 | exit.
 * Bins are numbered from the north pole: row = b / nx covers latitudes
 * 90 - (row + 1) * size .. 90 - row * size, column = b % nx from 0 E.
 *
 * The level at a point: start at a corner of known level and walk a
 * straight ray to the point; each crossing of a level-L shoreline leaves
 * the level-L polygon (level >= L -> L - 1) or enters it (-> L).
 * Crossings are taken in order along the ray. A crossing is counted when
 * the edge's end points lie on strictly different sides of the ray line
 * with "on the line" counted as one side, so rays through vertices are
 * counted consistently. The four corners vote (they agree except on
 * degenerate rays). */

typedef struct {
    double ax, ay, bx, by; /* bin units */
    int level;
} gs_edge;

typedef struct {
    int bin;
    double lon_sw, lat_sw, size_deg;
    int node_level[4];
    gs_edge *edges;
    size_t nedges;
} gs_bin;

typedef struct gs_cross gs_cross;

typedef struct {
    gs_bin *bins;
    size_t nbins;
    int nx;
    double size_deg;
    gs_cross *xbuf; /* crossings along one ray (scratch) */
    size_t xcap;
} gshhg;

static void gshhg_free(gshhg *g)
{
    if (!g)
        return;
    for (size_t i = 0; i < g->nbins; i++)
        free(g->bins[i].edges);
    free(g->bins);
    free(g->xbuf);
    g->xbuf = NULL;
    g->xcap = 0;
    g->bins = NULL;
    g->nbins = 0;
}

static int gs_get_int(int ncid, const char *path, const char *name, size_t index, int *out,
                      sph_error *err)
{
    int varid, st = nc_inq_varid(ncid, name, &varid);
    if (st == NC_NOERR)
        st = nc_get_var1_int(ncid, varid, &index, out);
    if (st != NC_NOERR)
        return sph_err_set(err, SPH_ERR_NETCDF, "%s: %s[%zu]: %s", path, name, index,
                           nc_strerror(st));
    return 0;
}

static int gs_load_bin(int ncid, const char *path, gshhg *g, int b, gs_bin *out,
                       sph_error *err)
{
    int info, nseg, first;
    memset(out, 0, sizeof *out);
    if (gs_get_int(ncid, path, "Embedded_node_levels_in_a_bin", (size_t)b, &info, err) ||
        gs_get_int(ncid, path, "N_segments_in_a_bin", (size_t)b, &nseg, err) ||
        gs_get_int(ncid, path, "Id_of_first_segment_in_a_bin", (size_t)b, &first, err))
        return -1;
    out->bin = b;
    out->size_deg = g->size_deg;
    out->lon_sw = (b % g->nx) * g->size_deg;
    out->lat_sw = 90.0 - (b / g->nx + 1) * g->size_deg;
    unsigned u = (unsigned)info & 0xffffu;
    out->node_level[0] = (int)((u >> 9) & 7);
    out->node_level[1] = (int)((u >> 6) & 7);
    out->node_level[2] = (int)((u >> 3) & 7);
    out->node_level[3] = (int)(u & 7);
    if (nseg <= 0)
        return 0;

    int v_info, v_start, v_dx, v_dy;
    int st = nc_inq_varid(ncid, "Embedded_npts_levels_exit_entry_for_a_segment", &v_info);
    if (st == NC_NOERR) st = nc_inq_varid(ncid, "Id_of_first_point_in_a_segment", &v_start);
    if (st == NC_NOERR) st = nc_inq_varid(ncid, "Relative_longitude_from_SW_corner_of_bin", &v_dx);
    if (st == NC_NOERR) st = nc_inq_varid(ncid, "Relative_latitude_from_SW_corner_of_bin", &v_dy);
    if (st != NC_NOERR)
        return sph_err_set(err, SPH_ERR_NETCDF, "%s: segment variables: %s", path,
                           nc_strerror(st));
    int *seg_info = calloc((size_t)nseg, sizeof *seg_info);
    int *seg_start = calloc((size_t)nseg, sizeof *seg_start);
    short *dx = NULL, *dy = NULL;
    int rc = -1;
    if (!seg_info || !seg_start) {
        sph_err_set(err, SPH_ERR_NOMEM, "%s: segments of bin %d", path, b);
        goto done;
    }
    size_t start = (size_t)first, count = (size_t)nseg;
    st = nc_get_vara_int(ncid, v_info, &start, &count, seg_info);
    if (st == NC_NOERR)
        st = nc_get_vara_int(ncid, v_start, &start, &count, seg_start);
    if (st != NC_NOERR) {
        sph_err_set(err, SPH_ERR_NETCDF, "%s: segments of bin %d: %s", path, b, nc_strerror(st));
        goto done;
    }
    size_t total = 0;
    for (int s = 0; s < nseg; s++)
        total += (size_t)(seg_info[s] >> 9);
    out->edges = calloc(total ? total : 1, sizeof *out->edges);
    if (!out->edges) {
        sph_err_set(err, SPH_ERR_NOMEM, "%s: edges of bin %d", path, b);
        goto done;
    }
    for (int s = 0; s < nseg; s++) {
        size_t npts = (size_t)(seg_info[s] >> 9);
        int level = (seg_info[s] >> 6) & 7;
        if (npts < 2)
            continue;
        short *ndx = realloc(dx, npts * sizeof *dx);
        if (ndx) dx = ndx;
        short *ndy = realloc(dy, npts * sizeof *dy);
        if (ndy) dy = ndy;
        if (!ndx || !ndy) {
            sph_err_set(err, SPH_ERR_NOMEM, "%s: points of bin %d", path, b);
            goto done;
        }
        size_t pstart = (size_t)seg_start[s];
        st = nc_get_vara_short(ncid, v_dx, &pstart, &npts, dx);
        if (st == NC_NOERR)
            st = nc_get_vara_short(ncid, v_dy, &pstart, &npts, dy);
        if (st != NC_NOERR) {
            sph_err_set(err, SPH_ERR_NETCDF, "%s: points of bin %d: %s", path, b,
                        nc_strerror(st));
            goto done;
        }
        for (size_t k = 0; k + 1 < npts; k++) {
            gs_edge *e = &out->edges[out->nedges++];
            e->ax = (unsigned short)dx[k];
            e->ay = (unsigned short)dy[k];
            e->bx = (unsigned short)dx[k + 1];
            e->by = (unsigned short)dy[k + 1];
            e->level = level;
        }
    }
    rc = 0;
done:
    free(seg_info);
    free(seg_start);
    free(dx);
    free(dy);
    return rc;
}

/* Loads the bins covering [lon0,lon1] x [lat0,lat1] (degrees east, 0..360). */
static int gshhg_load(const char *path, double lon0, double lon1, double lat0, double lat1,
                      gshhg *g, sph_error *err)
{
    memset(g, 0, sizeof *g);
    int ncid, st = nc_open(path, NC_NOWRITE, &ncid);
    if (st != NC_NOERR)
        return sph_err_set(err, SPH_ERR_NETCDF, "%s: open GSHHG binned shoreline: %s", path,
                           nc_strerror(st));
    int size_min, ny, rc = -1;
    if (gs_get_int(ncid, path, "Bin_size_in_minutes", 0, &size_min, err) ||
        gs_get_int(ncid, path, "N_bins_in_360_longitude_range", 0, &g->nx, err) ||
        gs_get_int(ncid, path, "N_bins_in_180_degree_latitude_range", 0, &ny, err))
        goto done;
    if (size_min <= 0 || g->nx * size_min != 360 * 60 || ny * size_min != 180 * 60) {
        sph_err_set(err, SPH_ERR_BAD_DATA, "%s: inconsistent bin layout (%d min, %d x %d)",
                    path, size_min, g->nx, ny);
        goto done;
    }
    g->size_deg = size_min / 60.0;
    int c0 = (int)floor(lon0 / g->size_deg), c1 = (int)floor(lon1 / g->size_deg);
    int r0 = (int)floor((90.0 - lat1) / g->size_deg), r1 = (int)floor((90.0 - lat0) / g->size_deg);
    g->bins = calloc((size_t)((c1 - c0 + 1) * (r1 - r0 + 1)), sizeof *g->bins);
    if (!g->bins) {
        sph_err_set(err, SPH_ERR_NOMEM, "%s: bins", path);
        goto done;
    }
    for (int r = r0; r <= r1; r++)
        for (int c = c0; c <= c1; c++) {
            if (gs_load_bin(ncid, path, g, r * g->nx + c, &g->bins[g->nbins], err))
                goto done;
            g->nbins++;
        }
    rc = 0;
done:
    nc_close(ncid);
    if (rc)
        gshhg_free(g);
    return rc;
}

struct gs_cross {
    double t;
    int level;
};

static int cross_cmp(const void *a, const void *b)
{
    double ta = ((const gs_cross *)a)->t, tb = ((const gs_cross *)b)->t;
    return (ta > tb) - (ta < tb);
}

/* Level at (px, py) (bin units) walking from corner k. */
static int gs_level_from_corner(const gs_bin *bin, int k, double px, double py,
                                gs_cross **buf, size_t *cap)
{
    static const double cxs[4] = {0.0, 65535.0, 65535.0, 0.0};
    static const double cys[4] = {0.0, 0.0, 65535.0, 65535.0};
    double cx = cxs[k], cy = cys[k], dx = px - cx, dy = py - cy;
    size_t n = 0;
    for (size_t i = 0; i < bin->nedges; i++) {
        const gs_edge *e = &bin->edges[i];
        double sa = dx * (e->ay - cy) - dy * (e->ax - cx);
        double sb = dx * (e->by - cy) - dy * (e->bx - cx);
        if ((sa > 0.0) == (sb > 0.0))
            continue;
        double ex = e->bx - e->ax, ey = e->by - e->ay;
        double den = dx * ey - dy * ex;
        if (den == 0.0)
            continue;
        double t = ((e->ax - cx) * ey - (e->ay - cy) * ex) / den;
        if (t <= 0.0 || t >= 1.0)
            continue;
        if (n == *cap) {
            size_t ncap = *cap ? 2 * *cap : 64;
            gs_cross *nb = realloc(*buf, ncap * sizeof *nb);
            if (!nb)
                return -1;
            *buf = nb;
            *cap = ncap;
        }
        (*buf)[n].t = t;
        (*buf)[n].level = e->level;
        n++;
    }
    if (n > 1)
        qsort(*buf, n, sizeof **buf, cross_cmp);
    int level = bin->node_level[k];
    for (size_t i = 0; i < n; i++) {
        int L = (*buf)[i].level;
        level = level >= L ? L - 1 : L;
    }
    return level;
}

/* GSHHG level at a point; -1 when the point lies in no loaded bin or on
 * allocation failure. *disagree is set when the corners did not agree. */
static int gshhg_level(gshhg *g, double lon, double lat, int *disagree)
{
    if (lon < 0)
        lon += 360.0;
    for (size_t i = 0; i < g->nbins; i++) {
        const gs_bin *b = &g->bins[i];
        if (lon < b->lon_sw || lon >= b->lon_sw + b->size_deg || lat < b->lat_sw ||
            lat >= b->lat_sw + b->size_deg)
            continue;
        double px = (lon - b->lon_sw) / b->size_deg * 65535.0;
        double py = (lat - b->lat_sw) / b->size_deg * 65535.0;
        int votes[8] = {0}, lv[4];
        for (int k = 0; k < 4; k++) {
            lv[k] = gs_level_from_corner(b, k, px, py, &g->xbuf, &g->xcap);
            if (lv[k] < 0 || lv[k] > 7)
                return -1;
            votes[lv[k]]++;
        }
        int best = lv[0];
        for (int k = 1; k < 4; k++)
            if (votes[lv[k]] > votes[best])
                best = lv[k];
        *disagree = votes[best] != 4;
        return best;
    }
    return -1;
}

/* Land mask on the fine grid: 1 where the GSHHG level is >= 1 (land, and
 * the few inland lakes, which are not part of the sea the model sees). */
static int build_landmask(const char *gshhg_path, unsigned char *mask, sph_error *err)
{
    gshhg g;
    if (gshhg_load(gshhg_path, FINE_LON0 - 0.01, fine_lon(FINE_NLON - 1) + 0.01,
                   FINE_LAT0 - 0.01, fine_lat(FINE_NLAT - 1) + 0.01, &g, err))
        return -1;
    size_t edges = 0;
    for (size_t i = 0; i < g.nbins; i++)
        edges += g.bins[i].nedges;
    log_info("gen_liaodong: GSHHG %s: %zu bins, %zu shoreline edges", gshhg_path, g.nbins, edges);
    int ndis = 0, rc = 0;
    for (int j = 0; j < FINE_NLAT && rc == 0; j++)
        for (int i = 0; i < FINE_NLON; i++) {
            /* Nudge off exact bin borders (grid lines at whole degrees). */
            int dis = 0, lv = gshhg_level(&g, fine_lon(i) + 1e-7, fine_lat(j) + 1e-7, &dis);
            if (lv < 0) {
                rc = sph_err_set(err, SPH_ERR_BAD_DATA, "%s: no level at %.2f E %.2f N",
                                 gshhg_path, fine_lon(i), fine_lat(j));
                break;
            }
            ndis += dis;
            mask[(size_t)j * FINE_NLON + i] = lv >= 1;
        }
    if (ndis)
        log_info("gen_liaodong: %d of %d mask points had disagreeing corner rays (majority used)",
                 ndis, FINE_NLON * FINE_NLAT);
    gshhg_free(&g);
    return rc;
}

static int write_landmask(const char *path, const unsigned char *mask, sph_error *err)
{
    ncw w;
    double lon[FINE_NLON], lat[FINE_NLAT];
    for (int i = 0; i < FINE_NLON; i++) lon[i] = fine_lon(i);
    for (int j = 0; j < FINE_NLAT; j++) lat[j] = fine_lat(j);
    if (ncw_create(&w, path, "Liaodong Bay land-sea mask at 0.01 degree from GSHHG",
                   "Land-sea mask rasterised at grid points from the GSHHG 2.3.7 "
                   "high-resolution binned shoreline (level >= 1 is land; the shoreline itself "
                   "is real data, not synthetic).",
                   err))
        return -1;
    int dims[2], varid;
    if (def_coord(&w, "lat", FINE_NLAT, lat, "latitude", "latitude", "degrees_north", "Y", &dims[0]) ||
        def_coord(&w, "lon", FINE_NLON, lon, "longitude", "longitude", "degrees_east", "X", &dims[1]))
        goto fail;
    NCW(&w, nc_def_var(w.ncid, "land_binary_mask", NC_BYTE, 2, dims, &varid));
    NCW(&w, nc_def_var_deflate(w.ncid, varid, 1, 1, 5));
    signed char flags[2] = {0, 1};
    NCW(&w, nc_put_att_schar(w.ncid, varid, "flag_values", NC_BYTE, 2, flags));
    if (put_text(&w, varid, "standard_name", "land_binary_mask") ||
        put_text(&w, varid, "long_name", "land (1) or sea (0) from GSHHG level >= 1") ||
        put_text(&w, varid, "units", "1") || put_text(&w, varid, "flag_meanings", "sea land"))
        goto fail;
    signed char *buf = malloc((size_t)FINE_NLON * FINE_NLAT);
    if (!buf) {
        sph_err_set(err, SPH_ERR_NOMEM, "%s: mask buffer", path);
        goto fail;
    }
    for (size_t k = 0; k < (size_t)FINE_NLON * FINE_NLAT; k++)
        buf[k] = (signed char)mask[k];
    int st = nc_put_var_schar(w.ncid, varid, buf);
    free(buf);
    NCW(&w, st);
    return ncw_commit(&w);
fail:
    ncw_abort(&w);
    return -1;
}

/* ------------------------------------------------------------------ */
/* Initial ice raster                                                  */

typedef struct {
    noise2d ang; /* patch outline (evaluated on the unit circle) */
    double k;    /* patch size factor */
} patch_shape;

/* Patch semi-axes at k = 1: the half-widths of the seed's box, so k < 1
 * keeps the outline inside the box. */
static void patch_axes(double *a_km, double *b_km, double *xc, double *yc)
{
    double x0, y0, x1, y1;
    local_km(PATCH_LON_W, PATCH_LAT_S, &x0, &y0);
    local_km(PATCH_LON_E, PATCH_LAT_N, &x1, &y1);
    *a_km = 0.5 * (x1 - x0);
    *b_km = 0.5 * (y1 - y0);
    *xc = 0.5 * (x0 + x1);
    *yc = 0.5 * (y0 + y1);
}

static int in_patch(const patch_shape *p, double lon, double lat)
{
    double a, b, xc, yc, x, y;
    patch_axes(&a, &b, &xc, &yc);
    local_km(lon, lat, &x, &y);
    double u = (x - xc) / (a * p->k), v = (y - yc) / (b * p->k);
    double r = sqrt(u * u + v * v);
    if (r == 0.0)
        return 1;
    /* Wobbly outline: radius modulated by up to +-10 % (noise on a circle of 3 "km"). */
    double wob = 1.0 + clampd(0.05 * noise_eval(&p->ang, 3.0 * u / r, 3.0 * v / r), -0.1, 0.1);
    return r <= wob;
}

static double patch_area(const patch_shape *p, const unsigned char *mask)
{
    double area = 0.0;
    for (int j = 0; j < FINE_NLAT; j++)
        for (int i = 0; i < FINE_NLON; i++)
            if (!mask[(size_t)j * FINE_NLON + i] && in_patch(p, fine_lon(i), fine_lat(j)))
                area += cell_area_km2(fine_lat(j), FINE_STEP, FINE_STEP);
    return area;
}

static int build_ice(gsl_rng *rng, const unsigned char *mask, float *conc, float *thick,
                     sph_error *err)
{
    const float fill = -999.0f;
    noise2d n_conc, n_thin, n_patch_h, n_patch_c;
    patch_shape shape;
    noise_init(&n_conc, rng, 8.0, 60.0);
    noise_init(&n_thin, rng, 8.0, 50.0);
    noise_init(&n_patch_h, rng, 3.0, 12.0);
    noise_init(&n_patch_c, rng, 3.0, 12.0);
    noise_init(&shape.ang, rng, 2.0, 8.0);
    /* Irregular southern ice edge: 6 along-shore modes, 12-80 km. */
    double e_k[6], e_ph[6], e_amp[6], e_var = 0.0;
    for (int m = 0; m < 6; m++) {
        double lambda = 12.0 + 68.0 * gsl_rng_uniform(rng);
        e_k[m] = 2.0 * M_PI / lambda;
        e_ph[m] = 2.0 * M_PI * gsl_rng_uniform(rng);
        e_amp[m] = lambda / 80.0;
        e_var += 0.5 * e_amp[m] * e_amp[m];
    }

    /* Patch size: bisection on k so the discrete patch area is 100 km^2. */
    double klo = 0.3, khi = 1.0;
    for (int it = 0; it < 40; it++) {
        shape.k = 0.5 * (klo + khi);
        if (patch_area(&shape, mask) < PATCH_AREA_KM2)
            klo = shape.k;
        else
            khi = shape.k;
    }
    shape.k = 0.5 * (klo + khi);

    double hsum = 0.0;
    size_t npatch = 0;
    for (int j = 0; j < FINE_NLAT; j++)
        for (int i = 0; i < FINE_NLON; i++) {
            size_t c = (size_t)j * FINE_NLON + i;
            double lon = fine_lon(i), lat = fine_lat(j), x, y;
            if (mask[c]) {
                conc[c] = thick[c] = fill;
                continue;
            }
            local_km(lon, lat, &x, &y);
            double edge = 0.0;
            for (int m = 0; m < 6; m++)
                edge += e_amp[m] * cos(e_k[m] * x + e_ph[m]);
            double lat_edge = 40.35 + 0.035 * clampd(edge / sqrt(e_var), -2.0, 2.0);
            if (in_patch(&shape, lon, lat)) {
                double h = 0.35 + 0.035 * noise_eval(&n_patch_h, x, y);
                thick[c] = (float)clampd(h, 0.27, 0.43);
                conc[c] = (float)clampd(0.925 + 0.02 * noise_eval(&n_patch_c, x, y), 0.90, 0.95);
                hsum += thick[c];
                npatch++;
            } else if (lat > lat_edge) {
                double d = lat - lat_edge; /* degrees north of the edge */
                double cn = 0.5 + 0.4 * tanh(d / 0.12) + 0.05 * noise_eval(&n_conc, x, y);
                double h = 0.035 + 0.035 * tanh(d / 0.25) + 0.01 * noise_eval(&n_thin, x, y);
                conc[c] = (float)clampd(cn, 0.5, 0.9);
                thick[c] = (float)clampd(h, 0.03, 0.09);
            } else {
                conc[c] = thick[c] = 0.0f;
            }
        }
    if (npatch == 0)
        return sph_err_set(err, SPH_ERR_INTERNAL, "ice: the patch has no sea cells");
    /* Shift the patch thickness so its mean is exactly 35 cm. */
    float shift = (float)(PATCH_MEAN_H - hsum / (double)npatch);
    for (int j = 0; j < FINE_NLAT; j++)
        for (int i = 0; i < FINE_NLON; i++) {
            size_t c = (size_t)j * FINE_NLON + i;
            if (!mask[c] && in_patch(&shape, fine_lon(i), fine_lat(j)))
                thick[c] += shift;
        }
    log_info("gen_liaodong: patch %zu cells, %.2f km^2, size factor %.3f, mean-shift %.4f m",
             npatch, patch_area(&shape, mask), shape.k, shift);
    return 0;
}

static int write_ice(const char *path, const float *conc, const float *thick, sph_error *err)
{
    ncw w;
    double lon[FINE_NLON], lat[FINE_NLAT], t = SCENE_T0;
    const float fill = -999.0f;
    for (int i = 0; i < FINE_NLON; i++) lon[i] = fine_lon(i);
    for (int j = 0; j < FINE_NLAT; j++) lat[j] = fine_lat(j);
    if (ncw_create(&w, path,
                   "Liaodong Bay initial sea ice, 1999-02-08 06:00 local (synthetic NOAA-style raster)",
                   "Initial ice raster in the style of a NOAA AVHRR analysis on a regular 0.01 "
                   "degree grid: a rafted thick-ice patch (mean 0.35 m, about 100 km^2) inside the "
                   "seed's box 121.75-121.89 E, 40.55-40.69 N, in thin ice (0.03-0.09 m, "
                   "concentration 0.5-0.9) north of an irregular edge near 40.35 N; open water "
                   "south of it; _FillValue on GSHHG land.",
                   err))
        return -1;
    int dims[3], vc, vh;
    if (def_coord(&w, "time", 1, &t, "time", "time", TIME_UNITS, "T", &dims[0]) ||
        def_coord(&w, "lat", FINE_NLAT, lat, "latitude", "latitude", "degrees_north", "Y", &dims[1]) ||
        def_coord(&w, "lon", FINE_NLON, lon, "longitude", "longitude", "degrees_east", "X", &dims[2]) ||
        def_float(&w, "siconc", 3, dims, "sea_ice_area_fraction", "sea ice concentration", "1",
                  &fill, &vc) ||
        def_float(&w, "sithick", 3, dims, "sea_ice_thickness",
                  "thickness of the ice itself (mean over the ice-covered part of the cell)", "m",
                  &fill, &vh) ||
        put_text(&w, NC_GLOBAL, "valid_time", "1999-02-07T22:00:00Z"))
        goto fail;
    float vr[2] = {0.0f, 1.0f};
    NCW(&w, nc_put_att_float(w.ncid, vc, "valid_range", NC_FLOAT, 2, vr));
    vr[1] = 5.0f;
    NCW(&w, nc_put_att_float(w.ncid, vh, "valid_range", NC_FLOAT, 2, vr));
    NCW(&w, nc_put_var_float(w.ncid, vc, conc));
    NCW(&w, nc_put_var_float(w.ncid, vh, thick));
    return ncw_commit(&w);
fail:
    ncw_abort(&w);
    return -1;
}

/* ------------------------------------------------------------------ */
/* Hourly atmosphere                                                   */

#define ATM_LON0 120.50
#define ATM_LAT0 39.25
#define ATM_NLON 11 /* 120.50 .. 123.00 */
#define ATM_NLAT 10 /* 39.25 .. 41.50 */
#define ATM_STEP 0.25
#define ATM_NT 103  /* 19 h .. 121 h */

/* Cosine of the solar zenith angle; t_h hours since 1999-02-07 00:00 UTC. */
static double cos_zenith(double t_h, double lon, double lat)
{
    double doy = 38.0 + t_h / 24.0; /* 1999-02-07 00:00 is day 38.0 (1-based day 38) */
    double decl = -23.44 * DEG2RAD * cos(2.0 * M_PI / 365.0 * (doy + 10.0));
    double B = 2.0 * M_PI * (doy - 81.0) / 364.0;
    double eot_min = 9.87 * sin(2.0 * B) - 7.53 * cos(B) - 1.5 * sin(B);
    double solar_h = fmod(t_h, 24.0) + lon / 15.0 + eot_min / 60.0;
    double H = 15.0 * (solar_h - 12.0) * DEG2RAD;
    double phi = lat * DEG2RAD;
    return sin(phi) * sin(decl) + cos(phi) * cos(decl) * cos(H);
}

/* Dew point (deg C) from T (deg C) and RH (%), Magnus over water (WMO). */
static double dew_point(double tc, double rh)
{
    const double b = 17.62, c = 243.12;
    double g = log(rh / 100.0) + b * tc / (c + tc);
    return c * g / (b - g);
}

static int write_atmos(const char *path, gsl_rng *rng, sph_error *err)
{
    ncw w;
    double lon[ATM_NLON], lat[ATM_NLAT], tt[ATM_NT];
    for (int i = 0; i < ATM_NLON; i++) lon[i] = ATM_LON0 + ATM_STEP * i;
    for (int j = 0; j < ATM_NLAT; j++) lat[j] = ATM_LAT0 + ATM_STEP * j;
    for (int n = 0; n < ATM_NT; n++) tt[n] = SCENE_T0 - FORCING_MARGIN + n;

    /* Red-noise (AR(1)) perturbations, one value per hour. */
    double nz_speed[ATM_NT], nz_dir[ATM_NT], nz_t[ATM_NT], nz_rh[ATM_NT];
    double a1 = 0.0, a2 = 0.0, a3 = 0.0, a4 = 0.0;
    for (int n = 0; n < ATM_NT; n++) {
        a1 = 0.8 * a1 + 0.6 * gsl_ran_gaussian(rng, 0.6);
        a2 = 0.9 * a2 + 0.44 * gsl_ran_gaussian(rng, 6.0);
        a3 = 0.8 * a3 + 0.6 * gsl_ran_gaussian(rng, 0.4);
        a4 = 0.8 * a4 + 0.6 * gsl_ran_gaussian(rng, 2.5);
        nz_speed[n] = a1; nz_dir[n] = a2; nz_t[n] = a3; nz_rh[n] = a4;
    }

    size_t nxy = (size_t)ATM_NLON * ATM_NLAT, ntot = nxy * ATM_NT;
    float *u = malloc(ntot * sizeof *u), *v = malloc(ntot * sizeof *v);
    float *ta = malloc(ntot * sizeof *ta), *td = malloc(ntot * sizeof *td);
    float *sw = malloc(ntot * sizeof *sw), *lw = malloc(ntot * sizeof *lw);
    w.ncid = -1;
    w.tmp[0] = '\0';
    if (!u || !v || !ta || !td || !sw || !lw) {
        sph_err_set(err, SPH_ERR_NOMEM, "%s: buffers", path);
        goto fail;
    }
    for (int n = 0; n < ATM_NT; n++) {
        double s = tt[n] - SCENE_T0;                 /* hours into the scene */
        double hl = fmod(tt[n] + LOCAL_UTC_OFFSET, 24.0); /* local hour */
        double front = bump(s, 38.0, 12.0);          /* passage of a cold front */
        /* Speed: 4 m/s, the front to ~10 m/s, settling at 5 m/s. */
        double speed = 4.0 + smoothstep01((s - 45.0) / 20.0) + 6.0 * front + nz_speed[n];
        /* Direction the wind comes from (deg): N, a short NNW spell, veering
         * to NNE with the front and staying NNE. */
        double dir = -5.0 + 25.0 * smoothstep01((s - 20.0) / 16.0) + 10.0 * bump(s, 38.0, 10.0)
                     - 20.0 * bump(s, 8.0, 5.0) + nz_dir[n];
        dir = clampd(dir, -30.0, 35.0);
        /* Air temperature (deg C): cold behind the front, warming on the last day. */
        double damp = 3.0 * (1.0 - 0.5 * front);
        double tc = -7.0 - 3.5 * bump(s, 50.0, 14.0) + 8.5 * smoothstep01((s - 62.0) / 30.0) +
                    damp * cos(2.0 * M_PI * (hl - 14.0) / 24.0) + nz_t[n];
        double rh = 70.0 + 7.0 * cos(2.0 * M_PI * (hl - 4.0) / 24.0) + 6.0 * front + nz_rh[n];
        rh = clampd(rh, 60.0, 82.0);
        double cloud = 0.7 - 0.25 * front;          /* shortwave transmission */
        double emis = 0.76 + 0.08 * front;          /* effective sky emissivity */
        for (int j = 0; j < ATM_NLAT; j++)
            for (int i = 0; i < ATM_NLON; i++) {
                size_t k = (size_t)n * nxy + (size_t)j * ATM_NLON + i;
                double dlat = lat[j] - 40.5, dlon = lon[i] - 121.5;
                /* A few percent of spatial structure: stronger offshore
                 * (south), colder inland (north), slight veering eastward. */
                double sp = clampd(speed * (1.0 - 0.03 * dlat), 0.3, 11.8);
                double d = (dir + 3.0 * dlon) * DEG2RAD;
                u[k] = (float)(-sp * sin(d));
                v[k] = (float)(-sp * cos(d));
                double tck = tc - 0.8 * dlat;
                ta[k] = (float)(tck + 273.15);
                td[k] = (float)(dew_point(tck, rh) + 273.15);
                double cz = cos_zenith(tt[n], lon[i], lat[j]);
                sw[k] = (float)(cz > 0.0 ? 1000.0 * cz * cloud : 0.0);
                double tk = tck + 273.15;
                lw[k] = (float)(emis * 5.670374419e-8 * tk * tk * tk * tk);
            }
    }

    if (ncw_create(&w, path, "Liaodong Bay hourly atmosphere, 1999-02-07 19Z to 02-12 01Z (synthetic)",
                   "Hourly instantaneous values on a 0.25 degree grid standing in for the JZ20-2 "
                   "platform record: winter monsoon from N to NNE, a cold front on 1999-02-09 "
                   "(4 -> 10 -> 5 m/s, veering from NNW/N to NNE), air temperature -12 to -4 C "
                   "with a diurnal cycle and a thaw (above 0 C for some hours) on 1999-02-11; "
                   "RH 60-82 % as dew point (Magnus over water); shortwave 1000 W m-2 cos(zenith) "
                   "times 0.7 (0.45 under the front); longwave emissivity 0.76-0.84 times sigma T^4.",
                   err))
        goto fail;
    int dims[3], vid[6];
    if (def_coord(&w, "time", ATM_NT, tt, "time", "time", TIME_UNITS, "T", &dims[0]) ||
        def_coord(&w, "lat", ATM_NLAT, lat, "latitude", "latitude", "degrees_north", "Y", &dims[1]) ||
        def_coord(&w, "lon", ATM_NLON, lon, "longitude", "longitude", "degrees_east", "X", &dims[2]) ||
        def_float(&w, "u10", 3, dims, "eastward_wind", "10 m eastward wind", "m s-1", NULL, &vid[0]) ||
        def_float(&w, "v10", 3, dims, "northward_wind", "10 m northward wind", "m s-1", NULL, &vid[1]) ||
        def_float(&w, "t2m", 3, dims, "air_temperature", "2 m air temperature", "K", NULL, &vid[2]) ||
        def_float(&w, "d2m", 3, dims, "dew_point_temperature", "2 m dew point temperature", "K",
                  NULL, &vid[3]) ||
        def_float(&w, "ssrd", 3, dims, "surface_downwelling_shortwave_flux_in_air",
                  "surface downwelling shortwave flux (instantaneous)", "W m-2", NULL, &vid[4]) ||
        def_float(&w, "strd", 3, dims, "surface_downwelling_longwave_flux_in_air",
                  "surface downwelling longwave flux (instantaneous)", "W m-2", NULL, &vid[5]))
        goto fail;
    float z = 10.0f;
    NCW(&w, nc_put_att_float(w.ncid, vid[0], "height_above_ground_m", NC_FLOAT, 1, &z));
    NCW(&w, nc_put_att_float(w.ncid, vid[1], "height_above_ground_m", NC_FLOAT, 1, &z));
    NCW(&w, nc_put_var_float(w.ncid, vid[0], u));
    NCW(&w, nc_put_var_float(w.ncid, vid[1], v));
    NCW(&w, nc_put_var_float(w.ncid, vid[2], ta));
    NCW(&w, nc_put_var_float(w.ncid, vid[3], td));
    NCW(&w, nc_put_var_float(w.ncid, vid[4], sw));
    NCW(&w, nc_put_var_float(w.ncid, vid[5], lw));
    free(u); free(v); free(ta); free(td); free(sw); free(lw);
    return ncw_commit(&w);
fail:
    free(u); free(v); free(ta); free(td); free(sw); free(lw);
    if (w.tmp[0])
        ncw_abort(&w);
    return -1;
}

/* ------------------------------------------------------------------ */
/* Tide constituents ("harmonic-1")                                    */

#define TIDE_LON0 120.80
#define TIDE_LAT0 39.60
#define TIDE_NLON 37 /* 120.80 .. 122.60 */
#define TIDE_NLAT 31 /* 39.60 .. 41.10 */
#define TIDE_STEP 0.05
#define TIDE_NC 4
#define TIDE_STRLEN 4

/* Along-axis distance xi and cross-axis distance eta (km, eta > 0 to the
 * east-south-east) from the bay mouth, and the axis bearing (degrees). */
static void bay_coords(double lon, double lat, double *xi, double *eta, double *bearing)
{
    double x0, y0, x1, y1, x, y;
    local_km(AXIS_LON0, AXIS_LAT0, &x0, &y0);
    local_km(AXIS_LON1, AXIS_LAT1, &x1, &y1);
    local_km(lon, lat, &x, &y);
    double L = hypot(x1 - x0, y1 - y0), ex = (x1 - x0) / L, ey = (y1 - y0) / L;
    *xi = (x - x0) * ex + (y - y0) * ey;
    *eta = (x - x0) * ey - (y - y0) * ex;
    *bearing = atan2(ex, ey) / DEG2RAD;
}

static int write_tide(const char *path, const unsigned char *mask, sph_error *err)
{
    ncw w;
    const float fill = -999.0f;
    double lon[TIDE_NLON], lat[TIDE_NLAT];
    for (int i = 0; i < TIDE_NLON; i++) lon[i] = TIDE_LON0 + TIDE_STEP * i;
    for (int j = 0; j < TIDE_NLAT; j++) lat[j] = TIDE_LAT0 + TIDE_STEP * j;
    size_t nxy = (size_t)TIDE_NLON * TIDE_NLAT, ntot = nxy * TIDE_NC;
    float *buf[6];
    for (int q = 0; q < 6; q++)
        buf[q] = malloc(ntot * sizeof **buf);
    w.tmp[0] = '\0';
    for (int q = 0; q < 6; q++)
        if (!buf[q]) {
            sph_err_set(err, SPH_ERR_NOMEM, "%s: buffers", path);
            goto fail;
        }
    /* Per constituent: elevation amplitude at the mouth (m) and its rise to
     * the head, Greenwich phase at the mouth (deg) and its rise to the head,
     * along-axis current amplitude (m/s). */
    static const char names[TIDE_NC][TIDE_STRLEN + 1] = {"m2", "s2", "k1", "o1"};
    static const double h0[TIDE_NC] = {1.00, 0.31, 0.28, 0.23};
    static const double hrise[TIDE_NC] = {0.30, 0.09, 0.05, 0.04};
    static const double g0[TIDE_NC] = {80.0, 125.0, 30.0, 350.0};
    static const double grise[TIDE_NC] = {20.0, 22.0, 8.0, 8.0};
    static const double U0[TIDE_NC] = {0.62, 0.20, 0.10, 0.08};
    double xi_head = 0.0, eta_dummy, bearing;
    bay_coords(AXIS_LON1, AXIS_LAT1, &xi_head, &eta_dummy, &bearing);
    double ex = sin(bearing * DEG2RAD), ey = cos(bearing * DEG2RAD); /* up-bay */
    double nx = ey, ny = -ex;                                         /* cross-bay */
    const double xi_end = xi_head + 25.0; /* current vanishes at the closed end */

    for (int c = 0; c < TIDE_NC; c++)
        for (int j = 0; j < TIDE_NLAT; j++)
            for (int i = 0; i < TIDE_NLON; i++) {
                size_t k = (size_t)c * nxy + (size_t)j * TIDE_NLON + i;
                /* Fine-grid index of this tide point (0.05 = 5 fine steps). */
                size_t f = (size_t)(5 * j) * FINE_NLON + (size_t)(5 * i);
                if (mask[f]) {
                    for (int q = 0; q < 6; q++)
                        buf[q][k] = fill;
                    continue;
                }
                double xi, eta, bdummy;
                bay_coords(lon[i], lat[j], &xi, &eta, &bdummy);
                double r = clampd(xi / xi_head, -0.3, 1.15);
                double amp = h0[c] + hrise[c] * r;
                double g = fmod(g0[c] + grise[c] * r + 360.0, 360.0);
                /* Along-axis current: standing-wave-like, leading the elevation
                 * by 90 deg, full strength in the bay, falling to ~0.1 of it at
                 * the closed end; weaker towards the side coasts. */
                double taper = clampd((xi_end - xi) / 40.0, 0.1, 1.0);
                double side = clampd(1.0 - 0.3 * (eta / 40.0) * (eta / 40.0), 0.5, 1.0);
                double Ua = U0[c] * taper * side, ga = (g - 90.0) * DEG2RAD;
                /* Cross-axis: 10 % of it, a further 90 deg ahead (a thin ellipse). */
                double Uc = 0.1 * Ua, gc = ga - 0.5 * M_PI;
                /* Phasors A e^{-i g}: components are sums of the two. */
                double ure = Ua * ex * cos(ga) + Uc * nx * cos(gc);
                double uim = -(Ua * ex * sin(ga) + Uc * nx * sin(gc));
                double vre = Ua * ey * cos(ga) + Uc * ny * cos(gc);
                double vim = -(Ua * ey * sin(ga) + Uc * ny * sin(gc));
                buf[0][k] = (float)amp;
                buf[1][k] = (float)g;
                buf[2][k] = (float)hypot(ure, uim);
                buf[3][k] = (float)fmod(-atan2(uim, ure) / DEG2RAD + 360.0, 360.0);
                buf[4][k] = (float)hypot(vre, vim);
                buf[5][k] = (float)fmod(-atan2(vim, vre) / DEG2RAD + 360.0, 360.0);
            }

    if (ncw_create(&w, path, "Liaodong Bay tidal constituents M2 S2 K1 O1 (synthetic, harmonic-1)",
                   "Idealised standing-wave tide along the bay axis (40.0 N 121.2 E to 40.9 N "
                   "122.0 E, bearing about 34 deg): M2 elevation 1.0 m at the mouth rising to "
                   "1.3 m at the head, phase rising 20 deg up the bay; reversing currents along "
                   "the axis (M2 0.62, S2 0.20, K1 0.10, O1 0.08 m/s) leading the elevation by "
                   "90 deg, with a 10 % cross-axis component; _FillValue on land. Evaluate as "
                   "A cos(omega t - phase) (phase = Greenwich phase lag; no nodal corrections "
                   "are implied by these synthetic values).",
                   err))
        goto fail;
    int dimc, dims_s, dlat, dlon, vname, vid[6];
    NCW(&w, nc_def_dim(w.ncid, "constituent", TIDE_NC, &dimc));
    NCW(&w, nc_def_dim(w.ncid, "name_strlen", TIDE_STRLEN, &dims_s));
    if (def_coord(&w, "lat", TIDE_NLAT, lat, "latitude", "latitude", "degrees_north", "Y", &dlat) ||
        def_coord(&w, "lon", TIDE_NLON, lon, "longitude", "longitude", "degrees_east", "X", &dlon) ||
        put_text(&w, NC_GLOBAL, "sphice_tide_format", "harmonic-1"))
        goto fail;
    int cdims[2] = {dimc, dims_s}, d3[3] = {dimc, dlat, dlon};
    NCW(&w, nc_def_var(w.ncid, "constituent", NC_CHAR, 2, cdims, &vname));
    if (put_text(&w, vname, "long_name", "tidal constituent name (lowercase, NUL padded)"))
        goto fail;
    /* CF has a standard name for the elevation amplitude only; the phases
     * and current amplitudes carry long_name (and no invented standard name,
     * which a reader matching on standard_name could mistake for a field). */
    if (def_float(&w, "h_amp", 3, d3, "sea_surface_height_amplitude_due_to_geocentric_ocean_tide",
                  "tidal elevation amplitude", "m", &fill, &vid[0]) ||
        def_float(&w, "h_phase", 3, d3, NULL, "tidal elevation Greenwich phase lag", "degree",
                  &fill, &vid[1]) ||
        def_float(&w, "u_amp", 3, d3, NULL, "eastward tidal current amplitude", "m s-1", &fill,
                  &vid[2]) ||
        def_float(&w, "u_phase", 3, d3, NULL, "eastward tidal current Greenwich phase lag",
                  "degree", &fill, &vid[3]) ||
        def_float(&w, "v_amp", 3, d3, NULL, "northward tidal current amplitude", "m s-1", &fill,
                  &vid[4]) ||
        def_float(&w, "v_phase", 3, d3, NULL, "northward tidal current Greenwich phase lag",
                  "degree", &fill, &vid[5]))
        goto fail;
    char namebuf[TIDE_NC * TIDE_STRLEN];
    memset(namebuf, 0, sizeof namebuf);
    for (int c = 0; c < TIDE_NC; c++)
        memcpy(namebuf + c * TIDE_STRLEN, names[c], strlen(names[c]));
    NCW(&w, nc_put_var_text(w.ncid, vname, namebuf));
    for (int q = 0; q < 6; q++)
        NCW(&w, nc_put_var_float(w.ncid, vid[q], buf[q]));
    for (int q = 0; q < 6; q++)
        free(buf[q]);
    return ncw_commit(&w);
fail:
    for (int q = 0; q < 6; q++)
        free(buf[q]);
    if (w.tmp[0])
        ncw_abort(&w);
    return -1;
}

/* ------------------------------------------------------------------ */

static int write_stations(const char *path, sph_error *err)
{
    static const char text[] =
        "{\n"
        "  \"scene\": \"liaodong-1999\",\n"
        "  \"source\": \"synthetic demo; positions approximate (platform areas, not surveyed "
        "coordinates)\",\n"
        "  \"stations\": [\n"
        "    {\"name\": \"JZ20-2\", \"kind\": \"platform area\", \"lon\": 121.37, \"lat\": 40.47, "
        "\"approximate\": true},\n"
        "    {\"name\": \"JZ9-3\", \"kind\": \"platform area\", \"lon\": 121.55, \"lat\": 40.77, "
        "\"approximate\": true}\n"
        "  ],\n"
        "  \"edge_reference\": {\"name\": \"head of Liaodong Bay\", \"lon\": 121.85, \"lat\": 40.90},\n"
        "  \"patch_box\": {\"lon_min\": 121.75, \"lon_max\": 121.89, \"lat_min\": 40.55, "
        "\"lat_max\": 40.69}\n"
        "}\n";
    return atomic_write_file(path, text, sizeof text - 1, err) == SPH_OK ? 0 : -1;
}

int main(int argc, char **argv)
{
    if (argc < 2 || argc > 3) {
        fprintf(stderr, "usage: %s OUTDIR [GSHHG_BINNED_FILE]\n", argv[0]);
        return 2;
    }
    const char *outdir = argv[1];
    const char *gshhg_path = argc == 3 ? argv[2] : getenv("SPHICE_GSHHG");
    if (!gshhg_path)
        gshhg_path = "/usr/share/gmt-gshhg/binned_GSHHS_h.nc";

    sph_error err;
    sph_error_clear(&err);
    int rc = 1;
    size_t nfine = (size_t)FINE_NLON * FINE_NLAT;
    unsigned char *mask = calloc(nfine, 1);
    float *conc = calloc(nfine, sizeof *conc), *thick = calloc(nfine, sizeof *thick);
    gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
    char path[4096];
    if (!mask || !conc || !thick || !rng) {
        sph_err_set(&err, SPH_ERR_NOMEM, "gen_liaodong: buffers");
        goto done;
    }
    gsl_rng_set(rng, GEN_SEED);
    if (mkdir_p(outdir, &err) || build_landmask(gshhg_path, mask, &err))
        goto done;
    snprintf(path, sizeof path, "%s/landmask_liaodong.nc", outdir);
    if (write_landmask(path, mask, &err))
        goto done;
    if (build_ice(rng, mask, conc, thick, &err))
        goto done;
    snprintf(path, sizeof path, "%s/ice_19990208T06.nc", outdir);
    if (write_ice(path, conc, thick, &err))
        goto done;
    snprintf(path, sizeof path, "%s/atmos_199902.nc", outdir);
    if (write_atmos(path, rng, &err))
        goto done;
    snprintf(path, sizeof path, "%s/tide_bohai_harmonic.nc", outdir);
    if (write_tide(path, mask, &err))
        goto done;
    snprintf(path, sizeof path, "%s/stations.json", outdir);
    if (write_stations(path, &err))
        goto done;
    log_info("gen_liaodong: wrote the Liaodong Bay 1999 scene to %s", outdir);
    rc = 0;
done:
    if (rc)
        log_error("gen_liaodong: %s", err.msg[0] ? err.msg : sph_strerror(err.code));
    gsl_rng_free(rng);
    free(mask);
    free(conc);
    free(thick);
    return rc;
}
