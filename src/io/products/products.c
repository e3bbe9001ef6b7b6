/* Forecast products: the writer, the gridded CF NetCDF file with the ice
 * edge geometry, GeoJSON, scores and the manifest (see io/products.h and
 * docs/products.md). Stations, particles and publishing live in
 * products_stations.c, products_particles.c and products_publish.c. */
#include "products_impl.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <netcdf.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "io/gis.h"
#include "io/quicklook.h"
#include "util/fileio.h"
#include "util/log.h"
#include "util/timeutil.h"
#include "util/version.h"

#define TIME_UNITS "seconds since 1970-01-01 00:00:00"
/* CF auxiliary coordinates of every time-dependent variable of the fields
 * file: the lead time and the scalar cycle time (CF 4.4, 5.7). */
#define FORECAST_COORDS "forecast_period forecast_reference_time"

void products_options_default(prod_options *o)
{
    memset(o, 0, sizeof *o);
    o->prefix = "sphice";
    o->edge_threshold = 0.15;
    o->quicklook_every = 0;
    o->quicklook_width = 1500;
    o->quicklook_height = 720;
    o->quicklook_thick_max = 0.6;
    o->deflate_level = 4;
    o->write_geojson = 1;
    prod_loads_options_default(&o->loads);
}

double products_drift_direction_deg(double u_east, double v_north)
{
    if (isnan(u_east) || isnan(v_north))
        return NAN;
    double d = atan2(u_east, v_north) * 180.0 / M_PI; /* from north, clockwise */
    d = fmod(d + 360.0, 360.0);
    return d >= 360.0 ? 0.0 : d;
}

/* ---- small helpers shared by products*.c ---- */

int prod_nc_check(int status, const char *what, const char *path, sph_error *err)
{
    if (status == NC_NOERR)
        return SPH_OK;
    return sph_err_set(err, SPH_ERR_NETCDF, "%s %s: %s", what, path, nc_strerror(status));
}

int prod_put_text(int ncid, int varid, const char *name, const char *text)
{
    if (!text)
        return NC_NOERR;
    return nc_put_att_text(ncid, varid, name, strlen(text), text);
}

int prod_def_lonlat(int ncid, const char *name, int ndims, const int *dims, char axis,
                    const char *long_name, int *varid)
{
    int x = axis == 'X', rc;
    const char ax[2] = {axis, 0};
    if ((rc = nc_def_var(ncid, name, NC_DOUBLE, ndims, dims, varid)) ||
        (rc = prod_put_text(ncid, *varid, "standard_name", x ? "longitude" : "latitude")) ||
        (rc = prod_put_text(ncid, *varid, "long_name", long_name)) ||
        (rc = prod_put_text(ncid, *varid, "units", x ? "degrees_east" : "degrees_north")))
        return rc;
    return prod_put_text(ncid, *varid, "axis", ax);
}

/* lead time as operational centres write it (Met Office, ECMWF's
 * "step"): hours from forecast_reference_time to the valid time */
int prod_def_forecast_period(int ncid, int dim_t, int *varid)
{
    int rc;
    if ((rc = nc_def_var(ncid, "forecast_period", NC_DOUBLE, 1, &dim_t, varid)) ||
        (rc = prod_put_text(ncid, *varid, "standard_name", "forecast_period")) ||
        (rc = prod_put_text(ncid, *varid, "long_name", "lead time: valid time minus forecast_reference_time")))
        return rc;
    return prod_put_text(ncid, *varid, "units", "hours");
}

int prod_def_lonlat_axes(int ncid, int d_lat, int d_lon, int d_bnds, int *v_lat, int *v_lon, int *v_latb,
                         int *v_lonb)
{
    int rc;
    if ((rc = prod_def_lonlat(ncid, "lat", 1, &d_lat, 'Y', "latitude of the cell centre", v_lat)) ||
        (rc = prod_put_text(ncid, *v_lat, "bounds", "lat_bnds")) ||
        (rc = prod_def_lonlat(ncid, "lon", 1, &d_lon, 'X', "longitude of the cell centre", v_lon)) ||
        (rc = prod_put_text(ncid, *v_lon, "bounds", "lon_bnds")))
        return rc;
    /* CF 7.1 cell boundaries: the centre -+ half a grid step */
    int db_lat[2] = { d_lat, d_bnds }, db_lon[2] = { d_lon, d_bnds };
    if ((rc = nc_def_var(ncid, "lat_bnds", NC_DOUBLE, 2, db_lat, v_latb)) ||
        (rc = prod_put_text(ncid, *v_latb, "long_name", "latitude of the cell edges")) ||
        (rc = prod_put_text(ncid, *v_latb, "units", "degrees_north")) ||
        (rc = nc_def_var(ncid, "lon_bnds", NC_DOUBLE, 2, db_lon, v_lonb)) ||
        (rc = prod_put_text(ncid, *v_lonb, "long_name", "longitude of the cell edges")))
        return rc;
    return prod_put_text(ncid, *v_lonb, "units", "degrees_east");
}

int prod_put_lonlat_bnds(int ncid, const prod_grid *g, int v_latb, int v_lonb)
{
    double *buf = malloc(2 * sizeof(double) * (size_t)(g->nlat > g->nlon ? g->nlat : g->nlon));
    if (!buf)
        return NC_ENOMEM;
    for (int j = 0; j < g->nlat; j++) {
        buf[2 * j] = g->lat0 + (j - 0.5) * g->dlat;
        buf[2 * j + 1] = g->lat0 + (j + 0.5) * g->dlat;
    }
    int st = nc_put_var_double(ncid, v_latb, buf);
    for (int i = 0; i < g->nlon; i++) {
        buf[2 * i] = g->lon0 + (i - 0.5) * g->dlon;
        buf[2 * i + 1] = g->lon0 + (i + 0.5) * g->dlon;
    }
    if (st == NC_NOERR)
        st = nc_put_var_double(ncid, v_lonb, buf);
    free(buf);
    return st;
}

static int put_double(int ncid, int varid, const char *name, double v)
{
    return nc_put_att_double(ncid, varid, name, NC_DOUBLE, 1, &v);
}

static void add_product(prod_writer *p, const char *name)
{
    if (p->nproducts < PROD_MAX_PRODUCTS)
        snprintf(p->products[p->nproducts++], PROD_NAME_LEN, "%s", name);
}

void prod_add_product(prod_writer *p, const char *name)
{
    add_product(p, name);
}

int prod_file_init(prod_writer *p, prod_file *f, const char *suffix, sph_error *err)
{
    int n = snprintf(f->name, sizeof f->name, "%s_%s", p->prefix, suffix);
    int m = snprintf(f->path, sizeof f->path, "%s/%s", p->stage, f->name);
    if (n < 0 || (size_t)n >= sizeof f->name || m < 0 || (size_t)m >= sizeof f->path)
        return sph_err_set(err, SPH_ERR_PARAM, "products: path too long in %s", p->stage);
    atomic_tmp_name(f->path, f->tmp, sizeof f->tmp);
    unlink(f->tmp);
    return SPH_OK;
}

int prod_file_commit(prod_writer *p, prod_file *f, sph_error *err)
{
    if (!f->tmp[0])
        return SPH_OK;
    int rc = atomic_commit(f->tmp, f->path, err);
    f->tmp[0] = '\0';
    if (rc == SPH_OK)
        add_product(p, f->name);
    return rc;
}

void prod_file_discard(prod_file *f)
{
    if (f->tmp[0])
        unlink(f->tmp);
    f->tmp[0] = '\0';
}

static char *dup_or_null(const char *s)
{
    return s ? strdup(s) : NULL;
}

