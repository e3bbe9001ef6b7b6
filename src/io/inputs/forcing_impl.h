/* Private structures of the forcing reader (io/forcing.h), shared by the
 * format-free files
 *   forcing.c       sources, variable discovery, units, time axes, the
 *                   slice cache, coverage checks, rotation, sampling
 *   forcing_grid.c  grids, point location, interpolation, gradients
 *   forcing_tide.c  harmonic tide synthesis
 * and the format drivers (forcing_driver below), one file each:
 *   forcing_netcdf.c  CF NetCDF (the first driver, and the default)
 * Only drivers call a format library; the format-free files call the
 * driver table. */
#ifndef SPHICE_IO_FORCING_IMPL_H
#define SPHICE_IO_FORCING_IMPL_H

#include <math.h>
#include <stddef.h>
#include "io/cf.h"
#include "io/forcing.h"
#include "io/tide.h"
#include "util/err.h"

#define FORCING_EARTH_RADIUS 6371000.0 /* m, spherical earth */
#define FORCING_MAX_DIMS 8
/* Points from which the per-point sampling loops run on the OpenMP threads
 * (per-point writes only: results independent of the thread count). */
#define FORCING_OMP_MIN 4096
/* Points a thread takes at a time in those loops: dynamic, so that a thread
 * sharing its core (the products' writer, another process) takes fewer and
 * the other does not wait for it at the loop's end (docs/bench.md "Session
 * 11: free drift (fd5)"); a point's values do not depend on who takes it. */
#define FORCING_OMP_GRAB 2048

/* One physical field a source can supply. */
typedef enum {
    FV_UWIND = 0, FV_VWIND, FV_TAIR, FV_DEW, FV_QAIR, FV_PSURF, FV_SW, FV_LW,
    FV_UCUR, FV_VCUR, FV_SSH, FV_SST, FV_FW, FV_RH, FV_SNOW, FV_PRECIP, FV_MLD, FV_BATHY, FV_COUNT
} fv_slot;

/* How a vector component was found (fvar.found_how). */
enum { FVEC_STD_EARTH = 0, FVEC_STD_GRID, FVEC_NAME };

/* A grid in canonical layout: node (i, j) is element j * nx + i, i along
 * the x (longitude-like) dimension, j along y. */
typedef struct fgrid {
    int curvilinear;
    size_t nx, ny;         /* the nodes held: the read window (all of the file's grid when
                              the source reads whole files) */
    double *lon1, *lat1;   /* regular: the file's lon1[fnx] increasing (unwrapped), lat1[fny]
                              monotonic (points are located on them, then mapped into the
                              window, so that a window samples exactly as the whole file) */
    int lon_wrap;          /* regular and global, window of all columns: a cell joins
                              column nx-1 to column 0 */
    double *lon2, *lat2;   /* node coordinates [ny*nx] of the window, both kinds
                              (lon in [-180,180)) */
    /* Read window (hyperslab, docs/forcing.md "Large files"): node (i, j) of the window is
     * node ((wi0 + i) mod fnx, wj0 + j) of the file's fnx x fny grid; on a global grid
     * the window may straddle the seam (two slabs). */
    size_t fnx, fny, wi0, wj0;
    int fwrap;             /* the file's regular grid is global (wraps) */
    int windowed;          /* the window is smaller than the file's grid */
    int edge[4];           /* window side is the file's side: west, east, south, north */
    double ext[4];         /* the file grid's extent: lon min, max, lat min, max */
    double wext[4];        /* the window's extent (messages) */
    double margin_km;      /* the margin it was cut with (messages) */
    double *cosang, *sinang; /* curvilinear: angle from east to the x axis, per node */
    char angle_var[64];    /* curvilinear: the file's angle variable ("" if none) */
    char angle_from[128];  /* where the angle comes from, for `sphice check` */
    char key[600];         /* coordinate variable names + sizes: grids with equal keys are shared */
    char desc[96];
    /* Per-call point stencils (filled once per forcing_sample_at call). */
    size_t *idx;           /* 4 per point */
    double *w;             /* 4 per point */
    int *ok;               /* 1 if the point lies in the grid */
    size_t *hint;          /* last cell per point, or (size_t)-1: curvilinear j*nx+i, regular
                              the file's row << 32 | column (forcing_grid.c); [nhint], point
                              p of a call at hint_base + p (forcing_set_point_base) */
    size_t npoints;        /* points idx, w and ok hold (one call's, at most one chunk) */
    size_t nhint, hint_base;
    size_t last_end;       /* hint_base + n of the last stencil call, and whether its last */
    int last_ok;           /* point lay in the grid (the curvilinear walk's predecessor) */
    unsigned long stamp;   /* call number the stencils belong to */
    size_t stamp_outside;  /* the points outside at that call (fgrid_stencils' result) */
    struct fgrid *next;
} fgrid;

