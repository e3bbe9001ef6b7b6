/* Station time series: CF discrete sampling geometry (featureType
 * timeSeries, orthogonal multidimensional: data(station, time)) and a CSV
 * file with one header line. Values are bilinear in the grid cell holding
 * the station, using only the corners where the field is defined (land and
 * fill corners are left out, weights renormalised); fill if none is. */
#include "products_impl.h"

#include <errno.h>
#include <math.h>
#include <netcdf.h>
#include <stdlib.h>
#include <string.h>

#include "io/stationplot.h"
#include "util/fileio.h"
#include "util/log.h"
#include "util/timeutil.h"

#define NAME_LEN 64

enum { ST_CONC, ST_THICK, ST_HBAR, ST_SPEED, ST_DIR, ST_U, ST_V, ST_PRES, ST_NVARS };

static const struct {
    const char *name, *standard_name, *long_name, *units;
} st_specs[ST_NVARS] = {
    { "siconc", "sea_ice_area_fraction", "sea ice area fraction", "1" },
    { "sithick", "sea_ice_thickness", "sea ice thickness (of the ice-covered part)", "m" },
    { "sivol", "sea_ice_thickness", "sea ice volume per unit area (mean thickness over the cell)",
      "m" },
    { "sispeed", "sea_ice_speed", "sea ice drift speed", "m s-1" },
    { "sidir", NULL,
      "sea ice drift direction: direction the ice moves towards, degrees clockwise from true "
      "north (180 = moving south)", "degree" },
    { "siu", "eastward_sea_ice_velocity", "eastward sea ice velocity", "m s-1" },
    { "siv", "northward_sea_ice_velocity", "northward sea ice velocity", "m s-1" },
    { "sicompstren", "compressive_strength_of_sea_ice",
      "vertically integrated ice pressure (compressive strength) P", "N m-1" },
};

#define NCS(call, what)                                                   \
    do {                                                                  \
        int st_ = (call);                                                 \
        if (st_ != NC_NOERR)                                              \
            return prod_nc_check(st_, what, p->st_nc.tmp, err);          \
    } while (0)

static double sample(const prod_writer *p, const double *f, double lon, double lat)
{
    const prod_grid *g = &p->grid;
    double x = (lon - g->lon0) / g->dlon, y = (lat - g->lat0) / g->dlat;
    int i0 = (int)floor(x), j0 = (int)floor(y);
    if (i0 > g->nlon - 2)
        i0 = g->nlon - 2;
    if (j0 > g->nlat - 2)
        j0 = g->nlat - 2;
    if (i0 < 0)
        i0 = 0;
    if (j0 < 0)
        j0 = 0;
    double fx = x - i0, fy = y - j0, sum = 0, wsum = 0;
    for (int c = 0; c < 4; c++) {
        int di = c & 1, dj = c >> 1;
        double w = (di ? fx : 1 - fx) * (dj ? fy : 1 - fy);
        double v = f[(size_t)(j0 + dj) * g->nlon + i0 + di];
        if (w > 0 && !isnan(v)) {
            sum += w * v;
            wsum += w;
        }
    }
    return wsum > 1e-12 ? sum / wsum : NAN;
}

#define NCQ(call, what) PROD_NC_TRY(call, what, q->nc->tmp)

/* The part a station series and the load series share (products_loads.c):
 * the two temporary files, the CSV's header, the NetCDF file's station and
 * time dimensions, station_name, lon, lat and time, left in define mode. */