/* ---- the gridded fields file ---- */

typedef struct {
    const char *name, *standard_name, *long_name, *units, *cell_methods;
} var_spec;

static const var_spec field_specs[PF_NVARS] = {
    { "siconc", "sea_ice_area_fraction",
      "sea ice area fraction (a fraction 0..1; SIMIP's siconc is in percent)", "1",
      "area: mean where sea time: point" },
    { "sivol", "sea_ice_thickness",
      "sea ice volume per unit cell area (mean thickness over the whole sea cell, open water "
      "counted as zero)", "m", "area: mean where sea time: point" },
    { "sithick", "sea_ice_thickness",
      "sea ice thickness (mean over the ice-covered part of the cell)", "m",
      "area: mean where sea_ice time: point" },
    { "siu", "eastward_sea_ice_velocity", "eastward sea ice velocity", "m s-1",
      "area: mean where sea_ice time: point" },
    { "siv", "northward_sea_ice_velocity", "northward sea ice velocity", "m s-1",
      "area: mean where sea_ice time: point" },
    { "sicompstren", "compressive_strength_of_sea_ice",
      "vertically integrated ice pressure (compressive strength) P", "N m-1",
      "area: mean where sea_ice time: point" },
    { "sidivvel", "divergence_of_sea_ice_velocity", "divergence of the sea ice velocity field",
      "s-1", "area: mean where sea_ice time: point" },
    /* SIMIP's sishearvel has no CF standard name (its proposed
     * maximum_shear_of_sea_ice_velocity is not in the table, v83 to v94) */
    { "sishearvel", NULL,
      "maximum shear rate of the sea ice velocity field", "s-1",
      "area: mean where sea_ice time: point" },
    /* SIMIP sisnthick: snow volume over the snow-covered area; the snow
     * lies on the whole ice part here (written with opts.write_snow) */
    { "sisnthick", "surface_snow_thickness",
      "snow thickness on the sea ice (mean over the ice-covered part of the cell)", "m",
      "area: mean where sea_ice time: point" },
};

#define NCT(call, what)                                                        \
    do {                                                                       \
        int st_ = (call);                                                      \
        if (st_ != NC_NOERR)                                                   \
            return prod_nc_check(st_, what, p->fields.path, err);             \
    } while (0)

static int def_scalar_series(prod_writer *p, int dim_t, const char *name, const char *std,
                             const char *long_name, const char *units, int *varid,
                             sph_error *err)
{
    int nc = p->nc;
    NCT(nc_def_var(nc, name, NC_DOUBLE, 1, &dim_t, varid), "define variable in");
    if (std)
        NCT(prod_put_text(nc, *varid, "standard_name", std), "write attribute in");
    NCT(prod_put_text(nc, *varid, "long_name", long_name), "write attribute in");
    NCT(prod_put_text(nc, *varid, "units", units), "write attribute in");
    double fill = NC_FILL_DOUBLE;
    NCT(nc_put_att_double(nc, *varid, "_FillValue", NC_DOUBLE, 1, &fill), "write attribute in");
    NCT(prod_put_text(nc, *varid, "coordinates", FORECAST_COORDS), "write attribute in");
    return SPH_OK;
}

static int put_global_provenance(prod_writer *p, int nc, const char *what, sph_error *err)
{
    char iso[32], now[32], hist[256];
    time_format_iso(p->cycle_time, iso, sizeof iso);
    time_format_iso(time_now(), now, sizeof now);
    const char *path = what;
#define G(name, text)                                                                   \
    do {                                                                                \
        int st_ = prod_put_text(nc, NC_GLOBAL, name, text);                            \
        if (st_ != NC_NOERR)                                                            \
            return prod_nc_check(st_, "write global attribute to", path, err);          \
    } while (0)
    G("Conventions", "CF-1.8, ACDD-1.3");
    G("title", p->title ? p->title : "sphice sea ice forecast");
    G("summary", p->summary ? p->summary
                            : "Sea ice forecast from the sphice smoothed-particle-hydrodynamics "
                              "sea ice model.");
    G("institution", p->institution);
    G("region", p->region);
    char source[256];
    snprintf(source, sizeof source, "sphice %s (git %s)", p->version, p->gitrev);
    G("source", source);
    snprintf(hist, sizeof hist, "%s created by sphice %s", now, p->version);
    G("history", hist);
    G("date_created", now);
    G("processing_level", "forecast");
    G("sphice_model_version", p->version);
    G("sphice_git_revision", p->gitrev);
    G("sphice_config_sha256", p->config_sha ? p->config_sha : "unknown");
    G("sphice_forcing_sha256", p->forcing ? p->forcing : "");
    G("sphice_cycle_time", iso);
    G("sphice_start_mode", p->start_mode);
#undef G
    int stale = p->stale;
    int st = nc_put_att_int(nc, NC_GLOBAL, "sphice_stale_forcing", NC_INT, 1, &stale);
    if (st == NC_NOERR)
        st = put_double(nc, NC_GLOBAL, "sphice_edge_threshold", p->opts.edge_threshold);
    return prod_nc_check(st, "write global attribute to", path, err);
}