/* Per-file description of a variable (packing can differ per file). */
typedef struct fvfile {
    int file;              /* index into source paths */
    int varid;             /* the driver's id of the variable in that file */
    int ndims;
    int tdim, ydim, xdim;  /* positions in the variable's dimensions; tdim -1 if none */
    int transpose;         /* x dimension comes before y in the file */
    size_t level[FORCING_MAX_DIMS]; /* start index along the other dimensions: the
                                       level nearest the surface (driver levels) */
    int merge_dim;         /* ERA5's expver: the first valid value along it; -1 none */
    size_t merge_n;
    double scale, offset;  /* unpacking */
    int has_fill;
    double fill;
    int nmiss;
    double miss[4];
    int valid_raw;         /* valid range compared to packed values */
    double vmin, vmax;
    double a, b;           /* unit conversion after unpacking */
    char units[64];
} fvfile;

typedef struct ftime {
    double t;              /* model time */
    int vf;                /* index into the variable's fvfile list */
    size_t k;              /* index along the file's time dimension */
    double period;         /* accumulation period (s) for accumulated fields */
} ftime;

struct fsource;

typedef struct fharm {
    /* Harmonic constants at the nodes: value(t) = sum_k f_k (c_k cos(phi_k) + s_k sin(phi_k))
     * where c = A cos G, s = A sin G; NaN over land. */
    int present[TIDE_NCONST];
    double *c[TIDE_NCONST], *s[TIDE_NCONST];
} fharm;

typedef struct fvar {
    struct fsource *src;
    fv_slot which;
    char standard_name[96];  /* the one found (or the canonical one for mapped names) */
    char varname[64];
    char units[64];
    char file0[512];         /* file of the first time */
    int accumulated;         /* J m-2 (or kg m-2 of snow, precipitation): an amount
                                over the interval ending at each time (divided by the
                                period), or, with forcing[].accumulation "running",
                                since a start that may reset (differenced) */
    int grid_relative;       /* vector component along the grid axes */
    int found_how;           /* FVEC_*: how a vector component was found */
    char orient[192];        /* vector components: orientation and why (forcing_var_info) */
    fgrid *grid;
    fvfile *vfiles;
    size_t nvfiles;
    ftime *times;
    size_t ntimes;           /* 0: static field (no time dimension) */
    /* Two-slot slice cache. slot_k == (size_t)-1 when empty. */
    size_t slot_k[2];
    double *slot[2];
    double *slot_gx[2], *slot_gy[2]; /* SSH gradient per slice */
    double fill_fraction;
    fharm *harm;             /* harmonic tide: slices are synthesised at the sample time */
    double harm_t;           /* time of the synthesised slot 0 */
} fvar;

struct forcing_driver;

typedef struct fsource {
    char name[SPHICE_MAX_NAME + 1];
    forcing_kind kind;
    char **paths;
    size_t npaths;
    fvar *vars[FV_COUNT];
    fgrid *grids;
    int harmonic;
    int accumulation;        /* FORCING_ACCUMULATION_* */
    tide_args targs;
    const struct forcing_driver *drv; /* the format of the source's files */
    /* Read window: grids set up while win_on is 1 keep only the nodes of the box
     * (degrees) plus win_margin_km (fgrid_setup_regular, fgrid_window). */
    int win_on;
    double win_box[4];       /* lon min, lon max, lat min, lat max */
    double win_margin_km;
    int open_file;           /* cached open file: index into paths, -1 none */
    void *open_fh;           /* its driver handle */
} fsource;

struct forcing {
    fsource *src;
    size_t nsrc;
    size_t reads;            /* slices read from disk (debug counter) */
    unsigned long stamp;
    double *tmp[6];          /* per-call work arrays of npoints */
    size_t tmp_n;
    size_t point_base;       /* forcing_set_point_base */
};

