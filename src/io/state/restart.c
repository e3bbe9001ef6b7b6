/* Restart particle files: see io/restart.h. */
#include "io/restart.h"
#include "io/ncfile.h"
#include "io/nc_guard.h"

#include <limits.h>
#include <math.h>
#include <netcdf.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "util/fileio.h"
#include "util/timeutil.h"

/* The restart file's particle variables are the fields of
 * SPH_PARTICLE_FIELDS (core/particles.h) with restart YES or OPT, in list
 * order; the NetCDF type follows the C type. */
static const nc_type rv_nctype[] = {
    [SPH_FIELD_DOUBLE] = NC_DOUBLE, [SPH_FIELD_LONG] = NC_INT64, [SPH_FIELD_UCHAR] = NC_UBYTE};

static int rv_put(int nc, int var, int type, const size_t *start, const size_t *count,
                  const void *a)
{
    switch (type) {
    case SPH_FIELD_DOUBLE: return nc_put_vara_double(nc, var, start, count, a);
    case SPH_FIELD_LONG: return nc_put_vara_long(nc, var, start, count, a);
    default: return nc_put_vara_uchar(nc, var, start, count, a);
    }
}

static int rv_get(int nc, int var, int type, const size_t *start, const size_t *count, void *a)
{
    switch (type) {
    case SPH_FIELD_DOUBLE: return nc_get_vara_double(nc, var, start, count, a);
    case SPH_FIELD_LONG: return nc_get_vara_long(nc, var, start, count, a);
    default: return nc_get_vara_uchar(nc, var, start, count, a);
    }
}

/* Clock and budget attributes: name and member. */
typedef struct {
    const char *name;
    size_t offset;
    int optional; /* 1: a file written before it existed reads it as zero */
} clock_att;

#define CA(name, member) {name, offsetof(sph_model_clock, member), 0}
#define CA_OPT(name, member) {name, offsetof(sph_model_clock, member), 1}
static const clock_att clock_atts[] = {
    CA("model_time_since_init", time),
    CA("model_thermo_accum", thermo_accum),
    CA("model_dens_scale", dens_scale),
    CA("budget_mass_initial", budget.mass_initial),
    CA("budget_mass", budget.mass),
    CA("budget_growth", budget.growth),
    CA("budget_new_ice", budget.new_ice),
    CA("budget_melt_top", budget.melt_top),
    CA("budget_melt_bottom", budget.melt_bottom),
    CA("budget_lateral_melt", budget.lateral_melt),
    CA("budget_outflow", budget.outflow),
    CA("budget_area", budget.area),
    CA("budget_volume", budget.volume),
    CA("budget_kinetic_energy", budget.kinetic_energy),
    CA_OPT("budget_snow_ice", budget.snow_ice),
    CA_OPT("budget_snow_initial", budget.snow_initial),
    CA_OPT("budget_snow", budget.snow),
    CA_OPT("budget_snowfall", budget.snowfall),
    CA_OPT("budget_snow_melt", budget.snow_melt),
    CA_OPT("budget_snow_to_ocean", budget.snow_to_ocean),
};
#undef CA
#undef CA_OPT
#define NCLOCK (sizeof clock_atts / sizeof clock_atts[0])

static int nc_fail(int st, const char *what, const char *path, sph_error *err)
{
    return sph_err_set(err, SPH_ERR_NETCDF, "restart %s: %s: %s", path, what, nc_strerror(st));
}

static int put_text(int nc, int var, const char *name, const char *text)
{
    return nc_put_att_text(nc, var, name, strlen(text), text);
}

/* Field k goes into the file unless it is a diagnostic optional field
 * that is zero on every particle (the ocean-flux accumulators while
 * output.ocean_fluxes is off), or an NZ field that is (the snow
 * temperature without thermo.snow_heat_capacity): reading it back as
 * absent gives the same zeros, and files stay as they were before such
 * fields existed. */