int prod_series_create(prod_writer *p, prod_series *q, const char *base, const char *header, int ns,
                       sph_error *err)
{
    char suffix[64];
    int rc;
    snprintf(suffix, sizeof suffix, "%s.nc", base);
    if ((rc = prod_file_init(p, q->nc, suffix, err)) != SPH_OK)
        return rc;
    snprintf(suffix, sizeof suffix, "%s.csv", base);
    if ((rc = prod_file_init(p, q->csv, suffix, err)) != SPH_OK)
        return rc;
    *q->f = fopen(q->csv->tmp, "w");
    if (!*q->f)
        return sph_err_set(err, SPH_ERR_IO, "create %s: %s", q->csv->tmp, strerror(errno));
    fputs(header, *q->f);

    int st = nc_create(q->nc->tmp, NC_NETCDF4 | NC_CLOBBER, q->ncid);
    if (st != NC_NOERR) {
        *q->ncid = -1;
        return prod_nc_check(st, "create", q->nc->tmp, err);
    }
    int nc = *q->ncid, d_len;
    NCQ(nc_def_dim(nc, "station", (size_t)ns, &q->d_st), "define dimension in");
    NCQ(nc_def_dim(nc, "time", NC_UNLIMITED, &q->d_t), "define dimension in");
    NCQ(nc_def_dim(nc, "name_strlen", NAME_LEN, &d_len), "define dimension in");
    int dn[2] = { q->d_st, d_len };
    NCQ(nc_def_var(nc, "station_name", NC_CHAR, 2, dn, &q->v_name), "define variable in");
    NCQ(prod_put_text(nc, q->v_name, "cf_role", "timeseries_id"), "write attribute in");
    NCQ(prod_put_text(nc, q->v_name, "long_name", "station name"), "write attribute in");
    NCQ(prod_def_lonlat(nc, "lon", 1, &q->d_st, 'X', "station longitude", &q->v_lon), "define variable in");
    NCQ(prod_def_lonlat(nc, "lat", 1, &q->d_st, 'Y', "station latitude", &q->v_lat), "define variable in");
    NCQ(nc_def_var(nc, "time", NC_DOUBLE, 1, &q->d_t, q->v_time), "define variable in");
    NCQ(prod_put_text(nc, *q->v_time, "standard_name", "time"), "write attribute in");
    NCQ(prod_put_text(nc, *q->v_time, "long_name", "valid time"), "write attribute in");
    NCQ(prod_put_text(nc, *q->v_time, "units", "seconds since 1970-01-01 00:00:00"),
        "write attribute in");
    NCQ(prod_put_text(nc, *q->v_time, "calendar", "standard"), "write attribute in");
    NCQ(prod_put_text(nc, *q->v_time, "axis", "T"), "write attribute in");
    return SPH_OK;
}

/* Closes both files of a series and commits them (atomically, listed). */
int prod_series_close(prod_writer *p, prod_series *q, sph_error *err)
{
    NCQ(ncfile_close(q->ncid), "close");
    FILE *f = *q->f;
    *q->f = NULL;
    int bad = fflush(f) != 0 || ferror(f);
    int e = errno;
    if (fclose(f) != 0)
        bad = 1;
    if (bad)
        return sph_err_set(err, SPH_ERR_IO, "write %s: %s", q->csv->tmp, strerror(e));
    int rc = prod_file_commit(p, q->nc, err);
    if (rc == SPH_OK)
        rc = prod_file_commit(p, q->csv, err);
    return rc;
}

int prod_stations_open(prod_writer *p, sph_error *err)
{
    int ns = p->opts.nstations;
    if (ns <= 0)
        return SPH_OK;
    prod_series q = { &p->st_nc, &p->st_csv, &p->csv, &p->st_ncid, &p->st_v_time, 0, 0, 0, 0, 0 };
    int rc = prod_series_create(p, &q, "stations",
                                "station,lon,lat,valid_time,siconc,sithick_m,sivol_m,drift_speed_m_s,"
                                "drift_direction_deg_towards,siu_m_s,siv_m_s,sicompstren_N_m\n", ns, err);
    if (rc != SPH_OK)
        return rc;
    int nc = p->st_ncid, d_st = q.d_st, d_t = q.d_t, v_name = q.v_name, v_lon = q.v_lon, v_lat = q.v_lat;
    int dd[2] = { d_st, d_t };
    float fill = PROD_FILL_FLOAT;
    for (int k = 0; k < ST_NVARS; k++) {
        NCS(nc_def_var(nc, st_specs[k].name, NC_FLOAT, 2, dd, &p->st_v[k]), "define variable in");
        int v = p->st_v[k];
        NCS(nc_put_att_float(nc, v, "_FillValue", NC_FLOAT, 1, &fill), "write attribute in");
        if (st_specs[k].standard_name)
            NCS(prod_put_text(nc, v, "standard_name", st_specs[k].standard_name),
                "write attribute in");
        NCS(prod_put_text(nc, v, "long_name", st_specs[k].long_name), "write attribute in");
        NCS(prod_put_text(nc, v, "units", st_specs[k].units), "write attribute in");
        NCS(prod_put_text(nc, v, "coordinates", "time lat lon station_name"), "write attribute in");
    }
    NCS(prod_put_text(nc, NC_GLOBAL, "Conventions", "CF-1.8, ACDD-1.3"), "write attribute in");
    NCS(prod_put_text(nc, NC_GLOBAL, "featureType", "timeSeries"), "write attribute in");
    NCS(prod_put_text(nc, NC_GLOBAL, "title", "sphice sea ice forecast at stations"),
        "write attribute in");
    NCS(prod_put_text(nc, NC_GLOBAL, "summary",
                      "Forecast sea ice at configured stations, sampled bilinearly from the "
                      "gridded products."), "write attribute in");
    NCS(prod_put_text(nc, NC_GLOBAL, "sphice_model_version", p->version), "write attribute in");
    NCS(prod_put_text(nc, NC_GLOBAL, "sphice_git_revision", p->gitrev), "write attribute in");
    NCS(prod_put_text(nc, NC_GLOBAL, "sphice_config_sha256", p->config_sha ? p->config_sha : "unknown"),
        "write attribute in");
    char iso[32];
    time_format_iso(p->cycle_time, iso, sizeof iso);
    NCS(prod_put_text(nc, NC_GLOBAL, "sphice_cycle_time", iso), "write attribute in");
    int stale = p->stale;
    NCS(nc_put_att_int(nc, NC_GLOBAL, "sphice_stale_forcing", NC_INT, 1, &stale),
        "write attribute in");
    NCS(nc_enddef(nc), "end definitions in");
    for (int s = 0; s < ns; s++) {
        char name[NAME_LEN] = { 0 };
        snprintf(name, sizeof name, "%s", p->stations[s].name);
        size_t start[2] = { (size_t)s, 0 }, count[2] = { 1, NAME_LEN };
        NCS(nc_put_vara_text(nc, v_name, start, count, name), "write station names to");
        size_t idx = (size_t)s;
        NCS(nc_put_var1_double(nc, v_lon, &idx, &p->stations[s].lon), "write station lon to");
        NCS(nc_put_var1_double(nc, v_lat, &idx, &p->stations[s].lat), "write station lat to");
    }
    return prod_loads_open(p, err);
}

