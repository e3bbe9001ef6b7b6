/* Private to src/io/products*.c: the writer's state. */
#ifndef SPHICE_IO_PRODUCTS_IMPL_H
#define SPHICE_IO_PRODUCTS_IMPL_H

#include <stdio.h>
#include "io/ncfile.h"
#include "io/products.h"

#define PROD_PATH 4096
#define PROD_STAGE_LEN 3584 /* leaves room for "/<name>" in PROD_PATH */

/* One output file under construction: final and temporary names. */
typedef struct prod_file {
    char name[PROD_NAME_LEN];  /* relative to the stage directory */
    char path[PROD_PATH];      /* final path */
    char tmp[PROD_PATH];       /* temporary path, "" once committed or unused */
} prod_file;

enum { PF_VAR_CONC, PF_VAR_HBAR, PF_VAR_THICK, PF_VAR_U, PF_VAR_V, PF_VAR_PRES, PF_VAR_DIV,
       PF_VAR_SHEAR, PF_VAR_SNOW, PF_NVARS };

typedef struct id_slot { long id; long index; } id_slot;

struct prod_writer {
    prod_grid grid;
    prod_options opts;
    char prefix[128];
    char ref_name[128];
    prod_station *stations;
    char stage[PROD_STAGE_LEN];
    /* provenance copies */
    char *title, *summary, *institution, *region, *version, *gitrev, *config_sha, *forcing,
        *start_mode;
    double cycle_time;
    int stale;
    prod_run_info run;
    int has_run;
    prod_init_info init;       /* init.flag points at init_flag */
    char init_flag[256];
    int has_init;

    /* gridded fields file */
    prod_file fields;
    int nc;
    int v_time, v_period, v_data[PF_NVARS], v_area, v_extent, v_volume, v_elen, v_edist;
    int v_node_count, v_part_count, v_ex, v_ey;
    size_t ntimes, edge_nodes, edge_parts;
    double t_first, t_last;
    double *masked[PF_NVARS];  /* last time's masked fields (NaN = fill) */
    float *fbuf;
    double *area_row;          /* cell area per row, m^2 */
    unsigned char *land;       /* last land mask (or NULL) */

    /* stations */
    prod_file st_nc, st_csv;
    int st_ncid;
    int st_v_time, st_v[8];
    FILE *csv;
    /* ice loads at stations with a structure (products_loads.c) */
    prod_file ld_nc, ld_csv;
    int ld_on, ld_ncid, ld_v_time, ld_v[24];
    prod_structure *ld_st;     /* copy of opts.structures */
    FILE *ld_f;
    /* the DEM's cache, cost and the latest loads (products_loads_dem.c;
     * ld_sum outlives prod_loads_close: the summary and the last map) */
    struct prod_dem_cache *ld_cache;
    size_t ld_ncache, ld_capcache;
    prod_loads_summary ld_sum;
    int ld_sum_station[PROD_MAX_LOAD_STATIONS]; /* station index of ld_sum.st[k] */

    /* particles */
    prod_file pt;
    int pt_nc;
    int pt_v_tid, pt_v_tindex, pt_v[9];
    size_t pt_nobs, pt_ntraj;
    id_slot *ids;              /* trajectory of an id outside [0, dense_n): open hash */
    size_t ids_cap, ids_used;
    int *dense;                /* trajectory of id in [0, dense_n), -1: none (ids are dense) */
    size_t dense_n;

    /* edge history for GeoJSON */
    edge_set *edges;
    double *edge_time, *edge_len, *edge_dist;
    size_t nedges, edges_cap;

    /* verification */
    double *persistence, *obs;
    double obs_time;
    int has_obs, has_scores;
    verify_scores scores;

    /* quick-looks */
    int last_quicklook_index;
    /* GIS products at the map times (io/gis.h) */
    struct gis_store *gis;
    double spacing_km;          /* mean particle spacing, sqrt(extent / N) */
    /* station series for the plots (products_stations.c) */
    double *st_series;          /* [station][time][ST_PLOT_NVARS] */
    double *st_times;
    size_t st_cap;

    /* results */
    double area_km2, extent_km2, volume_km3;
    int nproducts;
    char products[PROD_MAX_PRODUCTS][PROD_NAME_LEN];
    int failed;
};