/* ---- format drivers ----
 *
 * A driver reads one file format. The format-free code opens a file with
 * `open`, lists its variables with `variables` and matches them to the
 * slots itself (standard_name, the source's map, built-in names); for each
 * variable found it asks `grid` for the horizontal grid and the layout of
 * the dimensions, `levels` for the index along every other dimension,
 * `packing` for scale, offset, missing values and the units string, and
 * `times` for the raw time coordinate (it parses the CF units and
 * calendar itself). `slice` reads one horizontal field in file order;
 * unpacking, missing values, unit conversion and accumulation periods are
 * format-free. Every message a driver writes goes through forcing_fail, so
 * it names the source and the file. */

/* A variable as a driver lists it. */
typedef struct forcing_varinfo {
    char name[257];            /* its name in the file */
    char standard_name[128];   /* CF standard_name, "" if none */
    int id;                    /* the driver's id (fvfile.varid) */
} forcing_varinfo;

/* The raw time coordinate of a variable in one file. */
typedef struct forcing_timeinfo {
    char name[257];            /* of the time dimension/coordinate, for messages */
    char units[256];           /* "<unit> since <date>" */
    char calendar[64];         /* "" when the file names none */
    size_t n;                  /* number of times */
} forcing_timeinfo;

typedef struct forcing_driver {
    const char *name;          /* "netcdf", for messages and docs */
    /* 1 when the file at path is in this format (magic bytes, name). No
     * driver claiming a file: the first driver of the table opens it, so
     * its own message says why it cannot. */
    int (*probe)(const char *path);
    /* Opens file s->paths[file] for reading: *fh is the driver's handle. */
    int (*open)(fsource *s, int file, void **fh, sph_error *err);
    void (*close)(void *fh);
    /* Every variable of the open file, in file order (*list malloc'ed,
     * freed by the caller). Returns 0, or -1 when out of memory. */
    int (*variables)(void *fh, forcing_varinfo **list, size_t *n);
    /* Fills vf->ndims, tdim, ydim, xdim, transpose and *grid (shared with
     * the source's other variables: fgrid_find, fgrid_add). */
    int (*grid)(fsource *s, const char *path, void *fh, int varid, fvfile *vf, fgrid **grid,
                sph_error *err);
    /* Fills vf->level and vf->merge_dim/merge_n for the dimensions other
     * than time, y and x; *what describes the choice ("" if none). */
    int (*levels)(fsource *s, const char *path, void *fh, int varid, fvfile *vf, char *what,
                  size_t len, sph_error *err);
    /* Fills vf's packing (scale, offset, fill, miss, valid range) and
     * vf->units. Returns 0, or -1 when the variable has no units. */
    int (*packing)(void *fh, int varid, fvfile *vf);
    /* The time coordinate of a variable with vf->tdim >= 0: with vals NULL
     * fills *ti, else reads ti->n values into vals. */
    int (*times)(fsource *s, const char *path, void *fh, int varid, const fvfile *vf,
                 forcing_timeinfo *ti, double *vals, sph_error *err);
    /* One horizontal field of v at index k of the time dimension (if any)
     * and index mi of the merged dimension (if any), the other dimensions
     * at vf->level: ny*nx values, y-major, or x-major when vf->transpose,
     * still packed. */
    int (*slice)(fsource *s, const char *path, void *fh, const fvar *v, const fvfile *vf,
                 size_t k, size_t mi, double *raw, sph_error *err);
    /* Optional (NULL: the format has none). A harmonic tide file as the
     * source's only file: *harmonic = 0 when s->paths[0] is not one,
     * else 1 and the variables set up (ftide_constants). */
    int (*tide)(fsource *s, int *harmonic, cf_units *units, double t_ref, int nodal,
                unsigned required, sph_error *err);
} forcing_driver;

/* The table of drivers, probed in this order; the first is the default.
 * Adding a format: one file defining forcing_driver_<name>, and its name
 * here. */
#define FORCING_DRIVERS(X) X(netcdf)

#define FORCING_DRIVER_DECLARE(n) extern const forcing_driver forcing_driver_##n;
FORCING_DRIVERS(FORCING_DRIVER_DECLARE)
#undef FORCING_DRIVER_DECLARE

/* forcing_grid.c */
void fgrid_free(fgrid *g);
/* The grid of the source with this key, or NULL. */
fgrid *fgrid_find(const fsource *s, const char *key);
/* Adds a complete grid to the source's list (it owns it from then on). */
void fgrid_add(fsource *s, fgrid *g);
/* Regular grid: checks lon1/lat1 (nx, ny: the file's), unwraps longitudes, sets the
 * read window (s->win_on; else all nodes), allocates and fills lon2/lat2 for it, sets
 * lon_wrap and desc. */