static int rv_written(const sph_particles *P, int k)
{
    const sph_particle_field *f = &sph_particle_fields[k];
    if (f->restart == SPH_RESTART_NO)
        return 0;
    if (f->restart == SPH_RESTART_YES || (f->restart == SPH_RESTART_OPT && f->tag != SPH_FIELD_DIAGNOSTIC))
        return 1;
    const unsigned char *a = sph_particles_field(P, k);
    size_t bytes = P->n * sph_particles_field_count(P, k) * f->size;
    for (size_t i = 0; i < bytes; i++)
        if (a[i])
            return 1;
    return 0;
}

/* the removed particles' accumulators the mixed layer's cells hold (core/ocean.h) */
#define OCEAN_REMOVED(v, what, units) \
    {"ocean_ofx_" #v, "removed particles' " what " since the last fluxes record", units, offsetof(sph_ocean, ofx_##v)}
/* The mixed layer's state in the file (restart_write_ocean): variables
 * on the dimension ocean_cell, in this order. */
static const struct {
    const char *name, *long_name, *units;
    size_t offset;
} ocean_vars[] = {
    {"ocean_temp", "mixed-layer temperature", "degC", offsetof(sph_ocean, temp)},
    {"ocean_sal", "mixed-layer salinity", "1e-3", offsetof(sph_ocean, sal)},
    {"ocean_depth", "mixed-layer depth", "m", offsetof(sph_ocean, depth)},
    {"ocean_water", "water in the cell", "kg", offsetof(sph_ocean, water)},
    {"ocean_salt", "salt in the cell", "kg", offsetof(sph_ocean, salt)},
    {"ocean_frazil", "frazil ice waiting to become particles", "kg", offsetof(sph_ocean, frazil)},
    {"ocean_frazil_enth", "enthalpy of the waiting frazil", "J", offsetof(sph_ocean, frazil_enth)},
    {"ocean_ofx_heat", "open water's heat into the ocean since the last fluxes record", "J",
     offsetof(sph_ocean, ofx_heat)},
    {"ocean_ofx_water", "open water's fresh water into the ocean since the last fluxes record", "kg",
     offsetof(sph_ocean, ofx_water)},
    {"ocean_ofx_salt", "open water's salt into the ocean since the last fluxes record", "kg",
     offsetof(sph_ocean, ofx_salt)},
    /* from OCEAN_REQUIRED on: optional, written only when not all zero, absent reads as zero */
    OCEAN_REMOVED(heat_ice, "heat under their ice", "J"),
    OCEAN_REMOVED(taux, "stress on the ocean, plane x", "N s"),
    OCEAN_REMOVED(tauy, "stress on the ocean, plane y", "N s"),
    OCEAN_REMOVED(swbase, "shortwave at their base", "J"),
};
#define NOCEAN (sizeof ocean_vars / sizeof ocean_vars[0])
#define OCEAN_REQUIRED 10
static const char *const ocean_grid_atts[6] = {"ocean_x0", "ocean_y0", "ocean_dx", "ocean_dy", "ocean_nx",
                                               "ocean_ny"};

static double *ocean_array(const sph_ocean *o, size_t k)
{
    return *(double *const *)((const char *)o + ocean_vars[k].offset);
}

/* 0 for an optional ocean variable that is zero everywhere (not written). */
static int ocean_written(const sph_ocean *o, size_t k)
{
    if (k < OCEAN_REQUIRED)
        return 1;
    const double *a = ocean_array(o, k);
    for (size_t c = 0; c < o->ncell; c++)
        if (a[c] != 0.0)
            return 1;
    return 0;
}

static void ocean_grid_values(const sph_ocean *o, double g[6])
{
    g[0] = o->g.x0;
    g[1] = o->g.y0;
    g[2] = o->g.dx;
    g[3] = o->g.dy;
    g[4] = o->g.nx;
    g[5] = o->g.ny;
}

static int write_body(int nc, const sph_particles *P, const restart_header *h, const sph_ocean *o,
                      const char *path, sph_error *err)
{
    int st, d_p, d_l, v[SPH_PARTICLE_NFIELDS], vo[NOCEAN];
    size_t n = P->n;
    int nl = P->nlayers;
#define NC(call, what)                               \
    do {                                             \
        if ((st = (call)) != NC_NOERR)               \
            return nc_fail(st, what, path, err);     \
    } while (0)
    /* no fill: every value is written, except with no particle, where the
     * one slot below stays unwritten and so takes the fill value (without
     * it the file held whatever the chunk's memory held: two runs of an
     * open-water start wrote different restart bytes) */
    if (n > 0)
        NC(nc_set_fill(nc, NC_NOFILL, &st), "set fill");
    /* a fixed dimension of length 0 would be unlimited: keep it fixed and >= 1 */
    NC(nc_def_dim(nc, "particle", n > 0 ? n : 1, &d_p), "define dimension");
    NC(nc_def_dim(nc, "layer", (size_t)nl, &d_l), "define dimension");
    int dims2[2] = {d_p, d_l};
    for (int k = 0; k < SPH_PARTICLE_NFIELDS; k++) {
        const sph_particle_field *f = &sph_particle_fields[k];
        if (!rv_written(P, k))
            continue;
        NC(nc_def_var(nc, f->name, rv_nctype[f->type], f->layered ? 2 : 1, dims2, &v[k]),
           "define variable");
        NC(put_text(nc, v[k], "long_name", f->long_name), "write attribute");
        if (f->units)
            NC(put_text(nc, v[k], "units", f->units), "write attribute");
    }

    char iso[32];
    time_format_iso(h->time, iso, sizeof iso);
    NC(put_text(nc, NC_GLOBAL, "Conventions", "CF-1.8"), "write attribute");
    NC(put_text(nc, NC_GLOBAL, "sphice_restart_format", RESTART_FORMAT), "write attribute");
    NC(put_text(nc, NC_GLOBAL, "title", "sphice particle state (warm start)"), "write attribute");
    NC(put_text(nc, NC_GLOBAL, "projection", h->projection), "write attribute");
    NC(put_text(nc, NC_GLOBAL, "time_iso", iso), "write attribute");
    NC(nc_put_att_double(nc, NC_GLOBAL, "time", NC_DOUBLE, 1, &h->time), "write attribute");
    NC(nc_put_att_double(nc, NC_GLOBAL, "cycle_time", NC_DOUBLE, 1, &h->cycle_time),
       "write attribute");
    NC(nc_put_att_int(nc, NC_GLOBAL, "nlayers", NC_INT, 1, &nl), "write attribute");
    long long cnt = (long long)n, steps = h->clock.steps, removed = h->clock.budget.removed_particles;
    NC(nc_put_att_longlong(nc, NC_GLOBAL, "particles", NC_INT64, 1, &cnt), "write attribute");
    NC(nc_put_att_longlong(nc, NC_GLOBAL, "model_steps", NC_INT64, 1, &steps), "write attribute");
    NC(nc_put_att_longlong(nc, NC_GLOBAL, "budget_removed_particles", NC_INT64, 1, &removed),
       "write attribute");
    for (size_t a = 0; a < NCLOCK; a++) {
        const double *val = (const double *)((const char *)&h->clock + clock_atts[a].offset);
        if (clock_atts[a].optional && *val == 0.0)
            continue; /* absent reads as zero: a run without snow writes what it always did */
        NC(nc_put_att_double(nc, NC_GLOBAL, clock_atts[a].name, NC_DOUBLE, 1, val),
           "write attribute");
    }
    if (o) { /* the mixed layer (optional: a file without it reads as before) */
        int d_o;
        double g[6];
        ocean_grid_values(o, g);
        NC(nc_def_dim(nc, "ocean_cell", o->ncell, &d_o), "define dimension");
        for (int a = 0; a < 6; a++)
            NC(nc_put_att_double(nc, NC_GLOBAL, ocean_grid_atts[a], NC_DOUBLE, 1, &g[a]), "write attribute");
        for (size_t k = 0; k < NOCEAN; k++) {
            if (!ocean_written(o, k))
                continue;
            NC(nc_def_var(nc, ocean_vars[k].name, NC_DOUBLE, 1, &d_o, &vo[k]), "define variable");
            NC(put_text(nc, vo[k], "long_name", ocean_vars[k].long_name), "write attribute");
            NC(put_text(nc, vo[k], "units", ocean_vars[k].units), "write attribute");
        }
    }
    NC(nc_enddef(nc), "end definitions");
    if (o)
        for (size_t k = 0; k < NOCEAN; k++)
            if (ocean_written(o, k))
                NC(nc_put_var_double(nc, vo[k], ocean_array(o, k)), "write");
    if (n == 0)
        return SPH_OK;
    size_t start[2] = {0, 0}, count[2] = {n, (size_t)nl};
    for (int k = 0; k < SPH_PARTICLE_NFIELDS; k++)
        if (rv_written(P, k))
            NC(rv_put(nc, v[k], sph_particle_fields[k].type, start, count,
                      sph_particles_field(P, k)), "write");
#undef NC
    return SPH_OK;
}

int restart_write(const char *path, const sph_particles *P, const restart_header *h,
                  sph_error *err)
{
    return restart_write_ocean(path, P, h, NULL, err);
}

int restart_write_ocean(const char *path, const sph_particles *P, const restart_header *h, const sph_ocean *o,
                        sph_error *err)
{
    char tmp[4200];
    atomic_tmp_name(path, tmp, sizeof tmp);
    int nc, st = nc_create(tmp, NC_NETCDF4 | NC_CLOBBER, &nc);
    if (st != NC_NOERR)
        return nc_fail(st, "create", tmp, err);
    int rc = write_body(nc, P, h, o, path, err);
    st = ncfile_close(&nc);
    if (rc == SPH_OK && st != NC_NOERR)
        rc = nc_fail(st, "close", path, err);
    if (rc == SPH_OK && fault_point("restart-write"))
        rc = sph_err_set(err, SPH_ERR_IO, "restart %s: injected fault (SPHICE_FAULT=restart-write)",
                         path);
    if (rc != SPH_OK) {
        unlink(tmp);
        return rc;
    }
    return atomic_commit(tmp, path, err);
}

static int get_text_att(int nc, const char *name, char *buf, size_t len)
{
    size_t alen;
    nc_type t;
    if (nc_inq_att(nc, NC_GLOBAL, name, &t, &alen) != NC_NOERR || t != NC_CHAR || alen >= len)
        return -1;
    if (nc_get_att_text(nc, NC_GLOBAL, name, buf) != NC_NOERR)
        return -1;
    buf[alen] = '\0';
    return 0;
}

/* Integer and floating NetCDF types; a numeric attribute must be one. */
static int nc_type_integer(nc_type t)
{
    return t == NC_BYTE || t == NC_UBYTE || t == NC_SHORT || t == NC_USHORT || t == NC_INT ||
           t == NC_UINT || t == NC_INT64 || t == NC_UINT64;
}

static int nc_type_numeric(nc_type t)
{
    return nc_type_integer(t) || t == NC_FLOAT || t == NC_DOUBLE;
}

/* One numeric global attribute of one value. Returns SPH_OK, or the error
 * code with the problem in err (file and attribute named). */
static int numeric_att(int nc, const char *path, const char *name, int integer, sph_error *err)
{
    size_t alen;
    nc_type t;
    if (nc_inq_att(nc, NC_GLOBAL, name, &t, &alen) != NC_NOERR)
        return sph_err_set(err, SPH_ERR_BAD_DATA, "restart %s: attribute %s: missing", path, name);
    if (!(integer ? nc_type_integer(t) : nc_type_numeric(t)) || alen != 1)
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "restart %s: attribute %s: want one %s value, found %zu of NetCDF "
                           "type %d", path, name, integer ? "integer" : "numeric", alen, (int)t);
    return SPH_OK;
}

