/* The guards in front of nc_open (io/nc_guard.h).
 *
 * Classic: a CDF-1 file is written here byte by byte from the NetCDF
 * classic format specification (magic, numrecs, dim_list, gatt_list,
 * var_list, big-endian, names and values padded to 4 bytes), first read
 * back with libnetcdf itself to show the writer follows the format, then
 * broken one field at a time: each break must be refused by the validator
 * and by the doors the readers use (nc_guard_open, the restart reader),
 * naming the file and the field, before libnetcdf sees it (libnetcdf
 * 4.9.0 allocates what such headers declare and crashed on some under the
 * fuzzer). Files libnetcdf writes in CDF-1, CDF-2 and CDF-5 are accepted,
 * and the size the validator says a complete file has is the size
 * libnetcdf wrote (less at most 3 bytes of padding of the last variable).
 *
 * netCDF-4: a file libnetcdf writes (groups, a string attribute) passes
 * the checking child; a child that dies (here: the child hook raises
 * SIGSEGV, as HDF5 1.10.8 does on some files, netcdf-c #2667) or hangs
 * past the deadline gets the file refused in one line; a file with the
 * HDF5 signature and garbage after it is left to nc_open's own error.
 * Prints the cost of the check per file against a plain nc_open. */
#include <glob.h>
#include <netcdf.h>
#include <signal.h>
#include <stdint.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "io/nc_guard.h"
#include "io/restart.h"

#include "check.h"

static char dir[256];

static void put32(unsigned char *b, size_t *n, uint32_t v)
{
    b[(*n)++] = (unsigned char)(v >> 24);
    b[(*n)++] = (unsigned char)(v >> 16);
    b[(*n)++] = (unsigned char)(v >> 8);
    b[(*n)++] = (unsigned char)v;
}

static void set32(unsigned char *b, size_t at, uint32_t v)
{
    size_t n = at;
    put32(b, &n, v);
}

static void put_name(unsigned char *b, size_t *n, const char *s)
{
    size_t len = strlen(s);
    put32(b, n, (uint32_t)len);
    memcpy(b + *n, s, len);
    *n += len;
    while (*n % 4)
        b[(*n)++] = 0;
}

/* offsets of the fields the cases break */
typedef struct {
    size_t numrecs, ndims, dim1_len, gatt_tag, gatt_nelems, var0_namelen, var0_vatt_tag,
        var0_vatt_n, var0_type, var0_vsize, var0_begin, var1_dimid1;
    size_t size;
} layout;

/* dims time (record) and x = 3; global title = "ok"; float c(x) =
 * {1.5, 2.5, -3}; short r(time, x) with units "m", two records
 * {1, 2, 3}, {4, 5, 6} (a lone record variable: records not padded) */
static size_t build_cdf1(unsigned char *b, layout *L)
{
    size_t n = 0;
    memcpy(b, "CDF\001", 4);
    n = 4;
    L->numrecs = n;
    put32(b, &n, 2);
    put32(b, &n, 0x0A);
    L->ndims = n;
    put32(b, &n, 2);
    put_name(b, &n, "time");
    put32(b, &n, 0);
    put_name(b, &n, "x");
    L->dim1_len = n;
    put32(b, &n, 3);
    L->gatt_tag = n;
    put32(b, &n, 0x0C);
    put32(b, &n, 1);
    put_name(b, &n, "title");
    put32(b, &n, NC_CHAR);
    L->gatt_nelems = n;
    put32(b, &n, 2);
    memcpy(b + n, "ok\0\0", 4);
    n += 4;
    put32(b, &n, 0x0B);
    put32(b, &n, 2);
    L->var0_namelen = n;
    put_name(b, &n, "c");
    put32(b, &n, 1);
    put32(b, &n, 1);
    L->var0_vatt_tag = n;
    put32(b, &n, 0);
    L->var0_vatt_n = n;
    put32(b, &n, 0);
    L->var0_type = n;
    put32(b, &n, NC_FLOAT);
    L->var0_vsize = n;
    put32(b, &n, 12);
    L->var0_begin = n;
    put32(b, &n, 0); /* set below */
    put_name(b, &n, "r");
    put32(b, &n, 2);
    put32(b, &n, 0);
    L->var1_dimid1 = n;
    put32(b, &n, 1);
    put32(b, &n, 0x0C);
    put32(b, &n, 1);
    put_name(b, &n, "units");
    put32(b, &n, NC_CHAR);
    put32(b, &n, 1);
    memcpy(b + n, "m\0\0\0", 4);
    n += 4;
    put32(b, &n, NC_SHORT);
    put32(b, &n, 8); /* 3 shorts, padded */
    size_t var1_begin = n;
    put32(b, &n, 0);
    size_t header = n;
    set32(b, L->var0_begin, (uint32_t)header);
    set32(b, var1_begin, (uint32_t)(header + 12));
    float c[3] = {1.5f, 2.5f, -3.0f};
    for (int k = 0; k < 3; k++) {
        uint32_t u;
        memcpy(&u, &c[k], 4);
        put32(b, &n, u);
    }
    for (int k = 1; k <= 6; k++) {
        b[n++] = 0;
        b[n++] = (unsigned char)k;
    }
    L->size = n;
    return n;
}

