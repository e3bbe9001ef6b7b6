/* The forcing reader (io/forcing.h), format-free: sources, variable
 * discovery, unpacking and units, time axes over many files, the two-slot
 * slice cache, coverage checks and sampling at particle positions. Files
 * are read only through the driver table (forcing_impl.h); the NetCDF
 * driver is forcing_netcdf.c. Grids are in forcing_grid.c, harmonic tides
 * in forcing_tide.c. */
#include "forcing_impl.h"
#include "io/nc_guard.h"
#include "util/log.h"
#include "util/timeutil.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* What each slot is called and in which units sphice wants it. */
static const struct slot_def {
    const char *std[4];      /* earth-relative standard names, canonical first */
    const char *grid_std[3]; /* grid-relative standard names (rotated) */
    const char *target;      /* sphice units */
    int accumulable;         /* may come as J m-2 */
} slot_defs[FV_COUNT] = {
    [FV_UWIND] = {{"eastward_wind"}, {"x_wind"}, "m s-1", 0},
    [FV_VWIND] = {{"northward_wind"}, {"y_wind"}, "m s-1", 0},
    [FV_TAIR] = {{"air_temperature"}, {NULL}, "degC", 0},
    [FV_DEW] = {{"dew_point_temperature"}, {NULL}, "degC", 0},
    [FV_QAIR] = {{"specific_humidity"}, {NULL}, "1", 0},
    [FV_PSURF] = {{"surface_air_pressure", "air_pressure_at_mean_sea_level"}, {NULL}, "Pa", 0},
    [FV_SW] = {{"surface_downwelling_shortwave_flux_in_air"}, {NULL}, "W m-2", 1},
    [FV_LW] = {{"surface_downwelling_longwave_flux_in_air"}, {NULL}, "W m-2", 1},
    /* grid-relative: the CF names, met.no's and ROMS's spellings, and
     * ROMS's names at the u and v points of its C grid */
    [FV_UCUR] = {{"eastward_sea_water_velocity", "surface_eastward_sea_water_velocity"},
                 {"sea_water_x_velocity", "x_sea_water_velocity",
                  "sea_water_x_velocity_at_u_location"},
                 "m s-1", 0},
    [FV_VCUR] = {{"northward_sea_water_velocity", "surface_northward_sea_water_velocity"},
                 {"sea_water_y_velocity", "y_sea_water_velocity",
                  "sea_water_y_velocity_at_v_location"},
                 "m s-1", 0},
    [FV_SSH] = {{"sea_surface_height_above_geoid", "sea_surface_height",
                 "sea_surface_height_above_sea_level", "sea_surface_elevation"},
                {NULL}, "m", 0},
    [FV_SST] = {{"sea_surface_temperature"}, {NULL}, "degC", 0},
    [FV_FW] = {{"upward_sea_ice_basal_heat_flux"}, {NULL}, "W m-2", 1},
    [FV_RH] = {{"relative_humidity"}, {NULL}, "1", 0},
    /* water: a flux (kg m-2 s-1, or m s-1 of liquid water equivalent) or an
     * accumulated amount (kg m-2, or m of liquid water equivalent); see
     * water_units */
    [FV_SNOW] = {{"snowfall_flux", "snowfall_amount", "lwe_thickness_of_snowfall_amount",
                  "lwe_snowfall_rate"},
                 {NULL}, "kg m-2 s-1", 1},
    [FV_PRECIP] = {{"precipitation_flux", "precipitation_amount",
                    "lwe_thickness_of_precipitation_amount", "lwe_precipitation_rate"},
                   {NULL}, "kg m-2 s-1", 1},
    /* the ocean mixed layer (issue 20) */
    [FV_MLD] = {{"ocean_mixed_layer_thickness", "ocean_mixed_layer_thickness_defined_by_sigma_theta",
                 "ocean_mixed_layer_thickness_defined_by_sigma_t",
                 "ocean_mixed_layer_thickness_defined_by_temperature"},
                {NULL}, "m", 0},
    [FV_BATHY] = {{"sea_floor_depth_below_sea_surface", "sea_floor_depth_below_geoid",
                   "sea_floor_depth_below_mean_sea_level"},
                  {NULL}, "m", 0},
};

/* Physical bounds of each slot in sphice units (docs/forcing.md): a value
 * outside them that is not a declared missing value is bad input (an
 * undeclared fill such as 1e30, an Inf, wrong units), refused at reading. */
static const struct { double lo, hi; } slot_bounds[FV_COUNT] = {
    [FV_UWIND] = {-100.0, 100.0},        /* m/s: above any surface wind on record */
    [FV_VWIND] = {-100.0, 100.0},
    [FV_TAIR] = {-123.15, 76.85},        /* degC: 150 .. 350 K */
    [FV_DEW] = {-123.15, 76.85},
    [FV_QAIR] = {0.0, 0.1},              /* kg/kg: saturation at 50 degC is 0.09 */
    [FV_PSURF] = {10000.0, 120000.0},    /* Pa: above the highest summits, below any record */
    [FV_SW] = {-10.0, 1500.0},           /* W/m2: solar constant 1361; packing noise below 0 */
    [FV_LW] = {0.0, 1000.0},             /* W/m2: sigma (350 K)^4 = 851 */
    [FV_UCUR] = {-10.0, 10.0},           /* m/s: the fastest tidal races are about 7 m/s */
    [FV_VCUR] = {-10.0, 10.0},
    [FV_SSH] = {-100.0, 100.0},          /* m: geoid offsets and tides together */
    [FV_SST] = {-5.0, 45.0},             /* degC: sea water freezes at about -2 */
    [FV_FW] = {-2000.0, 2000.0},         /* W/m2 */
    [FV_RH] = {0.0, 1.5},                /* fraction: supersaturation stays far below 1.5 */
    /* kg m-2 s-1: 0.1 is 360 mm/h, above any record; packing noise of
     * accumulations may go slightly below 0 (the coupling takes max(0, .)) */
    [FV_SNOW] = {-1e-3, 0.1},
    [FV_PRECIP] = {-1e-3, 0.1},
    [FV_MLD] = {0.0, 12000.0},           /* m: a thickness is never negative; deeper than any sea */
    [FV_BATHY] = {-10000.0, 12000.0},    /* m: land heights (negative depth) to the deepest trench */
};

/* FVEC_STD_EARTH or FVEC_STD_GRID when standard name sn names slot w's
 * quantity, else -1. */
static int std_kind(const struct slot_def *d, const char *sn)
{
    for (int k = 0; k < 4 && d->std[k]; k++)
        if (strcmp(sn, d->std[k]) == 0)
            return FVEC_STD_EARTH;
    for (int k = 0; k < 3 && d->grid_std[k]; k++)
        if (strcmp(sn, d->grid_std[k]) == 0)
            return FVEC_STD_GRID;
    return -1;
}

/* Built-in names of known products, tried after the spec's map. */
static const forcing_name_map default_names[] = {
    {"eastward_wind", "u10"},       {"northward_wind", "v10"},
    {"air_temperature", "t2m"},     {"dew_point_temperature", "d2m"},
    {"surface_air_pressure", "sp"}, {"surface_downwelling_shortwave_flux_in_air", "ssrd"},
    {"surface_downwelling_longwave_flux_in_air", "strd"},
    {"eastward_sea_water_velocity", "uo"},  {"northward_sea_water_velocity", "vo"},
    {"sea_surface_height_above_geoid", "zos"},
    {"eastward_sea_water_velocity", "water_u"}, {"northward_sea_water_velocity", "water_v"},
    {"sea_surface_height_above_geoid", "surf_el"},
    {"relative_humidity", "hurs"},  {"relative_humidity", "rh2m"},
    /* GFS over NOMADS OPeNDAP (GrADS names, no standard_name) */
    {"eastward_wind", "ugrd10m"},   {"northward_wind", "vgrd10m"},
    {"air_temperature", "tmp2m"},   {"dew_point_temperature", "dpt2m"},
    {"surface_air_pressure", "pressfc"},
    {"surface_downwelling_shortwave_flux_in_air", "dswrfsfc"},
    {"surface_downwelling_longwave_flux_in_air", "dlwrfsfc"},
    /* GFS as wgrib2 -netcdf writes it (NAME_LEVEL, no standard_name) */
    {"eastward_wind", "UGRD_10maboveground"}, {"northward_wind", "VGRD_10maboveground"},
    {"air_temperature", "TMP_2maboveground"}, {"specific_humidity", "SPFH_2maboveground"},
    {"dew_point_temperature", "DPT_2maboveground"}, {"relative_humidity", "RH_2maboveground"},
    {"surface_air_pressure", "PRES_surface"},
    {"surface_downwelling_shortwave_flux_in_air", "DSWRF_surface"},
    {"surface_downwelling_longwave_flux_in_air", "DLWRF_surface"},
    /* ERA5 (CDS): sf and tp, metres of water equivalent, accumulated */
    {"snowfall_flux", "sf"},        {"precipitation_flux", "tp"},
    /* GFS: precipitation rate (kg m-2 s-1) over NOMADS OPeNDAP and as
     * wgrib2 -netcdf writes it; the accumulated APCP (kg m-2) after it */
    {"precipitation_flux", "pratesfc"}, {"precipitation_flux", "PRATE_surface"},
    {"precipitation_flux", "apcpsfc"},  {"precipitation_flux", "APCP_surface"},
};

