/* Read windows on a large file (issue 19 item 10, docs/forcing.md "Large
 * files"): the cost of reading the demo's Liaodong domain from a global
 * 1/12-degree file shaped like the CMEMS global analysis
 * (GLOBAL_ANALYSISFORECAST_PHY_001_024: dimensions time, depth, latitude
 * 2041 (-80 .. 90), longitude 4320 (-180 .. 180 - 1/12), float uo/vo with
 * _FillValue, standard names eastward/northward_sea_water_velocity, time in
 * hours since 1950-01-01), against reading the whole file, in the same run.
 *
 * The file is written by the benchmark into a temporary folder and removed
 * after: 3 time steps (6-hourly) and only the surface level (depth of
 * length 1, 0.494 m as the product's first level) to keep the disk use
 * small (about 2 x 35 MB per time uncompressed). The values are smooth
 * analytic fields with land (fill) where an analytic "continent" function
 * is positive, deflated at level 1 with shuffle. The product's exact chunk
 * shape was not found in its public documentation, so two chunkings are
 * measured: tiles of 1 x 1 x 256 x 512 and the netCDF library's default
 * chunks for this shape; a window cannot cost less than the chunks it
 * touches.
 *
 * Each read runs in its own child (peak memory its own): forcing_open with
 * and without a read window (forcing[].margin_km default, 300 km), then
 * sampling the currents at 2000 points in the domain at two times (all
 * three slices of both variables are read). Rows: method "whole" and
 * "window" (err = bytes the reader holds, MB; err2 = slices read), and
 * "window/whole" (cpu_s and wall_s: the ratios; peak_rss_mb: the window's;
 * err = wall-time ratio, err2 = bytes ratio, err3 = peak RSS ratio; status
 * "values_differ" when a sampled value is not bit for bit the whole read's).
 * The target: a regional read costs at most 5 % of the whole
 * file's.
 *   BENCH_QUICK=1: 2 time steps. */
#include "bench_common.h"
#include "io/forcing.h"
#include "util/err.h"

#include <netcdf.h>
#include <stdint.h>

#include "../tests/cmems_nc.h"

#define NLON 4320
#define NLAT 2041
#define T0 1700006400.0   /* 2023-11-15T00:00:00Z */
#define NPTS 2000

static const double demo_box[4] = {120.85, 122.55, 39.65, 41.05}; /* bench/../demo.json */

static int ntimes(void)
{
    return bench_quick() ? 2 : 3;
}

static const char *const uo_atts[] = {"standard_name", "eastward_sea_water_velocity", "units", "m s-1",
                                      NULL};
static const char *const vo_atts[] = {"standard_name", "northward_sea_water_velocity", "units",
                                      "m s-1", NULL};

/* chunks NULL: the library's default chunking */
static void write_global(const char *path, const size_t *chunks)
{
    int nc, d[4], c[4], vv[2];
    cmems_check(nc_create(path, NC_CLOBBER | NC_NETCDF4, &nc), path);
    cmems_coords(nc, (size_t)ntimes(), NLAT, NLON, d, c);
    vv[0] = cmems_data(nc, "uo", 4, d, chunks, uo_atts);
    vv[1] = cmems_data(nc, "vo", 4, d, chunks, vo_atts);
    cmems_check(nc_enddef(nc), "enddef");
    cmems_coord_values(nc, c, (size_t)ntimes(), T0 / 3600.0 + CMEMS_H1970, NLAT, -80.0, NLON,
                       -180.0, 1.0 / 12.0);
    float *buf = malloc((size_t)NLON * NLAT * sizeof *buf);
    if (!buf)
        exit(2);
    for (int k = 0; k < ntimes(); k++)
        for (int q = 0; q < 2; q++) {
            for (size_t j = 0; j < NLAT; j++) {
                double la = -80.0 + (double)j / 12.0;
                for (size_t i = 0; i < NLON; i++) {
                    double lo = -180.0 + (double)i / 12.0;
                    double landf = sin(lo * 0.05) * cos(la * 0.07) - 0.6;
                    buf[j * NLON + i] =
                        landf > 0 ? CMEMS_FILL
                                  : (float)(q == 0 ? 0.5 * sin(lo * 0.1 + k) * cos(la * 0.08)
                                                   : 0.4 * cos(lo * 0.07 - k) * sin(la * 0.11));
                }
            }
            size_t start[4] = {(size_t)k, 0, 0, 0}, count[4] = {1, 1, NLAT, NLON};
            cmems_check(nc_put_vara_float(nc, vv[q], start, count, buf), "data");
        }
    free(buf);
    cmems_check(nc_close(nc), "close");
}

typedef struct run_arg {
    const char *path;
    int window;
    double *out; /* shared: 2 * NPTS values */
} run_arg;