static int fields_define(prod_writer *p, sph_error *err)
{
    const prod_grid *g = &p->grid;
    int st = nc_create(p->fields.tmp, NC_NETCDF4 | NC_CLOBBER, &p->nc);
    if (st != NC_NOERR) {
        p->nc = -1;
        return prod_nc_check(st, "create", p->fields.tmp, err);
    }
    int nc = p->nc, d_t, d_lat, d_lon, d_node, d_part, d_bnds;
    NCT(nc_def_dim(nc, "time", NC_UNLIMITED, &d_t), "define dimension in");
    NCT(nc_def_dim(nc, "lat", (size_t)g->nlat, &d_lat), "define dimension in");
    NCT(nc_def_dim(nc, "lon", (size_t)g->nlon, &d_lon), "define dimension in");
    NCT(nc_def_dim(nc, "bnds", 2, &d_bnds), "define dimension in");
    NCT(nc_def_dim(nc, "edge_node", NC_UNLIMITED, &d_node), "define dimension in");
    NCT(nc_def_dim(nc, "edge_part", NC_UNLIMITED, &d_part), "define dimension in");

    int v;
    NCT(nc_def_var(nc, "time", NC_DOUBLE, 1, &d_t, &p->v_time), "define variable in");
    v = p->v_time;
    NCT(prod_put_text(nc, v, "standard_name", "time"), "write attribute in");
    NCT(prod_put_text(nc, v, "long_name", "valid time"), "write attribute in");
    NCT(prod_put_text(nc, v, "units", TIME_UNITS), "write attribute in");
    NCT(prod_put_text(nc, v, "calendar", "standard"), "write attribute in");
    NCT(prod_put_text(nc, v, "axis", "T"), "write attribute in");

    int v_ref;
    NCT(nc_def_var(nc, "forecast_reference_time", NC_DOUBLE, 0, NULL, &v_ref), "define variable in");
    NCT(prod_put_text(nc, v_ref, "standard_name", "forecast_reference_time"), "write attribute in");
    NCT(prod_put_text(nc, v_ref, "long_name", "forecast cycle (start) time"), "write attribute in");
    NCT(prod_put_text(nc, v_ref, "units", TIME_UNITS), "write attribute in");
    NCT(prod_put_text(nc, v_ref, "calendar", "standard"), "write attribute in");

    NCT(prod_def_forecast_period(nc, d_t, &p->v_period), "define variable in");

    int v_lat, v_lon, v_latb, v_lonb;
    NCT(prod_def_lonlat_axes(nc, d_lat, d_lon, d_bnds, &v_lat, &v_lon, &v_latb, &v_lonb), "define variable in");

    int dims2[2] = { d_lat, d_lon }, v_area, v_land;
    NCT(nc_def_var(nc, "cell_area", NC_DOUBLE, 2, dims2, &v_area), "define variable in");
    NCT(prod_put_text(nc, v_area, "standard_name", "cell_area"), "write attribute in");
    NCT(prod_put_text(nc, v_area, "long_name", "cell area on the sphere of radius 6371 km"),
        "write attribute in");
    NCT(prod_put_text(nc, v_area, "units", "m2"), "write attribute in");
    NCT(nc_def_var(nc, "landmask", NC_BYTE, 2, dims2, &v_land), "define variable in");
    NCT(prod_put_text(nc, v_land, "standard_name", "land_binary_mask"), "write attribute in");
    NCT(prod_put_text(nc, v_land, "long_name", "land mask used for the products (1 = land)"),
        "write attribute in");
    NCT(prod_put_text(nc, v_land, "units", "1"), "write attribute in");
    signed char flags[2] = { 0, 1 };
    NCT(nc_put_att_schar(nc, v_land, "flag_values", NC_BYTE, 2, flags), "write attribute in");
    NCT(prod_put_text(nc, v_land, "flag_meanings", "sea land"), "write attribute in");

    int dims3[3] = { d_t, d_lat, d_lon };
    size_t chunk[3] = { 1, (size_t)g->nlat, (size_t)g->nlon };
    float fill = PROD_FILL_FLOAT;
    for (int k = 0; k < PF_NVARS; k++) {
        const var_spec *s = &field_specs[k];
        if (k == PF_VAR_SNOW && !p->opts.write_snow)
            continue;
        NCT(nc_def_var(nc, s->name, NC_FLOAT, 3, dims3, &p->v_data[k]), "define variable in");
        v = p->v_data[k];
        NCT(nc_def_var_chunking(nc, v, NC_CHUNKED, chunk), "set chunking in");
        /* one time record per chunk, written once: a cache of one chunk
         * compresses and writes each record when the next one comes (in
         * products_add_time, on the writer thread where there is one)
         * rather than all of them at the close (netCDF's default cache held
         * the whole forecast); the file's data are the same */
        NCT(nc_set_var_chunk_cache(nc, v, (size_t)g->nlat * (size_t)g->nlon * sizeof(float) + 4096, 31, 1.0f),
            "set chunk cache in");
        if (p->opts.deflate_level > 0)
            NCT(nc_def_var_deflate(nc, v, 1, 1, p->opts.deflate_level), "set deflate in");
        NCT(nc_put_att_float(nc, v, "_FillValue", NC_FLOAT, 1, &fill), "write attribute in");
        NCT(prod_put_text(nc, v, "standard_name", s->standard_name), "write attribute in");
        NCT(prod_put_text(nc, v, "long_name", s->long_name), "write attribute in");
        NCT(prod_put_text(nc, v, "units", s->units), "write attribute in");
        NCT(prod_put_text(nc, v, "cell_methods", s->cell_methods), "write attribute in");
        NCT(prod_put_text(nc, v, "cell_measures", "area: cell_area"), "write attribute in");
        NCT(prod_put_text(nc, v, "coordinates", FORECAST_COORDS), "write attribute in");
    }
    float range[2] = { 0.0f, 1.0f };
    NCT(nc_put_att_float(nc, p->v_data[PF_VAR_CONC], "valid_range", NC_FLOAT, 2, range),
        "write attribute in");

    int rc;
    if ((rc = def_scalar_series(p, d_t, "siarea", "sea_ice_area",
                                "sea ice area (sum of concentration times cell area)", "km2",
                                &p->v_area, err)) != SPH_OK ||
        (rc = def_scalar_series(p, d_t, "siextent", "sea_ice_extent",
                                "sea ice extent (area of cells with concentration >= threshold)",
                                "km2", &p->v_extent, err)) != SPH_OK ||
        (rc = def_scalar_series(p, d_t, "sivolume", "sea_ice_volume", "sea ice volume", "km3",
                                &p->v_volume, err)) != SPH_OK ||
        (rc = def_scalar_series(p, d_t, "edge_length", NULL,
                                "length of the ice edge (great circle, R = 6371 km)", "km",
                                &p->v_elen, err)) != SPH_OK ||
        (rc = def_scalar_series(p, d_t, "edge_distance", NULL,
                                "largest great-circle distance of an ice edge point from the "
                                "reference point", "nautical_mile", &p->v_edist, err)) != SPH_OK)
        return rc;
    /* CF's sea_ice_extent names its threshold in a scalar coordinate of
     * standard name sea_ice_area_fraction */
    int v_thr;
    NCT(nc_def_var(nc, "extent_threshold", NC_DOUBLE, 0, NULL, &v_thr), "define variable in");
    NCT(prod_put_text(nc, v_thr, "standard_name", "sea_ice_area_fraction"), "write attribute in");
    NCT(prod_put_text(nc, v_thr, "long_name", "concentration threshold of the ice extent and the ice edge"),
        "write attribute in");
    NCT(prod_put_text(nc, v_thr, "units", "1"), "write attribute in");
    NCT(prod_put_text(nc, p->v_extent, "coordinates", FORECAST_COORDS " extent_threshold"), "write attribute in");
    NCT(prod_put_text(nc, p->v_elen, "geometry", "edge_geometry"), "write attribute in");
    NCT(prod_put_text(nc, p->v_edist, "geometry", "edge_geometry"), "write attribute in");
    if (p->opts.has_reference) {
        NCT(put_double(nc, p->v_edist, "reference_lon", p->opts.ref_lon), "write attribute in");
        NCT(put_double(nc, p->v_edist, "reference_lat", p->opts.ref_lat), "write attribute in");
        NCT(prod_put_text(nc, p->v_edist, "reference_name", p->ref_name), "write attribute in");
    }

    /* CF-1.8 geometry container: one multi-line instance per output time. */
    int v_geom;
    NCT(nc_def_var(nc, "edge_geometry", NC_INT, 0, NULL, &v_geom), "define variable in");
    NCT(prod_put_text(nc, v_geom, "geometry_type", "line"), "write attribute in");
    NCT(prod_put_text(nc, v_geom, "node_count", "edge_node_count"), "write attribute in");
    NCT(prod_put_text(nc, v_geom, "part_node_count", "edge_part_node_count"), "write attribute in");
    NCT(prod_put_text(nc, v_geom, "node_coordinates", "edge_x edge_y"), "write attribute in");
    NCT(prod_put_text(nc, v_geom, "long_name",
                      "ice edge: concentration contour at the threshold, one multi-line per time"),
        "write attribute in");
    NCT(put_double(nc, v_geom, "threshold", p->opts.edge_threshold), "write attribute in");
    NCT(nc_def_var(nc, "edge_node_count", NC_INT, 1, &d_t, &p->v_node_count), "define variable in");
    NCT(prod_put_text(nc, p->v_node_count, "long_name", "number of ice edge nodes at each time"),
        "write attribute in");
    NCT(prod_put_text(nc, p->v_node_count, "units", "1"), "write attribute in");
    NCT(nc_def_var(nc, "edge_part_node_count", NC_INT, 1, &d_part, &p->v_part_count),
        "define variable in");
    NCT(prod_put_text(nc, p->v_part_count, "long_name", "number of nodes in each ice edge line"),
        "write attribute in");
    NCT(prod_put_text(nc, p->v_part_count, "units", "1"), "write attribute in");
    size_t ch1 = 4096;
    NCT(prod_def_lonlat(nc, "edge_x", 1, &d_node, 'X', "ice edge node longitude", &p->v_ex), "define variable in");
    NCT(nc_def_var_chunking(nc, p->v_ex, NC_CHUNKED, &ch1), "set chunking in");
    NCT(prod_def_lonlat(nc, "edge_y", 1, &d_node, 'Y', "ice edge node latitude", &p->v_ey), "define variable in");
    NCT(nc_def_var_chunking(nc, p->v_ey, NC_CHUNKED, &ch1), "set chunking in");

    if ((rc = put_global_provenance(p, nc, p->fields.tmp, err)) != SPH_OK)
        return rc;
    double latmax = g->lat0 + (g->nlat - 1) * g->dlat, lonmax = g->lon0 + (g->nlon - 1) * g->dlon;
    NCT(put_double(nc, NC_GLOBAL, "geospatial_lat_min", g->lat0 - g->dlat / 2), "write attribute in");
    NCT(put_double(nc, NC_GLOBAL, "geospatial_lat_max", latmax + g->dlat / 2), "write attribute in");
    NCT(put_double(nc, NC_GLOBAL, "geospatial_lon_min", g->lon0 - g->dlon / 2), "write attribute in");
    NCT(put_double(nc, NC_GLOBAL, "geospatial_lon_max", lonmax + g->dlon / 2), "write attribute in");
    NCT(prod_put_text(nc, NC_GLOBAL, "geospatial_lat_units", "degrees_north"), "write attribute in");
    NCT(prod_put_text(nc, NC_GLOBAL, "geospatial_lon_units", "degrees_east"), "write attribute in");
    NCT(nc_enddef(nc), "end definitions in");

    /* static variables */
    NCT(nc_put_var_double(nc, v_ref, &p->cycle_time), "write forecast_reference_time to");
    NCT(nc_put_var_double(nc, v_thr, &p->opts.edge_threshold), "write extent_threshold to");
    double *buf = malloc(2 * sizeof(double) * (size_t)(g->nlat > g->nlon ? g->nlat : g->nlon));
    if (!buf)
        return sph_err_set(err, SPH_ERR_NOMEM, "products: out of memory");
    for (int j = 0; j < g->nlat; j++)
        buf[j] = g->lat0 + j * g->dlat;
    st = nc_put_var_double(nc, v_lat, buf);
    for (int i = 0; i < g->nlon; i++)
        buf[i] = g->lon0 + i * g->dlon;
    if (st == NC_NOERR)
        st = nc_put_var_double(nc, v_lon, buf);
    free(buf);
    if (st == NC_NOERR)
        st = prod_put_lonlat_bnds(nc, g, v_latb, v_lonb);
    NCT(st, "write coordinates to");
    size_t nn = (size_t)g->nlat * g->nlon;
    double *area = malloc(nn * sizeof *area);
    if (!area)
        return sph_err_set(err, SPH_ERR_NOMEM, "products: out of memory");
    for (size_t k = 0; k < nn; k++)
        area[k] = p->area_row[k / g->nlon];
    st = nc_put_var_double(nc, v_area, area);
    free(area);
    NCT(st, "write cell_area to");
    return SPH_OK;
}