/* the series kept for the plots: conc, thick, hbar, speed per (station, time) */
#define ST_PLOT_NVARS 4

static int keep_series(prod_writer *p, size_t ti, double t, int s, const double *v)
{
    size_t ns = (size_t)p->opts.nstations;
    if (ti >= p->st_cap) {
        size_t nc = p->st_cap ? 2 * p->st_cap : 32;
        double *a = realloc(p->st_series, ns * nc * ST_PLOT_NVARS * sizeof *a);
        if (!a)
            return -1;
        /* re-pack rows from stride st_cap to stride nc, last station first */
        for (size_t q = ns; q-- > 0;)
            memmove(a + q * nc * ST_PLOT_NVARS, a + q * p->st_cap * ST_PLOT_NVARS,
                    p->st_cap * ST_PLOT_NVARS * sizeof *a);
        p->st_series = a;
        double *b = realloc(p->st_times, nc * sizeof *b);
        if (!b)
            return -1;
        p->st_times = b;
        p->st_cap = nc;
    }
    p->st_times[ti] = t;
    double *row = p->st_series + ((size_t)s * p->st_cap + ti) * ST_PLOT_NVARS;
    row[0] = v[ST_CONC];
    row[1] = v[ST_THICK];
    row[2] = v[ST_HBAR];
    row[3] = v[ST_SPEED];
    return 0;
}