const forcing_name_map *forcing_default_names(size_t *n)
{
    *n = sizeof default_names / sizeof default_names[0];
    return default_names;
}

int forcing_fail(sph_error *err, const fsource *s, const char *path, int code, const char *fmt,
                 ...)
{
    char msg[768];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return sph_err_set(err, code, "forcing '%s': %s: %s", s ? s->name : "?", path ? path : "-",
                       msg);
}

static void iso(double t, char *buf, size_t len)
{
    time_format_iso(t, buf, len);
}

/* ---- drivers and files ---- */

#define FORCING_DRIVER_ENTRY(n) &forcing_driver_##n,
static const forcing_driver *const drivers[] = {FORCING_DRIVERS(FORCING_DRIVER_ENTRY)};
#undef FORCING_DRIVER_ENTRY

/* The driver of the file at path: the first that claims it, else the
 * first of the table (whose open then says what is wrong). */
static const forcing_driver *driver_for(const char *path)
{
    for (size_t i = 0; i < sizeof drivers / sizeof drivers[0]; i++)
        if (drivers[i]->probe(path))
            return drivers[i];
    return drivers[0];
}

/* File `file` of the source, kept open until another one is needed. */
static int src_file(fsource *s, int file, void **fh, sph_error *err)
{
    if (s->open_file == file) {
        *fh = s->open_fh;
        return 0;
    }
    if (s->open_file >= 0)
        s->drv->close(s->open_fh);
    s->open_file = -1;
    s->open_fh = NULL;
    int rc = s->drv->open(s, file, fh, err);
    if (rc)
        return rc;
    s->open_file = file;
    s->open_fh = *fh;
    return 0;
}

/* ---- variables ---- */

static void fvar_free(fvar *v)
{
    if (!v)
        return;
    for (int k = 0; k < 2; k++) {
        free(v->slot[k]);
        free(v->slot_gx[k]);
        free(v->slot_gy[k]);
    }
    if (v->harm) {
        for (int k = 0; k < TIDE_NCONST; k++) {
            free(v->harm->c[k]);
            free(v->harm->s[k]);
        }
        free(v->harm);
    }
    free(v->vfiles);
    free(v->times);
    free(v);
}

/* Finds the variable of slot w among the nv variables of a file: by
 * standard_name first, then the spec's map, then the built-in product
 * names. *varid is an index into vars. */
static int find_var(const forcing_varinfo *vars, size_t nv, const forcing_source_spec *spec,
                    fv_slot w, int *varid, int *how, char *sn_out, size_t sn_len,
                    char *tried, size_t tried_len)
{
    const struct slot_def *d = &slot_defs[w];
    for (size_t i = 0; i < nv; i++) {
        const char *sn = vars[i].standard_name;
        int kind = sn[0] ? std_kind(d, sn) : -1;
        if (kind < 0)
            continue;
        *varid = (int)i;
        *how = kind;
        snprintf(sn_out, sn_len, "%s", sn);
        return 0;
    }
    size_t nd;
    const forcing_name_map *dn = forcing_default_names(&nd);
    size_t used = 0;
    tried[0] = '\0';
    for (int pass = 0; pass < 2; pass++) {
        const forcing_name_map *m = pass == 0 ? spec->map : dn;
        size_t nm = pass == 0 ? spec->nmap : nd;
        for (size_t i = 0; m && i < nm; i++) {
            int match = 0;
            for (int k = 0; k < 4 && d->std[k]; k++)
                match |= m[i].standard_name && strcmp(m[i].standard_name, d->std[k]) == 0;
            if (!match || !m[i].variable)
                continue;
            if (used < tried_len)
                used += (size_t)snprintf(tried + used, tried_len - used, "%s'%s'",
                                         used ? ", " : "", m[i].variable);
            *varid = -1;
            for (size_t j = 0; j < nv && *varid < 0; j++)
                if (strcmp(vars[j].name, m[i].variable) == 0)
                    *varid = (int)j;
            if (*varid >= 0) {
                const char *sn = vars[*varid].standard_name;
                int kind = sn[0] ? std_kind(d, sn) : -1;
                *how = kind >= 0 ? kind : FVEC_NAME;
                snprintf(sn_out, sn_len, "%s", d->std[0]);
                return 0;
            }
        }
        if (pass == 0 && spec->nmap && used)
            break; /* an explicit map replaces the built-in names */
    }
    return -1;
}

/* Snowfall and precipitation: the units' dimension says what the values
 * are. kg m-2 s-1: a flux; m s-1: a rate of liquid water equivalent
 * (times 1000 kg m-3); kg m-2: an accumulated amount; m: an accumulated
 * depth of liquid water equivalent (times 1000 kg m-3). ECMWF writes ERA5's
 * sf as "m of water equivalent": that suffix is read as liquid water
 * equivalent. Anything else is refused. */
static int water_units(fsource *s, fvar *v, const char *path, fvfile *vf, cf_units *units,
                       sph_error *err)
{
    static const char lwe_suffix[] = " of water equivalent";
    char u[sizeof vf->units];
    snprintf(u, sizeof u, "%s", vf->units);
    size_t ul = strlen(u), sl = sizeof lwe_suffix - 1;
    int lwe_named = ul > sl && strcmp(u + ul - sl, lwe_suffix) == 0;
    if (lwe_named)
        u[ul - sl] = '\0';
    static const struct { const char *to; double factor; int accumulated, lwe; } forms[] = {
        {"kg m-2 s-1", 1.0, 0, 0}, {"m s-1", 1000.0, 0, 1}, {"kg m-2", 1.0, 1, 0}, {"m", 1000.0, 1, 1}};
    int rc = -2;
    for (size_t i = 0; i < sizeof forms / sizeof forms[0]; i++) {
        if (lwe_named && !forms[i].lwe)
            continue;
        rc = cf_units_linear(units, u, forms[i].to, &vf->a, &vf->b);
        if (rc == -1)
            break;
        if (rc != 0)
            continue;
        vf->a *= forms[i].factor;
        vf->b *= forms[i].factor;
        if (v->nvfiles > 0 && forms[i].accumulated != v->accumulated)
            return forcing_fail(err, s, path, SPH_ERR_UNITS,
                                "variable '%s' is accumulated in some files and not in others",
                                v->varname);
        v->accumulated = forms[i].accumulated;
        return 0;
    }
    if (rc == -1)
        return forcing_fail(err, s, path, SPH_ERR_UNITS,
                            "unknown units '%s' of variable '%s' (%s): set forcing[].variables to "
                            "a variable in kg m-2 s-1, kg m-2 or metres of water equivalent",
                            vf->units, v->varname, v->standard_name);
    return forcing_fail(err, s, path, SPH_ERR_UNITS,
                        "units '%s' of variable '%s' (%s) are neither a flux (kg m-2 s-1, m s-1 of "
                        "water) nor an amount (kg m-2, m of water): set forcing[].variables to "
                        "another variable",
                        vf->units, v->varname, v->standard_name);
}

/* Packing, missing values and units of one variable in one file. */
static int read_var_atts(fsource *s, fvar *v, const char *path, void *fh, int varid, fvfile *vf,
                         cf_units *units, sph_error *err)
{
    const struct slot_def *d = &slot_defs[v->which];
    if (s->drv->packing(fh, varid, vf) != 0) {
        if (v->which != FV_QAIR)
            return forcing_fail(err, s, path, SPH_ERR_UNITS,
                                "variable '%s' (%s) has no units attribute", v->varname,
                                v->standard_name);
        snprintf(vf->units, sizeof vf->units, "1");
    }
    int rc, accumulated = 0;
    if (v->which == FV_SNOW || v->which == FV_PRECIP)
        return water_units(s, v, path, vf, units, err);
    rc = cf_units_linear(units, vf->units, d->target, &vf->a, &vf->b);
    if (rc == -2 && d->accumulable &&
        cf_units_linear(units, vf->units, "J m-2", &vf->a, &vf->b) == 0) {
        rc = 0;
        accumulated = 1;
    }
    if (rc == -1)
        return forcing_fail(err, s, path, SPH_ERR_UNITS, "unknown units '%s' of variable '%s' (%s)",
                            vf->units, v->varname, v->standard_name);
    if (rc != 0)
        return forcing_fail(err, s, path, SPH_ERR_UNITS,
                            "units '%s' of variable '%s' (%s) cannot be converted to '%s'%s",
                            vf->units, v->varname, v->standard_name, d->target,
                            d->accumulable ? " or 'J m-2'" : "");
    if (v->nvfiles > 0 && accumulated != v->accumulated)
        return forcing_fail(err, s, path, SPH_ERR_UNITS,
                            "variable '%s' is accumulated in some files and not in others",
                            v->varname);
    v->accumulated = accumulated;
    return 0;
}