/* Land mask is written at the first time (it may come with the fields). */
static int write_landmask(prod_writer *p, sph_error *err)
{
    int v;
    NCT(nc_inq_varid(p->nc, "landmask", &v), "find landmask in");
    size_t nn = (size_t)p->grid.nlat * p->grid.nlon;
    signed char *b = calloc(nn, 1);
    if (!b)
        return sph_err_set(err, SPH_ERR_NOMEM, "products: out of memory");
    for (size_t k = 0; k < nn; k++)
        b[k] = p->land ? (signed char)(p->land[k] != 0) : 0;
    int st = nc_put_var_schar(p->nc, v, b);
    free(b);
    NCT(st, "write landmask to");
    return SPH_OK;
}

int products_open(prod_writer **out, const prod_options *opts, const prod_grid *grid,
                  const prod_meta *meta, const char *stage_dir, sph_error *err)
{
    *out = NULL;
    if (prod_grid_check(grid, err) != SPH_OK)
        return err ? err->code : SPH_ERR_PARAM;
    if (!opts || !meta || !stage_dir || !stage_dir[0])
        return sph_err_set(err, SPH_ERR_PARAM, "products: missing options, metadata or stage dir");
    if (!(opts->edge_threshold > 0 && opts->edge_threshold <= 1))
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "products: edge threshold %g outside (0, 1]", opts->edge_threshold);
    if (opts->deflate_level < 0 || opts->deflate_level > 9)
        return sph_err_set(err, SPH_ERR_CONFIG, "products: deflate level %d outside 0..9",
                           opts->deflate_level);
    if (opts->nstations < 0 || (opts->nstations > 0 && !opts->stations))
        return sph_err_set(err, SPH_ERR_CONFIG, "products: bad station list");
    double lonmax = grid->lon0 + (grid->nlon - 1) * grid->dlon;
    double latmax = grid->lat0 + (grid->nlat - 1) * grid->dlat;
    for (int s = 0; s < opts->nstations; s++) {
        const prod_station *st = &opts->stations[s];
        if (!(st->lon >= grid->lon0 && st->lon <= lonmax && st->lat >= grid->lat0 &&
              st->lat <= latmax))
            return sph_err_set(err, SPH_ERR_CONFIG,
                               "products: station '%s' (%g E, %g N) outside the output grid",
                               st->name, st->lon, st->lat);
    }
    if (opts->quicklook_every > 0 && (opts->quicklook_width < 200 || opts->quicklook_height < 150))
        return sph_err_set(err, SPH_ERR_CONFIG, "products: quick-look size %dx%d too small",
                           opts->quicklook_width, opts->quicklook_height);
    if (strlen(stage_dir) >= PROD_STAGE_LEN)
        return sph_err_set(err, SPH_ERR_CONFIG, "products: stage directory path too long");
    if (mkdir_p(stage_dir, err) != SPH_OK)
        return err ? err->code : SPH_ERR_IO;

    prod_writer *p = calloc(1, sizeof *p);
    if (!p)
        return sph_err_set(err, SPH_ERR_NOMEM, "products: out of memory");
    p->nc = p->st_ncid = p->pt_nc = -1;
    p->grid = *grid;
    p->opts = *opts;
    snprintf(p->prefix, sizeof p->prefix, "%s", opts->prefix && opts->prefix[0] ? opts->prefix : "sphice");
    snprintf(p->ref_name, sizeof p->ref_name, "%s", opts->ref_name ? opts->ref_name : "reference point");
    p->opts.prefix = p->prefix;
    p->opts.ref_name = p->ref_name;
    snprintf(p->stage, sizeof p->stage, "%s", stage_dir);
    p->last_quicklook_index = -1;
    if (opts->nstations > 0) {
        p->stations = malloc(sizeof *p->stations * (size_t)opts->nstations);
        if (!p->stations)
            goto nomem;
        memcpy(p->stations, opts->stations, sizeof *p->stations * (size_t)opts->nstations);
        for (int s = 0; s < opts->nstations; s++)
            p->stations[s].name[sizeof p->stations[s].name - 1] = '\0';
        p->opts.stations = p->stations;
    }
    p->title = dup_or_null(meta->title);
    p->summary = dup_or_null(meta->summary);
    p->institution = dup_or_null(meta->institution);
    p->region = dup_or_null(meta->region);
    p->version = strdup(meta->model_version ? meta->model_version : SPHICE_VERSION);
    p->gitrev = strdup(meta->git_revision ? meta->git_revision : SPHICE_GIT);
    p->config_sha = dup_or_null(meta->config_sha256);
    p->start_mode = dup_or_null(meta->start_mode);
    p->cycle_time = meta->cycle_time;
    p->stale = meta->stale_forcing != 0;
    if (!p->version || !p->gitrev)
        goto nomem;
    if (meta->forcing_sha256) {
        size_t len = 1;
        for (const char *const *f = meta->forcing_sha256; *f; f++)
            len += strlen(*f) + 1;
        p->forcing = calloc(len, 1);
        if (!p->forcing)
            goto nomem;
        size_t off = 0;
        for (const char *const *f = meta->forcing_sha256; *f; f++)
            off += (size_t)snprintf(p->forcing + off, len - off, "%s%s", off ? "\n" : "", *f);
    }

    size_t nn = (size_t)grid->nlat * grid->nlon;
    for (int k = 0; k < PF_NVARS; k++)
        if (!(p->masked[k] = malloc(nn * sizeof(double))))
            goto nomem;
    p->fbuf = malloc(nn * sizeof(float));
    p->area_row = malloc((size_t)grid->nlat * sizeof(double));
    if (!p->fbuf || !p->area_row)
        goto nomem;
    for (int j = 0; j < grid->nlat; j++)
        p->area_row[j] = prod_grid_cell_area_m2(grid, j);

    int rc;
    if ((rc = prod_file_init(p, &p->fields, "fields.nc", err)) != SPH_OK ||
        (rc = fields_define(p, err)) != SPH_OK ||
        (rc = prod_stations_open(p, err)) != SPH_OK ||
        (rc = prod_particles_open(p, err)) != SPH_OK) {
        products_abort(p);
        return rc;
    }
    *out = p;
    return SPH_OK;