static void run_read(const void *argp, bench_row *r)
{
    const run_arg *a = argp;
    double c0 = bench_cpu(), w0 = bench_wall();
    const char *files[1] = {a->path};
    forcing_source_spec sp = cmems_spec(files, FQ_CURRENT, a->window, 300.0); /* the key's default */
    forcing *f = NULL;
    sph_error e;
    sph_error_clear(&e);
    double t_end = T0 + 6.0 * 3600.0 * (ntimes() - 1);
    if (forcing_open(&f, &sp, 1, T0, t_end, demo_box[0], demo_box[1], demo_box[2], demo_box[3], &e)) {
        fprintf(stderr, "bench_hyperslab: %s\n", e.msg);
        snprintf(r->status, sizeof r->status, "error");
        return;
    }
    double lon[NPTS], lat[NPTS];
    uint64_t s = 88172645463325252ull;
    for (int p = 0; p < NPTS; p++) {
        s ^= s << 13, s ^= s >> 7, s ^= s << 17;
        lon[p] = demo_box[0] + (demo_box[1] - demo_box[0]) * (double)(s >> 11) / 9007199254740992.0;
        s ^= s << 13, s ^= s >> 7, s ^= s << 17;
        lat[p] = demo_box[2] + (demo_box[3] - demo_box[2]) * (double)(s >> 11) / 9007199254740992.0;
    }
    for (int k = 0; k + 1 < ntimes(); k++) {
        forcing_sample fs;
        memset(&fs, 0, sizeof fs);
        fs.uw_east = a->out;
        fs.vw_north = a->out + NPTS;
        if (forcing_sample_at(f, T0 + 6.0 * 3600.0 * (k + 0.5), NPTS, lon, lat, &fs, &e)) {
            fprintf(stderr, "bench_hyperslab: %s\n", e.msg);
            snprintf(r->status, sizeof r->status, "error");
            break;
        }
    }
    r->cpu_s = bench_cpu() - c0;
    r->wall_s = bench_wall() - w0;
    r->err_name[0] = "bytes_held_mb";
    r->err[0] = (double)forcing_debug_bytes(f) / 1048576.0;
    r->err_name[1] = "slices_read";
    r->err[1] = (double)forcing_debug_slice_reads(f);
    forcing_close(f);
}

int main(void)
{
    char dir[] = "/tmp/sphice-bench-hyperslab-XXXXXX";
    if (!mkdtemp(dir)) {
        perror("bench_hyperslab: mkdtemp");
        return 2;
    }
    double *shared = mmap(NULL, 4 * NPTS * sizeof(double), PROT_READ | PROT_WRITE,
                          MAP_SHARED | MAP_ANONYMOUS, -1, 0);
    if (shared == MAP_FAILED)
        return 2;
    static const size_t tiles[4] = {1, 1, 256, 512};
    static const struct {
        const char *name;
        const size_t *chunks;
    } layouts[] = {{"chunks 1x1x256x512", tiles}, {"library default chunks", NULL}};
    int rc = 0;
    for (size_t l = 0; l < sizeof layouts / sizeof layouts[0]; l++) {
        char path[512], config[160];
        snprintf(path, sizeof path, "%s/global_%zu.nc", dir, l);
        double w0 = bench_wall();
        write_global(path, layouts[l].chunks);
        size_t ch[4] = {0, 0, 0, 0};
        int nc, v, storage;
        if (nc_open(path, NC_NOWRITE, &nc) == NC_NOERR) {
            if (nc_inq_varid(nc, "uo", &v) == NC_NOERR)
                nc_inq_var_chunking(nc, v, &storage, ch);
            nc_close(nc);
        }
        fprintf(stderr, "bench_hyperslab: wrote %s (%s: %zux%zux%zux%zu) in %.1f s\n", path,
                layouts[l].name, ch[0], ch[1], ch[2], ch[3], bench_wall() - w0);
        snprintf(config, sizeof config,
                 "global 1/12 deg %dx%d %d times; chunks %zux%zux%zux%zu; liaodong; margin 300 km",
                 NLON, NLAT, ntimes(), ch[0], ch[1], ch[2], ch[3]);
        bench_row whole, win;
        run_arg aw = {path, 0, shared}, ar = {path, 1, shared + 2 * NPTS};
        rc |= bench_run_forked_row("hyperslab", run_read, &aw, "whole", config, &whole);
        rc |= bench_run_forked_row("hyperslab", run_read, &ar, "window", config, &win);
        size_t diff = 0;
        for (int p = 0; p < 2 * NPTS; p++)
            diff += memcmp(&shared[p], &shared[2 * NPTS + p], sizeof(double)) != 0;
        bench_row ratio;
        bench_row_init(&ratio, "hyperslab");
        snprintf(ratio.method, sizeof ratio.method, "window/whole");
        snprintf(ratio.config, sizeof ratio.config, "%s", config);
        ratio.cpu_s = whole.cpu_s > 0 ? win.cpu_s / whole.cpu_s : NAN;
        ratio.wall_s = whole.wall_s > 0 ? win.wall_s / whole.wall_s : NAN;
        ratio.rss_mb = win.rss_mb;
        snprintf(ratio.status, sizeof ratio.status, "%s", diff ? "values_differ" : "ok");
        ratio.err_name[0] = "wall_ratio";
        ratio.err[0] = ratio.wall_s;
        ratio.err_name[1] = "bytes_ratio";
        ratio.err[1] = whole.err[0] > 0 ? win.err[0] / whole.err[0] : NAN;
        ratio.err_name[2] = "rss_ratio";
        ratio.err[2] = whole.rss_mb > 0 ? win.rss_mb / whole.rss_mb : NAN;
        bench_row_print(&ratio);
        fprintf(stderr,
                "bench_hyperslab: %s: whole %.3f s wall, %.1f MB held, %.0f MB peak RSS; window "
                "%.4f s, %.3f MB, %.0f MB RSS: time %.2f %%, bytes %.3f %% (target <= 5 %%); %zu "
                "of %d values differ\n",
                layouts[l].name, whole.wall_s, whole.err[0], whole.rss_mb, win.wall_s, win.err[0],
                win.rss_mb, 100.0 * ratio.wall_s, 100.0 * ratio.err[1], diff, 2 * NPTS);
        unlink(path);
    }
    rmdir(dir);
    munmap(shared, 4 * NPTS * sizeof(double));
    return rc ? 1 : 0;
}