/* Appends the times of variable v in this file to v->times. */
static int read_times(fsource *s, fvar *v, const char *path, void *fh, int varid,
                      const fvfile *vf, int vfi, sph_error *err)
{
    if (vf->tdim < 0) {
        if (v->nvfiles > 1)
            return 0; /* a static field: the first file is enough */
        return 0;
    }
    forcing_timeinfo ti;
    int rc = s->drv->times(s, path, fh, varid, vf, &ti, NULL, err);
    if (rc)
        return rc;
    const char *tname = ti.name, *units = ti.units, *calname = ti.calendar;
    size_t nt = ti.n;
    cf_calendar cal;
    if (cf_calendar_parse(calname, &cal) != 0)
        return forcing_fail(err, s, path, SPH_ERR_UNITS, "unknown calendar '%s' of '%s'", calname,
                            tname);
    cf_time_units tu;
    if (cf_time_parse(units, cal, &tu) != 0)
        return forcing_fail(err, s, path, SPH_ERR_UNITS,
                            "time units '%s' of '%s' are not '<unit> since <date>'", units, tname);
    if (nt == 0)
        return 0;
    double *vals = malloc(nt * sizeof *vals);
    ftime *nts = realloc(v->times, (v->ntimes + nt) * sizeof *nts);
    if (nts)
        v->times = nts;
    if (!vals || !nts) {
        free(vals);
        return forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
    }
    rc = s->drv->times(s, path, fh, varid, vf, &ti, vals, err);
    if (rc) {
        free(vals);
        return rc;
    }
    size_t dropped = 0;
    for (size_t k = 0; k < nt; k++) {
        double t;
        if (!isfinite(vals[k])) {
            free(vals);
            return forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                                "time variable '%s' has a missing value at index %zu", tname, k);
        }
        if (cf_time_to_model(&tu, vals[k], &t) != 0) {
            dropped++;
            continue;
        }
        v->times[v->ntimes++] = (ftime){.t = t, .vf = vfi, .k = k, .period = 0};
    }
    if (dropped)
        log_warn("forcing '%s': %s: %zu times of '%s' have no real date in calendar '%s' and "
                 "are skipped",
                 s->name, path, dropped, tname, calname);
    free(vals);
    return 0;
}

static int cmp_time(const void *a, const void *b)
{
    const ftime *x = a, *y = b;
    if (x->t != y->t)
        return x->t < y->t ? -1 : 1;
    return x->vf - y->vf;
}

static const unsigned kind_defaults[] = {
    [FORCING_ATMOSPHERE] = FQ_WIND | FQ_TAIR | FQ_HUMIDITY | FQ_SWDN | FQ_LWDN | FQ_SNOWFALL | FQ_PRECIP,
    [FORCING_OCEAN] = FQ_CURRENT | FQ_SSH | FQ_SST | FQ_OCEAN_FLUX,
    [FORCING_TIDE] = FQ_CURRENT | FQ_SSH,
};

static unsigned slot_flag(fv_slot w)
{
    switch (w) {
    case FV_UWIND: case FV_VWIND: return FQ_WIND;
    case FV_TAIR: return FQ_TAIR;
    case FV_DEW: case FV_QAIR: case FV_RH: case FV_PSURF: return FQ_HUMIDITY;
    case FV_SW: return FQ_SWDN;
    case FV_LW: return FQ_LWDN;
    case FV_UCUR: case FV_VCUR: return FQ_CURRENT;
    case FV_SSH: return FQ_SSH;
    case FV_SST: return FQ_SST;
    case FV_FW: return FQ_OCEAN_FLUX;
    case FV_SNOW: return FQ_SNOWFALL;
    case FV_PRECIP: return FQ_PRECIP;
    case FV_MLD: return FQ_MLD;
    case FV_BATHY: return FQ_BATHY;
    default: return 0;
    }
}

int forcing_quantity_of(const char *standard_name)
{
    for (int w = 0; w < FV_COUNT; w++) {
        for (int k = 0; k < 4 && slot_defs[w].std[k]; k++)
            if (!strcmp(slot_defs[w].std[k], standard_name))
                return (int)slot_flag((fv_slot)w);
        for (int k = 0; k < 3 && slot_defs[w].grid_std[k]; k++)
            if (!strcmp(slot_defs[w].grid_std[k], standard_name))
                return (int)slot_flag((fv_slot)w);
    }
    return 0;
}

static int scan_file(fsource *s, const forcing_source_spec *spec, int fi, unsigned want,
                     cf_units *units, sph_error *err)
{
    const char *path = s->paths[fi];
    void *fh;
    int rc = s->drv->open(s, fi, &fh, err);
    if (rc)
        return rc;
    forcing_varinfo *vars = NULL;
    size_t nv = 0;
    if (s->drv->variables(fh, &vars, &nv) != 0)
        rc = forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
    for (int w = 0; w < FV_COUNT && rc == 0; w++) {
        /* air temperature also where humidity may come as relative humidity */
        if (!(slot_flag((fv_slot)w) & want) && !(w == FV_TAIR && (want & FQ_HUMIDITY)))
            continue;
        int vi, how;
        char sn[96], tried[256];
        if (find_var(vars, nv, spec, (fv_slot)w, &vi, &how, sn, sizeof sn, tried,
                     sizeof tried))
            continue;
        int varid = vars[vi].id;
        fvar *v = s->vars[w];
        if (!v) {
            v = calloc(1, sizeof *v);
            if (!v) {
                rc = forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
                break;
            }
            s->vars[w] = v;
            v->src = s;
            v->which = (fv_slot)w;
            v->slot_k[0] = v->slot_k[1] = (size_t)-1;
            v->found_how = how;
            snprintf(v->standard_name, sizeof v->standard_name, "%s", sn);
            snprintf(v->varname, sizeof v->varname, "%.*s", (int)sizeof v->varname - 1,
                     vars[vi].name);
        }
        fvfile *nvf = realloc(v->vfiles, (v->nvfiles + 1) * sizeof *nvf);
        if (!nvf) {
            rc = forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
            break;
        }
        v->vfiles = nvf;
        fvfile *vf = &v->vfiles[v->nvfiles];
        memset(vf, 0, sizeof *vf);
        vf->merge_dim = -1;
        vf->file = fi;
        vf->varid = varid;
        fgrid *g = NULL;
        rc = s->drv->grid(s, path, fh, varid, vf, &g, err);
        if (rc)
            break;
        if (v->grid && g != v->grid) {
            rc = forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                              "grid of variable '%s' differs from the one in %s", v->varname,
                              v->file0);
            break;
        }
        v->grid = g;
        char level[256];
        rc = s->drv->levels(s, path, fh, varid, vf, level, sizeof level, err);
        if (rc)
            break;
        if (level[0] && v->nvfiles == 0)
            log_info("forcing '%s': variable '%s': %s", path, v->varname, level);
        rc = read_var_atts(s, v, path, fh, varid, vf, units, err);
        if (rc)
            break;
        if (v->nvfiles == 0)
            snprintf(v->file0, sizeof v->file0, "%s", path);
        v->nvfiles++;
        rc = read_times(s, v, path, fh, varid, vf, (int)v->nvfiles - 1, err);
    }
    free(vars);
    s->drv->close(fh);
    return rc;
}

/* ---- slices ---- */

/* One horizontal slice at time index ti; along a merged dimension
 * (vf->merge_dim) at index mi. */
static int read_slice_at(forcing *f, fvar *v, size_t ti, size_t mi, double *dst, sph_error *err)
{
    fsource *s = v->src;
    const ftime *ft = v->ntimes ? &v->times[ti] : NULL;
    const fvfile *vf = &v->vfiles[ft ? ft->vf : 0];
    const char *path = s->paths[vf->file];
    void *fh;
    size_t nx = v->grid->nx, ny = v->grid->ny, n = nx * ny;
    double *raw = dst;
    if (vf->transpose && !(raw = malloc(n * sizeof *raw)))
        return forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
    /* slices are read during the run, while the products' background
     * writer may be inside NetCDF (io/nc_guard.h) */
    nc_guard_lock();
    int rc = src_file(s, vf->file, &fh, err) ? err->code : 0;
    if (!rc)
        rc = s->drv->slice(s, path, fh, v, vf, ft ? ft->k : 0, mi, raw, err);
    nc_guard_unlock();
    if (rc) {
        if (raw != dst)
            free(raw);
        return rc;
    }
    if (raw != dst) {
        for (size_t i = 0; i < nx; i++)
            for (size_t j = 0; j < ny; j++)
                dst[j * nx + i] = raw[i * ny + j];
        free(raw);
    }
    f->reads++;
    const int running = v->accumulated && s->accumulation == FORCING_ACCUMULATION_RUNNING;
    for (size_t p = 0; p < n; p++) {
        double x = dst[p];
        int missing = vf->has_fill && (x == vf->fill || (isnan(vf->fill) && isnan(x)));
        for (int m = 0; m < vf->nmiss && !missing; m++)
            missing = x == vf->miss[m] || (isnan(vf->miss[m]) && isnan(x));
        if (!missing && isnan(x)) {
            char when[40] = "static";
            if (ft)
                iso(ft->t, when, sizeof when);
            return forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                                "NaN in variable '%s' at %s (time index %zu, point %zu) that is "
                                "not a declared _FillValue or missing_value",
                                v->varname, when, ft ? ft->k : 0, p);
        }
        if (!missing && vf->valid_raw)
            missing = x < vf->vmin || x > vf->vmax;
        x = x * vf->scale + vf->offset;
        if (!missing && !vf->valid_raw)
            missing = x < vf->vmin || x > vf->vmax;
        x = vf->a * x + vf->b;
        if (v->accumulated && running)
            ; /* an amount since the start: read_slice differences and checks it */
        else if (v->accumulated)
            x /= ft ? ft->period : 1.0;
        if (!missing && !running &&
            !(x >= slot_bounds[v->which].lo && x <= slot_bounds[v->which].hi)) {
            char when[40] = "static";
            if (ft)
                iso(ft->t, when, sizeof when);
            return forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                                "value %g %s of variable '%s' (%s) at %s (time index %zu), point "
                                "%zu (lon %.4f, lat %.4f), is outside the physical bounds %g .. "
                                "%g %s and not a declared _FillValue or missing_value",
                                x, slot_defs[v->which].target, v->varname, v->standard_name, when,
                                ft ? ft->k : 0, p, v->grid->lon2[p], v->grid->lat2[p],
                                slot_bounds[v->which].lo, slot_bounds[v->which].hi,
                                slot_defs[v->which].target);
        }
        dst[p] = missing ? NAN : x;
    }
    return 0;
}