nomem:
    products_abort(p);
    return sph_err_set(err, SPH_ERR_NOMEM, "products: out of memory");
}

int products_set_observation(prod_writer *p, double t_obs, const double *obs_conc, sph_error *err)
{
    if (!p || !obs_conc || !isfinite(t_obs))
        return sph_err_set(err, SPH_ERR_PARAM, "products: bad observation");
    size_t nn = (size_t)p->grid.nlat * p->grid.nlon;
    if (!p->obs && !(p->obs = malloc(nn * sizeof *p->obs)))
        return sph_err_set(err, SPH_ERR_NOMEM, "products: out of memory");
    memcpy(p->obs, obs_conc, nn * sizeof *p->obs);
    p->obs_time = t_obs;
    p->has_obs = 1;
    return SPH_OK;
}

void products_set_run_info(prod_writer *p, const prod_run_info *info)
{
    if (p && info) {
        p->run = *info;
        p->has_run = 1;
    }
}

int products_add_file(prod_writer *p, const char *name, sph_error *err)
{
    if (!p || !name || !name[0] || strchr(name, '/'))
        return sph_err_set(err, SPH_ERR_PARAM, "products: bad extra file name");
    char path[PROD_PATH];
    struct stat sb;
    snprintf(path, sizeof path, "%s/%s", p->stage, name);
    if (stat(path, &sb) != 0)
        return sph_err_set(err, SPH_ERR_IO, "products: %s: %s", path, strerror(errno));
    if (p->nproducts >= PROD_MAX_PRODUCTS - 6)
        return sph_err_set(err, SPH_ERR_PARAM, "products: too many files for the manifest");
    add_product(p, name);
    return SPH_OK;
}

void products_set_init_info(prod_writer *p, const prod_init_info *info)
{
    if (p && info) {
        p->init = *info;
        snprintf(p->init_flag, sizeof p->init_flag, "%s", info->flag && info->flag[0] ? info->flag : "none");
        p->init.flag = p->init_flag;
        p->has_init = 1;
    }
}

/* Masking rules of prod_fields (see io/products.h); NaN marks fill. */
static void mask_fields(prod_writer *p, const prod_fields *f)
{
    size_t nn = (size_t)p->grid.nlat * p->grid.nlon;
    const double *src[PF_NVARS] = { f->conc, f->hbar, f->thick, f->u_east, f->v_north,
                                    f->pressure, f->divergence, f->shear, f->snow };
    for (size_t k = 0; k < nn; k++) {
        int land = f->land && f->land[k];
        double c = land ? NAN : (isfinite(f->conc[k]) ? f->conc[k] : 0.0);
        p->masked[PF_VAR_CONC][k] = c;
        double h = NAN;
        if (!land && f->hbar)
            h = isfinite(f->hbar[k]) ? f->hbar[k] : 0.0;
        p->masked[PF_VAR_HBAR][k] = h;
        for (int v = PF_VAR_THICK; v < PF_NVARS; v++)
            p->masked[v][k] = (!land && c > 0 && src[v] && isfinite(src[v][k])) ? src[v][k] : NAN;
    }
}

static int write_record(prod_writer *p, int var, size_t t, sph_error *err)
{
    size_t nn = (size_t)p->grid.nlat * p->grid.nlon;
    const double *m = p->masked[var];
    for (size_t k = 0; k < nn; k++)
        p->fbuf[k] = isnan(m[k]) ? PROD_FILL_FLOAT : (float)m[k];
    size_t start[3] = { t, 0, 0 }, count[3] = { 1, (size_t)p->grid.nlat, (size_t)p->grid.nlon };
    NCT(nc_put_vara_float(p->nc, p->v_data[var], start, count, p->fbuf), "write data to");
    return SPH_OK;
}

static int put_series(prod_writer *p, int varid, size_t t, double v, sph_error *err)
{
    if (isnan(v))
        v = NC_FILL_DOUBLE;
    NCT(nc_put_var1_double(p->nc, varid, &t, &v), "write series to");
    return SPH_OK;
}

static int write_edge_record(prod_writer *p, size_t t, const edge_set *e, sph_error *err)
{
    int total = (int)e->npts_total;
    NCT(nc_put_var1_int(p->nc, p->v_node_count, &t, &total), "write edge_node_count to");
    if (e->nlines == 0)
        return SPH_OK;
    int *parts = malloc(e->nlines * sizeof *parts);
    double *x = malloc(e->npts_total * sizeof *x), *y = malloc(e->npts_total * sizeof *y);
    if (!parts || !x || !y) {
        free(parts);
        free(x);
        free(y);
        return sph_err_set(err, SPH_ERR_NOMEM, "products: out of memory");
    }
    size_t o = 0;
    for (size_t l = 0; l < e->nlines; l++) {
        parts[l] = (int)e->lines[l].npts;
        memcpy(x + o, e->lines[l].lon, e->lines[l].npts * sizeof *x);
        memcpy(y + o, e->lines[l].lat, e->lines[l].npts * sizeof *y);
        o += e->lines[l].npts;
    }
    size_t sp = p->edge_parts, np = e->nlines, sn = p->edge_nodes, nnodes = e->npts_total;
    int st = nc_put_vara_int(p->nc, p->v_part_count, &sp, &np, parts);
    if (st == NC_NOERR)
        st = nc_put_vara_double(p->nc, p->v_ex, &sn, &nnodes, x);
    if (st == NC_NOERR)
        st = nc_put_vara_double(p->nc, p->v_ey, &sn, &nnodes, y);
    free(parts);
    free(x);
    free(y);
    NCT(st, "write ice edge to");
    p->edge_parts += np;
    p->edge_nodes += nnodes;
    return SPH_OK;
}

