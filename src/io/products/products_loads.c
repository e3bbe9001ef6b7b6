/* Ice loads at the stations with a structure (issue 25 item 3, the cheap
 * model only): <prefix>_loads.nc (CF timeSeries, data(station, time)) and
 * <prefix>_loads.csv. The thickness, concentration and drift speed are the
 * station product's own samples (prod_stations_add passes them). The load
 * is ISO 19906's global crushing load F = p_G w h (dem_iso_force) where the
 * concentration reaches the edge threshold and the thickness is positive,
 * 0 elsewhere (no proportional scaling by concentration: ice present is
 * taken as level ice against the leg); fill where w/h <= 2 (outside the
 * formula's validity). On a cone (stations[].structure.kind "cone") the
 * cheap load is Ralston's horizontal bending-failure load
 * (dem_ralston_cone, ride-up thickness = the ice thickness), fill with the
 * method's refusal as the reason outside its range. dem_scene_choose says which model the scene needs
 * and why; the DEM is not run from here: where it is needed the model is
 * "dem_needed" and the load is still the cheap one. Written only when a
 * station has a structure. */
#include "products_impl.h"

#include <errno.h>
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/dem.h"
#include "util/fileio.h"
#include "util/timeutil.h"

/* the scene's DEM thresholds besides the concentration (the edge threshold) */
#define LOAD_MIN_SPEED 0.05    /* m s-1 */
#define LOAD_MIN_THICKNESS 0.1 /* m */
#define LOAD_ICE_DENSITY 900.0 /* kg m-3, the ice riding up a cone (Ralston's W) */

#define LOADS_CSV_HEADER                                                                                   \
    "station,lon,lat,valid_time,siconc,sithick_m,drift_speed_m_s,structure_diameter_m,c_r_MPa,ice_load_kN,"  \
    "model,reason\n"

enum { LD_CONC, LD_THICK, LD_SPEED, LD_LOAD, LD_MODEL, LD_REASON };

#define NCL(call, what) PROD_NC_TRY(call, what, p->ld_nc.tmp)

static int structure_index(const prod_writer *p, int s)
{
    int k = 0;
    for (int q = 0; q < s; q++)
        k += p->ld_st[q].w > 0;
    return p->ld_st[s].w > 0 ? k : -1;
}

static int def_var(prod_writer *p, int nc, const int *dd, int k, nc_type type, const char *name,
                   const char *std, const char *lname, const char *units, sph_error *err)
{
    NCL(nc_def_var(nc, name, type, 2, dd, &p->ld_v[k]), "define variable in");
    int v = p->ld_v[k];
    if (type == NC_DOUBLE) {
        double fill = PROD_FILL_FLOAT;
        NCL(nc_put_att_double(nc, v, "_FillValue", NC_DOUBLE, 1, &fill), "write attribute in");
    }
    if (std)
        NCL(prod_put_text(nc, v, "standard_name", std), "write attribute in");
    NCL(prod_put_text(nc, v, "long_name", lname), "write attribute in");
    if (units)
        NCL(prod_put_text(nc, v, "units", units), "write attribute in");
    NCL(prod_put_text(nc, v, "coordinates", "time lat lon station_name"), "write attribute in");
    return SPH_OK;
}