static int get_double_att(int nc, const char *path, const char *name, double *v, sph_error *err)
{
    int rc = numeric_att(nc, path, name, 0, err);
    if (rc)
        return rc;
    if (nc_get_att_double(nc, NC_GLOBAL, name, v) != NC_NOERR)
        return sph_err_set(err, SPH_ERR_BAD_DATA, "restart %s: attribute %s: cannot be read",
                           path, name);
    return SPH_OK;
}

/* An integer attribute in lo..hi. */
static int get_ll_att(int nc, const char *path, const char *name, long long lo, long long hi,
                      long long *v, sph_error *err)
{
    int rc = numeric_att(nc, path, name, 1, err);
    if (rc)
        return rc;
    if (nc_get_att_longlong(nc, NC_GLOBAL, name, v) != NC_NOERR || *v < lo || *v > hi)
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "restart %s: attribute %s: not an integer in %lld..%lld", path, name,
                           lo, hi);
    return SPH_OK;
}

/* The particle and layer dimensions. */
static int get_dims(int nc, const char *path, int *d_p, size_t *len_p, int *d_l, size_t *len_l,
                    sph_error *err)
{
    if (nc_inq_dimid(nc, "particle", d_p) || nc_inq_dimlen(nc, *d_p, len_p))
        return sph_err_set(err, SPH_ERR_BAD_DATA, "restart %s: dimension particle: missing", path);
    if (nc_inq_dimid(nc, "layer", d_l) || nc_inq_dimlen(nc, *d_l, len_l))
        return sph_err_set(err, SPH_ERR_BAD_DATA, "restart %s: dimension layer: missing", path);
    return SPH_OK;
}