static int render_quicklook(prod_writer *p, size_t index, double t, const edge_set *e,
                            sph_error *err)
{
    if (p->nproducts >= PROD_MAX_PRODUCTS - 8) {
        log_warn("products: too many files, quick-look for output time %zu skipped", index);
        return SPH_OK;
    }
    char iso[32], stamp[32], name[PROD_NAME_LEN], path[PROD_PATH], run[256];
    time_format_iso(t, iso, sizeof iso);
    /* "YYYY-MM-DDTHH:MM:SSZ" -> "YYYYMMDDTHHMMZ" */
    snprintf(stamp, sizeof stamp, "%.4s%.2s%.2sT%.2s%.2sZ", iso, iso + 5, iso + 8, iso + 11, iso + 14);
    snprintf(name, sizeof name, "%s_quicklook_%s.png", p->prefix, stamp);
    snprintf(path, sizeof path, "%s/%s", p->stage, name);
    quicklook_opts qo;
    quicklook_opts_default(&qo);
    qo.width = p->opts.quicklook_width;
    qo.height = p->opts.quicklook_height;
    qo.threshold = p->opts.edge_threshold;
    if (p->opts.quicklook_thick_max > 0)
        qo.thick_max = p->opts.quicklook_thick_max;
    qo.title = p->title;
    qo.domain = p->region;
    snprintf(run, sizeof run, "%s, %s start, sphice %s", p->prefix,
             p->start_mode ? p->start_mode : "cold", p->version);
    qo.run = run;
    qo.cycle_time = p->cycle_time;
    qo.smooth_km = 0.5 * p->spacing_km;
    if (p->opts.quicklook_drift) {
        qo.u_east = p->masked[PF_VAR_U];
        qo.v_north = p->masked[PF_VAR_V];
    }
    int ns = p->opts.nstations;
    const char **names = ns ? malloc(sizeof *names * (size_t)ns) : NULL;
    double *lon = ns ? malloc(sizeof *lon * (size_t)ns) : NULL;
    double *lat = ns ? malloc(sizeof *lat * (size_t)ns) : NULL;
    unsigned char *mark = p->ld_sum.on && ns ? calloc((size_t)ns, 1) : NULL; /* loads above the threshold */
    int rc;
    if (ns && (!names || !lon || !lat || (p->ld_sum.on && !mark))) {
        rc = sph_err_set(err, SPH_ERR_NOMEM, "products: out of memory");
    } else {
        for (int s = 0; s < ns; s++) {
            names[s] = p->stations[s].name;
            lon[s] = p->stations[s].lon;
            lat[s] = p->stations[s].lat;
            if (mark)
                mark[s] = (unsigned char)prod_loads_alert(p, s);
        }
        qo.st_mark = mark;
        qo.mark_threshold_kn = p->opts.loads.map_threshold * 1e-3;
        rc = quicklook_write_png(path, &p->grid, p->masked[PF_VAR_CONC], p->masked[PF_VAR_THICK],
                                 p->land, e, names, lon, lat, ns, t, &qo, err);
    }
    free(names);
    free(lon);
    free(lat);
    free(mark);
    if (rc == SPH_OK) {
        add_product(p, name);
        p->last_quicklook_index = (int)index;
        rc = prod_gis_add(p, t, stamp, e, err);
    }
    return rc;
}

static int fail(prod_writer *p, int rc)
{
    p->failed = 1;
    return rc;
}

int products_add_time(prod_writer *p, double t, const prod_fields *f,
                      const prod_particles_view *particles, sph_error *err)
{
    if (!p || !f || !f->conc)
        return sph_err_set(err, SPH_ERR_PARAM, "products: no concentration field");
    if (p->failed)
        return sph_err_set(err, SPH_ERR_INTERNAL, "products: writer already failed");
    if (!isfinite(t) || (p->ntimes > 0 && !(t > p->t_last)))
        return fail(p, sph_err_set(err, SPH_ERR_PARAM,
                                   "products: output time %.0f not after the previous one", t));
    const prod_grid *g = &p->grid;
    size_t nn = (size_t)g->nlat * g->nlon, ti = p->ntimes;
    int rc;
    if (f->land) {
        if (!p->land && !(p->land = malloc(nn)))
            return fail(p, sph_err_set(err, SPH_ERR_NOMEM, "products: out of memory"));
        memcpy(p->land, f->land, nn);
    }
    mask_fields(p, f);
    if (ti == 0 && (rc = write_landmask(p, err)) != SPH_OK)
        return fail(p, rc);
    NCT(nc_put_var1_double(p->nc, p->v_time, &ti, &t), "write time to");
    double lead_h = (t - p->cycle_time) / 3600.0;
    NCT(nc_put_var1_double(p->nc, p->v_period, &ti, &lead_h), "write forecast_period to");
    for (int v = 0; v < PF_NVARS; v++) {
        if (v == PF_VAR_SNOW && !p->opts.write_snow)
            continue;
        if ((rc = write_record(p, v, ti, err)) != SPH_OK)
            return fail(p, rc);
        if (v == 0 && fault_point("products-mid-write")) {
            if (getenv("SPHICE_FAULT_EXIT"))
                _exit(99);
            return fail(p, sph_err_set(err, SPH_ERR_IO,
                                       "write %s: fault injected (products-mid-write)",
                                       p->fields.tmp));
        }
    }

    double area = 0, extent = 0, volume = 0;
    for (int j = 0; j < g->nlat; j++)
        for (int i = 0; i < g->nlon; i++) {
            size_t k = (size_t)j * g->nlon + i;
            double c = p->masked[PF_VAR_CONC][k], h = p->masked[PF_VAR_HBAR][k];
            if (isnan(c))
                continue;
            area += c * p->area_row[j];
            if (c >= p->opts.edge_threshold)
                extent += p->area_row[j];
            if (!isnan(h))
                volume += h * p->area_row[j];
        }
    p->area_km2 = area * 1e-6;
    p->extent_km2 = extent * 1e-6;
    p->volume_km3 = volume * 1e-9;

    edge_set e;
    if ((rc = edge_extract(g, p->masked[PF_VAR_CONC], p->land, p->opts.edge_threshold, &e, err)) !=
        SPH_OK)
        return fail(p, rc);
    double elen = edge_length_km(&e);
    double edist = p->opts.has_reference ? edge_max_distance_nm(&e, p->opts.ref_lon, p->opts.ref_lat)
                                         : NAN;
    if ((rc = write_edge_record(p, ti, &e, err)) != SPH_OK ||
        (rc = put_series(p, p->v_area, ti, p->area_km2, err)) != SPH_OK ||
        (rc = put_series(p, p->v_extent, ti, p->extent_km2, err)) != SPH_OK ||
        (rc = put_series(p, p->v_volume, ti, p->volume_km3, err)) != SPH_OK ||
        (rc = put_series(p, p->v_elen, ti, elen, err)) != SPH_OK ||
        (rc = put_series(p, p->v_edist, ti, edist, err)) != SPH_OK) {
        edge_set_free(&e);
        return fail(p, rc);
    }
    /* keep the edge for the GeoJSON file */
    if (p->nedges == p->edges_cap) {
        size_t nc = p->edges_cap ? 2 * p->edges_cap : 16;
        edge_set *ne = realloc(p->edges, nc * sizeof *ne);
        if (ne)
            p->edges = ne;
        double *a = ne ? realloc(p->edge_time, nc * sizeof *a) : NULL;
        if (a)
            p->edge_time = a;
        double *b = a ? realloc(p->edge_len, nc * sizeof *b) : NULL;
        if (b)
            p->edge_len = b;
        double *c = b ? realloc(p->edge_dist, nc * sizeof *c) : NULL;
        if (c)
            p->edge_dist = c;
        if (!c) {
            edge_set_free(&e);
            return fail(p, sph_err_set(err, SPH_ERR_NOMEM, "products: out of memory"));
        }
        p->edges_cap = nc;
    }
    p->edges[p->nedges] = e;
    p->edge_time[p->nedges] = t;
    p->edge_len[p->nedges] = elen;
    p->edge_dist[p->nedges] = edist;
    p->nedges++;

    if (ti == 0) {
        if (!(p->persistence = malloc(nn * sizeof(double))))
            return fail(p, sph_err_set(err, SPH_ERR_NOMEM, "products: out of memory"));
        memcpy(p->persistence, p->masked[PF_VAR_CONC], nn * sizeof(double));
        p->t_first = t;
    }
    p->ntimes++;
    p->t_last = t;

    if ((rc = prod_stations_add(p, t, err)) != SPH_OK)
        return fail(p, rc);
    if (particles && (rc = prod_particles_add(p, t, particles, err)) != SPH_OK)
        return fail(p, rc);
    if (particles && particles->n > 0) /* the maps smooth at this scale */
        p->spacing_km = sqrt(p->extent_km2 / (double)particles->n);
    if (p->has_obs && fabs(t - p->obs_time) <= 1.0) {
        if ((rc = verify_compute(g, p->masked[PF_VAR_CONC], p->obs, p->persistence, p->land,
                                 p->opts.edge_threshold, &p->scores, err)) != SPH_OK)
            return fail(p, rc);
        p->scores.valid_time = t;
        p->has_scores = 1;
    }
    if (p->opts.quicklook_every > 0 && ti % (size_t)p->opts.quicklook_every == 0 &&
        (rc = render_quicklook(p, ti, t, &p->edges[p->nedges - 1], err)) != SPH_OK)
        return fail(p, rc);
    return SPH_OK;
}