int prod_loads_open(prod_writer *p, sph_error *err)
{
    int ns = 0;
    for (int s = 0; p->opts.structures && s < p->opts.nstations; s++)
        ns += p->opts.structures[s].w > 0;
    if (ns == 0)
        return SPH_OK;
    p->ld_st = malloc(sizeof *p->ld_st * (size_t)p->opts.nstations);
    if (!p->ld_st)
        return sph_err_set(err, SPH_ERR_NOMEM, "loads: out of memory");
    memcpy(p->ld_st, p->opts.structures, sizeof *p->ld_st * (size_t)p->opts.nstations);
    p->ld_on = 1;
    p->ld_ncid = -1;
    prod_series q = { &p->ld_nc, &p->ld_csv, &p->ld_f, &p->ld_ncid, &p->ld_v_time, 0, 0, 0, 0, 0 };
    int rc = prod_series_create(p, &q, "loads", LOADS_CSV_HEADER, ns, err);
    if (rc != SPH_OK)
        return rc;
    int nc = p->ld_ncid, d_st = q.d_st, d_t = q.d_t, v_name = q.v_name, v_lon = q.v_lon, v_lat = q.v_lat, v_w,
        v_cr, v_ca;
    NCL(nc_def_var(nc, "structure_diameter", NC_DOUBLE, 1, &d_st, &v_w), "define variable in");
    NCL(prod_put_text(nc, v_w, "long_name", "structure's waterline diameter (vertical leg w, cone D)"), "write attribute in");
    NCL(prod_put_text(nc, v_w, "units", "m"), "write attribute in");
    NCL(nc_def_var(nc, "c_r", NC_DOUBLE, 1, &d_st, &v_cr), "define variable in");
    NCL(prod_put_text(nc, v_cr, "long_name", "ISO 19906 ice strength coefficient C_R"), "write attribute in");
    NCL(prod_put_text(nc, v_cr, "units", "Pa"), "write attribute in");
    NCL(nc_def_var(nc, "structure_cone_angle", NC_DOUBLE, 1, &d_st, &v_ca), "define variable in");
    NCL(prod_put_text(nc, v_ca, "long_name", "cone angle from the horizontal (fill: a vertical structure)"),
        "write attribute in");
    NCL(prod_put_text(nc, v_ca, "units", "degree"), "write attribute in");
    double ca_fill = PROD_FILL_FLOAT;
    NCL(nc_put_att_double(nc, v_ca, "_FillValue", NC_DOUBLE, 1, &ca_fill), "write attribute in");
    int dd[2] = { d_st, d_t };
    if ((rc = def_var(p, nc, dd, LD_CONC, NC_DOUBLE, "siconc", "sea_ice_area_fraction", "sea ice area fraction",
                      "1", err)) ||
        (rc = def_var(p, nc, dd, LD_THICK, NC_DOUBLE, "sithick", "sea_ice_thickness",
                      "sea ice thickness (of the ice-covered part)", "m", err)) ||
        (rc = def_var(p, nc, dd, LD_SPEED, NC_DOUBLE, "sispeed", "sea_ice_speed", "sea ice drift speed",
                      "m s-1", err)) ||
        (rc = def_var(p, nc, dd, LD_LOAD, NC_DOUBLE, "ice_load", NULL,
                      "ISO 19906 global ice crushing load on the vertical structure, F = p_G w h; on a cone "
                      "Ralston's horizontal bending-failure load (0 below the concentration threshold)", "N", err)) ||
        (rc = def_var(p, nc, dd, LD_MODEL, NC_STRING, "load_model", NULL,
                      "load model the scene needs: cheap, dem_needed (the DEM is not run: ice_load is the "
                      "cheap model's), none (no sample)", NULL, err)) ||
        (rc = def_var(p, nc, dd, LD_REASON, NC_STRING, "load_model_reason", NULL, "why that model", NULL, err)))
        return rc;
    NCL(prod_put_text(nc, NC_GLOBAL, "Conventions", "CF-1.8"), "write attribute in");
    NCL(prod_put_text(nc, NC_GLOBAL, "featureType", "timeSeries"), "write attribute in");
    NCL(prod_put_text(nc, NC_GLOBAL, "title", "sphice ice loads at stations with a structure"), "write attribute in");
    NCL(prod_put_text(nc, NC_GLOBAL, "sphice_model_version", p->version), "write attribute in");
    double thr[3] = { p->opts.edge_threshold, LOAD_MIN_SPEED, LOAD_MIN_THICKNESS };
    NCL(nc_put_att_double(nc, NC_GLOBAL, "sphice_dem_thresholds_conc_speed_thickness", NC_DOUBLE, 3, thr),
        "write attribute in");
    NCL(nc_enddef(nc), "end definitions in");
    for (int s = 0; s < p->opts.nstations; s++) {
        int k = structure_index(p, s);
        if (k < 0)
            continue;
        const prod_station *sp = &p->stations[s];
        char name[64] = { 0 };
        snprintf(name, sizeof name, "%s", sp->name);
        size_t start[2] = { (size_t)k, 0 }, count[2] = { 1, 64 }, idx = (size_t)k;
        NCL(nc_put_vara_text(nc, v_name, start, count, name), "write station names to");
        NCL(nc_put_var1_double(nc, v_lon, &idx, &sp->lon), "write station lon to");
        NCL(nc_put_var1_double(nc, v_lat, &idx, &sp->lat), "write station lat to");
        NCL(nc_put_var1_double(nc, v_w, &idx, &p->ld_st[s].w), "write structure to");
        NCL(nc_put_var1_double(nc, v_cr, &idx, &p->ld_st[s].c_r), "write structure to");
        double ca = p->ld_st[s].cone_angle > 0 ? p->ld_st[s].cone_angle : PROD_FILL_FLOAT;
        NCL(nc_put_var1_double(nc, v_ca, &idx, &ca), "write structure to");
    }
    return SPH_OK;
}