static void write_file(const char *path, const unsigned char *b, size_t n)
{
    FILE *f = fopen(path, "wb");
    CHECK(f && fwrite(b, 1, n, f) == n && fclose(f) == 0, "write %s", path);
}

static void hand_written_valid(const unsigned char *b, const layout *L)
{
    char path[512];
    snprintf(path, sizeof path, "%s/valid.nc", dir);
    write_file(path, b, L->size);
    /* libnetcdf reads what the spec says was written */
    int nc, vc, vr;
    CHECK(nc_open(path, NC_NOWRITE, &nc) == NC_NOERR, "libnetcdf opens the hand-written file");
    float c[3] = {0};
    short r[6] = {0};
    size_t nrec = 0;
    int unl = -1;
    CHECK(nc_inq_varid(nc, "c", &vc) == NC_NOERR && nc_get_var_float(nc, vc, c) == NC_NOERR &&
              c[0] == 1.5f && c[1] == 2.5f && c[2] == -3.0f,
          "c = {1.5, 2.5, -3}: %g %g %g", c[0], c[1], c[2]);
    CHECK(nc_inq_unlimdim(nc, &unl) == NC_NOERR && nc_inq_dimlen(nc, unl, &nrec) == NC_NOERR &&
              nrec == 2, "two records (%zu)", nrec);
    CHECK(nc_inq_varid(nc, "r", &vr) == NC_NOERR && nc_get_var_short(nc, vr, r) == NC_NOERR &&
              r[0] == 1 && r[2] == 3 && r[3] == 4 && r[5] == 6,
          "r = {1..6}: %d %d %d %d", r[0], r[2], r[3], r[5]);
    nc_close(nc);
    uint64_t need = 0;
    char why[400];
    CHECK(nc_guard_classic(b, L->size, L->size, &need, why, sizeof why) == 0, "valid: %s", why);
    CHECK(need == L->size, "a complete file: need %llu = %zu bytes", (unsigned long long)need,
          L->size);
    sph_error e;
    sph_error_clear(&e);
    CHECK(nc_guard_check(path, NULL, &e) == SPH_OK, "valid file passes the door: %s", e.msg);
}

typedef struct {
    const char *what;
    size_t *field; /* into a layout */
    uint32_t value;
    long cut; /* bytes cut from the end */
    const char *want;
} breakage;

