/* Ice loads at the stations with a structure (issue 25 items 3 and 4):
 * <prefix>_loads.nc (CF timeSeries, data(station, time)) and
 * <prefix>_loads.csv. The thickness, concentration and drift speed are the
 * station product's own samples (prod_stations_add passes them). The cheap
 * load is ISO 19906's global crushing load F = p_G w h (dem_iso_force)
 * where the concentration reaches the edge threshold and the thickness is
 * positive, 0 elsewhere (no proportional scaling by concentration: ice
 * present is taken as level ice against the leg); fill where w/h <= 2
 * (outside the formula's validity). On a cone (stations[].structure.kind
 * "cone") the cheap load is Ralston's horizontal bending-failure load
 * (dem_ralston_cone, ride-up thickness = the ice thickness), fill with the
 * method's refusal as the reason outside its range. dem_scene_choose with
 * the loads.* keys says which model the scene needs and why; where it is
 * the DEM, the station DEM runs (products_loads_dem.c, cached within the
 * cycle; a vertical leg or the station's cone, docs/dem.md) and
 * its statistics are written beside the cheap load; station_load is the
 * load of the model that ran (the cheap ice_load, or the DEM's maximum).
 * Written only when a station has a structure. */
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

#define LOAD_ICE_DENSITY 900.0 /* kg m-3, the ice riding up a cone (Ralston's W) */

#define LOADS_CSV_HEADER                                                                                   \
    "station,lon,lat,valid_time,siconc,sithick_m,drift_speed_m_s,structure_diameter_m,c_r_MPa,ice_load_kN,"  \
    "station_load_kN,dem_load_mean_kN,dem_load_max_kN,dem_load_std_kN,dem_load_freq_Hz,dem_disp_max_mm,"      \
    "dem_disp_std_mm,dem_acc_max_m_s2,dem_acc_std_m_s2,dem_thickness_m,dem_speed_m_s,dem_cached,model,reason\n"

/* the doubles first (LD_NUM of them), then the cache flag and the strings */
enum { LD_CONC, LD_THICK, LD_SPEED, LD_LOAD, LD_STLOAD, LD_DMEAN, LD_DMAX, LD_DSTD, LD_DFREQ, LD_UMAX, LD_USTD,
       LD_AMAX, LD_ASTD, LD_DTHICK, LD_DSPEED, LD_NUM, LD_CACHED = LD_NUM, LD_MODEL, LD_REASON, LD_NVARS };

static const char *const model_key_names[] = { "auto", "cheap", "dem" };

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

static int def_structure(int nc, int d_st, const char *name, const char *lname, const char *units, int *v,
                         prod_writer *p, sph_error *err)
{
    NCL(nc_def_var(nc, name, NC_DOUBLE, 1, &d_st, v), "define variable in");
    NCL(prod_put_text(nc, *v, "long_name", lname), "write attribute in");
    NCL(prod_put_text(nc, *v, "units", units), "write attribute in");
    return SPH_OK;
}