static int read_header_open(int nc, const char *path, restart_header *h, sph_error *err)
{
    char fmt[64];
    memset(h, 0, sizeof *h);
    if (get_text_att(nc, "sphice_restart_format", fmt, sizeof fmt) || strcmp(fmt, RESTART_FORMAT))
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "restart %s: not an sphice restart file (attribute "
                           "sphice_restart_format is not \"%s\")", path, RESTART_FORMAT);
    if (get_text_att(nc, "projection", h->projection, sizeof h->projection))
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "restart %s: attribute projection: missing, not text or longer than "
                           "%zu characters", path, sizeof h->projection - 1);
    long long cnt, steps, removed, nl;
    int rc;
    if ((rc = get_double_att(nc, path, "time", &h->time, err)) ||
        (rc = get_double_att(nc, path, "cycle_time", &h->cycle_time, err)) ||
        (rc = get_ll_att(nc, path, "nlayers", 1, SPH_MAX_LAYERS, &nl, err)) ||
        (rc = get_ll_att(nc, path, "particles", 0, RESTART_MAX_PARTICLES, &cnt, err)) ||
        (rc = get_ll_att(nc, path, "model_steps", 0, LONG_MAX, &steps, err)) ||
        (rc = get_ll_att(nc, path, "budget_removed_particles", 0, LONG_MAX, &removed, err)))
        return rc;
    if (!isfinite(h->time))
        return sph_err_set(err, SPH_ERR_BAD_DATA, "restart %s: attribute time: %g is not finite",
                           path, h->time);
    if (isinf(h->cycle_time)) /* NaN: unknown */
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "restart %s: attribute cycle_time: %g is not finite", path,
                           h->cycle_time);
    for (size_t a = 0; a < NCLOCK; a++) {
        double *val = (double *)((char *)&h->clock + clock_atts[a].offset);
        int attid;
        if (clock_atts[a].optional && nc_inq_attid(nc, NC_GLOBAL, clock_atts[a].name, &attid) != NC_NOERR) {
            *val = 0.0;
            continue;
        }
        if ((rc = get_double_att(nc, path, clock_atts[a].name, val, err)))
            return rc;
        if (!isfinite(*val))
            return sph_err_set(err, SPH_ERR_BAD_DATA, "restart %s: attribute %s: %g is not finite",
                               path, clock_atts[a].name, *val);
    }
    /* the sizes the header declares are the file's dimensions (a fixed
     * dimension is >= 1: 0 particles are written on a dimension of 1) */
    int d_p, d_l;
    size_t len_p, len_l;
    if ((rc = get_dims(nc, path, &d_p, &len_p, &d_l, &len_l, err)))
        return rc;
    if (len_p != (cnt > 0 ? (size_t)cnt : 1))
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "restart %s: attribute particles: %lld, the dimension particle is %zu",
                           path, cnt, len_p);
    if (len_l != (size_t)nl)
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "restart %s: attribute nlayers: %lld, the dimension layer is %zu", path,
                           nl, len_l);
    h->nlayers = (int)nl;
    h->n = (size_t)cnt;
    h->clock.steps = (long)steps;
    h->clock.budget.removed_particles = (long)removed;
    return SPH_OK;
}

