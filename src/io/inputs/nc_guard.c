/* Guards around nc_open for files from outside: see io/nc_guard.h.
 *
 * The classic layout (NetCDF User Guide, "The NetCDF Classic Format
 * Specification"; CDF-5: "CDF-5 format specifications", PnetCDF):
 *   netcdf_file = header data
 *   header      = magic numrecs dim_list gatt_list var_list
 *   magic       = 'C' 'D' 'F' VERSION (1, 2 or 5)
 *   numrecs     = NON_NEG | STREAMING (all bits set)
 *   dim_list    = ABSENT | NC_DIMENSION nelems [dim ...]
 *   att_list    = ABSENT | NC_ATTRIBUTE nelems [attr ...]
 *   var_list    = ABSENT | NC_VARIABLE nelems [var ...]
 *   ABSENT      = ZERO ZERO
 *   dim         = name dim_length          (0: the record dimension)
 *   attr        = name nc_type nelems [values ...] (padded to 4 bytes)
 *   var         = name nelems [dimid ...] vatt_list nc_type vsize begin
 *   name        = nelems namestring        (padded to 4 bytes)
 * Big-endian. Tags and nc_type are 32-bit; nelems, lengths, dimids and
 * vsize are 32-bit (NON_NEG: at most 2^31 - 1) in CDF-1 and CDF-2 and
 * 64-bit in CDF-5; begin is 32-bit in CDF-1, 64-bit in CDF-2 and CDF-5.
 * CDF-1 and CDF-2 have the six classic types, CDF-5 also types 7 to 11. */
#include "io/nc_guard.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <netcdf.h>
#include <limits.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

/* ------------------------------------------------------------ classic */

typedef struct {
    const unsigned char *base, *p, *end;
    int version;
    uint64_t file_size;
    int bad;
    char *why;
    size_t whysz;
} hdr;