int prod_loads_open(prod_writer *p, sph_error *err)
{
    int ns = 0;
    for (int s = 0; p->opts.structures && s < p->opts.nstations; s++)
        ns += p->opts.structures[s].w > 0;
    if (ns == 0)
        return SPH_OK;
    if (ns > PROD_MAX_LOAD_STATIONS)
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "loads: %d stations have a structure, at most %d may: set stations[].structure.kind "
                           "to \"none\" for the others", ns, PROD_MAX_LOAD_STATIONS);
    p->ld_st = malloc(sizeof *p->ld_st * (size_t)p->opts.nstations);
    if (!p->ld_st)
        return sph_err_set(err, SPH_ERR_NOMEM, "loads: out of memory");
    memcpy(p->ld_st, p->opts.structures, sizeof *p->ld_st * (size_t)p->opts.nstations);
    memset(&p->ld_sum, 0, sizeof p->ld_sum);
    p->ld_sum.on = 1;
    for (int s = 0; s < p->opts.nstations; s++) {
        int k = structure_index(p, s);
        if (k < 0)
            continue;
        prod_load_latest *l = &p->ld_sum.st[k];
        snprintf(l->name, sizeof l->name, "%s", p->stations[s].name);
        l->time = l->load = l->max_load = NAN;
        snprintf(l->model, sizeof l->model, "none");
        p->ld_sum_station[k] = s;
    }
    p->ld_sum.nstations = ns;
    p->ld_on = 1;
    p->ld_ncid = -1;
    prod_series q = { &p->ld_nc, &p->ld_csv, &p->ld_f, &p->ld_ncid, &p->ld_v_time, 0, 0, 0, 0, 0 };
    int rc = prod_series_create(p, &q, "loads", LOADS_CSV_HEADER, ns, err);
    if (rc != SPH_OK)
        return rc;
    int nc = p->ld_ncid, d_st = q.d_st, d_t = q.d_t, v_name = q.v_name, v_lon = q.v_lon, v_lat = q.v_lat;
    int vs[5], v_ca;
    if ((rc = def_structure(nc, d_st, "structure_diameter", "structure's waterline diameter (vertical leg w, cone D)",
                            "m", &vs[0], p, err)) ||
        (rc = def_structure(nc, d_st, "c_r", "ISO 19906 ice strength coefficient C_R", "Pa", &vs[1], p, err)) ||
        (rc = def_structure(nc, d_st, "structure_mass", "DEM structure's mass (0: fixed)", "kg", &vs[2], p, err)) ||
        (rc = def_structure(nc, d_st, "structure_stiffness", "DEM structure's horizontal stiffness", "N m-1",
                            &vs[3], p, err)) ||
        (rc = def_structure(nc, d_st, "structure_damping", "DEM structure's damping ratio", "1", &vs[4], p, err)))
        return rc;
    NCL(nc_def_var(nc, "structure_cone_angle", NC_DOUBLE, 1, &d_st, &v_ca), "define variable in");
    NCL(prod_put_text(nc, v_ca, "long_name", "cone angle from the horizontal (fill: a vertical structure)"),
        "write attribute in");
    NCL(prod_put_text(nc, v_ca, "units", "degree"), "write attribute in");
    double ca_fill = PROD_FILL_FLOAT;
    NCL(nc_put_att_double(nc, v_ca, "_FillValue", NC_DOUBLE, 1, &ca_fill), "write attribute in");
    int dd[2] = { d_st, d_t };
    static const struct { const char *name, *std, *lname, *units; } V[LD_NUM] = {
        { "siconc", "sea_ice_area_fraction", "sea ice area fraction", "1" },
        { "sithick", "sea_ice_thickness", "sea ice thickness (of the ice-covered part)", "m" },
        { "sispeed", "sea_ice_speed", "sea ice drift speed", "m s-1" },
        { "ice_load", NULL, "ISO 19906 global ice crushing load on the vertical structure, F = p_G w h; on a cone "
                            "Ralston's horizontal bending-failure load (0 below the concentration threshold)", "N" },
        { "station_load", NULL, "ice load of the model that ran: ice_load (cheap) or dem_load_max (dem)", "N" },
        { "dem_load_mean", NULL, "DEM ice load along the drift: mean over the run", "N" },
        { "dem_load_max", NULL, "DEM ice load along the drift: maximum over the run", "N" },
        { "dem_load_std", NULL, "DEM ice load along the drift: standard deviation over the run", "N" },
        { "dem_load_frequency", NULL, "DEM ice load: dominant frequency (1 kHz block means)", "Hz" },
        { "dem_displacement_max", NULL, "DEM structure displacement along the drift: maximum magnitude", "m" },
        { "dem_displacement_std", NULL, "DEM structure displacement along the drift: standard deviation", "m" },
        { "dem_acceleration_max", NULL, "DEM structure acceleration along the drift: maximum magnitude", "m s-2" },
        { "dem_acceleration_std", NULL, "DEM structure acceleration along the drift: standard deviation", "m s-2" },
        { "dem_thickness", NULL, "DEM sheet's thickness (sithick rounded to loads.dem_cache_thickness)", "m" },
        { "dem_speed", NULL, "DEM sheet's speed (sispeed rounded to loads.dem_cache_speed)", "m s-1" },
    };
    for (int k = 0; k < LD_NUM; k++)
        if ((rc = def_var(p, nc, dd, k, NC_DOUBLE, V[k].name, V[k].std, V[k].lname, V[k].units, err)))
            return rc;
    if ((rc = def_var(p, nc, dd, LD_CACHED, NC_BYTE, "dem_cached", NULL,
                      "1: the DEM result came from the cycle's cache of an equal (thickness, speed, structure) run; "
                      "0: run here; -1: no DEM", NULL, err)) ||
        (rc = def_var(p, nc, dd, LD_MODEL, NC_STRING, "load_model", NULL,
                      "load model that ran: cheap, dem, none (no sample or no ice for a forced DEM)", NULL, err)) ||
        (rc = def_var(p, nc, dd, LD_REASON, NC_STRING, "load_model_reason", NULL, "why that model", NULL, err)))
        return rc;
    NCL(prod_put_text(nc, NC_GLOBAL, "Conventions", "CF-1.8"), "write attribute in");
    NCL(prod_put_text(nc, NC_GLOBAL, "featureType", "timeSeries"), "write attribute in");
    NCL(prod_put_text(nc, NC_GLOBAL, "title", "sphice ice loads at stations with a structure"), "write attribute in");
    NCL(prod_put_text(nc, NC_GLOBAL, "sphice_model_version", p->version), "write attribute in");
    const prod_loads_options *lo = &p->opts.loads;
    double thr[3] = { p->opts.edge_threshold, lo->min_speed, lo->min_thickness };
    NCL(nc_put_att_double(nc, NC_GLOBAL, "sphice_dem_thresholds_conc_speed_thickness", NC_DOUBLE, 3, thr),
        "write attribute in");
    NCL(prod_put_text(nc, NC_GLOBAL, "sphice_loads_model", model_key_names[lo->model]), "write attribute in");
    double demk[8] = { lo->duration, lo->particle_diameter, lo->sheet_length, lo->sheet_width, lo->dt,
                      (double)lo->max_particles, lo->cache_thickness, lo->cache_speed };
    NCL(nc_put_att_double(nc, NC_GLOBAL,
                          "sphice_dem_duration_diameter_length_width_dt_max_particles_cache_thickness_cache_speed",
                          NC_DOUBLE, 8, demk),
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
        const prod_structure *ps = &p->ld_st[s];
        double sv[5] = { ps->w, ps->c_r, ps->mass, ps->stiffness, ps->damping };
        for (int j = 0; j < 5; j++)
            NCL(nc_put_var1_double(nc, vs[j], &idx, &sv[j]), "write structure to");
        double ca = ps->cone_angle > 0 ? ps->cone_angle : PROD_FILL_FLOAT;
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
    const prod_loads_options *lo = &p->opts.loads;
    if (k == 0)
        NCL(nc_put_var1_double(p->ld_ncid, p->ld_v_time, &ti, &t), "write time to");
    dem_scene_keys keys = { p->opts.edge_threshold, lo->min_speed, lo->min_thickness, lo->model };
    const char *why = "";
    int m = dem_scene_choose(&keys, conc, speed, thick, &why);
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
            if (isnan(load) && m == DEM_MODEL_CHEAP)
                why = "outside ISO 19906's validity (w/h <= 2): no load";
        }
    }
    double v[LD_NUM];
    for (int q = 0; q < LD_NUM; q++)
        v[q] = NAN;
    v[LD_CONC] = conc;
    v[LD_THICK] = thick;
    v[LD_SPEED] = speed;
    v[LD_LOAD] = load;
    signed char cached = -1;
    if (m == DEM_MODEL_DEM) {
        /* a forced DEM needs ice to push: none at the station, or a sheet
         * that rounds to nothing at the cache's resolution, runs nothing */
        double hr = lo->cache_thickness > 0 ? lo->cache_thickness * round(thick / lo->cache_thickness) : thick;
        if (!(conc >= keys.min_concentration) || !(hr > 0.0) || !(speed >= 0.0)) {
            m = -1;
            why = !(conc >= keys.min_concentration) || !(thick > 0.0) ? "no ice at the station for the forced DEM"
                  : !(speed >= 0.0) ? "no drift speed at the station for the forced DEM"
                                    : "the thickness rounds to 0 at loads.dem_cache_thickness: no DEM sheet";
        } else {
            prod_dem_result r;
            int c = 0, rc = prod_loads_dem(p, s, thick, speed, &r, &c, err);
            if (rc != SPH_OK)
                return rc;
            cached = (signed char)c;
            v[LD_DMEAN] = r.mean;
            v[LD_DMAX] = r.max;
            v[LD_DSTD] = r.std;
            v[LD_DFREQ] = r.freq;
            v[LD_UMAX] = r.disp_max;
            v[LD_USTD] = r.disp_std;
            v[LD_AMAX] = r.acc_max;
            v[LD_ASTD] = r.acc_std;
            v[LD_DTHICK] = r.thickness;
            v[LD_DSPEED] = r.speed;
            v[LD_STLOAD] = r.max;
            p->ld_sum.dem_rows++;
        }
    } else if (m == DEM_MODEL_CHEAP) {
        v[LD_STLOAD] = load;
        p->ld_sum.cheap_rows++;
    }
    const char *model = m == DEM_MODEL_DEM ? "dem" : m == DEM_MODEL_CHEAP ? "cheap" : "none";
    prod_load_latest *l = &p->ld_sum.st[k];
    l->time = t;
    l->load = v[LD_STLOAD];
    if (!isnan(v[LD_STLOAD]) && !(l->max_load >= v[LD_STLOAD]))
        l->max_load = v[LD_STLOAD];
    snprintf(l->model, sizeof l->model, "%s", model);
    size_t idx[2] = { (size_t)k, ti };
    for (int q = 0; q < LD_NUM; q++) {
        double x = isnan(v[q]) ? PROD_FILL_FLOAT : v[q];
        NCL(nc_put_var1_double(p->ld_ncid, p->ld_v[q], idx, &x), "write load data to");
    }
    NCL(nc_put_var1_schar(p->ld_ncid, p->ld_v[LD_CACHED], idx, &cached), "write load data to");
    NCL(nc_put_var1_string(p->ld_ncid, p->ld_v[LD_MODEL], idx, &model), "write load data to");
    NCL(nc_put_var1_string(p->ld_ncid, p->ld_v[LD_REASON], idx, &why), "write load data to");
    char iso[32];
    time_format_iso(t, iso, sizeof iso);
    prod_csv_station(p->ld_f, st, iso);
    /* kN, mm for the loads and displacements; %.17g where the DEM's numbers must survive */
    double cv[17] = { conc, thick, speed, ps->w, ps->c_r * 1e-6, load * 1e-3, v[LD_STLOAD] * 1e-3,
                      v[LD_DMEAN] * 1e-3, v[LD_DMAX] * 1e-3, v[LD_DSTD] * 1e-3, v[LD_DFREQ], v[LD_UMAX] * 1e3,
                      v[LD_USTD] * 1e3, v[LD_AMAX], v[LD_ASTD], v[LD_DTHICK], v[LD_DSPEED] };
    for (int q = 0; q < 17; q++) {
        fputc(',', p->ld_f);
        if (!isnan(cv[q]))
            fprintf(p->ld_f, "%.*f", q == 5 || q == 6 ? 3 : q >= 7 ? 6 : 4, cv[q]);
    }
    fprintf(p->ld_f, ",%d,%s,\"%s\"\n", cached, model, why);
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
        prod_loads_dem_free(p);
    }
    return rc;
}

void prod_loads_abort(prod_writer *p)
{
    free(p->ld_st);
    p->ld_st = NULL;
    prod_loads_dem_free(p);
    if (!p->ld_on)
        return;
    p->ld_on = 0;
    prod_series q = { &p->ld_nc, &p->ld_csv, &p->ld_f, &p->ld_ncid, &p->ld_v_time, 0, 0, 0, 0, 0 };
    prod_series_abort(&q);
}