static int open_restart(const char *path, int *nc, sph_error *err)
{
    if (access(path, R_OK) != 0)
        return sph_err_set(err, SPH_ERR_IO, "restart %s: cannot read the file", path);
    /* a malformed header is refused before libnetcdf sees it, and HDF5
     * reads the file only in a separate process (nc_guard.h) */
    char label[4200];
    snprintf(label, sizeof label, "restart %s", path);
    return nc_guard_open_isolated(path, label, nc, err);
}

int restart_read_header(const char *path, restart_header *h, sph_error *err)
{
    int nc, rc = open_restart(path, &nc, err);
    if (rc)
        return rc;
    rc = read_header_open(nc, path, h, err);
    nc_close(nc);
    return rc;
}

/* NetCDF types a field's C type reads without loss: the type it is
 * written in, and narrower ones of the same kind. */
static int type_converts(int ctype, nc_type t)
{
    switch (ctype) {
    case SPH_FIELD_DOUBLE: return t == NC_DOUBLE || t == NC_FLOAT;
    case SPH_FIELD_LONG:
        return t == NC_INT64 || t == NC_INT || t == NC_UINT || t == NC_SHORT || t == NC_USHORT ||
               t == NC_BYTE || t == NC_UBYTE;
    default: return t == NC_UBYTE;
    }
}

