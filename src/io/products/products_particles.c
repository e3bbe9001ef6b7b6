/* Particle trajectories: CF discrete sampling geometry, featureType
 * trajectory, indexed ragged array (CF 1.8 H.4.4): every observation names
 * its trajectory through trajectory_index; trajectories are appended as
 * new particle ids appear. Observations of one output time are contiguous
 * (one block per products_add_time), which products_read_particles uses. */
#include "products_impl.h"

#include <limits.h>
#include <math.h>
#include <netcdf.h>
#include <stdlib.h>
#include <string.h>

#include "core/particles.h"
#include "util/timeutil.h"

/* The file's variables: the coordinates time, lon, lat, then the particle
 * fields of SPH_PARTICLE_PRODUCT_FIELDS (core/particles.h), in its order. */
enum { PT_TIME, PT_LON, PT_LAT, PT_NCOORDS };
enum { PT_NVARS = PT_NCOORDS + SPH_PARTICLE_NPRODUCT_FIELDS };
/* sisnthick, the last field of SPH_PARTICLE_PRODUCT_FIELDS: written only
 * with opts.write_snow */
enum { PT_SNOW = PT_NVARS - 1 };
_Static_assert(PT_NVARS <= sizeof ((prod_writer *)0)->pt_v / sizeof(int),
               "prod_writer.pt_v holds every particle product variable");