/* A slice; along a merged dimension (ERA5's expver) the first valid
 * value at each point, in index order. */
static int read_slice_merged(forcing *f, fvar *v, size_t ti, double *dst, sph_error *err)
{
    const ftime *ft = v->ntimes ? &v->times[ti] : NULL;
    const fvfile *vf = &v->vfiles[ft ? ft->vf : 0];
    int rc = read_slice_at(f, v, ti, 0, dst, err);
    if (rc || vf->merge_dim < 0)
        return rc;
    size_t n = v->grid->nx * v->grid->ny;
    double *tmp = NULL;
    for (size_t mi = 1; mi < vf->merge_n && rc == 0; mi++) {
        size_t holes = 0;
        for (size_t p = 0; p < n; p++)
            holes += isnan(dst[p]);
        if (holes == 0)
            break;
        if (!tmp && !(tmp = malloc(n * sizeof *tmp)))
            return forcing_fail(err, v->src, v->src->paths[vf->file], SPH_ERR_NOMEM,
                                "out of memory");
        rc = read_slice_at(f, v, ti, mi, tmp, err);
        for (size_t p = 0; rc == 0 && p < n; p++)
            if (isnan(dst[p]))
                dst[p] = tmp[p];
    }
    free(tmp);
    return rc;
}

/* A slice in sphice units. A running accumulation (forcing[].accumulation
 * "running") becomes the mean rate over the interval ending at time ti:
 * (a_k - a_{k-1}) / (t_k - t_{k-1}), or a_k / (t_k - t_{k-1}) when the
 * grid total of a_k is below that of a_{k-1} (the accumulation was reset
 * at t_{k-1}); the first time takes the rate of the interval after it. */
static int read_slice(forcing *f, fvar *v, size_t ti, double *dst, sph_error *err)
{
    if (!(v->accumulated && v->src->accumulation == FORCING_ACCUMULATION_RUNNING))
        return read_slice_merged(f, v, ti, dst, err);
    size_t k = ti == 0 ? 1 : ti, n = v->grid->nx * v->grid->ny;
    const char *path = v->src->paths[v->vfiles[v->times[k].vf].file];
    double *prev = malloc(n * sizeof *prev);
    if (!prev)
        return forcing_fail(err, v->src, path, SPH_ERR_NOMEM, "out of memory");
    int rc = read_slice_merged(f, v, k, dst, err);
    if (!rc)
        rc = read_slice_merged(f, v, k - 1, prev, err);
    if (rc) {
        free(prev);
        return rc;
    }
    double sum_now = 0.0, sum_prev = 0.0;
    for (size_t p = 0; p < n; p++)
        if (isfinite(dst[p]) && isfinite(prev[p])) {
            sum_now += dst[p];
            sum_prev += prev[p];
        }
    int reset = sum_now < sum_prev;
    double dt = v->times[k].t - v->times[k - 1].t;
    for (size_t p = 0; p < n; p++) {
        if (!isfinite(dst[p]))
            continue;
        double x = (reset || !isfinite(prev[p]) ? dst[p] : dst[p] - prev[p]) / dt;
        if (!(x >= slot_bounds[v->which].lo && x <= slot_bounds[v->which].hi)) {
            char when[40];
            iso(v->times[k].t, when, sizeof when);
            free(prev);
            return forcing_fail(err, v->src, path, SPH_ERR_BAD_DATA,
                                "rate %g %s of the running accumulation '%s' (%s) at %s (time index "
                                "%zu), point %zu, is outside the physical bounds %g .. %g: check "
                                "forcing[].accumulation",
                                x, slot_defs[v->which].target, v->varname, v->standard_name, when,
                                v->times[k].k, p, slot_bounds[v->which].lo,
                                slot_bounds[v->which].hi);
        }
        dst[p] = x;
    }
    free(prev);
    return 0;
}

static int alloc_slot(fvar *v, int k)
{
    size_t n = v->grid->nx * v->grid->ny;
    if (!v->slot[k] && !(v->slot[k] = malloc(n * sizeof(double))))
        return -1;
    if (v->which == FV_SSH && !v->slot_gx[k]) {
        v->slot_gx[k] = malloc(n * sizeof(double));
        v->slot_gy[k] = malloc(n * sizeof(double));
        if (!v->slot_gx[k] || !v->slot_gy[k])
            return -1;
    }
    return 0;
}

/* Makes time index ti resident without evicting time index keep. */
static int ensure_slice(forcing *f, fvar *v, size_t ti, size_t keep, int *slot, sph_error *err)
{
    for (int k = 0; k < 2; k++)
        if (v->slot_k[k] == ti) {
            *slot = k;
            return 0;
        }
    int k = v->slot_k[0] == keep ? 1 : 0;
    if (alloc_slot(v, k))
        return forcing_fail(err, v->src, v->file0, SPH_ERR_NOMEM, "out of memory");
    v->slot_k[k] = (size_t)-1;
    int rc = read_slice(f, v, ti, v->slot[k], err);
    if (rc)
        return rc;
    if (v->which == FV_SSH)
        fgrid_gradient(v->grid, v->slot[k], v->slot_gx[k], v->slot_gy[k]);
    v->slot_k[k] = ti;
    *slot = k;
    return 0;
}

/* Time indices around t and the weight of the second. */
static int bracket_time(const fvar *v, double t, size_t *k0, size_t *k1, double *alpha,
                        sph_error *err)
{
    if (v->ntimes == 0 || v->harm) {
        *k0 = *k1 = 0;
        *alpha = 0;
        return 0;
    }
    const ftime *tt = v->times;
    size_t n = v->ntimes;
    if (!(t >= tt[0].t - 1e-6 && t <= tt[n - 1].t + 1e-6)) {
        char a[40], b[40], c[40];
        iso(t, a, sizeof a);
        iso(tt[0].t, b, sizeof b);
        iso(tt[n - 1].t, c, sizeof c);
        return forcing_fail(err, v->src, v->file0, SPH_ERR_COVERAGE,
                            "time %s is outside the time axis %s .. %s of variable '%s'", a, b, c,
                            v->varname);
    }
    if (n == 1) {
        *k0 = *k1 = 0;
        *alpha = 0;
        return 0;
    }
    /* Interval (t_lo, t_hi]: a step ending exactly on a time of the axis
     * stays in the interval it started in, so it reads nothing new. */
    size_t lo = 0, hi = n - 1;
    while (hi - lo > 1) {
        size_t m = (lo + hi) / 2;
        if (tt[m].t < t)
            lo = m;
        else
            hi = m;
    }
    *k0 = lo;
    *k1 = hi;
    double a = (t - tt[lo].t) / (tt[hi].t - tt[lo].t);
    *alpha = a < 0 ? 0 : a > 1 ? 1 : a;
    return 0;
}

/* ---- open / close ---- */

static int finish_var(fsource *s, fvar *v, sph_error *err)
{
    if (v->ntimes > 1) {
        qsort(v->times, v->ntimes, sizeof *v->times, cmp_time);
        size_t m = 1;
        for (size_t k = 1; k < v->ntimes; k++)
            if (v->times[k].t > v->times[m - 1].t + 1e-6)
                v->times[m++] = v->times[k];
        v->ntimes = m;
        snprintf(v->file0, sizeof v->file0, "%s", s->paths[v->vfiles[v->times[0].vf].file]);
    }
    if (v->accumulated) {
        if (v->ntimes < 2)
            return forcing_fail(err, s, v->file0, SPH_ERR_BAD_DATA,
                                "accumulated variable '%s' needs at least two times to find the "
                                "accumulation period",
                                v->varname);
        for (size_t k = 0; k < v->ntimes; k++)
            v->times[k].period = k > 0 ? v->times[k].t - v->times[k - 1].t
                                       : v->times[1].t - v->times[0].t;
    }
    if (v->vfiles[0].tdim >= 0 && v->ntimes == 0)
        return forcing_fail(err, s, v->file0, SPH_ERR_COVERAGE,
                            "variable '%s' has no valid times", v->varname);
    snprintf(v->units, sizeof v->units, "%s", v->vfiles[0].units);
    return 0;
}

/* The extent of the file's grid (not of the read window). */
static void grid_extent(const fgrid *g, double *x0, double *x1, double *y0, double *y1)
{
    *x0 = g->ext[0];
    *x1 = g->ext[1];
    *y0 = g->ext[2];
    *y1 = g->ext[3];
}