static void broken_headers(const unsigned char *good, const layout *L0)
{
    layout L = *L0;
    breakage cases[] = {
        {"numrecs beyond the file's bytes", &L.numrecs, 0x7FFFFFFF, 0, "numrecs is 2147483647"},
        {"numrecs negative", &L.numrecs, 0x80000000u, 0, "negative"},
        {"16.7 million dimensions (the fuzzer's forcing crash)", &L.ndims, 0x00FF0400, 0,
         "the dimension list counts 16712704"},
        {"an attribute of 2^31 - 16 characters", &L.gatt_nelems, 0x7FFFFFF0, 0,
         "attribute 0 of the file (global) declares 2147483632 values"},
        {"a name of 300 bytes", &L.var0_namelen, 300, 0, "variable 0 has a name of 300 bytes"},
        {"a dimension id beyond the list", &L.var1_dimid1, 7, 0, "dimension id 7"},
        {"type 12", &L.var0_type, 12, 0, "type 12"},
        {"CDF-5's ubyte in CDF-1", &L.var0_type, NC_UBYTE, 0, "type 7"},
        {"begin past the end", &L.var0_begin, 1000000, 0, "past the end of the file"},
        {"begin inside the header", &L.var0_begin, 8, 0, "inside the header"},
        {"a second record dimension", &L.dim1_len, 0, 0, "second record"},
        {"a wrong list tag", &L.gatt_tag, 0x0D, 0, "tag 0xd"},
        {"an absent list with a count", &L.var0_vatt_n, 5, 0, "absent (tag 0) but counts 5"},
        {"a vsize beyond shape and file", &L.var0_vsize, 0x7FFF0000, 0, "vsize 2147418112"},
        {"the last record cut short", NULL, 0, 4, "truncated NetCDF file"},
    };
    unsigned char buf[1024];
    char path[512];
    snprintf(path, sizeof path, "%s/broken.nc", dir);
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        memcpy(buf, good, L0->size);
        size_t n = L0->size - (size_t)cases[k].cut;
        if (cases[k].field)
            set32(buf, *cases[k].field, cases[k].value);
        uint64_t need = 0;
        char why[400] = "";
        int rc = nc_guard_classic(buf, n, n, &need, why, sizeof why);
        if (cases[k].cut)
            CHECK(rc == 0 && need > n, "%s: header valid, %llu bytes needed, %zu there",
                  cases[k].what, (unsigned long long)need, n);
        else
            CHECK(rc != 0 && strstr(why, cases[k].want), "%s: refused naming the field (want '%s'): %s",
                  cases[k].what, cases[k].want, why);
        write_file(path, buf, n);
        sph_error e;
        sph_error_clear(&e);
        int ncid = -1;
        rc = nc_guard_open(path, "test file", &ncid, &e);
        CHECK(rc == SPH_ERR_NETCDF && strstr(e.msg, "test file: ") && strstr(e.msg, cases[k].want) &&
                  !strchr(e.msg, '\n'),
              "%s: nc_guard_open refuses in one line (rc %d): %s", cases[k].what, rc, e.msg);
        if (rc == SPH_OK)
            nc_close(ncid);
        /* the restart reader goes through the same door */
        restart_header h;
        sph_error_clear(&e);
        rc = restart_read_header(path, &h, &e);
        CHECK(rc == SPH_ERR_NETCDF && strstr(e.msg, path) && strstr(e.msg, cases[k].want),
              "%s: the restart reader refuses naming file and field (rc %d): %s", cases[k].what, rc,
              e.msg);
    }
    unlink(path);
}

/* files libnetcdf writes in each classic flavour */
static void library_written(void)
{
    const int modes[3] = {NC_CLOBBER, NC_CLOBBER | NC_64BIT_OFFSET, NC_CLOBBER | NC_64BIT_DATA};
    const char *names[3] = {"CDF-1", "CDF-2", "CDF-5"};
    for (int m = 0; m < 3; m++) {
        char path[512];
        snprintf(path, sizeof path, "%s/lib%d.nc", dir, m);
        int nc, dt, dx, dy, v1, v2, v3, v4, dims[3];
        int ok = nc_create(path, modes[m], &nc) == NC_NOERR;
        ok = ok && nc_def_dim(nc, "time", NC_UNLIMITED, &dt) == NC_NOERR &&
             nc_def_dim(nc, "y", 5, &dy) == NC_NOERR && nc_def_dim(nc, "x", 7, &dx) == NC_NOERR;
        double vals[3] = {1, 2, 3};
        ok = ok && nc_put_att_text(nc, NC_GLOBAL, "title", 4, "test") == NC_NOERR &&
             nc_put_att_double(nc, NC_GLOBAL, "vals", NC_DOUBLE, 3, vals) == NC_NOERR;
        dims[0] = dt, dims[1] = dy, dims[2] = dx;
        ok = ok && nc_def_var(nc, "lat", NC_FLOAT, 1, &dims[1], &v1) == NC_NOERR &&
             nc_def_var(nc, "u", NC_FLOAT, 3, dims, &v2) == NC_NOERR &&
             nc_def_var(nc, "flag", NC_BYTE, 3, dims, &v3) == NC_NOERR &&
             nc_def_var(nc, "scalar", NC_DOUBLE, 0, NULL, &v4) == NC_NOERR &&
             nc_put_att_text(nc, v2, "units", 5, "m s-1") == NC_NOERR && nc_enddef(nc) == NC_NOERR;
        float lat[5] = {40, 40.5f, 41, 41.5f, 42}, u[3 * 35];
        signed char fl[3 * 35];
        for (int k = 0; k < 3 * 35; k++)
            u[k] = (float)k, fl[k] = (signed char)(k % 100);
        size_t st[3] = {0, 0, 0}, ct[3] = {3, 5, 7};
        double one = 1.0;
        ok = ok && nc_put_var_float(nc, v1, lat) == NC_NOERR &&
             nc_put_vara_float(nc, v2, st, ct, u) == NC_NOERR &&
             nc_put_vara_schar(nc, v3, st, ct, fl) == NC_NOERR && nc_put_var_double(nc, v4, &one) == NC_NOERR;
        ok = nc_close(nc) == NC_NOERR && ok;
        CHECK(ok, "%s written by libnetcdf", names[m]);
        struct stat sb;
        FILE *f = fopen(path, "rb");
        unsigned char *buf = NULL;
        size_t n = 0;
        if (f && stat(path, &sb) == 0 && (buf = malloc((size_t)sb.st_size))) {
            n = fread(buf, 1, (size_t)sb.st_size, f);
        }
        if (f)
            fclose(f);
        uint64_t need = 0;
        char why[400] = "";
        CHECK(buf && nc_guard_classic(buf, n, n, &need, why, sizeof why) == 0, "%s accepted: %s",
              names[m], why);
        /* the file ends with the last record's last variable, padded to 4 */
        CHECK(need <= n && n - need <= 3, "%s: needs %llu bytes, libnetcdf wrote %zu", names[m],
              (unsigned long long)need, n);
        sph_error e;
        sph_error_clear(&e);
        CHECK(nc_guard_check(path, NULL, &e) == SPH_OK, "%s passes the door: %s", names[m], e.msg);
        free(buf);
        unlink(path);
    }
}