#define PT_IS_FIELD_(field, ...)                                                \
    _Static_assert(sizeof ((sph_particles *)0)->field > 0, #field " is a particle field");
SPH_PARTICLE_PRODUCT_FIELDS(PT_IS_FIELD_)
#undef PT_IS_FIELD_

static const struct {
    const char *name, *standard_name, *long_name, *units;
} pt_specs[PT_NVARS] = {
    { "time", "time", "valid time", "seconds since 1970-01-01 00:00:00" },
    { "lon", "longitude", "particle longitude", "degrees_east" },
    { "lat", "latitude", "particle latitude", "degrees_north" },
#define PT_SPEC_(field, member, name, standard_name, long_name, units) \
    { name, standard_name, long_name, units },
    SPH_PARTICLE_PRODUCT_FIELDS(PT_SPEC_)
#undef PT_SPEC_
};

/* Bytes of chunk cache per variable: two chunks of 65536 doubles */
#define PT_CHUNK_CACHE ((size_t)2 * 65536 * sizeof(double))

#define NCP(call, what)                                                  \
    do {                                                                 \
        int st_ = (call);                                                \
        if (st_ != NC_NOERR)                                             \
            return prod_nc_check(st_, what, p->pt.tmp, err);            \
    } while (0)

int prod_particles_open(prod_writer *p, sph_error *err)
{
    if (!p->opts.write_particles)
        return SPH_OK;
    int rc = prod_file_init(p, &p->pt, "particles.nc", err);
    if (rc != SPH_OK)
        return rc;
    int st = nc_create(p->pt.tmp, NC_NETCDF4 | NC_CLOBBER, &p->pt_nc);
    if (st != NC_NOERR) {
        p->pt_nc = -1;
        return prod_nc_check(st, "create", p->pt.tmp, err);
    }
    int nc = p->pt_nc, d_obs, d_traj;
    NCP(nc_def_dim(nc, "obs", NC_UNLIMITED, &d_obs), "define dimension in");
    NCP(nc_def_dim(nc, "trajectory", NC_UNLIMITED, &d_traj), "define dimension in");
    NCP(nc_def_var(nc, "trajectory_id", NC_INT64, 1, &d_traj, &p->pt_v_tid), "define variable in");
    NCP(prod_put_text(nc, p->pt_v_tid, "cf_role", "trajectory_id"), "write attribute in");
    NCP(prod_put_text(nc, p->pt_v_tid, "long_name", "particle id"), "write attribute in");
    NCP(nc_def_var(nc, "trajectory_index", NC_INT, 1, &d_obs, &p->pt_v_tindex), "define variable in");
    NCP(prod_put_text(nc, p->pt_v_tindex, "instance_dimension", "trajectory"), "write attribute in");
    NCP(prod_put_text(nc, p->pt_v_tindex, "long_name", "index of the trajectory of this observation"),
        "write attribute in");
    size_t chunk = 65536;
    NCP(nc_def_var_chunking(nc, p->pt_v_tindex, NC_CHUNKED, &chunk), "set chunking in");
    /* Observations are appended and never read back while writing: a cache
     * of a few chunks per variable is all the writer needs (netCDF's default,
     * 16 MB per variable, held up to 180 MB at 1e6 particles); the file is the
     * same whatever the cache */
    NCP(nc_set_var_chunk_cache(nc, p->pt_v_tid, PT_CHUNK_CACHE, 31, 1.0f), "set chunk cache in");
    NCP(nc_set_var_chunk_cache(nc, p->pt_v_tindex, PT_CHUNK_CACHE, 31, 1.0f), "set chunk cache in");
    for (int k = 0; k < PT_NVARS; k++) {
        int type = k <= PT_LAT ? NC_DOUBLE : NC_FLOAT;
        if (k == PT_SNOW && !p->opts.write_snow)
            continue;
        NCP(nc_def_var(nc, pt_specs[k].name, type, 1, &d_obs, &p->pt_v[k]), "define variable in");
        int v = p->pt_v[k];
        NCP(nc_def_var_chunking(nc, v, NC_CHUNKED, &chunk), "set chunking in");
        NCP(nc_set_var_chunk_cache(nc, v, PT_CHUNK_CACHE, 31, 1.0f), "set chunk cache in");
        if (p->opts.deflate_level > 0)
            NCP(nc_def_var_deflate(nc, v, 1, 1, p->opts.deflate_level), "set deflate in");
        if (pt_specs[k].standard_name)
            NCP(prod_put_text(nc, v, "standard_name", pt_specs[k].standard_name), "write attribute in");
        NCP(prod_put_text(nc, v, "long_name", pt_specs[k].long_name), "write attribute in");
        NCP(prod_put_text(nc, v, "units", pt_specs[k].units), "write attribute in");
        if (k == PT_TIME) {
            NCP(prod_put_text(nc, v, "calendar", "standard"), "write attribute in");
            NCP(prod_put_text(nc, v, "axis", "T"), "write attribute in");
        } else if (k == PT_LON) {
            NCP(prod_put_text(nc, v, "axis", "X"), "write attribute in");
        } else if (k == PT_LAT) {
            NCP(prod_put_text(nc, v, "axis", "Y"), "write attribute in");
        } else {
            NCP(prod_put_text(nc, v, "coordinates", "time lat lon"), "write attribute in");
        }
    }
    NCP(prod_put_text(nc, NC_GLOBAL, "Conventions", "CF-1.8, ACDD-1.3"), "write attribute in");
    NCP(prod_put_text(nc, NC_GLOBAL, "featureType", "trajectory"), "write attribute in");
    NCP(prod_put_text(nc, NC_GLOBAL, "title", "sphice particle trajectories"), "write attribute in");
    NCP(prod_put_text(nc, NC_GLOBAL, "summary",
                      "Positions and state of the SPH ice particles at every output time "
                      "(indexed ragged array), for drift analysis and replay."),
        "write attribute in");
    NCP(prod_put_text(nc, NC_GLOBAL, "sphice_model_version", p->version), "write attribute in");
    NCP(prod_put_text(nc, NC_GLOBAL, "sphice_git_revision", p->gitrev), "write attribute in");
    char iso[32];
    time_format_iso(p->cycle_time, iso, sizeof iso);
    NCP(prod_put_text(nc, NC_GLOBAL, "sphice_cycle_time", iso), "write attribute in");
    NCP(nc_enddef(nc), "end definitions in");
    return SPH_OK;
}

static size_t hash_id(long id, size_t mask)
{
    unsigned long long x = (unsigned long long)id * 0x9E3779B97F4A7C15ULL;
    return (size_t)(x >> 17) & mask;
}

/* The hash rebuilt with ncap slots, without the ids below `below` (now in
 * the dense table). */
static int ids_rehash(prod_writer *p, size_t ncap, long below)
{
    id_slot *n = malloc(ncap * sizeof *n);
    if (!n)
        return -1;
    for (size_t k = 0; k < ncap; k++)
        n[k].index = -1;
    p->ids_used = 0;
    for (size_t k = 0; k < p->ids_cap; k++) {
        if (p->ids[k].index < 0 || (p->ids[k].id >= 0 && p->ids[k].id < below))
            continue;
        p->ids_used++;
        size_t h = hash_id(p->ids[k].id, ncap - 1);
        while (n[h].index >= 0)
            h = (h + 1) & (ncap - 1);
        n[h] = p->ids[k];
    }
    free(p->ids);
    p->ids = n;
    p->ids_cap = ncap;
    return 0;
}

/* The dense table grown to cover id (4 bytes per id instead of the hash's
 * 32 per trajectory: memory at 1e6 particles); the hash's ids it now
 * covers move into it. */
static int dense_grow(prod_writer *p, long id)
{
    size_t nn = p->dense_n ? 2 * p->dense_n : 4096;
    while (nn <= (size_t)id)
        nn *= 2;
    int *d = realloc(p->dense, nn * sizeof *d);
    if (!d)
        return -1;
    for (size_t k = p->dense_n; k < nn; k++)
        d[k] = -1;
    p->dense = d;
    p->dense_n = nn;
    size_t moved = 0;
    for (size_t k = 0; k < p->ids_cap; k++)
        if (p->ids[k].index >= 0 && p->ids[k].id >= 0 && (size_t)p->ids[k].id < nn) {
            d[p->ids[k].id] = (int)p->ids[k].index;
            moved++;
        }
    return moved ? ids_rehash(p, p->ids_cap, (long)nn) : 0;
}

/* Trajectory index of a particle id, appending a new trajectory if unseen:
 * ids from 0 up to about twice the trajectories (a seeding's, new ice's) in
 * a dense table, others in an open hash; the indices are the order in which
 * ids are first met either way. */
static long traj_index(prod_writer *p, long id, int *is_new)
{
    if (p->pt_ntraj >= INT_MAX)
        return -1;
    if (id >= 0 && (size_t)id >= p->dense_n && (size_t)id < 2 * (p->pt_ntraj + 1) + 4096 &&
        dense_grow(p, id) != 0)
        return -1;
    if (id >= 0 && (size_t)id < p->dense_n) {
        *is_new = p->dense[id] < 0;
        if (*is_new)
            p->dense[id] = (int)p->pt_ntraj++;
        return p->dense[id];
    }
    if (2 * (p->ids_used + 1) > p->ids_cap && ids_rehash(p, p->ids_cap ? 2 * p->ids_cap : 1024, 0) != 0)
        return -1;
    size_t mask = p->ids_cap - 1, h = hash_id(id, mask);
    while (p->ids[h].index >= 0) {
        if (p->ids[h].id == id) {
            *is_new = 0;
            return p->ids[h].index;
        }
        h = (h + 1) & mask;
    }
    p->ids[h].id = id;
    p->ids[h].index = (long)p->pt_ntraj++;
    p->ids_used++;
    *is_new = 1;
    return p->ids[h].index;
}

/* values per write of the time and the float fields (prod_particles_add) */
#define PT_CHUNK ((size_t)65536)

int prod_particles_add(prod_writer *p, double t, const prod_particles_view *pv, sph_error *err)
{
    if (!p->opts.write_particles || pv->n == 0)
        return SPH_OK;
    if (!pv->lon || !pv->lat || !pv->id)
        return sph_err_set(err, SPH_ERR_PARAM, "products: particles need lon, lat and id");
    size_t n = pv->n;
    /* the trajectory indices, the time and the float fields go out in
     * chunks of PT_CHUNK values (their work arrays: 16 bytes per particle
     * less at 1e6) */
    const size_t chunk = n < PT_CHUNK ? n : PT_CHUNK;
    int *tix = malloc(chunk * sizeof *tix);
    double *d = malloc(chunk * sizeof *d);
    float *f = malloc(chunk * sizeof *f);
    int rc = SPH_OK;
    if (!tix || !d || !f) {
        rc = sph_err_set(err, SPH_ERR_NOMEM, "products: out of memory (%zu particles)", n);
        goto done;
    }
    /* new trajectories take the next indices in the order met: their ids go
     * out in one write (one value at a time cost a second per 1e5 new ids) */
    size_t traj0 = p->pt_ntraj, nnew = 0;
    long long *newid = NULL;
    for (size_t k = 0; k < n && rc == SPH_OK; k++) {
        int is_new;
        long ti = traj_index(p, pv->id[k], &is_new);
        if (ti < 0) {
            rc = sph_err_set(err, SPH_ERR_NOMEM, "products: out of memory (particle ids)");
            break;
        }
        if (is_new) {
            if (!newid && !(newid = malloc((n - k) * sizeof *newid))) {
                rc = sph_err_set(err, SPH_ERR_NOMEM, "products: out of memory (%zu particles)", n);
                break;
            }
            newid[nnew++] = pv->id[k]; /* index traj0 + nnew - 1 */
        }
    }
    if (rc == SPH_OK && nnew) {
        int st = nc_put_vara_longlong(p->pt_nc, p->pt_v_tid, &traj0, &nnew, newid);
        if (st != NC_NOERR)
            rc = prod_nc_check(st, "write trajectory_id to", p->pt.tmp, err);
    }
    free(newid);
    if (rc != SPH_OK)
        goto done;
    size_t start = p->pt_nobs, count = n;
    int st = NC_NOERR;
    /* every id is known now: traj_index finds the index given above */
    for (size_t k0 = 0; k0 < n && st == NC_NOERR; k0 += chunk) {
        size_t s0 = start + k0, c0 = n - k0 < chunk ? n - k0 : chunk;
        for (size_t k = 0; k < c0; k++) {
            int is_new;
            long ti = traj_index(p, pv->id[k0 + k], &is_new);
            if (ti < 0) {
                rc = sph_err_set(err, SPH_ERR_NOMEM, "products: out of memory (particle ids)");
                goto done;
            }
            tix[k] = (int)ti;
        }
        st = nc_put_vara_int(p->pt_nc, p->pt_v_tindex, &s0, &c0, tix);
    }
    for (size_t k = 0; k < chunk; k++)
        d[k] = t;
    for (size_t k0 = 0; k0 < n && st == NC_NOERR; k0 += chunk) {
        size_t s0 = start + k0, c0 = n - k0 < chunk ? n - k0 : chunk;
        st = nc_put_vara_double(p->pt_nc, p->pt_v[PT_TIME], &s0, &c0, d);
    }
    if (st == NC_NOERR)
        st = nc_put_vara_double(p->pt_nc, p->pt_v[PT_LON], &start, &count, pv->lon);
    if (st == NC_NOERR)
        st = nc_put_vara_double(p->pt_nc, p->pt_v[PT_LAT], &start, &count, pv->lat);
#define PT_VIEW_(field, member, ...) pv->member,
    const double *src[PT_NVARS] = { NULL, NULL, NULL, SPH_PARTICLE_PRODUCT_FIELDS(PT_VIEW_) };
#undef PT_VIEW_
    for (int v = PT_NCOORDS; v < PT_NVARS && st == NC_NOERR; v++) {
        if (v == PT_SNOW && !p->opts.write_snow)
            continue;
        for (size_t k0 = 0; k0 < n && st == NC_NOERR; k0 += chunk) {
            size_t s0 = start + k0, c0 = n - k0 < chunk ? n - k0 : chunk;
            for (size_t k = 0; k < c0; k++)
                f[k] = src[v] && isfinite(src[v][k0 + k]) ? (float)src[v][k0 + k] : NC_FILL_FLOAT;
            st = nc_put_vara_float(p->pt_nc, p->pt_v[v], &s0, &c0, f);
        }
    }
    if (st != NC_NOERR)
        rc = prod_nc_check(st, "write particles to", p->pt.tmp, err);
    else
        p->pt_nobs += n;
done:
    free(tix);
    free(d);
    free(f);
    return rc;
}

int prod_particles_close(prod_writer *p, sph_error *err)
{
    if (!p->opts.write_particles)
        return SPH_OK;
    NCP(ncfile_close(&p->pt_nc), "close");
    return prod_file_commit(p, &p->pt, err);
}

void prod_particles_abort(prod_writer *p)
{
    (void)ncfile_close(&p->pt_nc);
    prod_file_discard(&p->pt);
}

void prod_particles_free(prod_particles *p)
{
    if (!p)
        return;
    free(p->lon);
    free(p->lat);
#define PT_FREE_(field, member, ...) free(p->member);
    SPH_PARTICLE_PRODUCT_FIELDS(PT_FREE_)
#undef PT_FREE_
    free(p->id);
    memset(p, 0, sizeof *p);
}

int products_read_particles(const char *path, double t, prod_particles *out, sph_error *err)
{
    memset(out, 0, sizeof *out);
    int nc, st = nc_open(path, NC_NOWRITE, &nc);
    if (st != NC_NOERR)
        return prod_nc_check(st, "open", path, err);
    int rc = SPH_OK, d_obs, v_time, v_tix, v_tid;
    size_t nobs = 0;
    double *times = NULL;
    int *tix = NULL;
    long long *tid = NULL;
    float *fb = NULL;
    st = nc_inq_dimid(nc, "obs", &d_obs);
    if (st == NC_NOERR)
        st = nc_inq_dimlen(nc, d_obs, &nobs);
    if (st == NC_NOERR)
        st = nc_inq_varid(nc, "time", &v_time);
    if (st == NC_NOERR)
        st = nc_inq_varid(nc, "trajectory_index", &v_tix);
    if (st == NC_NOERR)
        st = nc_inq_varid(nc, "trajectory_id", &v_tid);
    if (st != NC_NOERR) {
        rc = prod_nc_check(st, "read particle file (not an sphice trajectory file?)", path, err);
        goto done;
    }
    if (nobs == 0) {
        rc = sph_err_set(err, SPH_ERR_BAD_DATA, "read %s: no particle observations", path);
        goto done;
    }
    times = malloc(nobs * sizeof *times);
    if (!times) {
        rc = sph_err_set(err, SPH_ERR_NOMEM, "read %s: out of memory", path);
        goto done;
    }
    if ((st = nc_get_var_double(nc, v_time, times)) != NC_NOERR) {
        rc = prod_nc_check(st, "read time from", path, err);
        goto done;
    }
    double want = isnan(t) ? times[nobs - 1] : t;
    size_t a = nobs, b = 0;
    for (size_t k = 0; k < nobs; k++)
        if (fabs(times[k] - want) <= 0.5) {
            if (a == nobs)
                a = k;
            b = k + 1;
        }
    if (a == nobs) {
        char iso[32];
        time_format_iso(want, iso, sizeof iso);
        rc = sph_err_set(err, SPH_ERR_COVERAGE, "read %s: no particles at %s", path, iso);
        goto done;
    }
    size_t n = b - a, ntraj = 0;
    int d_traj;
    st = nc_inq_dimid(nc, "trajectory", &d_traj);
    if (st == NC_NOERR)
        st = nc_inq_dimlen(nc, d_traj, &ntraj);
    out->n = n;
    out->time = want;
    out->lon = malloc(n * sizeof(double));
    out->lat = malloc(n * sizeof(double));
    int fields_ok = 1;
#define PT_ALLOC_(field, member, ...) \
    fields_ok &= (out->member = malloc(n * sizeof(double))) != NULL;
    SPH_PARTICLE_PRODUCT_FIELDS(PT_ALLOC_)
#undef PT_ALLOC_
    out->id = malloc(n * sizeof(long));
    tix = malloc(n * sizeof *tix);
    tid = malloc((ntraj ? ntraj : 1) * sizeof *tid);
    fb = malloc(n * sizeof *fb);
    if (!out->lon || !out->lat || !fields_ok || !out->id || !tix || !tid || !fb) {
        rc = sph_err_set(err, SPH_ERR_NOMEM, "read %s: out of memory", path);
        goto done;
    }
    int v_lon, v_lat;
    if (st == NC_NOERR)
        st = nc_get_vara_int(nc, v_tix, &a, &n, tix);
    if (st == NC_NOERR && ntraj)
        st = nc_get_var_longlong(nc, v_tid, tid);
    if (st == NC_NOERR)
        st = nc_inq_varid(nc, "lon", &v_lon);
    if (st == NC_NOERR)
        st = nc_get_vara_double(nc, v_lon, &a, &n, out->lon);
    if (st == NC_NOERR)
        st = nc_inq_varid(nc, "lat", &v_lat);
    if (st == NC_NOERR)
        st = nc_get_vara_double(nc, v_lat, &a, &n, out->lat);
#define PT_DST_(field, member, ...) out->member,
    double *dst[SPH_PARTICLE_NPRODUCT_FIELDS] = { SPH_PARTICLE_PRODUCT_FIELDS(PT_DST_) };
#undef PT_DST_
    for (int q = 0; q < SPH_PARTICLE_NPRODUCT_FIELDS && st == NC_NOERR; q++) {
        int v;
        st = nc_inq_varid(nc, pt_specs[PT_NCOORDS + q].name, &v);
        if (st == NC_ENOTVAR && PT_NCOORDS + q == PT_SNOW) { /* written without snow */
            st = NC_NOERR;
            for (size_t k = 0; k < n; k++)
                dst[q][k] = NAN;
            continue;
        }
        if (st == NC_NOERR)
            st = nc_get_vara_float(nc, v, &a, &n, fb);
        for (size_t k = 0; k < n && st == NC_NOERR; k++)
            dst[q][k] = fb[k] == NC_FILL_FLOAT ? NAN : fb[k];
    }
    if (st != NC_NOERR) {
        rc = prod_nc_check(st, "read particles from", path, err);
        goto done;
    }
    for (size_t k = 0; k < n; k++) {
        if (tix[k] < 0 || (size_t)tix[k] >= ntraj) {
            rc = sph_err_set(err, SPH_ERR_BAD_DATA, "read %s: trajectory_index %d out of range",
                             path, tix[k]);
            goto done;
        }
        out->id[k] = (long)tid[tix[k]];
    }
done:
    nc_close(nc);
    free(times);
    free(tix);
    free(tid);
    free(fb);
    if (rc != SPH_OK)
        prod_particles_free(out);
    return rc;
}