static int check_coverage(forcing *f, fvar *v, double t0, double t1, double lon0, double lon1,
                          double lat0, double lat1, sph_error *err)
{
    fsource *s = v->src;
    if (v->ntimes && !v->harm) {
        double a = v->times[0].t, b = v->times[v->ntimes - 1].t;
        if (a > t0 + 1e-6 || b < t1 - 1e-6) {
            char sa[40], sb[40], s0[40], s1[40];
            iso(a, sa, sizeof sa);
            iso(b, sb, sizeof sb);
            iso(t0, s0, sizeof s0);
            iso(t1, s1, sizeof s1);
            return forcing_fail(err, s, v->file0, SPH_ERR_COVERAGE,
                                "time axis of '%s' (%s .. %s) does not cover the period %s .. %s",
                                v->varname, sa, sb, s0, s1);
        }
    }
    const int m = 9;
    for (int a = 0; a < m; a++)
        for (int b = 0; b < m; b++) {
            double x = lon0 + (lon1 - lon0) * a / (m - 1), y = lat0 + (lat1 - lat0) * b / (m - 1);
            if (!fgrid_covers(v->grid, x, y)) {
                double gx0, gx1, gy0, gy1;
                grid_extent(v->grid, &gx0, &gx1, &gy0, &gy1);
                return forcing_fail(err, s, v->file0, SPH_ERR_COVERAGE,
                                    "grid of '%s' (%s, lon %.4g .. %.4g, lat %.4g .. %.4g) does "
                                    "not cover the domain box lon %.4g .. %.4g, lat %.4g .. %.4g "
                                    "(point %.4g, %.4g outside)",
                                    v->varname, v->grid->desc, gx0, gx1, gy0, gy1, lon0, lon1,
                                    lat0, lat1, x, y);
            }
        }
    /* Read (and validate) the first slice now: a bad file fails at open. */
    size_t k0, k1;
    double alpha;
    int slot;
    if (v->harm)
        return 0;
    if (bracket_time(v, t0, &k0, &k1, &alpha, err) || ensure_slice(f, v, k0, (size_t)-1, &slot, err))
        return err->code;
    size_t n = v->grid->nx * v->grid->ny, nmiss = 0;
    for (size_t p = 0; p < n; p++)
        nmiss += isnan(v->slot[slot][p]);
    v->fill_fraction = (double)nmiss / (double)n;
    return 0;
}

static const char *const vectors_names[] = {"auto", "earth", "grid"};

/* Decides whether the pair (u, v) is earth- or grid-relative (see
 * forcing_source_spec.vectors) and records why in their orient. */
static int vector_pair(fsource *s, const forcing_source_spec *spec, fvar *u, fvar *v,
                       sph_error *err)
{
    if (!u || !v)
        return 0;
    int key = spec->vectors >= FORCING_VECTORS_AUTO && spec->vectors <= FORCING_VECTORS_GRID
                  ? spec->vectors
                  : FORCING_VECTORS_AUTO;
    const fvar *by_std = NULL;
    for (int c = 0; c < 2; c++) {
        const fvar *x = c ? v : u;
        if (x->found_how == FVEC_NAME)
            continue;
        if (by_std && by_std->found_how != x->found_how)
            return forcing_fail(err, s, u->file0, SPH_ERR_BAD_DATA,
                                "vector components '%s' (standard_name '%s') and '%s' "
                                "(standard_name '%s') disagree on east/north against grid axes",
                                by_std->varname, by_std->standard_name, x->varname,
                                x->standard_name);
        if (!by_std)
            by_std = x;
    }
    char why[160];
    int grid;
    if (by_std) {
        grid = by_std->found_how == FVEC_STD_GRID;
        if ((key == FORCING_VECTORS_EARTH && grid) || (key == FORCING_VECTORS_GRID && !grid))
            return forcing_fail(err, s, u->file0, SPH_ERR_CONFIG,
                                "variable '%s' has standard_name '%s' (%s-relative) but "
                                "forcing[].vectors is \"%s\"",
                                by_std->varname, by_std->standard_name, grid ? "grid" : "earth",
                                vectors_names[key]);
        snprintf(why, sizeof why, "standard_name '%.60s' of '%.40s'", by_std->standard_name,
                 by_std->varname);
    } else if (key != FORCING_VECTORS_AUTO) {
        grid = key == FORCING_VECTORS_GRID;
        snprintf(why, sizeof why, "forcing[].vectors \"%s\"", vectors_names[key]);
    } else if (!u->grid->curvilinear && !v->grid->curvilinear) {
        grid = 0;
        snprintf(why, sizeof why, "regular longitude/latitude grid: its axes point east and north");
    } else if (u->grid->angle_var[0]) {
        grid = 1;
        snprintf(why, sizeof why, "ROMS convention: the file's angle variable '%.60s'",
                 u->grid->angle_var);
    } else if (u->grid != v->grid) {
        grid = 1;
        snprintf(why, sizeof why, "'%.40s' and '%.40s' on staggered C-grid points", u->varname,
                 v->varname);
    } else {
        return forcing_fail(err, s, u->file0, SPH_ERR_CONFIG,
                            "variables '%s' and '%s' were found by name on a curvilinear grid and "
                            "the file does not say whether they are east/north or along the grid "
                            "axes: set forcing[].vectors to \"earth\" or \"grid\"",
                            u->varname, v->varname);
    }
    u->grid_relative = v->grid_relative = grid;
    const fgrid *g = u->grid;
    if (!grid)
        snprintf(u->orient, sizeof u->orient, "earth-relative (%s)", why);
    else if (g->curvilinear)
        snprintf(u->orient, sizeof u->orient, "grid-relative (%.80s), rotated by %.80s", why,
                 g->angle_from);
    else
        snprintf(u->orient, sizeof u->orient,
                 "grid-relative (%.80s), regular longitude/latitude grid: no rotation", why);
    snprintf(v->orient, sizeof v->orient, "%s", u->orient);
    return 0;
}

static int open_source(forcing *f, fsource *s, const forcing_source_spec *spec, double t_start,
                       cf_units *units, sph_error *err)
{
    unsigned want = spec->required | spec->optional;
    if (!want)
        want = kind_defaults[spec->kind <= FORCING_TIDE ? spec->kind : 0];
    if (spec->nfiles == 0)
        return forcing_fail(err, s, "-", SPH_ERR_CONFIG, "no files given");
    s->paths = calloc(spec->nfiles, sizeof *s->paths);
    if (!s->paths)
        return forcing_fail(err, s, "-", SPH_ERR_NOMEM, "out of memory");
    for (size_t i = 0; i < spec->nfiles; i++) {
        if (!(s->paths[i] = strdup(spec->files[i])))
            return forcing_fail(err, s, "-", SPH_ERR_NOMEM, "out of memory");
        s->npaths++;
    }
    s->drv = driver_for(s->paths[0]);
    s->accumulation = spec->accumulation;
    if (spec->kind == FORCING_TIDE && s->drv->tide) {
        int harmonic = 0;
        double t_ref = floor(t_start / 86400.0) * 86400.0;
        int rc = s->drv->tide(s, &harmonic, units, t_ref, !spec->tide_no_nodal,
                              want & spec->required, err);
        if (rc && !harmonic)
            return rc;
        if (harmonic) {
            s->harmonic = 1;
            /* Keep only the quantities asked for, as scan_file does for
             * time series: a source configured for currents alone must not
             * sample (and fail on) the elevation and its gradient. */
            for (int w = 0; rc == 0 && w < FV_COUNT; w++)
                if (s->vars[w] && !(slot_flag((fv_slot)w) & want)) {
                    fvar_free(s->vars[w]);
                    s->vars[w] = NULL;
                }
            return rc;
        }
    }
    /* grids read from here on keep only their read window (harmonic tides: whole) */
    s->win_on = spec->window;
    s->win_margin_km = spec->margin_km > 0 ? spec->margin_km : 0.0;
    for (size_t i = 0; i < s->npaths; i++)
        if (scan_file(s, spec, (int)i, want, units, err))
            return err->code;
    /* Humidity: specific humidity when present, else dew point, else
     * relative humidity (which needs the air temperature of the same source). */
    if (s->vars[FV_QAIR] && s->vars[FV_DEW]) {
        fvar_free(s->vars[FV_DEW]);
        s->vars[FV_DEW] = NULL;
    }
    if ((s->vars[FV_QAIR] || s->vars[FV_DEW]) && s->vars[FV_RH]) {
        fvar_free(s->vars[FV_RH]);
        s->vars[FV_RH] = NULL;
    }
    if (s->vars[FV_RH] && !s->vars[FV_TAIR])
        return forcing_fail(err, s, s->vars[FV_RH]->file0, SPH_ERR_MISSING_VAR,
                            "relative_humidity ('%s') found but no air_temperature to convert it",
                            s->vars[FV_RH]->varname);
    if (s->vars[FV_TAIR] && !(want & FQ_TAIR) && !s->vars[FV_RH]) {
        fvar_free(s->vars[FV_TAIR]);
        s->vars[FV_TAIR] = NULL;
    }
    if (!s->vars[FV_DEW] && !s->vars[FV_RH] && s->vars[FV_PSURF]) {
        fvar_free(s->vars[FV_PSURF]);
        s->vars[FV_PSURF] = NULL;
    }
    for (int w = 0; w < FV_COUNT; w++) {
        unsigned fl = slot_flag((fv_slot)w);
        if (!(fl & spec->required) || s->vars[w] || w == FV_PSURF)
            continue;
        if ((w == FV_DEW || w == FV_QAIR || w == FV_RH) &&
            (s->vars[FV_QAIR] || s->vars[FV_DEW] || s->vars[FV_RH]))
            continue;
        /* Report the first missing one with the names tried. */
        char tried[256] = "", sn[96];
        int varid, gr;
        void *fh;
        sph_error quiet;
        sph_error_clear(&quiet);
        if (s->drv->open(s, 0, &fh, &quiet) == 0) {
            forcing_varinfo *vars = NULL;
            size_t nv = 0;
            if (s->drv->variables(fh, &vars, &nv) == 0)
                find_var(vars, nv, spec, (fv_slot)w, &varid, &gr, sn, sizeof sn, tried,
                         sizeof tried);
            free(vars);
            s->drv->close(fh);
        }
        char where[600];
        if (s->npaths > 1)
            snprintf(where, sizeof where, "%s (and %zu more files)", s->paths[0], s->npaths - 1);
        else
            snprintf(where, sizeof where, "%s", s->paths[0]);
        const char *what = slot_defs[w].std[0];
        if (w == FV_QAIR || w == FV_DEW || w == FV_RH)
            what = "specific_humidity, dew_point_temperature or relative_humidity";
        return forcing_fail(err, s, where, SPH_ERR_MISSING_VAR,
                            "variable for %s not found (looked for standard_name%s%s%s)", what,
                            tried[0] ? " and mapped name " : "", tried,
                            slot_defs[w].grid_std[0] ? " and the grid-relative standard_name" : "");
    }
    if (s->vars[FV_UWIND] && !s->vars[FV_VWIND])
        return forcing_fail(err, s, s->vars[FV_UWIND]->file0, SPH_ERR_MISSING_VAR,
                            "eastward_wind found but not northward_wind");
    if (s->vars[FV_UCUR] && !s->vars[FV_VCUR])
        return forcing_fail(err, s, s->vars[FV_UCUR]->file0, SPH_ERR_MISSING_VAR,
                            "eastward_sea_water_velocity found but not northward_sea_water_velocity");
    if (vector_pair(s, spec, s->vars[FV_UWIND], s->vars[FV_VWIND], err) ||
        vector_pair(s, spec, s->vars[FV_UCUR], s->vars[FV_VCUR], err))
        return err->code;
    for (int w = 0; w < FV_COUNT; w++)
        if (s->vars[w] && finish_var(s, s->vars[w], err))
            return err->code;
    (void)f;
    return 0;
}