static void fail(hdr *h, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void fail(hdr *h, const char *fmt, ...)
{
    if (h->bad)
        return;
    h->bad = 1;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(h->why, h->whysz, fmt, ap);
    va_end(ap);
}

static uint64_t left(const hdr *h) { return (uint64_t)(h->end - h->p); }
static uint64_t at(const hdr *h) { return (uint64_t)(h->p - h->base); }

static uint64_t get_be(hdr *h, int bytes, const char *what)
{
    if (h->bad)
        return 0;
    if (left(h) < (uint64_t)bytes) {
        fail(h, "the header ends inside %s at byte %llu", what, (unsigned long long)at(h));
        return 0;
    }
    uint64_t v = 0;
    for (int k = 0; k < bytes; k++)
        v = (v << 8) | *h->p++;
    return v;
}

/* NON_NEG: a count, length, dimid or vsize */
static uint64_t get_nonneg(hdr *h, const char *what)
{
    uint64_t v = get_be(h, h->version == 5 ? 8 : 4, what);
    uint64_t max = h->version == 5 ? (uint64_t)INT64_MAX : (uint64_t)INT32_MAX;
    if (!h->bad && v > max)
        fail(h, "%s is %llu (negative as a signed %d-bit value) at byte %llu", what,
             (unsigned long long)v, h->version == 5 ? 64 : 32, (unsigned long long)(at(h) - 1));
    return v;
}

/* n bytes and their padding to 4 */
static void skip_padded(hdr *h, uint64_t n, const char *what)
{
    if (h->bad)
        return;
    uint64_t padded = (n + 3) & ~(uint64_t)3;
    if (n > left(h) || padded > left(h)) {
        fail(h, "%s declares %llu bytes at byte %llu, past the header's end (%llu bytes left)", what,
             (unsigned long long)n, (unsigned long long)at(h), (unsigned long long)left(h));
        return;
    }
    h->p += padded;
}

static void get_name(hdr *h, const char *what)
{
    uint64_t n = get_nonneg(h, what);
    if (h->bad)
        return;
    if (n == 0 || n > NC_MAX_NAME) {
        fail(h, "%s has a name of %llu bytes at byte %llu (1 to %d allowed)", what,
             (unsigned long long)n, (unsigned long long)at(h), NC_MAX_NAME);
        return;
    }
    if (n > left(h)) {
        skip_padded(h, n, what);
        return;
    }
    if (memchr(h->p, 0, (size_t)n)) {
        fail(h, "%s has a NUL byte in its name at byte %llu", what, (unsigned long long)at(h));
        return;
    }
    skip_padded(h, n, what);
}

static int type_size(const hdr *h, uint64_t t)
{
    switch (t) {
    case NC_BYTE: case NC_CHAR: return 1;
    case NC_SHORT: return 2;
    case NC_INT: case NC_FLOAT: return 4;
    case NC_DOUBLE: return 8;
    default: break;
    }
    if (h->version != 5)
        return 0;
    switch (t) {
    case NC_UBYTE: return 1;
    case NC_USHORT: return 2;
    case NC_UINT: return 4;
    case NC_INT64: case NC_UINT64: return 8;
    default: return 0;
    }
}

/* A list's tag and count: the count, with ABSENT (0 0) as 0. min_item:
 * the fewest bytes one element takes, which bounds the count. */
static uint64_t get_list(hdr *h, uint32_t tag_want, const char *what, uint64_t min_item,
                         uint64_t max_count)
{
    uint64_t tag = get_be(h, 4, what);
    uint64_t n = get_nonneg(h, what);
    if (h->bad)
        return 0;
    if (tag == 0) {
        if (n != 0)
            fail(h, "%s is absent (tag 0) but counts %llu elements", what, (unsigned long long)n);
        return 0;
    }
    if (tag != tag_want) {
        fail(h, "%s has tag 0x%llx at byte %llu (0x%x expected)", what, (unsigned long long)tag,
             (unsigned long long)(at(h) - (h->version == 5 ? 12 : 8)), (unsigned)tag_want);
        return 0;
    }
    if (n > max_count || n > left(h) / min_item)
        fail(h, "%s counts %llu elements; the %llu bytes left in the header hold at most %llu", what,
             (unsigned long long)n, (unsigned long long)left(h),
             (unsigned long long)(left(h) / min_item < max_count ? left(h) / min_item : max_count));
    return n;
}

static void check_atts(hdr *h, const char *owner)
{
    char what[160];
    uint64_t w = h->version == 5 ? 8 : 4;
    snprintf(what, sizeof what, "the attribute list of %s", owner);
    uint64_t n = get_list(h, 0x0C, what, w + 4 + 4 + w, (uint64_t)1 << 31);
    for (uint64_t a = 0; a < n && !h->bad; a++) {
        snprintf(what, sizeof what, "attribute %llu of %s", (unsigned long long)a, owner);
        get_name(h, what);
        uint64_t t = get_be(h, 4, what);
        uint64_t nv = get_nonneg(h, what);
        if (h->bad)
            return;
        int ts = type_size(h, t);
        if (!ts) {
            fail(h, "%s has type %llu, not one of CDF-%d's", what, (unsigned long long)t, h->version);
            return;
        }
        if (nv > left(h) / (uint64_t)ts) {
            fail(h, "%s declares %llu values of %d bytes at byte %llu; the header has %llu bytes left",
                 what, (unsigned long long)nv, ts, (unsigned long long)at(h),
                 (unsigned long long)left(h));
            return;
        }
        skip_padded(h, nv * (uint64_t)ts, what);
    }
}

typedef struct {
    uint64_t begin, bytes;
    int rec;
} vinfo;

int nc_guard_classic(const unsigned char *buf, size_t n, uint64_t file_size, uint64_t *need,
                     char *why, size_t whysz)
{
    char dummy[8];
    if (!why) {
        why = dummy;
        whysz = sizeof dummy;
    }
    why[0] = '\0';
    *need = 0;
    if (n < 4 || memcmp(buf, "CDF", 3) != 0 || (buf[3] != 1 && buf[3] != 2 && buf[3] != 5)) {
        snprintf(why, whysz, "not a classic NetCDF file (no CDF-1, CDF-2 or CDF-5 magic)");
        return -1;
    }
    hdr h = {buf, buf + 4, buf + n, buf[3], file_size, 0, why, whysz};
    uint64_t w = h.version == 5 ? 8 : 4;
    uint64_t numrecs = get_be(&h, (int)w, "numrecs");
    int streaming = numrecs == (h.version == 5 ? UINT64_MAX : 0xFFFFFFFFu);
    if (!h.bad && !streaming && numrecs > (h.version == 5 ? (uint64_t)INT64_MAX : (uint64_t)INT32_MAX))
        fail(&h, "numrecs is %llu (negative as a signed value)", (unsigned long long)numrecs);
    if (!h.bad && !streaming && numrecs > file_size)
        fail(&h, "numrecs is %llu, more records than the file has bytes (%llu)",
             (unsigned long long)numrecs, (unsigned long long)file_size);
    /* dimensions: name (w + 4) and length (w) at least */
    uint64_t ndims = get_list(&h, 0x0A, "the dimension list", w + 4 + w, NC_MAX_DIMS);
    uint64_t dimlen[NC_MAX_DIMS];
    int nrecdims = 0;
    char what[160];
    for (uint64_t d = 0; d < ndims && !h.bad; d++) {
        snprintf(what, sizeof what, "dimension %llu", (unsigned long long)d);
        get_name(&h, what);
        dimlen[d] = get_nonneg(&h, what);
        if (!h.bad && dimlen[d] == 0 && ++nrecdims > 1)
            fail(&h, "dimension %llu is a second record (unlimited) dimension", (unsigned long long)d);
    }
    check_atts(&h, "the file (global)");
    /* variables: name (w + 4), dims (w), atts (4 + w), type (4), vsize (w), begin */
    uint64_t wb = h.version == 1 ? 4 : 8;
    uint64_t nvars = get_list(&h, 0x0B, "the variable list", w + 4 + w + 4 + w + 4 + w + wb,
                              (uint64_t)1 << 31);
    if (h.bad)
        return -1;
    vinfo *v = calloc(nvars ? (size_t)nvars : 1, sizeof *v);
    if (!v) {
        snprintf(why, whysz, "out of memory checking %llu variables", (unsigned long long)nvars);
        return -1;
    }
    for (uint64_t k = 0; k < nvars && !h.bad; k++) {
        snprintf(what, sizeof what, "variable %llu", (unsigned long long)k);
        get_name(&h, what);
        uint64_t nd = get_nonneg(&h, what);
        if (!h.bad && (nd > NC_MAX_VAR_DIMS || nd > left(&h) / w)) {
            fail(&h, "%s has %llu dimensions (at most %d, and what the header holds)", what,
                 (unsigned long long)nd, NC_MAX_VAR_DIMS);
            break;
        }
        uint64_t elems = 1;
        int rec = 0, overflow = 0;
        for (uint64_t d = 0; d < nd && !h.bad; d++) {
            uint64_t id = get_nonneg(&h, what);
            if (h.bad)
                break;
            if (id >= ndims) {
                fail(&h, "%s uses dimension id %llu; the file has %llu dimensions", what,
                     (unsigned long long)id, (unsigned long long)ndims);
                break;
            }
            if (dimlen[id] == 0) {
                if (d != 0) {
                    fail(&h, "%s has the record dimension in position %llu (only the first may be)",
                         what, (unsigned long long)d);
                    break;
                }
                rec = 1;
            } else if (__builtin_mul_overflow(elems, dimlen[id], &elems)) {
                overflow = 1;
            }
        }
        snprintf(what, sizeof what, "variable %llu", (unsigned long long)k);
        check_atts(&h, what);
        uint64_t t = get_be(&h, 4, what);
        uint64_t vsize = get_nonneg(&h, what);
        uint64_t begin = get_be(&h, (int)wb, what);
        if (h.bad)
            break;
        int ts = type_size(&h, t);
        if (!ts) {
            fail(&h, "%s has type %llu, not one of CDF-%d's", what, (unsigned long long)t, h.version);
            break;
        }
        uint64_t bytes = 0;
        if (overflow || __builtin_mul_overflow(elems, (uint64_t)ts, &bytes) || bytes > (uint64_t)INT64_MAX) {
            fail(&h, "%s's size overflows 64 bits", what);
            break;
        }
        uint64_t padded = (bytes + 3) & ~(uint64_t)3;
        uint64_t vmax = padded > file_size ? padded : file_size;
        if (vsize > vmax) {
            fail(&h, "%s declares vsize %llu, more than its shape needs (%llu) and the file has (%llu)",
                 what, (unsigned long long)vsize, (unsigned long long)padded,
                 (unsigned long long)file_size);
            break;
        }
        if (begin > file_size) {
            fail(&h, "%s begins at byte %llu, past the end of the file (%llu bytes)", what,
                 (unsigned long long)begin, (unsigned long long)file_size);
            break;
        }
        v[k].begin = begin;
        v[k].bytes = bytes;
        v[k].rec = rec;
    }
    uint64_t header_end = at(&h);
    uint64_t recsize = 0;
    int nrec = 0;
    for (uint64_t k = 0; k < nvars && !h.bad; k++) {
        if (v[k].begin < header_end) {
            fail(&h, "variable %llu begins at byte %llu, inside the header (%llu bytes)",
                 (unsigned long long)k, (unsigned long long)v[k].begin,
                 (unsigned long long)header_end);
            break;
        }
        if (v[k].rec) {
            nrec++;
            if (__builtin_add_overflow(recsize, (v[k].bytes + 3) & ~(uint64_t)3, &recsize))
                fail(&h, "the record size overflows 64 bits");
        }
    }
    if (!h.bad && nrec == 1)
        for (uint64_t k = 0; k < nvars; k++)
            if (v[k].rec)
                recsize = v[k].bytes; /* a lone record variable is not padded */
    uint64_t need_max = 0;
    for (uint64_t k = 0; k < nvars && !h.bad; k++) {
        uint64_t end = 0;
        if (!v[k].rec) {
            if (__builtin_add_overflow(v[k].begin, v[k].bytes, &end))
                end = UINT64_MAX;
        } else if (streaming || numrecs == 0) {
            continue;
        } else {
            uint64_t off;
            if (__builtin_mul_overflow(numrecs - 1, recsize, &off) ||
                __builtin_add_overflow(off, v[k].begin, &end) ||
                __builtin_add_overflow(end, v[k].bytes, &end))
                end = UINT64_MAX;
        }
        if (end > need_max)
            need_max = end;
    }
    free(v);
    if (h.bad)
        return -1;
    *need = need_max;
    return 0;
}

/* ----------------------------------------------------------- netCDF-4 */

static atomic_long n_probed, n_died, n_timed_out;
static _Atomic double probe_timeout = 20.0;
static void (*_Atomic child_hook)(void);

static pthread_mutex_t nc_mutex = PTHREAD_RECURSIVE_MUTEX_INITIALIZER_NP;
void nc_guard_lock(void) { pthread_mutex_lock(&nc_mutex); }
void nc_guard_unlock(void) { pthread_mutex_unlock(&nc_mutex); }
/* In a forked child (one thread): the lock the parent's thread held at the
 * fork, free again */
static void nc_lock_reset_in_child(void)
{
    static const pthread_mutex_t fresh = PTHREAD_RECURSIVE_MUTEX_INITIALIZER_NP;
    memcpy(&nc_mutex, &fresh, sizeof nc_mutex);
}

void nc_guard_set_timeout(double seconds) { probe_timeout = seconds > 0 ? seconds : 20.0; }
void nc_guard_set_child_hook(void (*hook)(void)) { child_hook = hook; }

void nc_guard_stats(long *probed, long *died, long *timed_out)
{
    if (probed)
        *probed = n_probed;
    if (died)
        *died = n_died;
    if (timed_out)
        *timed_out = n_timed_out;
}

/* The child reads data only from files up to this size, at most this much
 * per variable. */
#define PROBE_DATA_FILE ((uint64_t)64 << 20)
#define PROBE_DATA_VAR ((size_t)256 << 20)

static int probe_atts(int g, int v, int natts)
{
    for (int a = 0; a < natts; a++) {
        char name[NC_MAX_NAME + 1];
        nc_type t;
        size_t len, size;
        if (nc_inq_attname(g, v, a, name) || nc_inq_att(g, v, name, &t, &len) ||
            nc_inq_type(g, t, NULL, &size))
            return -1;
        if (t == NC_STRING) {
            char **s = calloc(len ? len : 1, sizeof *s);
            if (!s)
                return -1;
            int st = nc_get_att_string(g, v, name, s);
            if (st == NC_NOERR)
                nc_free_string(len, s);
            free(s);
            if (st)
                return -1;
        } else if (t <= NC_UINT64 && size && len <= PROBE_DATA_VAR / size) {
            void *buf = malloc(len * size + 1);
            if (!buf)
                return -1;
            int st = nc_get_att(g, v, name, buf);
            free(buf);
            if (st)
                return -1;
        }
    }
    return 0;
}

static int probe_group(int g, int read_data, int depth)
{
    if (depth > 64)
        return -1;
    int nd = 0, nv = 0, natts = 0, ng = 0;
    if (nc_inq_dimids(g, &nd, NULL, 0) || nc_inq_varids(g, &nv, NULL) || nc_inq_natts(g, &natts) ||
        nc_inq_grps(g, &ng, NULL))
        return -1;
    int rc = probe_atts(g, NC_GLOBAL, natts);
    int *ids = malloc(sizeof *ids * (size_t)((nd > nv ? (nd > ng ? nd : ng) : (nv > ng ? nv : ng)) + 1));
    if (!ids)
        return -1;
    if (!rc && nc_inq_dimids(g, &nd, ids, 0) == NC_NOERR) {
        for (int d = 0; d < nd && !rc; d++) {
            char name[NC_MAX_NAME + 1];
            size_t len;
            rc = nc_inq_dim(g, ids[d], name, &len) ? -1 : 0;
        }
    }
    if (!rc && nc_inq_varids(g, &nv, ids) == NC_NOERR) {
        for (int k = 0; k < nv && !rc; k++) {
            char name[NC_MAX_NAME + 1];
            nc_type t;
            int vnd, vd[NC_MAX_VAR_DIMS], vna;
            if (nc_inq_var(g, ids[k], name, &t, &vnd, vd, &vna) || vnd < 0 || vnd > NC_MAX_VAR_DIMS) {
                rc = -1;
                break;
            }
            rc = probe_atts(g, ids[k], vna);
            size_t elems = 1, size = 0;
            int fits = !rc && nc_inq_type(g, t, NULL, &size) == NC_NOERR && size > 0;
            for (int d = 0; d < vnd && fits; d++) {
                size_t len;
                if (nc_inq_dimlen(g, vd[d], &len) || __builtin_mul_overflow(elems, len, &elems))
                    fits = 0;
            }
            if (!read_data || !fits || elems == 0 || elems > PROBE_DATA_VAR / size)
                continue;
            if (t == NC_STRING) {
                char **s = calloc(elems, sizeof *s);
                if (!s)
                    continue;
                if (nc_get_var_string(g, ids[k], s) == NC_NOERR)
                    nc_free_string(elems, s);
                free(s);
            } else if (t <= NC_UINT64) {
                void *buf = malloc(elems * size);
                if (buf)
                    (void)nc_get_var(g, ids[k], buf);
                free(buf);
            }
        }
    }
    if (!rc && nc_inq_grps(g, &ng, ids) == NC_NOERR)
        for (int k = 0; k < ng && !rc; k++)
            rc = probe_group(ids[k], read_data, depth + 1);
    free(ids);
    return rc;
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* A checking process keeps only its own descriptors: the parent's files,
 * sockets and lock files (a flock lock lives as long as any copy of its
 * descriptor) are closed in it at once. */
static void close_others(int keep)
{
    if (keep > 3 && syscall(SYS_close_range, 3u, (unsigned)keep - 1, 0u) != 0)
        for (int fd = 3; fd < keep; fd++)
            close(fd);
    if (syscall(SYS_close_range, (unsigned)keep + 1, ~0u, 0u) != 0) {
        long max = sysconf(_SC_OPEN_MAX);
        for (long fd = keep + 1; fd < (max > 0 && max < 65536 ? max : 65536); fd++)
            close((int)fd);
    }
}

/* The checking process's start: the hook, output to /dev/null, nothing of
 * the parent's open. */
static void child_start(int keep)
{
    void (*hook)(void) = child_hook;
    if (hook)
        hook();
    signal(SIGPIPE, SIG_DFL);
    int dn = open("/dev/null", O_WRONLY);
    if (dn >= 0) {
        dup2(dn, 1);
        dup2(dn, 2);
        if (dn != keep && dn > 2)
            close(dn);
    }
    close_others(keep);
}

/* nc_open with the stack below this frame cleared first. HDF5 1.10.8
 * frees pointers it never set (H5G__link_release_table under nc_open):
 * what it frees is whatever the stack held there, so the checking child
 * and this process would see different garbage; cleared, they see the
 * same zeros (and free(NULL) is harmless). */
__attribute__((noinline)) static void clear_stack_below(void)
{
    volatile unsigned char pad[128 * 1024];
    explicit_bzero((void *)pad, sizeof pad);
    __asm__ volatile("" : : "r"(pad) : "memory");
}

int nc_guard_nc_open(const char *path, int *ncid)
{
    clear_stack_below();
    nc_guard_lock();
    int st = nc_open(path, NC_NOWRITE, ncid);
    nc_guard_unlock();
    return st;
}

/* One file: 0 walked, 3 nc_open refused it, 4 an inquiry failed (both
 * left to the caller's own open, which reports the library's reason) */
static int probe_one(const char *path, uint64_t size)
{
    int nc;
    if (nc_guard_nc_open(path, &nc) != NC_NOERR)
        return 3;
    int rc = probe_group(nc, size <= PROBE_DATA_FILE, 0);
    nc_close(nc);
    return rc ? 4 : 0;
}

/* Waits for one status byte on fd until the deadline: the byte, -1 when
 * the other end closed (the process died), -2 at the deadline. */
static int wait_byte(int fd, double deadline)
{
    for (;;) {
        double wait = deadline - now_s();
        if (wait <= 0)
            return -2;
        struct pollfd p = {fd, POLLIN, 0};
        int r = poll(&p, 1, (int)ceil(wait * 1000.0));
        if (r > 0) {
            unsigned char c;
            ssize_t n = read(fd, &c, 1);
            if (n == 1)
                return c;
            if (n == 0 || (errno != EINTR && errno != EAGAIN))
                return -1;
        } else if (r < 0 && errno != EINTR) {
            return -1;
        }
    }
}

/* The check runs in a child forked for each file: its state is this
 * process's state at that moment, so that an open the child survives is
 * the open this process then makes. (A checking server forked once and
 * reused was tried: HDF5 1.10.8's invalid frees depend on the heap, and a
 * server that had checked earlier files survived a file that then crashed
 * the fuzzer's process.) A fresh child for one file: the status byte, -1 died (*st its wait
 * status), -2 deadline */
static int fresh_probe(const char *path, uint64_t size, double deadline, int *st)
{
    int sv[2];
    *st = 0;
    if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0)
        return -3;
    nc_guard_lock(); /* no other thread inside HDF5 while the child's copy is taken */
    pid_t pid = fork();
    if (pid != 0)
        nc_guard_unlock();
    else
        nc_lock_reset_in_child();
    if (pid < 0) {
        close(sv[0]);
        close(sv[1]);
        return -3;
    }
    if (pid == 0) {
        child_start(sv[1]);
        unsigned char c = (unsigned char)probe_one(path, size);
        _exit(write(sv[1], &c, 1) == 1 ? 0 : 5);
    }
    close(sv[1]);
    int r = wait_byte(sv[0], deadline);
    close(sv[0]);
    if (r == -2)
        kill(pid, SIGKILL);
    while (waitpid(pid, st, 0) < 0 && errno == EINTR)
        ;
    return r;
}

static int probe_hdf5(const char *path, const char *label, uint64_t size, sph_error *err)
{
    char abs[PATH_MAX];
    if (!realpath(path, abs) || strlen(abs) >= PATH_MAX)
        snprintf(abs, sizeof abs, "%s", path);
    n_probed++;
    int st = 0;
    int r = fresh_probe(abs, size, now_s() + probe_timeout, &st);
    if (r == -3)
        return sph_err_set(err, SPH_ERR_IO, "%s: cannot check the netCDF-4 file: %s", label,
                           strerror(errno));
    if (r == -2) {
        n_timed_out++;
        return sph_err_set(err, SPH_ERR_NETCDF,
                           "%s: refused: the NetCDF/HDF5 library did not finish reading this "
                           "netCDF-4 file within %g s in a checking process (malformed file?)",
                           label, (double)probe_timeout);
    }
    if (r == 0 || r == 3 || r == 4)
        return SPH_OK;
    n_died++;
    if (r == -1 && WIFSIGNALED(st))
        return sph_err_set(err, SPH_ERR_NETCDF,
                           "%s: refused: the NetCDF/HDF5 library crashed (signal %d, %s) reading "
                           "this netCDF-4 file in a checking process: the file is malformed",
                           label, WTERMSIG(st), strsignal(WTERMSIG(st)));
    return sph_err_set(err, SPH_ERR_NETCDF,
                       "%s: refused: the NetCDF/HDF5 library failed (exit status %d) reading this "
                       "netCDF-4 file in a checking process: the file is malformed", label,
                       r == -1 && WIFEXITED(st) ? WEXITSTATUS(st) : r);
}

/* -------------------------------------------------------------- doors */

#define HEADER_CAP ((size_t)8 << 20)

int nc_guard_check(const char *path, const char *label, sph_error *err)
{
    if (!label)
        label = path;
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return sph_err_set(err, SPH_ERR_IO, "%s: cannot open %s: %s", label, path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        return SPH_OK; /* not a regular file (a pipe, a device): nc_open decides */
    }
    uint64_t size = (uint64_t)st.st_size;
    unsigned char m[8];
    ssize_t got = pread(fd, m, sizeof m, 0);
    if (got >= 4 && memcmp(m, "CDF", 3) == 0 && (m[3] == 1 || m[3] == 2 || m[3] == 5)) {
        size_t cap = size < HEADER_CAP ? (size_t)size : HEADER_CAP;
        unsigned char *buf = malloc(cap ? cap : 1);
        if (!buf) {
            close(fd);
            return sph_err_set(err, SPH_ERR_NOMEM, "%s: out of memory", label);
        }
        size_t have = 0;
        while (have < cap) {
            ssize_t r = pread(fd, buf + have, cap - have, (off_t)have);
            if (r <= 0)
                break;
            have += (size_t)r;
        }
        close(fd);
        uint64_t need = 0;
        char why[400];
        int rc = nc_guard_classic(buf, have, size, &need, why, sizeof why);
        free(buf);
        if (rc != 0)
            return sph_err_set(err, SPH_ERR_NETCDF, "%s: corrupt NetCDF header: %s%s", label, why,
                               have < size && strstr(why, "header") ? " (only the first 8 MiB are read)" : "");
        if (size < need)
            return sph_err_set(err, SPH_ERR_NETCDF,
                               "%s: truncated NetCDF file: %lld bytes, the header needs %llu", label,
                               (long long)size, (unsigned long long)need);
        return SPH_OK;
    }
    /* HDF5's signature at 0, 512, 1024, 2048, ... (netCDF-4 looks there) */
    int hdf5 = 0;
    for (uint64_t off = 0; off + 8 <= size && !hdf5; off = off ? off * 2 : 512) {
        if (off && pread(fd, m, sizeof m, (off_t)off) != (ssize_t)sizeof m)
            break;
        if (!off && got != (ssize_t)sizeof m)
            break;
        hdf5 = memcmp(m, "\x89HDF\r\n\x1a\n", 8) == 0;
    }
    close(fd);
    if (!hdf5)
        return SPH_OK;
    return probe_hdf5(path, label, size, err);
}

int nc_guard_open(const char *path, const char *label, int *ncid, sph_error *err)
{
    if (!label)
        label = path;
    int rc = nc_guard_check(path, label, err);
    if (rc)
        return rc;
    int st = nc_guard_nc_open(path, ncid);
    if (st != NC_NOERR)
        return sph_err_set(err, SPH_ERR_NETCDF, "%s: cannot open as NetCDF: %s", label,
                           nc_strerror(st));
    return SPH_OK;
}

/* ------------------------------------------------- isolated reading */

#define COPY_MAX_BYTES ((size_t)4 << 30) /* one variable's data, at most */

/* Exit codes of the copying child (status bytes): 0 copied; 3 nc_open
 * refused the file; 6 not copyable to CDF-5 (groups, user or string
 * types, several unlimited dimensions); 7 the copy failed (an inquiry or a
 * write, a variable too large). */
static int copy_atts(int in, int iv, int out, int ov, int natts)
{
    for (int a = 0; a < natts; a++) {
        char name[NC_MAX_NAME + 1];
        nc_type t;
        size_t len;
        if (nc_inq_attname(in, iv, a, name) || nc_inq_att(in, iv, name, &t, &len))
            return 7;
        if (t > NC_UINT64 || t == NC_NAT)
            return 6;
        size_t sz;
        if (nc_inq_type(in, t, NULL, &sz) || (len && sz > COPY_MAX_BYTES / len))
            return 7;
        void *b = malloc(len * sz + 1);
        if (!b)
            return 7;
        int rc = nc_get_att(in, iv, name, b) || nc_put_att(out, ov, name, t, len, b) ? 7 : 0;
        free(b);
        if (rc)
            return rc;
    }
    return 0;
}

static int copy_file(const char *path, const char *to)
{
    int in, out;
    if (nc_guard_nc_open(path, &in) != NC_NOERR)
        return 3;
    int rc = 7, ngrps = 0, ndims = 0, nvars = 0, natts = 0, nunlim = 0;
    if (nc_inq_grps(in, &ngrps, NULL) || ngrps > 0 || nc_inq_unlimdims(in, &nunlim, NULL) || nunlim > 1) {
        nc_close(in);
        return ngrps > 0 || nunlim > 1 ? 6 : 7;
    }
    if (nc_create(to, NC_CLOBBER | NC_64BIT_DATA, &out) != NC_NOERR) {
        nc_close(in);
        return 7;
    }
    nc_set_fill(out, NC_NOFILL, NULL);
    int unlim = -1;
    if (nc_inq(in, &ndims, &nvars, &natts, &unlim))
        goto done;
    /* dimension ids of a flat netCDF-4 file are 0 .. ndims-1 in order */
    for (int d = 0; d < ndims; d++) {
        char name[NC_MAX_NAME + 1];
        size_t len;
        int od;
        if (nc_inq_dim(in, d, name, &len) || nc_def_dim(out, name, d == unlim ? NC_UNLIMITED : len, &od) ||
            od != d)
            goto done;
    }
    if ((rc = copy_atts(in, NC_GLOBAL, out, NC_GLOBAL, natts)))
        goto done;
    rc = 7;
    for (int v = 0; v < nvars; v++) {
        char name[NC_MAX_NAME + 1];
        nc_type t;
        int nd, dims[NC_MAX_VAR_DIMS], na, ov;
        if (nc_inq_var(in, v, name, &t, &nd, dims, &na))
            goto done;
        if (t > NC_UINT64 || t == NC_NAT) {
            rc = 6;
            goto done;
        }
        if (nc_def_var(out, name, t, nd, dims, &ov) || ov != v)
            goto done;
        if ((rc = copy_atts(in, v, out, ov, na)))
            goto done;
        rc = 7;
    }
    if (nc_enddef(out))
        goto done;
    for (int v = 0; v < nvars; v++) {
        nc_type t;
        int nd, dims[NC_MAX_VAR_DIMS];
        size_t sz, n = 1, start[NC_MAX_VAR_DIMS], count[NC_MAX_VAR_DIMS];
        if (nc_inq_var(in, v, NULL, &t, &nd, dims, NULL) || nc_inq_type(in, t, NULL, &sz))
            goto done;
        for (int k = 0; k < nd; k++) {
            size_t len;
            if (nc_inq_dimlen(in, dims[k], &len) || (len && n > COPY_MAX_BYTES / sz / len))
                goto done;
            n *= len;
            start[k] = 0;
            count[k] = len; /* explicit: a record variable of the copy has no records yet */
        }
        if (n == 0)
            continue;
        void *b = malloc(n * sz);
        if (!b)
            goto done;
        int bad = nc_get_var(in, v, b) || nc_put_vara(out, v, start, count, b);
        free(b);
        if (bad)
            goto done;
    }
    rc = 0;
done:
    nc_close(in);
    if (nc_close(out))
        rc = rc ? rc : 7;
    return rc;
}

int nc_guard_open_isolated(const char *path, const char *label, int *ncid, sph_error *err)
{
    if (!label)
        label = path;
    unsigned char m[8];
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return sph_err_set(err, SPH_ERR_IO, "%s: cannot open %s: %s", label, path, strerror(errno));
    ssize_t got = pread(fd, m, sizeof m, 0);
    close(fd);
    if (!(got == (ssize_t)sizeof m && memcmp(m, "\x89HDF\r\n\x1a\n", 8) == 0))
        return nc_guard_open(path, label, ncid, err); /* classic (validated here) or not NetCDF */
    const char *td = getenv("TMPDIR");
    char tmp[PATH_MAX];
    snprintf(tmp, sizeof tmp, "%s/sphice-ncread-XXXXXX", td && *td ? td : "/tmp");
    int tfd = mkstemp(tmp);
    if (tfd < 0)
        return sph_err_set(err, SPH_ERR_IO, "%s: cannot create a file for its isolated reading in %s: %s", label,
                           td && *td ? td : "/tmp", strerror(errno));
    close(tfd);
    int sv[2];
    if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0) {
        unlink(tmp);
        return sph_err_set(err, SPH_ERR_IO, "%s: cannot read it in a separate process: %s", label, strerror(errno));
    }
    char abs[PATH_MAX];
    if (!realpath(path, abs))
        snprintf(abs, sizeof abs, "%s", path);
    n_probed++;
    nc_guard_lock(); /* as fresh_probe */
    pid_t pid = fork();
    if (pid != 0)
        nc_guard_unlock();
    else
        nc_lock_reset_in_child();
    if (pid < 0) {
        close(sv[0]);
        close(sv[1]);
        unlink(tmp);
        return sph_err_set(err, SPH_ERR_IO, "%s: cannot read it in a separate process: %s", label, strerror(errno));
    }
    if (pid == 0) {
        child_start(sv[1]);
        unsigned char c = (unsigned char)copy_file(abs, tmp);
        _exit(write(sv[1], &c, 1) == 1 ? 0 : 5);
    }
    close(sv[1]);
    int r = wait_byte(sv[0], now_s() + probe_timeout), st = 0;
    close(sv[0]);
    if (r == -2)
        kill(pid, SIGKILL);
    while (waitpid(pid, &st, 0) < 0 && errno == EINTR)
        ;
    int rc;
    if (r == 0) {
        /* the copy is CDF-5: validated and read here without HDF5 */
        rc = nc_guard_open(tmp, label, ncid, err);
    } else if (r == 3) {
        rc = sph_err_set(err, SPH_ERR_NETCDF, "%s: refused: the NetCDF/HDF5 library cannot open this netCDF-4 "
                         "file (in a separate process)", label);
    } else if (r == 6) {
        rc = sph_err_set(err, SPH_ERR_NETCDF, "%s: refused: groups, string or user types or several unlimited "
                         "dimensions, which this reader does not take", label);
    } else if (r == 7) {
        rc = sph_err_set(err, SPH_ERR_NETCDF, "%s: refused: its netCDF-4 data could not be read (malformed file?)",
                         label);
    } else if (r == -2) {
        n_timed_out++;
        rc = sph_err_set(err, SPH_ERR_NETCDF, "%s: refused: the NetCDF/HDF5 library did not finish reading this "
                         "netCDF-4 file within %g s in a separate process (malformed file?)", label,
                         (double)probe_timeout);
    } else {
        n_died++;
        rc = WIFSIGNALED(st)
                 ? sph_err_set(err, SPH_ERR_NETCDF, "%s: refused: the NetCDF/HDF5 library crashed (signal %d, %s) "
                               "reading this netCDF-4 file in a separate process: the file is malformed", label,
                               WTERMSIG(st), strsignal(WTERMSIG(st)))
                 : sph_err_set(err, SPH_ERR_NETCDF, "%s: refused: the NetCDF/HDF5 library failed (status %d) "
                               "reading this netCDF-4 file in a separate process: the file is malformed", label,
                               r == -1 && WIFEXITED(st) ? WEXITSTATUS(st) : r);
    }
    unlink(tmp); /* an open file stays readable */
    return rc;
}