/* Checks that field f's variable is there (optional ones may be absent:
 * *var = -1) with a type that converts and the dimensions (particle) or
 * (particle, layer). */
static int check_var(int nc, const char *path, const sph_particle_field *f, int d_p, int d_l,
                     int *var, sph_error *err)
{
    *var = -1;
    if (nc_inq_varid(nc, f->name, var) != NC_NOERR) {
        *var = -1;
        if (f->restart == SPH_RESTART_OPT || f->restart == SPH_RESTART_NZ)
            return SPH_OK;
        return sph_err_set(err, SPH_ERR_MISSING_VAR, "restart %s: variable %s: missing", path,
                           f->name);
    }
    nc_type t;
    int ndims, dims[NC_MAX_VAR_DIMS];
    if (nc_inq_vartype(nc, *var, &t) || nc_inq_varndims(nc, *var, &ndims) ||
        ndims > NC_MAX_VAR_DIMS || nc_inq_vardimid(nc, *var, dims))
        return sph_err_set(err, SPH_ERR_BAD_DATA, "restart %s: variable %s: cannot be inquired",
                           path, f->name);
    static const char *const want_type[] = {
        [SPH_FIELD_DOUBLE] = "double or float", [SPH_FIELD_LONG] = "an integer type up to int64",
        [SPH_FIELD_UCHAR] = "ubyte"};
    if (!type_converts(f->type, t))
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "restart %s: variable %s: NetCDF type %d, want %s", path, f->name,
                           (int)t, want_type[f->type]);
    int want = f->layered ? 2 : 1;
    if (ndims != want || dims[0] != d_p || (want == 2 && dims[1] != d_l))
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "restart %s: variable %s: %d dimensions, want (particle%s)", path,
                           f->name, ndims, f->layered ? ", layer" : "");
    return SPH_OK;
}