/* products.c */
void prod_add_product(prod_writer *p, const char *name); /* lists a file for the manifest */
int prod_file_init(prod_writer *p, prod_file *f, const char *suffix, sph_error *err);
int prod_file_commit(prod_writer *p, prod_file *f, sph_error *err);
void prod_file_discard(prod_file *f);
int prod_nc_check(int status, const char *what, const char *path, sph_error *err);
int prod_put_text(int ncid, int varid, const char *name, const char *text);
struct cJSON;
/* Writes doc (freed here) as indented JSON to path, atomically. */
int prod_write_json(const char *path, struct cJSON *doc, sph_error *err);
/* Defines a CF longitude (axis 'X') or latitude (axis 'Y') coordinate,
 * doubles over dims: standard_name, long_name, units, axis. */
int prod_def_lonlat(int ncid, const char *name, int ndims, const int *dims, char axis,
                    const char *long_name, int *varid);
/* Defines forecast_period(time) in hours (CF standard name forecast_period). */
int prod_def_forecast_period(int ncid, int dim_t, int *varid);
/* Defines the 1-D lat/lon axes with CF 7.1 bounds attributes and their
 * lat_bnds/lon_bnds over d_bnds (size 2); netCDF status. */
int prod_def_lonlat_axes(int ncid, int d_lat, int d_lon, int d_bnds, int *v_lat, int *v_lon, int *v_latb,
                         int *v_lonb);
/* Writes lat_bnds/lon_bnds of g: each centre -+ half a grid step; netCDF status. */
int prod_put_lonlat_bnds(int ncid, const prod_grid *g, int v_latb, int v_lonb);

/* products_stations.c */
int prod_stations_open(prod_writer *p, sph_error *err);
int prod_stations_add(prod_writer *p, double t, sph_error *err);
int prod_stations_close(prod_writer *p, sph_error *err);
void prod_stations_abort(prod_writer *p);

/* products_gis.c: at each map time the class polygons and edge are kept
 * and the fields written as a COG; at close the GeoJSON and GeoPackage */
int prod_gis_add(prod_writer *p, double t, const char *stamp, const edge_set *e, sph_error *err);
int prod_gis_close(prod_writer *p, sph_error *err);

/* products_particles.c */
int prod_particles_open(prod_writer *p, sph_error *err);
int prod_particles_add(prod_writer *p, double t, const prod_particles_view *v, sph_error *err);
int prod_particles_close(prod_writer *p, sph_error *err);
void prod_particles_abort(prod_writer *p);

/* products_stations.c: a CF timeSeries file and its CSV, opened */
typedef struct prod_series {
    prod_file *nc, *csv;
    FILE **f;
    int *ncid, *v_time;
    int d_st, d_t, v_name, v_lon, v_lat; /* out */
} prod_series;
int prod_series_create(prod_writer *p, prod_series *q, const char *base, const char *header, int ns,
                       sph_error *err);
int prod_series_close(prod_writer *p, prod_series *q, sph_error *err);
void prod_series_abort(prod_series *q);
void prod_csv_station(FILE *f, const prod_station *st, const char *iso);
/* a NetCDF call's failure as the products' error, naming the file */
#define PROD_NC_TRY(call, what, file)                                    \
    do {                                                                  \
        int st_ = (call);                                                 \
        if (st_ != NC_NOERR)                                              \
            return prod_nc_check(st_, what, file, err);                   \
    } while (0)

/* products_loads.c: the ice-load product, fed by the station sampling */
int prod_loads_open(prod_writer *p, sph_error *err);
int prod_loads_add(prod_writer *p, size_t ti, double t, int s, double conc, double thick, double speed,
                   sph_error *err);
int prod_loads_close(prod_writer *p, sph_error *err);
void prod_loads_abort(prod_writer *p);

/* products_loads_dem.c: the DEM result for station s's structure at
 * thickness h and speed u, from the cycle's cache (*cached = 1) or a new
 * run; the cost goes into p->ld_sum. */
int prod_loads_dem(prod_writer *p, int s, double h, double u, prod_dem_result *r, int *cached, sph_error *err);
void prod_loads_dem_free(prod_writer *p);
/* 1 when station s's latest load exceeds opts.loads.map_threshold (the maps' mark) */
int prod_loads_alert(const prod_writer *p, int s);

#endif