/* ---- close ---- */

static int fields_finish(prod_writer *p, sph_error *err)
{
    int nc = p->nc;
    char a[32], b[32];
    time_format_iso(p->t_first, a, sizeof a);
    time_format_iso(p->t_last, b, sizeof b);
    NCT(nc_redef(nc), "reopen definitions of");
    if (p->ntimes > 0) {
        NCT(prod_put_text(nc, NC_GLOBAL, "time_coverage_start", a), "write attribute to");
        NCT(prod_put_text(nc, NC_GLOBAL, "time_coverage_end", b), "write attribute to");
    }
    if (p->has_init) {
        const struct { const char *name; double v; } ia[] = {
            { "sphice_raster_ice_area_km2", p->init.raster_area_km2 },
            { "sphice_raster_ice_volume_km3", p->init.raster_volume_km3 },
            { "sphice_seeded_ice_area_km2", p->init.seeded_area_km2 },
            { "sphice_seeded_ice_volume_km3", p->init.seeded_volume_km3 },
            { "sphice_particles_on_land_fraction", p->init.land_fraction },
        };
        for (size_t k = 0; k < sizeof ia / sizeof ia[0]; k++)
            if (isfinite(ia[k].v))
                NCT(put_double(nc, NC_GLOBAL, ia[k].name, ia[k].v), "write attribute to");
        NCT(prod_put_text(nc, NC_GLOBAL, "sphice_quality_flag", p->init.flag), "write attribute to");
    }
    if (p->has_run) {
        NCT(put_double(nc, NC_GLOBAL, "sphice_regime_fraction_free_drift", p->run.frac_free_drift),
            "write attribute to");
        NCT(put_double(nc, NC_GLOBAL, "sphice_regime_fraction_rheology", p->run.frac_rheology),
            "write attribute to");
        NCT(put_double(nc, NC_GLOBAL, "sphice_regime_fraction_zero_layer", p->run.frac_zero_layer),
            "write attribute to");
        NCT(put_double(nc, NC_GLOBAL, "sphice_regime_fraction_multi_layer",
                       p->run.frac_multi_layer), "write attribute to");
        NCT(put_double(nc, NC_GLOBAL, "sphice_solver_mean_iterations", p->run.solver_iterations),
            "write attribute to");
        NCT(put_double(nc, NC_GLOBAL, "sphice_solver_stalled_fraction", p->run.solver_stalled),
            "write attribute to");
        if (p->run.solver_rel_tol_on) { /* model.evp.rel_tol > 0: the residual rule */
            NCT(put_double(nc, NC_GLOBAL, "sphice_solver_mean_relative_residual", p->run.solver_residual),
                "write attribute to");
            NCT(put_double(nc, NC_GLOBAL, "sphice_solver_unconverged_fraction", p->run.solver_unconverged),
                "write attribute to");
            if (p->run.solver_unconverged > 0.0)
                NCT(prod_put_text(nc, NC_GLOBAL, "sphice_solver_warning",
                                  "some steps ended with the mEVP relative residual above model.evp.rel_tol "
                                  "(sphice_solver_unconverged_fraction): the stress solution is not converged there"),
                    "write attribute to");
        }
        NCT(put_double(nc, NC_GLOBAL, "sphice_mass_budget_residual", p->run.budget_residual),
            "write attribute to");
        if (p->run.dt > 0.0) {
            NCT(put_double(nc, NC_GLOBAL, "sphice_dt_dynamics", p->run.dt), "write attribute to");
            NCT(prod_put_text(nc, NC_GLOBAL, "sphice_dt_policy", p->run.dt_auto ? "auto" : "configured"),
                "write attribute to");
        }
        long long ps = p->run.particles_start, pe = p->run.particles_end;
        NCT(nc_put_att_longlong(nc, NC_GLOBAL, "sphice_particles_start", NC_INT64, 1, &ps),
            "write attribute to");
        NCT(nc_put_att_longlong(nc, NC_GLOBAL, "sphice_particles_end", NC_INT64, 1, &pe),
            "write attribute to");
    }
    if (p->has_scores) {
        const verify_scores *s = &p->scores;
        time_format_iso(s->valid_time, a, sizeof a);
        NCT(prod_put_text(nc, NC_GLOBAL, "sphice_score_valid_time", a), "write attribute to");
        struct { const char *n; double v; } sc[] = {
            { "sphice_score_iiee_km2", s->iiee_km2 },
            { "sphice_score_overestimate_km2", s->over_km2 },
            { "sphice_score_underestimate_km2", s->under_km2 },
            { "sphice_score_absolute_extent_error_km2", s->aee_km2 },
            { "sphice_score_misplacement_error_km2", s->me_km2 },
            { "sphice_score_edge_displacement_km", s->displacement_km },
            { "sphice_score_concentration_bias", s->conc_bias },
            { "sphice_score_concentration_rmse", s->conc_rmse },
            { "sphice_score_skill_vs_persistence", s->skill_persistence },
        };
        for (size_t k = 0; k < sizeof sc / sizeof sc[0]; k++)
            NCT(put_double(nc, NC_GLOBAL, sc[k].n, isfinite(sc[k].v) ? sc[k].v : NC_FILL_DOUBLE),
                "write attribute to");
    }
    NCT(nc_enddef(nc), "end definitions of");
    NCT(ncfile_close(&p->nc), "close");
    return prod_file_commit(p, &p->fields, err);
}