static int read_body(int nc, const char *path, const restart_header *h, sph_particles *P,
                     sph_error *err)
{
    size_t n = h->n;
    if (n > P->cap)
        return sph_err_set(err, SPH_ERR_PARAM, "restart %s: %zu particles, room for %zu", path, n,
                           P->cap);
    if (h->nlayers != P->nlayers)
        return sph_err_set(err, SPH_ERR_CONFIG,
                           "restart %s: %d thermodynamic layers, the model has %d "
                           "(model.thermo.nlayers changed: start cold)", path, h->nlayers,
                           P->nlayers);
    int d_p, d_l;
    size_t len_p, len_l;
    int rc = get_dims(nc, path, &d_p, &len_p, &d_l, &len_l, err);
    if (rc)
        return rc;
    if (len_p != (n > 0 ? n : 1) || len_l != (size_t)h->nlayers)
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "restart %s: dimensions particle %zu, layer %zu; the header says %zu "
                           "particles, %d layers", path, len_p, len_l, n, h->nlayers);
    /* every variable checked before anything is read: a refusal changes nothing */
    int v[SPH_PARTICLE_NFIELDS];
    for (int k = 0; k < SPH_PARTICLE_NFIELDS; k++) {
        v[k] = -1;
        if (sph_particle_fields[k].restart != SPH_RESTART_NO &&
            (rc = check_var(nc, path, &sph_particle_fields[k], d_p, d_l, &v[k], err)))
            return rc;
    }
    P->n = 0;
    if (n == 0)
        return SPH_OK;
    size_t start[2] = {0, 0}, count[2] = {n, (size_t)h->nlayers};
    int st;
    for (int k = 0; k < SPH_PARTICLE_NFIELDS; k++) {
        const sph_particle_field *f = &sph_particle_fields[k];
        void *a = sph_particles_field(P, k);
        size_t bytes = n * sph_particles_field_count(P, k) * f->size;
        if (f->restart == SPH_RESTART_NO) {
            /* diagnosed by the next step; zero so nothing stale is ever read */
            if (f->tag == SPH_FIELD_DIAGNOSTIC)
                memset(a, 0, bytes);
            continue;
        }
        if (v[k] < 0) {
            memset(a, 0, bytes); /* optional, restarts written before it */
            continue;
        }
        if ((st = rv_get(nc, v[k], f->type, start, count, a)) != NC_NOERR)
            return sph_err_set(err, SPH_ERR_BAD_DATA, "restart %s: variable %s: %s", path,
                               f->name, nc_strerror(st));
    }
    P->n = n;
    return SPH_OK;
}

int restart_read(const char *path, const char *expect_projection, restart_header *h,
                 sph_particles *P, sph_error *err)
{
    int nc, rc = open_restart(path, &nc, err);
    if (rc)
        return rc;
    rc = read_header_open(nc, path, h, err);
    if (rc == SPH_OK && expect_projection && strcmp(expect_projection, h->projection))
        rc = sph_err_set(err, SPH_ERR_CONFIG,
                         "restart %s: written on the plane \"%s\", the model uses \"%s\" "
                         "(domain or projection changed: start cold)", path, h->projection,
                         expect_projection);
    if (rc == SPH_OK)
        rc = read_body(nc, path, h, P, err);
    nc_close(nc);
    return rc;
}