static void die_in_child(void) { raise(SIGSEGV); }
static void hang_in_child(void) { sleep(30); }

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void netcdf4(void)
{
    char path[512];
    snprintf(path, sizeof path, "%s/nc4.nc", dir);
    int nc, g, dx, v;
    int ok = nc_create(path, NC_CLOBBER | NC_NETCDF4, &nc) == NC_NOERR &&
             nc_def_grp(nc, "sub", &g) == NC_NOERR && nc_def_dim(nc, "x", 10, &dx) == NC_NOERR &&
             nc_def_var(g, "t", NC_DOUBLE, 1, &dx, &v) == NC_NOERR;
    const char *s[1] = {"a string attribute"};
    ok = ok && nc_put_att_string(nc, NC_GLOBAL, "note", 1, s) == NC_NOERR && nc_enddef(nc) == NC_NOERR;
    double t[10] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9};
    ok = ok && nc_put_var_double(g, v, t) == NC_NOERR;
    ok = nc_close(nc) == NC_NOERR && ok;
    CHECK(ok, "netCDF-4 file written");
    long p0, d0, t0, p1, d1, t1;
    nc_guard_stats(&p0, &d0, &t0);
    sph_error e;
    sph_error_clear(&e);
    CHECK(nc_guard_check(path, NULL, &e) == SPH_OK, "a valid netCDF-4 file passes: %s", e.msg);
    nc_guard_stats(&p1, &d1, &t1);
    CHECK(p1 == p0 + 1 && d1 == d0 && t1 == t0, "checked in one child (%ld -> %ld), none died",
          p0, p1);

    /* the library dies in the child: the file is refused, this process lives */
    nc_guard_set_child_hook(die_in_child);
    sph_error_clear(&e);
    int ncid = -1;
    int rc = nc_guard_open(path, "forcing x.nc", &ncid, &e);
    nc_guard_set_child_hook(NULL);
    CHECK(rc == SPH_ERR_NETCDF && strstr(e.msg, "forcing x.nc: refused") &&
              strstr(e.msg, "crashed (signal 11") && !strchr(e.msg, '\n'),
          "a dying child refuses the file in one line (rc %d): %s", rc, e.msg);
    nc_guard_stats(&p1, &d1, &t1);
    CHECK(d1 == d0 + 1, "counted as died (%ld)", d1);

    /* the library hangs in the child: refused at the deadline */
    nc_guard_set_child_hook(hang_in_child);
    nc_guard_set_timeout(0.5);
    sph_error_clear(&e);
    double a = now();
    rc = nc_guard_check(path, NULL, &e);
    double took = now() - a;
    nc_guard_set_child_hook(NULL);
    nc_guard_set_timeout(20);
    CHECK(rc == SPH_ERR_NETCDF && strstr(e.msg, path) && strstr(e.msg, "did not finish"),
          "a hanging child refuses the file (rc %d): %s", rc, e.msg);
    CHECK(took >= 0.5 && took < 5.0, "refused at the 0.5 s deadline (%.2f s)", took);

    /* HDF5's signature then garbage: nc_open's own error, one line */
    char junk[512];
    snprintf(junk, sizeof junk, "%s/junk.nc", dir);
    unsigned char b[4096];
    memcpy(b, "\211HDF\r\n\032\n", 8);
    for (size_t k = 8; k < sizeof b; k++)
        b[k] = (unsigned char)(k * 37u + 11u);
    write_file(junk, b, sizeof b);
    sph_error_clear(&e);
    rc = nc_guard_open(junk, NULL, &ncid, &e);
    CHECK(rc == SPH_ERR_NETCDF && strstr(e.msg, "cannot open as NetCDF") && strstr(e.msg, junk),
          "HDF5 garbage: nc_open's error (rc %d): %s", rc, e.msg);
    unlink(junk);

    /* the cost of the check per file, against a plain nc_open + nc_close */
    enum { N = 30 };
    a = now();
    for (int k = 0; k < N; k++) {
        if (nc_open(path, NC_NOWRITE, &ncid) == NC_NOERR)
            nc_close(ncid);
    }
    double plain = (now() - a) / N;
    a = now();
    int fails = 0;
    for (int k = 0; k < N; k++) {
        sph_error_clear(&e);
        fails += nc_guard_check(path, NULL, &e) != SPH_OK;
    }
    double guarded = (now() - a) / N;
    CHECK(fails == 0, "%d of %d checks failed", fails, N);
    printf("nc_guard: netCDF-4 check %.2f ms per file (fork, open, walk, data), plain nc_open+close "
           "%.2f ms\n", 1e3 * guarded, 1e3 * plain);
    unlink(path);
}