int fgrid_setup_regular(fgrid *g, const fsource *s, const char *path, sph_error *err);
/* Curvilinear (and projected) grid with lon2/lat2 (and, when set, cosang/sinang)
 * for all the file's nx x ny nodes: sets fnx, fny and ext, and, when the source has a
 * read window (s->win_on), keeps only the window's nodes (the bounding index box of
 * the cells that overlap the box plus the margin, plus FGRID_GUARD nodes each side).
 * Returns 0, or -1 when out of memory. */
int fgrid_window(fgrid *g, const fsource *s);
/* Nodes kept around the cells the box touches: the bilinear stencil's fallback
 * reaches one node further, and the SSH gradient at those nodes one more. */
#define FGRID_GUARD 3
/* Bytes of the arrays a grid holds (forcing_debug_bytes). */
size_t fgrid_bytes(const fgrid *g);
/* Curvilinear grid: cosang/sinang from an angle per node (radians; NULL
 * or NaN: from the node coordinates). */
void fgrid_angles(fgrid *g, const double *angle);
double fgrid_wrap180(double x);
/* Locates n points; sets g->ok[p]. Returns the number of points outside. */
size_t fgrid_stencils(fgrid *g, unsigned long stamp, size_t n, const double *lon,
                      const double *lat);
/* Interpolates one slice (NaN = missing) at point p using its stencil; falls
 * back to the nearest valid node within one cell. Returns 0, or -1 when no
 * valid value is near. */
int fgrid_interp(const fgrid *g, const double *slice, size_t p, double lon, double lat,
                 double *value);
/* fgrid_interp of two slices at point p in one pass over the stencil (the
 * same values bit for bit); slice a only when want_a, b only when want_b. */
/* (inline: sample_var's loop over the points takes it with want_a and
 * want_b constant) */
static inline int fgrid_interp2(const fgrid *g, const double *a, const double *b, int want_a,
                                int want_b, size_t p, double lon, double lat, double *va, double *vb)
{
    const size_t *idx = g->idx + 4 * p;
    const double *w = g->w + 4 * p;
    double sa = 0, wa = 0, sb = 0, wb = 0;
    for (int k = 0; k < 4; k++) {
        if (!(w[k] > 0))
            continue;
        double x = want_a ? a[idx[k]] : NAN, y = want_b ? b[idx[k]] : NAN;
        if (!isnan(x)) {
            sa += w[k] * x;
            wa += w[k];
        }
        if (!isnan(y)) {
            sb += w[k] * y;
            wb += w[k];
        }
    }
    int bad = 0;
    if (want_a) {
        if (wa > 1e-12)
            *va = sa / wa;
        else
            bad |= fgrid_interp(g, a, p, lon, lat, va);
    }
    if (want_b) {
        if (wb > 1e-12)
            *vb = sb / wb;
        else
            bad |= fgrid_interp(g, b, p, lon, lat, vb);
    }
    return bad ? -1 : 0;
}
/* Centred-difference gradient (d/d east, d/d north in units per metre). */
void fgrid_gradient(const fgrid *g, const double *h, double *gx, double *gy);
/* 1 when the point lies in the grid. */
int fgrid_covers(fgrid *g, double lon, double lat);
/* 1 when the point lies within the extent of the file's grid (a point the read
 * window leaves out, for messages). */
int fgrid_covers_file(const fgrid *g, double lon, double lat);

/* forcing_tide.c */
/* Harmonic constants of v from amplitudes and phases (degrees) of nc
 * constituents, [k][j*nx+i] on v's grid, NaN = missing; index[k] is the
 * constituent's tide_constituent_index. A repeated constituent: the first
 * wins. Sets v->fill_fraction. */
int ftide_constants(fsource *s, fvar *v, const int *index, size_t nc, const double *amp,
                    const double *phase, sph_error *err);
void ftide_synth(fvar *v, const tide_args *a, double t, double *out);

/* forcing.c helpers shared with the others */
/* Sets "forcing '<source>': <path>: <message>" in err; returns code. */
int forcing_fail(sph_error *err, const fsource *s, const char *path, int code, const char *fmt,
                 ...) __attribute__((format(printf, 5, 6)));

#endif