int forcing_open(forcing **out, const forcing_source_spec *specs, size_t nspecs, double t_start,
                 double t_end, double lon_min, double lon_max, double lat_min, double lat_max,
                 sph_error *err)
{
    *out = NULL;
    forcing *f = calloc(1, sizeof *f);
    if (!f)
        return sph_err_set(err, SPH_ERR_NOMEM, "forcing: out of memory");
    f->src = calloc(nspecs ? nspecs : 1, sizeof *f->src);
    if (!f->src) {
        free(f);
        return sph_err_set(err, SPH_ERR_NOMEM, "forcing: out of memory");
    }
    cf_units *units = NULL;
    if (cf_units_create(&units, err)) {
        forcing_close(f);
        return err->code;
    }
    int rc = 0;
    for (size_t i = 0; i < nspecs && !rc; i++) {
        fsource *s = &f->src[i];
        f->nsrc++;
        s->open_file = -1;
        s->kind = specs[i].kind;
        snprintf(s->name, sizeof s->name, "%s", specs[i].name ? specs[i].name : "?");
        s->win_box[0] = lon_min;
        s->win_box[1] = lon_max;
        s->win_box[2] = lat_min;
        s->win_box[3] = lat_max;
        rc = open_source(f, s, &specs[i], t_start, units, err);
        for (int w = 0; w < FV_COUNT && !rc; w++)
            if (s->vars[w])
                rc = check_coverage(f, s->vars[w], t_start, t_end, lon_min, lon_max, lat_min,
                                    lat_max, err);
    }
    cf_units_free(units);
    if (rc) {
        forcing_close(f);
        return rc;
    }
    *out = f;
    return 0;
}

void forcing_close(forcing *f)
{
    if (!f)
        return;
    for (size_t i = 0; i < f->nsrc; i++) {
        fsource *s = &f->src[i];
        for (int w = 0; w < FV_COUNT; w++)
            fvar_free(s->vars[w]);
        while (s->grids) {
            fgrid *g = s->grids;
            s->grids = g->next;
            fgrid_free(g);
        }
        if (s->open_file >= 0)
            s->drv->close(s->open_fh);
        for (size_t k = 0; k < s->npaths; k++)
            free(s->paths[k]);
        free(s->paths);
    }
    for (int k = 0; k < 6; k++)
        free(f->tmp[k]);
    free(f->src);
    free(f);
}

size_t forcing_debug_slice_reads(const forcing *f)
{
    return f ? f->reads : 0;
}

size_t forcing_debug_bytes(const forcing *f)
{
    if (!f)
        return 0;
    size_t b = f->tmp_n * 6 * sizeof(double);
    for (size_t i = 0; i < f->nsrc; i++) {
        const fsource *s = &f->src[i];
        for (const fgrid *g = s->grids; g; g = g->next)
            b += fgrid_bytes(g);
        for (int w = 0; w < FV_COUNT; w++) {
            const fvar *v = s->vars[w];
            if (!v)
                continue;
            size_t n = v->grid->nx * v->grid->ny;
            b += sizeof *v + v->nvfiles * sizeof *v->vfiles + v->ntimes * sizeof *v->times;
            for (int k = 0; k < 2; k++)
                b += ((v->slot[k] != NULL) + (v->slot_gx[k] != NULL) + (v->slot_gy[k] != NULL)) *
                     n * sizeof(double);
            for (int k = 0; v->harm && k < TIDE_NCONST; k++)
                b += ((v->harm->c[k] != NULL) + (v->harm->s[k] != NULL)) * n * sizeof(double);
        }
    }
    return b;
}

/* ---- sampling ---- */

/* Interpolates v at the n points and time t into dst (and the SSH gradient
 * into gx, gy when given). */
/* o[p] = slices a and b at the points, blended by alpha (want0: a has
 * weight, want1: b has); always inlined with want0 and want1 constant.
 * Returns the first point without a value, n if none (per-point writes:
 * the same values with any thread count). */
static inline __attribute__((always_inline)) size_t
blend_points(const fgrid *g, const double *a, const double *b, const int want0, const int want1,
             double alpha, size_t n, const double *lon, const double *lat, double *o)
{
    size_t first_bad = n;
#pragma omp parallel for schedule(dynamic, FORCING_OMP_GRAB) reduction(min : first_bad) if (n >= FORCING_OMP_MIN)
    for (size_t p = 0; p < n; p++) {
        double x0 = 0, x1 = 0;
        if (fgrid_interp2(g, a, b, want0, want1, p, lon[p], lat[p], &x0, &x1)) {
            if (p < first_bad)
                first_bad = p;
            continue;
        }
        o[p] = alpha <= 0 ? x0 : alpha >= 1 ? x1 : (1 - alpha) * x0 + alpha * x1;
    }
    return first_bad;
}

/* blend_points for three slice pairs on one grid (a height and its
 * gradient) in one pass over the points: per field the same operations as
 * blend_points, so the same values; bad[f]: field f's first point without
 * a value (n if none). */
static inline __attribute__((always_inline)) void
blend_points3(const fgrid *g, const double *const a[3], const double *const b[3], const int want0,
              const int want1, double alpha, size_t n, const double *lon, const double *lat,
              double *const o[3], size_t bad[3])
{
    size_t b0 = n, b1 = n, b2 = n;
#pragma omp parallel for schedule(dynamic, FORCING_OMP_GRAB) reduction(min : b0, b1, b2) if (n >= FORCING_OMP_MIN)
    for (size_t p = 0; p < n; p++) {
        for (int f = 0; f < 3; f++) {
            double x0 = 0, x1 = 0;
            if (fgrid_interp2(g, a[f], b[f], want0, want1, p, lon[p], lat[p], &x0, &x1)) {
                size_t *bf = f == 0 ? &b0 : f == 1 ? &b1 : &b2;
                if (p < *bf)
                    *bf = p;
                continue;
            }
            o[f][p] = alpha <= 0 ? x0 : alpha >= 1 ? x1 : (1 - alpha) * x0 + alpha * x1;
        }
    }
    bad[0] = b0;
    bad[1] = b1;
    bad[2] = b2;
}

/* sample_var's part before the blend: the stencils at the points (an
 * error for a point outside), the time bracket (alpha) and the slices
 * s0, s1 that hold it (read or synthesised). */