/* nc_guard_open_isolated: a flat netCDF-4 file (compressed, with an
 * unlimited dimension, several types and attributes) is read through a
 * CDF-5 copy made by a separate process: the handle this process gets is
 * classic (HDF5 never opened the file here), the data and attributes are
 * the file's bit for bit; a dying copier, groups, and garbage after the
 * HDF5 signature are refused in one line; a classic file opens as before. */
static void isolated(void)
{
    setenv("TMPDIR", dir, 1);
    char path[512];
    snprintf(path, sizeof path, "%s/flat4.nc", dir);
    int nc, dt, dn, vx, vi, vb;
    double x[3][5];
    long long ids[5] = {1, -2, 3000000000LL, 4, 5};
    unsigned char fl[5] = {0, 1, 2, 255, 7};
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 5; k++)
            x[i][k] = 0.1 * i + 1e-3 * k - 7.25;
    int dims[2];
    int ok = nc_create(path, NC_CLOBBER | NC_NETCDF4, &nc) == NC_NOERR && nc_def_dim(nc, "time", NC_UNLIMITED, &dt) == NC_NOERR &&
             nc_def_dim(nc, "n", 5, &dn) == NC_NOERR;
    dims[0] = dt;
    dims[1] = dn;
    ok = ok && nc_def_var(nc, "x", NC_DOUBLE, 2, dims, &vx) == NC_NOERR && nc_def_var_deflate(nc, vx, 1, 1, 4) == NC_NOERR &&
         nc_def_var(nc, "id", NC_INT64, 1, &dn, &vi) == NC_NOERR && nc_def_var(nc, "flag", NC_UBYTE, 1, &dn, &vb) == NC_NOERR &&
         nc_put_att_text(nc, vx, "units", 1, "m") == NC_NOERR && nc_put_att_text(nc, NC_GLOBAL, "title", 4, "flat") == NC_NOERR;
    double fill = -9e33;
    ok = ok && nc_put_att_double(nc, vx, "_FillValue", NC_DOUBLE, 1, &fill) == NC_NOERR && nc_enddef(nc) == NC_NOERR;
    size_t st[2] = {0, 0}, ct[2] = {3, 5};
    ok = ok && nc_put_vara_double(nc, vx, st, ct, &x[0][0]) == NC_NOERR && nc_put_var_longlong(nc, vi, ids) == NC_NOERR &&
         nc_put_var_uchar(nc, vb, fl) == NC_NOERR;
    ok = nc_close(nc) == NC_NOERR && ok;
    CHECK(ok, "flat netCDF-4 file written");
    sph_error e;
    sph_error_clear(&e);
    int id = -1;
    int rc = nc_guard_open_isolated(path, "restart r.nc", &id, &e);
    CHECK(rc == SPH_OK, "isolated open: %s", e.msg);
    if (rc == SPH_OK) {
        int fmt = -1;
        nc_inq_format(id, &fmt);
        CHECK(fmt == NC_FORMAT_CDF5, "the handle here is a CDF-5 copy (format %d), not the HDF5 file", fmt);
        double y[3][5];
        long long gi[5];
        unsigned char gf[5];
        char units[8] = "", title[8] = "";
        size_t len = 0;
        int vy, vj, vc, ul = -1;
        ok = nc_inq_varid(id, "x", &vy) == NC_NOERR && nc_get_var_double(id, vy, &y[0][0]) == NC_NOERR &&
             nc_inq_varid(id, "id", &vj) == NC_NOERR && nc_get_var_longlong(id, vj, gi) == NC_NOERR &&
             nc_inq_varid(id, "flag", &vc) == NC_NOERR && nc_get_var_uchar(id, vc, gf) == NC_NOERR &&
             nc_get_att_text(id, vy, "units", units) == NC_NOERR && nc_get_att_text(id, NC_GLOBAL, "title", title) == NC_NOERR &&
             nc_inq_unlimdim(id, &ul) == NC_NOERR && nc_inq_dimlen(id, ul, &len) == NC_NOERR;
        CHECK(ok && !memcmp(x, y, sizeof x) && !memcmp(ids, gi, sizeof ids) && !memcmp(fl, gf, sizeof fl) &&
                  !strcmp(units, "m") && !strcmp(title, "flat") && len == 3,
              "data, attributes and the unlimited dimension are the file's bit for bit");
        nc_close(id);
    }
    /* the copier dies: refused, this process lives */
    nc_guard_set_child_hook(die_in_child);
    sph_error_clear(&e);
    rc = nc_guard_open_isolated(path, "restart r.nc", &id, &e);
    nc_guard_set_child_hook(NULL);
    CHECK(rc == SPH_ERR_NETCDF && strstr(e.msg, "restart r.nc: refused") && strstr(e.msg, "crashed (signal 11") &&
              !strchr(e.msg, '\n'),
          "a dying copier refuses the file in one line: %s", e.msg);
    /* groups (the netCDF-4 file of netcdf4()): refused, named */
    char grp[512];
    snprintf(grp, sizeof grp, "%s/grp4.nc", dir);
    int g, gd, gv;
    ok = nc_create(grp, NC_CLOBBER | NC_NETCDF4, &nc) == NC_NOERR && nc_def_grp(nc, "sub", &g) == NC_NOERR &&
         nc_def_dim(g, "x", 2, &gd) == NC_NOERR && nc_def_var(g, "t", NC_INT, 1, &gd, &gv) == NC_NOERR;
    ok = nc_close(nc) == NC_NOERR && ok;
    sph_error_clear(&e);
    rc = ok ? nc_guard_open_isolated(grp, "restart g.nc", &id, &e) : -1;
    CHECK(rc == SPH_ERR_NETCDF && strstr(e.msg, "restart g.nc: refused: groups"), "groups refused: %s", e.msg);
    /* HDF5's signature then garbage */
    char junk[512];
    snprintf(junk, sizeof junk, "%s/junk4.nc", dir);
    unsigned char b[4096];
    memcpy(b, "\211HDF\r\n\032\n", 8);
    for (size_t k = 8; k < sizeof b; k++)
        b[k] = (unsigned char)(k * 53u + 5u);
    write_file(junk, b, sizeof b);
    sph_error_clear(&e);
    rc = nc_guard_open_isolated(junk, NULL, &id, &e);
    CHECK(rc == SPH_ERR_NETCDF && strstr(e.msg, junk) && strstr(e.msg, "refused") && !strchr(e.msg, '\n'),
          "HDF5 garbage refused in one line: %s", e.msg);
    /* no temporary copy left behind (TMPDIR is this test's folder) */
    char pat[600];
    snprintf(pat, sizeof pat, "%s/sphice-ncread-*", dir);
    glob_t gl;
    int left = glob(pat, 0, NULL, &gl) == 0 ? (int)gl.gl_pathc : 0;
    if (left)
        globfree(&gl);
    CHECK(left == 0, "no temporary copy left (%d)", left);
    unlink(junk);
    unlink(grp);
    unlink(path);
}

int main(void)
{
    snprintf(dir, sizeof dir, "/tmp/test_nc_guard.%d", (int)getpid());
    mkdir(dir, 0700);
    unsigned char good[1024];
    layout L;
    build_cdf1(good, &L);
    hand_written_valid(good, &L);
    broken_headers(good, &L);
    library_written();
    netcdf4();
    isolated();
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd) != 0)
        printf("note: could not remove %s\n", dir);
    return check_summary("test_nc_guard");
}