static int write_plots(prod_writer *p, sph_error *err)
{
    size_t nt = p->ntimes, ns = (size_t)p->opts.nstations;
    double *buf = malloc(4 * (nt ? nt : 1) * sizeof *buf);
    if (!buf)
        return sph_err_set(err, SPH_ERR_NOMEM, "station plots: out of memory");
    int rc = SPH_OK;
    for (size_t s = 0; s < ns && rc == SPH_OK; s++) {
        if (p->nproducts >= PROD_MAX_PRODUCTS - 4) {
            log_warn("products: too many files, plot of station %s skipped", p->stations[s].name);
            continue;
        }
        for (size_t t = 0; t < nt; t++)
            for (int k = 0; k < ST_PLOT_NVARS; k++)
                buf[k * nt + t] = p->st_series[(s * p->st_cap + t) * ST_PLOT_NVARS + k];
        char safe[NAME_LEN], name[PROD_NAME_LEN], path[PROD_PATH];
        size_t q = 0;
        for (const char *c = p->stations[s].name; *c && q + 1 < sizeof safe; c++, q++) {
            int ok = (*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') || (*c >= '0' && *c <= '9') ||
                     *c == '-' || *c == '_';
            safe[q] = ok ? *c : '_';
        }
        safe[q] = 0;
        snprintf(name, sizeof name, "%s_station_%s.png", p->prefix, safe);
        snprintf(path, sizeof path, "%s/%s", p->stage, name);
        stationplot_series ser = { p->stations[s].name, p->stations[s].lon, p->stations[s].lat, nt, p->st_times,
                                   buf, buf + nt, buf + 2 * nt, buf + 3 * nt, p->cycle_time, 0, 0 };
        if ((rc = stationplot_write_png(path, &ser, err)) == SPH_OK)
            prod_add_product(p, name);
    }
    free(buf);
    return rc;
}

/* A CSV row's start: the name quoted (embedded quotes doubled), lon, lat,
 * the valid time; the values follow, empty = missing. */
void prod_csv_station(FILE *f, const prod_station *st, const char *iso)
{
    fputc('"', f);
    for (const char *c = st->name; *c; c++) {
        if (*c == '"')
            fputc('"', f);
        fputc(*c, f);
    }
    fprintf(f, "\",%.6f,%.6f,%s", st->lon, st->lat, iso);
}

static void csv_num(FILE *f, double v, int decimals)
{
    fputc(',', f);
    if (!isnan(v))
        fprintf(f, "%.*f", decimals, v);
}

int prod_stations_add(prod_writer *p, double t, sph_error *err)
{
    int ns = p->opts.nstations;
    if (ns <= 0)
        return SPH_OK;
    size_t ti = p->ntimes - 1; /* the record just written by products_add_time */
    NCS(nc_put_var1_double(p->st_ncid, p->st_v_time, &ti, &t), "write time to");
    char iso[32];
    time_format_iso(t, iso, sizeof iso);
    for (int s = 0; s < ns; s++) {
        const prod_station *st = &p->stations[s];
        double v[ST_NVARS];
        v[ST_CONC] = sample(p, p->masked[PF_VAR_CONC], st->lon, st->lat);
        v[ST_THICK] = sample(p, p->masked[PF_VAR_THICK], st->lon, st->lat);
        v[ST_HBAR] = sample(p, p->masked[PF_VAR_HBAR], st->lon, st->lat);
        v[ST_U] = sample(p, p->masked[PF_VAR_U], st->lon, st->lat);
        v[ST_V] = sample(p, p->masked[PF_VAR_V], st->lon, st->lat);
        v[ST_PRES] = sample(p, p->masked[PF_VAR_PRES], st->lon, st->lat);
        v[ST_SPEED] = hypot(v[ST_U], v[ST_V]);
        v[ST_DIR] = products_drift_direction_deg(v[ST_U], v[ST_V]);
        if (keep_series(p, ti, t, s, v))
            return sph_err_set(err, SPH_ERR_NOMEM, "stations: out of memory");
        int lrc = prod_loads_add(p, ti, t, s, v[ST_CONC], v[ST_THICK], v[ST_SPEED], err);
        if (lrc != SPH_OK)
            return lrc;
        for (int k = 0; k < ST_NVARS; k++) {
            float x = isnan(v[k]) ? PROD_FILL_FLOAT : (float)v[k];
            size_t idx[2] = { (size_t)s, ti };
            NCS(nc_put_var1_float(p->st_ncid, p->st_v[k], idx, &x), "write station data to");
        }
        prod_csv_station(p->csv, st, iso);
        csv_num(p->csv, v[ST_CONC], 4);
        csv_num(p->csv, v[ST_THICK], 4);
        csv_num(p->csv, v[ST_HBAR], 4);
        csv_num(p->csv, v[ST_SPEED], 4);
        csv_num(p->csv, v[ST_DIR], 1);
        csv_num(p->csv, v[ST_U], 4);
        csv_num(p->csv, v[ST_V], 4);
        csv_num(p->csv, v[ST_PRES], 1);
        fputc('\n', p->csv);
    }
    if (ferror(p->csv))
        return sph_err_set(err, SPH_ERR_IO, "write %s: %s", p->st_csv.tmp, strerror(errno));
    return SPH_OK;
}

int prod_stations_close(prod_writer *p, sph_error *err)
{
    if (p->opts.nstations <= 0)
        return SPH_OK;
    prod_series q = { &p->st_nc, &p->st_csv, &p->csv, &p->st_ncid, &p->st_v_time, 0, 0, 0, 0, 0 };
    int rc = prod_series_close(p, &q, err);
    if (rc == SPH_OK)
        rc = prod_loads_close(p, err);
    if (rc == SPH_OK && p->ntimes > 0)
        rc = write_plots(p, err);
    return rc;
}

void prod_series_abort(prod_series *q)
{
    (void)ncfile_close(q->ncid);
    if (*q->f)
        fclose(*q->f);
    *q->f = NULL;
    prod_file_discard(q->nc);
    prod_file_discard(q->csv);
}

void prod_stations_abort(prod_writer *p)
{
    prod_series q = { &p->st_nc, &p->st_csv, &p->csv, &p->st_ncid, &p->st_v_time, 0, 0, 0, 0, 0 };
    prod_series_abort(&q);
    prod_loads_abort(p);
}