static int write_geojson(prod_writer *p, sph_error *err)
{
    char name[PROD_NAME_LEN], path[PROD_PATH], iso[32];
    snprintf(name, sizeof name, "%s_edge.geojson", p->prefix);
    snprintf(path, sizeof path, "%s/%s", p->stage, name);
    cJSON *feats, *fc = gis_geojson_collection(&feats);
    if (!fc)
        return sph_err_set(err, SPH_ERR_NOMEM, "write %s: out of memory", path);
    for (size_t t = 0; t < p->nedges; t++) {
        const edge_set *e = &p->edges[t];
        cJSON *lines, *props = gis_geojson_feature(feats, "MultiLineString", &lines);
        for (size_t l = 0; l < e->nlines; l++) {
            cJSON *line = cJSON_CreateArray();
            cJSON_AddItemToArray(lines, line);
            for (size_t q = 0; q < e->lines[l].npts; q++) {
                /* RFC 7946: [longitude, latitude]; 6 decimals ~ 0.1 m */
                double xy[2] = { round(e->lines[l].lon[q] * 1e6) / 1e6,
                                 round(e->lines[l].lat[q] * 1e6) / 1e6 };
                cJSON_AddItemToArray(line, cJSON_CreateDoubleArray(xy, 2));
            }
        }
        time_format_iso(p->edge_time[t], iso, sizeof iso);
        cJSON_AddStringToObject(props, "valid_time", iso);
        cJSON_AddNumberToObject(props, "threshold", p->opts.edge_threshold);
        cJSON_AddNumberToObject(props, "edge_length_km", p->edge_len[t]);
        if (isfinite(p->edge_dist[t])) {
            cJSON_AddNumberToObject(props, "edge_distance_nm", p->edge_dist[t]);
            cJSON_AddStringToObject(props, "reference", p->ref_name);
        }
    }
    int rc = gis_geojson_write(fc, path, err);
    if (rc == SPH_OK)
        add_product(p, name);
    return rc;
}

static int write_manifest(prod_writer *p, sph_error *err)
{
    char path[PROD_PATH], iso[32], hex[65];
    snprintf(path, sizeof path, "%s/manifest.json", p->stage);
    cJSON *m = cJSON_CreateObject(), *files = cJSON_CreateArray();
    if (!m || !files) {
        cJSON_Delete(m);
        cJSON_Delete(files);
        return sph_err_set(err, SPH_ERR_NOMEM, "write %s: out of memory", path);
    }
    time_format_iso(p->cycle_time, iso, sizeof iso);
    cJSON_AddStringToObject(m, "cycle_time", iso);
    cJSON_AddNumberToObject(m, "output_times", (double)p->ntimes);
    cJSON_AddBoolToObject(m, "stale_forcing", p->stale);
    cJSON_AddStringToObject(m, "model_version", p->version);
    cJSON_AddStringToObject(m, "git_revision", p->gitrev);
    cJSON_AddItemToObject(m, "files", files);
    int rc = SPH_OK;
    for (int k = 0; k < p->nproducts && rc == SPH_OK; k++) {
        char fp[PROD_PATH];
        snprintf(fp, sizeof fp, "%s/%s", p->stage, p->products[k]);
        struct stat sb;
        if (stat(fp, &sb) != 0) {
            rc = sph_err_set(err, SPH_ERR_IO, "manifest: %s: %s", fp, strerror(errno));
            break;
        }
        if ((rc = sha256_file(fp, hex, err)) != SPH_OK)
            break;
        cJSON *f = cJSON_CreateObject();
        cJSON_AddItemToArray(files, f);
        cJSON_AddStringToObject(f, "name", p->products[k]);
        cJSON_AddNumberToObject(f, "bytes", (double)sb.st_size);
        cJSON_AddStringToObject(f, "sha256", hex);
    }
    cJSON_AddBoolToObject(m, "complete", 1);
    if (rc != SPH_OK) {
        cJSON_Delete(m);
        return rc;
    }
    if ((rc = prod_write_json(path, m, err)) == SPH_OK)
        add_product(p, "manifest.json");
    return rc;
}

int prod_write_json(const char *path, struct cJSON *doc, sph_error *err)
{
    char *text = cJSON_Print(doc);
    cJSON_Delete(doc);
    if (!text)
        return sph_err_set(err, SPH_ERR_NOMEM, "write %s: out of memory", path);
    int rc = atomic_write_file(path, text, strlen(text), err);
    free(text);
    return rc;
}

static void writer_free(prod_writer *p)
{
    for (int k = 0; k < PF_NVARS; k++)
        free(p->masked[k]);
    free(p->fbuf);
    free(p->area_row);
    free(p->land);
    free(p->stations);
    free(p->title);
    free(p->summary);
    free(p->institution);
    free(p->region);
    free(p->version);
    free(p->gitrev);
    free(p->config_sha);
    free(p->forcing);
    free(p->start_mode);
    for (size_t t = 0; t < p->nedges; t++)
        edge_set_free(&p->edges[t]);
    free(p->edges);
    free(p->edge_time);
    free(p->edge_len);
    free(p->edge_dist);
    free(p->persistence);
    free(p->obs);
    free(p->ids);
    free(p->dense);
    gis_store_free(p->gis);
    free(p->st_series);
    free(p->st_times);
    free(p);
}

void products_abort(prod_writer *p)
{
    if (!p)
        return;
    (void)ncfile_close(&p->nc);
    prod_file_discard(&p->fields);
    prod_stations_abort(p);
    prod_particles_abort(p);
    writer_free(p);
}

int products_close(prod_writer *p, prod_summary *summary, sph_error *err)
{
    if (!p)
        return sph_err_set(err, SPH_ERR_PARAM, "products: no writer");
    int rc;
    if (p->failed) {
        products_abort(p);
        return sph_err_set(err, SPH_ERR_INTERNAL, "products: writer failed earlier; nothing kept");
    }
    if (p->ntimes == 0) {
        products_abort(p);
        return sph_err_set(err, SPH_ERR_PARAM, "products: no output time was written");
    }
    if (p->has_obs && !p->has_scores) {
        char iso[32];
        time_format_iso(p->obs_time, iso, sizeof iso);
        log_warn("products: observation valid at %s matches no output time; no scores", iso);
    }
    if ((rc = fields_finish(p, err)) != SPH_OK || (rc = prod_stations_close(p, err)) != SPH_OK ||
        (rc = prod_particles_close(p, err)) != SPH_OK ||
        (p->opts.write_geojson && (rc = write_geojson(p, err)) != SPH_OK))
        goto failed;
    if (p->has_scores) {
        char name[PROD_NAME_LEN], path[PROD_PATH], iso[32];
        snprintf(name, sizeof name, "%s_scores.json", p->prefix);
        snprintf(path, sizeof path, "%s/%s", p->stage, name);
        time_format_iso(p->cycle_time, iso, sizeof iso);
        if ((rc = verify_write_json(path, &p->scores, "cycle_time", iso, err)) != SPH_OK)
            goto failed;
        add_product(p, name);
    }
    if (p->opts.quicklook_every > 0 && p->last_quicklook_index != (int)p->ntimes - 1 &&
        (rc = render_quicklook(p, p->ntimes - 1, p->t_last, &p->edges[p->nedges - 1], err)) !=
            SPH_OK)
        goto failed;
    if ((rc = prod_gis_close(p, err)) != SPH_OK)
        goto failed;
    if ((rc = write_manifest(p, err)) != SPH_OK)
        goto failed;
    if (summary) {
        memset(summary, 0, sizeof *summary);
        summary->ntimes = (int)p->ntimes;
        summary->ice_area_km2 = p->area_km2;
        summary->ice_extent_km2 = p->extent_km2;
        summary->ice_volume_km3 = p->volume_km3;
        summary->edge_length_km = p->edge_len[p->nedges - 1];
        summary->edge_distance_nm = p->edge_dist[p->nedges - 1];
        summary->has_scores = p->has_scores;
        summary->scores = p->scores;
        summary->nproducts = p->nproducts;
        memcpy(summary->products, p->products, sizeof summary->products);
        summary->loads = p->ld_sum;
    }
    writer_free(p);
    return SPH_OK;
failed:
    products_abort(p);
    return rc;
}