int restart_read_ocean(const char *path, sph_ocean *o, int *found, sph_error *err)
{
    *found = 0;
    int nc, d_o, rc = open_restart(path, &nc, err);
    if (rc)
        return rc;
    if (nc_inq_dimid(nc, "ocean_cell", &d_o) != NC_NOERR) {
        nc_close(nc);
        return SPH_OK; /* written without the mixed layer */
    }
    size_t len = 0;
    double g[6], want[6];
    ocean_grid_values(o, want);
    nc_inq_dimlen(nc, d_o, &len);
    for (int a = 0; a < 6 && rc == SPH_OK; a++)
        rc = get_double_att(nc, path, ocean_grid_atts[a], &g[a], err);
    if (rc == SPH_OK && (len != o->ncell || memcmp(g, want, sizeof g) != 0))
        rc = sph_err_set(err, SPH_ERR_CONFIG,
                         "restart %s: the mixed layer was written on a %g x %g grid of %g x %g m cells from "
                         "(%g, %g), the model's is %g x %g of %g x %g m from (%g, %g) (model.ocean.cell or "
                         "the domain changed: start cold)", path, g[4], g[5], g[2], g[3], g[0], g[1], want[4],
                         want[5], want[2], want[3], want[0], want[1]);
    /* every variable checked before anything is read: a refusal changes nothing */
    int v[NOCEAN];
    for (size_t k = 0; k < NOCEAN && rc == SPH_OK; k++) {
        nc_type t;
        int nd, dim;
        int have = nc_inq_varid(nc, ocean_vars[k].name, &v[k]) == NC_NOERR;
        if (!have && k >= OCEAN_REQUIRED)
            v[k] = -1; /* absent: zero */
        else if (!have)
            rc = sph_err_set(err, SPH_ERR_MISSING_VAR, "restart %s: variable %s: missing (the file has "
                             "the dimension ocean_cell)", path, ocean_vars[k].name);
        else if (nc_inq_vartype(nc, v[k], &t) || nc_inq_varndims(nc, v[k], &nd) || nd != 1 ||
                 nc_inq_vardimid(nc, v[k], &dim) || dim != d_o || (t != NC_DOUBLE && t != NC_FLOAT))
            rc = sph_err_set(err, SPH_ERR_BAD_DATA, "restart %s: variable %s: want double (ocean_cell)", path,
                             ocean_vars[k].name);
    }
    double *tmp = rc == SPH_OK ? malloc(NOCEAN * o->ncell * sizeof(double)) : NULL;
    if (rc == SPH_OK && !tmp)
        rc = sph_err_set(err, SPH_ERR_NOMEM, "restart %s: out of memory (mixed layer)", path);
    for (size_t k = 0; k < NOCEAN && rc == SPH_OK; k++) {
        double *a = tmp + k * o->ncell;
        if (v[k] < 0) {
            memset(a, 0, o->ncell * sizeof(double));
            continue;
        }
        if (nc_get_var_double(nc, v[k], a) != NC_NOERR)
            rc = sph_err_set(err, SPH_ERR_BAD_DATA, "restart %s: variable %s: cannot be read", path,
                             ocean_vars[k].name);
        for (size_t c = 0; c < o->ncell && rc == SPH_OK; c++)
            if (!isfinite(a[c]))
                rc = sph_err_set(err, SPH_ERR_BAD_DATA, "restart %s: variable %s: cell %zu is not finite",
                                 path, ocean_vars[k].name, c);
    }
    if (rc == SPH_OK) {
        for (size_t k = 0; k < NOCEAN; k++)
            memcpy(ocean_array(o, k), tmp + k * o->ncell, o->ncell * sizeof(double));
        *found = 1;
    }
    free(tmp);
    nc_close(nc);
    return rc;
}