static int prep_var(forcing *f, fvar *v, double t, size_t n, const double *lon, const double *lat,
                    int *s0_out, int *s1_out, double *alpha_out, sph_error *err)
{
    fgrid *g = v->grid;
    if (fgrid_stencils(g, f->stamp, n, lon, lat)) {
        for (size_t p = 0; p < n; p++) {
            if (g->ok[p])
                continue;
            if (g->windowed && fgrid_covers_file(g, lon[p], lat[p]))
                return forcing_fail(err, v->src, v->file0, SPH_ERR_COVERAGE,
                                    "point (%.6g, %.6g) is outside the read window of variable "
                                    "'%s' (%s; lon %.4g .. %.4g, lat %.4g .. %.4g: the domain "
                                    "plus forcing[].margin_km = %g km)",
                                    lon[p], lat[p], v->varname, g->desc, g->wext[0], g->wext[1],
                                    g->wext[2], g->wext[3], g->margin_km);
            return forcing_fail(err, v->src, v->file0, SPH_ERR_COVERAGE,
                                "point (%.6g, %.6g) is outside the grid of variable '%s' (%s)",
                                lon[p], lat[p], v->varname, g->desc);
        }
        return forcing_fail(err, v->src, v->file0, SPH_ERR_NOMEM, "out of memory");
    }
    size_t k0, k1;
    double alpha;
    int s0 = 0, s1 = 0;
    if (bracket_time(v, t, &k0, &k1, &alpha, err))
        return err->code;
    if (v->harm) {
        if (alloc_slot(v, 0))
            return forcing_fail(err, v->src, v->file0, SPH_ERR_NOMEM, "out of memory");
        if (v->slot_k[0] != 0 || v->harm_t != t) {
            ftide_synth(v, &v->src->targs, t, v->slot[0]);
            if (v->which == FV_SSH)
                fgrid_gradient(g, v->slot[0], v->slot_gx[0], v->slot_gy[0]);
            v->slot_k[0] = 0;
            v->harm_t = t;
        }
    } else if (ensure_slice(f, v, k0, k1, &s0, err) || ensure_slice(f, v, k1, k0, &s1, err)) {
        return err->code;
    }
    *s0_out = s0;
    *s1_out = s1;
    *alpha_out = alpha;
    return 0;
}

static int blend_fail(sph_error *err, const fvar *v, int field, const double *lon, const double *lat,
                      size_t p)
{
    return forcing_fail(err, v->src, v->file0, SPH_ERR_COVERAGE,
                        "no valid %s%s of variable '%s' within one grid cell of "
                        "point (%.6g, %.6g)",
                        field ? "gradient of " : "", v->standard_name, v->varname, lon[p], lat[p]);
}

/* blend_points for two variables on one grid at the same time weights
 * (the wind's or the current's two components) in one pass over the
 * stencils: per variable the same operations as blend_points, so the same
 * values; bad[c]: variable c's first point without a value (n if none). */
static inline __attribute__((always_inline)) void
blend_points2(const fgrid *g, const double *a0, const double *b0, const double *a1, const double *b1,
              const int want0, const int want1, double alpha, size_t n, const double *lon,
              const double *lat, double *o0, double *o1, size_t bad[2])
{
    size_t c0 = n, c1 = n;
#pragma omp parallel for schedule(dynamic, FORCING_OMP_GRAB) reduction(min : c0, c1) if (n >= FORCING_OMP_MIN)
    for (size_t p = 0; p < n; p++) {
        double x0 = 0, x1 = 0;
        if (fgrid_interp2(g, a0, b0, want0, want1, p, lon[p], lat[p], &x0, &x1)) {
            if (p < c0)
                c0 = p;
        } else {
            o0[p] = alpha <= 0 ? x0 : alpha >= 1 ? x1 : (1 - alpha) * x0 + alpha * x1;
        }
        x0 = x1 = 0;
        if (fgrid_interp2(g, a1, b1, want0, want1, p, lon[p], lat[p], &x0, &x1)) {
            if (p < c1)
                c1 = p;
        } else {
            o1[p] = alpha <= 0 ? x0 : alpha >= 1 ? x1 : (1 - alpha) * x0 + alpha * x1;
        }
    }
    bad[0] = c0;
    bad[1] = c1;
}

static int sample_var(forcing *f, fvar *v, double t, size_t n, const double *lon,
                      const double *lat, double *dst, double *gx, double *gy, sph_error *err)
{
    fgrid *g = v->grid;
    int s0 = 0, s1 = 0;
    double alpha;
    if (prep_var(f, v, t, n, lon, lat, &s0, &s1, &alpha, err))
        return err->code;
    if (dst && gx && gy) { /* the height and its gradient: one pass over the stencils */
        const double *a[3] = {v->slot[s0], v->slot_gx[s0], v->slot_gy[s0]};
        const double *b[3] = {v->slot[s1], v->slot_gx[s1], v->slot_gy[s1]};
        double *o[3] = {dst, gx, gy};
        size_t bad[3];
        const int want0 = alpha < 1, want1 = alpha > 0;
        if (want0 && want1)
            blend_points3(g, a, b, 1, 1, alpha, n, lon, lat, o, bad);
        else if (want0)
            blend_points3(g, a, b, 1, 0, alpha, n, lon, lat, o, bad);
        else
            blend_points3(g, a, b, 0, 1, alpha, n, lon, lat, o, bad);
        for (int field = 0; field < 3; field++)
            if (bad[field] < n)
                return forcing_fail(err, v->src, v->file0, SPH_ERR_COVERAGE,
                                    "no valid %s%s of variable '%s' within one grid cell of "
                                    "point (%.6g, %.6g)",
                                    field ? "gradient of " : "", v->standard_name, v->varname,
                                    lon[bad[field]], lat[bad[field]]);
        return 0;
    }
    for (int field = 0; field < 3; field++) {
        double *o = field == 0 ? dst : field == 1 ? gx : gy;
        if (!o)
            continue;
        const double *a = field == 0 ? v->slot[s0] : field == 1 ? v->slot_gx[s0] : v->slot_gy[s0];
        const double *b = field == 0 ? v->slot[s1] : field == 1 ? v->slot_gx[s1] : v->slot_gy[s1];
        /* per-point writes; the first point without a value is the one reported */
        const int want0 = alpha < 1, want1 = alpha > 0;
        size_t first_bad = want0 && want1 ? blend_points(g, a, b, 1, 1, alpha, n, lon, lat, o)
                           : want0         ? blend_points(g, a, b, 1, 0, alpha, n, lon, lat, o)
                                           : blend_points(g, a, b, 0, 1, alpha, n, lon, lat, o);
        if (first_bad < n)
            return forcing_fail(err, v->src, v->file0, SPH_ERR_COVERAGE,
                                "no valid %s%s of variable '%s' within one grid cell of "
                                "point (%.6g, %.6g)",
                                field ? "gradient of " : "", v->standard_name, v->varname,
                                lon[first_bad], lat[first_bad]);
    }
    return 0;
}

/* sample_var for two variables without gradients (a vector's components)
 * into du, dv: one blend pass where they share a grid and time weights,
 * each on its own otherwise; the same values and the same first error as
 * sample_var u then v (u's slices are read before v's; where v's read
 * fails, u's blend runs first and its error comes first). */
static int sample_pair(forcing *f, fvar *vu, fvar *vv, double t, size_t n, const double *lon,
                       const double *lat, double *du, double *dv, sph_error *err)
{
    if (vu->grid != vv->grid)
        return sample_var(f, vu, t, n, lon, lat, du, NULL, NULL, err) ||
                       sample_var(f, vv, t, n, lon, lat, dv, NULL, NULL, err)
                   ? err->code
                   : 0;
    int u0 = 0, u1 = 0, v0 = 0, v1 = 0;
    double au, av;
    if (prep_var(f, vu, t, n, lon, lat, &u0, &u1, &au, err))
        return err->code;
    const fgrid *g = vu->grid;
    sph_error verr;
    sph_error_clear(&verr);
    const int vfail = prep_var(f, vv, t, n, lon, lat, &v0, &v1, &av, &verr) != 0;
    if (vfail || au != av) { /* one blend each (sample_var's); u's error first */
        for (int c = 0; c < 2; c++) {
            if (c && vfail) {
                *err = verr;
                return err->code;
            }
            const fvar *v = c ? vv : vu;
            const double alpha = c ? av : au;
            const double *a = v->slot[c ? v0 : u0], *b = v->slot[c ? v1 : u1];
            double *o = c ? dv : du;
            const int want0 = alpha < 1, want1 = alpha > 0;
            size_t first_bad = want0 && want1 ? blend_points(g, a, b, 1, 1, alpha, n, lon, lat, o)
                               : want0         ? blend_points(g, a, b, 1, 0, alpha, n, lon, lat, o)
                                               : blend_points(g, a, b, 0, 1, alpha, n, lon, lat, o);
            if (first_bad < n)
                return blend_fail(err, v, 0, lon, lat, first_bad);
        }
        return 0;
    }
    const double *a0 = vu->slot[u0], *b0 = vu->slot[u1], *a1 = vv->slot[v0], *b1 = vv->slot[v1];
    const int want0 = au < 1, want1 = au > 0;
    size_t bad[2];
    if (want0 && want1)
        blend_points2(g, a0, b0, a1, b1, 1, 1, au, n, lon, lat, du, dv, bad);
    else if (want0)
        blend_points2(g, a0, b0, a1, b1, 1, 0, au, n, lon, lat, du, dv, bad);
    else
        blend_points2(g, a0, b0, a1, b1, 0, 1, au, n, lon, lat, du, dv, bad);
    if (bad[0] < n)
        return blend_fail(err, vu, 0, lon, lat, bad[0]);
    if (bad[1] < n)
        return blend_fail(err, vv, 0, lon, lat, bad[1]);
    return 0;
}