int prod_loads_add(prod_writer *p, size_t ti, double t, int s, double conc, double thick, double speed,
                   sph_error *err)
{
    int k = p->ld_on ? structure_index(p, s) : -1;
    if (k < 0)
        return SPH_OK;
    const prod_station *st = &p->stations[s];
    const prod_structure *ps = &p->ld_st[s];
    if (k == 0)
        NCL(nc_put_var1_double(p->ld_ncid, p->ld_v_time, &ti, &t), "write time to");
    dem_scene_keys keys = { p->opts.edge_threshold, LOAD_MIN_SPEED, LOAD_MIN_THICKNESS, DEM_CHOOSE_AUTO };
    const char *why = "";
    int m = dem_scene_choose(&keys, conc, speed, thick, &why);
    const char *model = m == DEM_MODEL_DEM ? "dem_needed" : m == DEM_MODEL_CHEAP ? "cheap" : "none";
    double load = NAN;
    if (!isnan(conc) && !isnan(thick)) {
        if (conc < keys.min_concentration || !(thick > 0))
            load = 0.0;
        else if (ps->cone_angle > 0) { /* a cone: Ralston's bending-failure load, h_r = h */
            dem_cone_ice ci = { ps->sigma_f, thick, thick, LOAD_ICE_DENSITY, ps->mu, ps->cone_angle, ps->w, ps->neck };
            dem_cone_load cl;
            const char *rwhy = "";
            load = dem_ralston_cone(&ci, &cl, &rwhy) == 0 ? cl.h : NAN;
            if (isnan(load))
                why = rwhy;
        } else {
            load = dem_iso_force(ps->c_r, thick, ps->w);
            if (isnan(load))
                why = "outside ISO 19906's validity (w/h <= 2): no load";
        }
    }
    double v[4] = { conc, thick, speed, load };
    size_t idx[2] = { (size_t)k, ti };
    for (int q = 0; q < 4; q++) {
        double x = isnan(v[q]) ? PROD_FILL_FLOAT : v[q];
        NCL(nc_put_var1_double(p->ld_ncid, p->ld_v[q], idx, &x), "write load data to");
    }
    NCL(nc_put_var1_string(p->ld_ncid, p->ld_v[LD_MODEL], idx, &model), "write load data to");
    NCL(nc_put_var1_string(p->ld_ncid, p->ld_v[LD_REASON], idx, &why), "write load data to");
    char iso[32];
    time_format_iso(t, iso, sizeof iso);
    prod_csv_station(p->ld_f, st, iso);
    double cv[6] = { conc, thick, speed, ps->w, ps->c_r * 1e-6, load * 1e-3 };
    for (int q = 0; q < 6; q++) {
        fputc(',', p->ld_f);
        if (!isnan(cv[q]))
            fprintf(p->ld_f, "%.*f", q == 5 ? 3 : 4, cv[q]);
    }
    fprintf(p->ld_f, ",%s,\"%s\"\n", model, why);
    if (ferror(p->ld_f))
        return sph_err_set(err, SPH_ERR_IO, "write %s: %s", p->ld_csv.tmp, strerror(errno));
    return SPH_OK;
}

int prod_loads_close(prod_writer *p, sph_error *err)
{
    if (!p->ld_on)
        return SPH_OK;
    prod_series q = { &p->ld_nc, &p->ld_csv, &p->ld_f, &p->ld_ncid, &p->ld_v_time, 0, 0, 0, 0, 0 };
    int rc = prod_series_close(p, &q, err);
    if (rc == SPH_OK) {
        p->ld_on = 0;
        free(p->ld_st);
        p->ld_st = NULL;
    }
    return rc;
}

void prod_loads_abort(prod_writer *p)
{
    free(p->ld_st);
    p->ld_st = NULL;
    if (!p->ld_on)
        return;
    p->ld_on = 0;
    prod_series q = { &p->ld_nc, &p->ld_csv, &p->ld_f, &p->ld_ncid, &p->ld_v_time, 0, 0, 0, 0, 0 };
    prod_series_abort(&q);
}