/* Rotates grid-relative components (u, v) to east/north at the points. */
static void rotate(const fgrid *g, size_t n, double *u, double *v)
{
    if (!g->cosang)
        return;
    for (size_t p = 0; p < n; p++) {
        const size_t *idx = g->idx + 4 * p;
        const double *w = g->w + 4 * p;
        double c = 0, s = 0;
        for (int k = 0; k < 4; k++) {
            c += w[k] * g->cosang[idx[k]];
            s += w[k] * g->sinang[idx[k]];
        }
        double r = hypot(c, s);
        c /= r;
        s /= r;
        double e = u[p] * c - v[p] * s, nn = u[p] * s + v[p] * c;
        u[p] = e;
        v[p] = nn;
    }
}

/* Specific humidity (kg/kg) from relative humidity rh (0..1, over water),
 * temperature t_c (deg C) and pressure (Pa), with the saturation vapour
 * pressure over water of the IFS (ECMWF IFS documentation Cy47r3 Part IV
 * eq. 7.5, Tetens with Buck's coefficients):
 *   e = rh 611.21 exp(17.502 (T - 273.16) / (T - 32.19)),  T in K
 *   q = 0.621981 e / (p - 0.378019 e)   (epsilon = R_dry / R_vap)
 * From a dew point: rh = 1 at T = Td. */
static double specific_humidity(double rh, double t_c, double p)
{
    double t = t_c + 273.15;
    double e = rh * 611.21 * exp(17.502 * (t - 273.16) / (t - 32.19));
    const double eps = 0.621981;
    return eps * e / (p - (1 - eps) * e);
}

static void put(double *dst, const double *src, size_t n, int add)
{
    if (!dst)
        return;
#pragma omp parallel for schedule(dynamic, FORCING_OMP_GRAB) if (n >= FORCING_OMP_MIN)
    for (size_t p = 0; p < n; p++)
        dst[p] = add ? dst[p] + src[p] : src[p];
}

void forcing_set_point_base(forcing *f, size_t base) { f->point_base = base; }

int forcing_sample_at(forcing *f, double t, size_t n, const double *lon, const double *lat,
                      forcing_sample *out, sph_error *err)
{
    out->provided = 0;
    if (n == 0)
        return 0;
    if (n > f->tmp_n) {
        for (int k = 0; k < 6; k++) {
            free(f->tmp[k]);
            f->tmp[k] = malloc(n * sizeof(double));
            if (!f->tmp[k]) {
                f->tmp_n = 0;
                return sph_err_set(err, SPH_ERR_NOMEM, "forcing: out of memory");
            }
        }
        f->tmp_n = n;
    }
    f->stamp++;
    for (size_t i = 0; i < f->nsrc; i++) /* the point hints' offset (forcing_set_point_base) */
        for (fgrid *g = f->src[i].grids; g; g = g->next)
            g->hint_base = f->point_base;
    double *A = f->tmp[0], *B = f->tmp[1], *C = f->tmp[2], *D = f->tmp[3];
    for (size_t i = 0; i < f->nsrc; i++) {
        fsource *s = &f->src[i];
        fvar **v = s->vars;
        if (v[FV_UWIND] && !(out->provided & FQ_WIND) && (out->u_east || out->v_north)) {
            /* straight into the sample where no rotation follows (put's copy) */
            const int direct = !v[FV_UWIND]->grid_relative && out->u_east && out->v_north;
            double *du = direct ? out->u_east : A, *dv = direct ? out->v_north : B;
            if (sample_pair(f, v[FV_UWIND], v[FV_VWIND], t, n, lon, lat, du, dv, err))
                return err->code;
            if (v[FV_UWIND]->grid_relative)
                rotate(v[FV_UWIND]->grid, n, A, B);
            if (!direct) {
                put(out->u_east, A, n, 0);
                put(out->v_north, B, n, 0);
            }
            out->provided |= FQ_WIND;
        }
        if (v[FV_TAIR] && !(out->provided & FQ_TAIR) && out->tair) {
            if (sample_var(f, v[FV_TAIR], t, n, lon, lat, out->tair, NULL, NULL, err))
                return err->code;
            out->provided |= FQ_TAIR;
        }
        if ((v[FV_QAIR] || v[FV_DEW] || v[FV_RH]) && !(out->provided & FQ_HUMIDITY) &&
            out->qair) {
            if (v[FV_QAIR]) {
                if (sample_var(f, v[FV_QAIR], t, n, lon, lat, out->qair, NULL, NULL, err))
                    return err->code;
            } else {
                fvar *hv = v[FV_DEW] ? v[FV_DEW] : v[FV_RH];
                if (sample_var(f, hv, t, n, lon, lat, A, NULL, NULL, err))
                    return err->code;
                if (!v[FV_DEW] && sample_var(f, v[FV_TAIR], t, n, lon, lat, C, NULL, NULL, err))
                    return err->code;
                if (v[FV_PSURF]) {
                    if (sample_var(f, v[FV_PSURF], t, n, lon, lat, B, NULL, NULL, err))
                        return err->code;
                } else {
                    for (size_t p = 0; p < n; p++)
                        B[p] = 101325.0;
                }
                for (size_t p = 0; p < n; p++)
                    out->qair[p] = v[FV_DEW] ? specific_humidity(1.0, A[p], B[p])
                                             : specific_humidity(A[p], C[p], B[p]);
            }
            out->provided |= FQ_HUMIDITY;
        }
        static const struct {
            fv_slot w;
            unsigned flag;
            size_t off;
        } scalars[] = {
            {FV_SW, FQ_SWDN, offsetof(forcing_sample, swdn)},
            {FV_LW, FQ_LWDN, offsetof(forcing_sample, lwdn)},
            {FV_SST, FQ_SST, offsetof(forcing_sample, sst)},
            {FV_FW, FQ_OCEAN_FLUX, offsetof(forcing_sample, fw)},
            {FV_SNOW, FQ_SNOWFALL, offsetof(forcing_sample, snowfall)},
            {FV_PRECIP, FQ_PRECIP, offsetof(forcing_sample, precip)},
            {FV_MLD, FQ_MLD, offsetof(forcing_sample, mld)},
            {FV_BATHY, FQ_BATHY, offsetof(forcing_sample, bathy)},
        };
        for (size_t k = 0; k < sizeof scalars / sizeof scalars[0]; k++) {
            double *dst = *(double **)((char *)out + scalars[k].off);
            if (!v[scalars[k].w] || (out->provided & scalars[k].flag) || !dst)
                continue;
            if (sample_var(f, v[scalars[k].w], t, n, lon, lat, dst, NULL, NULL, err))
                return err->code;
            out->provided |= scalars[k].flag;
        }
        /* Currents and sea-surface height add up over sources (ocean + tide). */
        if (v[FV_UCUR] && (out->uw_east || out->vw_north)) {
            int add = (out->provided & FQ_CURRENT) != 0;
            const int direct = !v[FV_UCUR]->grid_relative && !add && out->uw_east && out->vw_north;
            double *du = direct ? out->uw_east : A, *dv = direct ? out->vw_north : B;
            if (sample_pair(f, v[FV_UCUR], v[FV_VCUR], t, n, lon, lat, du, dv, err))
                return err->code;
            if (v[FV_UCUR]->grid_relative)
                rotate(v[FV_UCUR]->grid, n, A, B);
            if (!direct) {
                put(out->uw_east, A, n, add);
                put(out->vw_north, B, n, add);
            }
            out->provided |= FQ_CURRENT;
        }
        if (v[FV_SSH] && (out->ssh || out->ssh_dx_east || out->ssh_dy_north)) {
            int grad = out->ssh_dx_east || out->ssh_dy_north;
            if (sample_var(f, v[FV_SSH], t, n, lon, lat, A, grad ? C : NULL, grad ? D : NULL, err))
                return err->code;
            int add = (out->provided & FQ_SSH) != 0;
            put(out->ssh, A, n, add);
            if (grad) {
                put(out->ssh_dx_east, C, n, add);
                put(out->ssh_dy_north, D, n, add);
            }
            out->provided |= FQ_SSH;
        }
    }
    return 0;
}

/* ---- description ---- */

size_t forcing_describe(const forcing *f, forcing_var_info *info, size_t max)
{
    size_t m = 0;
    for (size_t i = 0; f && i < f->nsrc; i++) {
        const fsource *s = &f->src[i];
        for (int w = 0; w < FV_COUNT; w++) {
            const fvar *v = s->vars[w];
            if (!v)
                continue;
            if (m < max) {
                forcing_var_info *d = &info[m];
                memset(d, 0, sizeof *d);
                snprintf(d->source, sizeof d->source, "%s", s->name);
                snprintf(d->standard_name, sizeof d->standard_name, "%s", v->standard_name);
                snprintf(d->variable, sizeof d->variable, "%s", v->varname);
                snprintf(d->file, sizeof d->file, "%s", v->file0);
                snprintf(d->units, sizeof d->units, "%.48s%s", v->units,
                         v->accumulated ? " (accumulated)" : "");
                snprintf(d->grid, sizeof d->grid, "%s", v->grid->desc);
                if (v->harm || v->ntimes == 0) {
                    d->t_first = -INFINITY;
                    d->t_last = INFINITY;
                } else {
                    d->t_first = v->times[0].t;
                    d->t_last = v->times[v->ntimes - 1].t;
                }
                d->fill_fraction = v->fill_fraction;
                snprintf(d->orientation, sizeof d->orientation, "%s", v->orient);
            }
            m++;
        }
    }
    return m;
}
