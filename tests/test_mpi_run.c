/* `sphice run` with parallel.decomposition "domain" (issue 24 item 2;
 * service/forecast_domain.c, docs/domain.md): one member decomposed by
 * space over the MPI ranks must publish exactly the products of the serial
 * canonical run.
 *
 * The case: the small engine case (tests/engine_case.h) with packed ice
 * (A = 1, 1 m) from 121.2 E to 121.88 E, so its eastern particles lie
 * within a kernel support of the coast at 121.9 E (mirror ghosts), a
 * northward 10 m/s wind along the coast, thermodynamics off, full physics
 * with mEVP (30 iterations), 1 h at 300 s (2 h with SPHICE_LONG). The
 * serial run (build/sphice, the plain build, key "domain") against
 * `mpirun --oversubscribe -np 2` (and -np 4 with SPHICE_LONG=1) of
 * build-mpi/sphice: tools/same-products.sh over the
 * cycle folders (every file; NetCDF compared by ncdump at 17 digits with
 * the attributes that name the run rather than the forecast -- dates,
 * version, wall times -- left out), and the particles file's data
 * variables bit for bit (nc_get_var, memcmp). With thermodynamics
 * (model.thermo.dt 600): a strip of packed ice (1 cm in every other
 * column, 1 m elsewhere) under warm air (+25 C) whose thin particles melt
 * out and are removed, and with SPHICE_LONG=1 also the first case's ice
 * under its cold air (-10 C: the ice grows); each serial against -np 2
 * (and -np 4 with SPHICE_LONG=1), the same comparisons, and the published
 * mass budget closing (residual below the serial core's
 * model.mass_tolerance, 1e-9). A warm start: the 12Z cycle from a serial
 * 06Z restart, serial against -np 2 (and -np 4 with SPHICE_LONG=1): every
 * product and the next restart identical; from the ocean-fluxes case below
 * (with SPHICE_LONG=1 also from the first case and the cold-air case). The ocean-fluxes file (no mixed layer): the melt case
 * for 2 h with two hourly records, the same comparisons, and the next
 * cycle warm-started from its restart. The mixed layer with new ice in
 * open water and the ocean-fluxes file (the season case): 2 h, the same
 * comparisons on -np 2 (and -np 4 with SPHICE_LONG=1), the fluxes file
 * among the products, and its warm start on -np 2. The refusals: each
 * unsupported combination fails in one line naming its key. A failure
 * inside the decomposed run (forcing too short, met by every rank after
 * rank 0 sent the jobs) fails every rank with one line, publishes
 * nothing and does not hang (timeout 120). Skipped
 * (one line) without mpirun or the MPI build; the refusals run anyway. */
#include <math.h>
#include <netcdf.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "check.h"
#include "engine_case.h"
#include "service/cycle.h"

static char dir[] = "/tmp/sphice-mpirun-XXXXXX";

static int run(const char *cmd)
{
    int rc = system(cmd);
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

/* Every variable of the particles file a equal to b's, bit for bit. */
static int same_particles_file(const char *a, const char *b, int *nvars)
{
    int na, nb, ok = nc_open(a, NC_NOWRITE, &na) == NC_NOERR;
    if (!ok)
        return 0;
    if (nc_open(b, NC_NOWRITE, &nb) != NC_NOERR) {
        nc_close(na);
        return 0;
    }
    int nv = 0, nvb = 0;
    ok = nc_inq_nvars(na, &nv) == NC_NOERR && nc_inq_nvars(nb, &nvb) == NC_NOERR && nv == nvb && nv > 0;
    for (int v = 0; ok && v < nv; v++) {
        char name[NC_MAX_NAME + 1];
        int nd, dims[NC_MAX_VAR_DIMS], vb;
        nc_type t;
        ok = nc_inq_var(na, v, name, &t, &nd, dims, NULL) == NC_NOERR && nc_inq_varid(nb, name, &vb) == NC_NOERR;
        size_t n = 1, sz = 0;
        for (int d = 0; ok && d < nd; d++) {
            size_t len;
            ok = nc_inq_dimlen(na, dims[d], &len) == NC_NOERR;
            n *= len;
        }
        ok = ok && nc_inq_type(na, t, NULL, &sz) == NC_NOERR;
        void *x = ok ? malloc(n * sz + 1) : NULL, *y = ok ? malloc(n * sz + 1) : NULL;
        ok = ok && x && y && nc_get_var(na, v, x) == NC_NOERR && nc_get_var(nb, vb, y) == NC_NOERR &&
             memcmp(x, y, n * sz) == 0;
        if (!ok)
            printf("  particles: variable %s differs\n", name);
        free(x);
        free(y);
    }
    *nvars = nv;
    nc_close(na);
    nc_close(nb);
    return ok;
}

static void write_config(const char *name, const char *from, const char *to, const char *extra)
{
    char text[8192], path[1200];
    ec_config(text, sizeof text, dir, 300, "[\"wind\"]", "ice1.nc", extra);
    ec_config_replace(text, sizeof text, "\"thermo\": {\"dt\": 600}",
                      "\"thermo\": {\"dt\": 0}, \"physics\": \"full\", \"evp\": {\"iterations\": 30}");
    if (from)
        ec_config_replace(text, sizeof text, from, to);
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    CHECK(f && fputs(text, f) >= 0, "write %s", path);
    if (f)
        fclose(f);
}

/* path's text into text (size bytes; empty if unreadable). */
static void read_text(const char *path, char *text, size_t size)
{
    FILE *f = fopen(path, "r");
    size_t got = f ? fread(text, 1, size - 1, f) : 0;
    text[got] = 0;
    if (f)
        fclose(f);
}

/* Replaces the first `from` in the configuration file name of dir by `to`. */
static void edit_config(const char *name, const char *from, const char *to)
{
    char text[8192], path[1200];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    read_text(path, text, sizeof text);
    CHECK(ec_config_replace(text, sizeof text, from, to), "%s: %s replaced", name, from);
    FILE *f = fopen(path, "w");
    CHECK(f && fputs(text, f) >= 0, "write %s", path);
    if (f)
        fclose(f);
}

/* The warm air of the melt case: +25 C, the case's wind. */
static double warm_atm(int which, double lon, double lat, size_t k)
{
    return which == 2 ? 298.15 : ec_atm_fn(which, lon, lat, k);
}

/* The number after "key": in the serial run's cycle.json of case name (NAN if absent). */
static double cycle_number(const char *name, const char *key)
{
    char path[1300], text[65536], pat[128];
    snprintf(path, sizeof path, "%s/%s-serial/19990208T06Z/cycle.json", dir, name);
    read_text(path, text, sizeof text);
    snprintf(pat, sizeof pat, "\"%s\":", key);
    const char *at = strstr(text, pat);
    return at ? strtod(at + strlen(pat), NULL) : NAN;
}

/* The global attribute budget_<term> of the serial run's restart file. */
static double restart_budget(const char *name, const char *term)
{
    char path[1300], att[128];
    snprintf(path, sizeof path, "%s/%s-serial/19990208T06Z/restart-19990208T12Z.nc", dir, name);
    snprintf(att, sizeof att, "budget_%s", term);
    int nc = -1;
    double v = NAN;
    int opened = nc_open(path, NC_NOWRITE, &nc) == NC_NOERR;
    if (!opened || nc_get_att_double(nc, NC_GLOBAL, att, &v) != NC_NOERR)
        v = NAN;
    if (opened)
        nc_close(nc);
    return v;
}

/* Serial "domain" against mpirun -np 2 (and 4 with SPHICE_LONG) for the
 * configuration cfg in dir: products and particles identical. */
static void compare_runs(const char *ser_bin, const char *mpi_bin, const char *name, const char *cfg, int hours)
{
    char cmd[4096];
    snprintf(cmd, sizeof cmd, "OMP_NUM_THREADS=1 %s run %s/%s --cycle 1999-02-08T06:00Z --hours %d --out "
             "%s/%s-serial --force >%s/%s-serial.log 2>&1", ser_bin, dir, cfg, hours, dir, name, dir, name);
    CHECK(run(cmd) == 0, "%s: serial canonical run (%s/%s-serial.log)", name, dir, name);
    const char *mpirun = "mpirun --oversubscribe -x OMP_NUM_THREADS=1 -x OMP_WAIT_POLICY=passive";
    const char *root = geteuid() == 0 ? "--allow-run-as-root" : "";
    const int np[2] = {2, 4};
    for (int i = 0; i < (check_long() ? 2 : 1); i++) {
        snprintf(cmd, sizeof cmd, "%s %s -np %d %s run %s/%s --cycle 1999-02-08T06:00Z --hours %d --out "
                 "%s/%s-np%d --force >%s/%s-np%d.log 2>&1", mpirun, root, np[i], mpi_bin, dir, cfg, hours, dir,
                 name, np[i], dir, name, np[i]);
        int rc = run(cmd);
        CHECK(rc == 0, "%s: mpirun -np %d: rc %d (%s/%s-np%d.log)", name, np[i], rc, dir, name, np[i]);
        snprintf(cmd, sizeof cmd, "sh tools/same-products.sh %s/%s-serial/19990208T06Z %s/%s-np%d/19990208T06Z",
                 dir, name, dir, name, np[i]);
        CHECK(run(cmd) == 0, "%s: -np %d: every product equals the serial canonical run's (same-products)", name,
              np[i]);
        char a[1400], b[1400];
        snprintf(a, sizeof a, "%s/%s-serial/19990208T06Z/sphice_particles.nc", dir, name);
        snprintf(b, sizeof b, "%s/%s-np%d/19990208T06Z/sphice_particles.nc", dir, name, np[i]);
        int nv = 0;
        CHECK(same_particles_file(a, b, &nv), "%s: -np %d: the particles file's %d variables equal bit for bit",
              name, np[i], nv);
    }
    /* the budget closes with the sources: mass = initial + sources */
    double res = cycle_number(name, "budget_residual");
    CHECK(res >= 0.0 && res < 1e-9, "%s: the mass budget's residual %.3g is below model.mass_tolerance 1e-9", name,
          res);
}

/* A warm start under the decomposition: the 12Z cycle of configuration
 * cfg warm-started from the restart file that the serial run of case from
 * wrote (<from>/19990208T06Z/restart-19990208T12Z.nc, copied into each
 * output folder as its previous cycle), serial "domain" against mpirun -np 2
 * (and 4 with SPHICE_LONG): both logs say warm start, and every product of
 * the 12Z cycle -- the next cycle's restart file included -- and the
 * particles file's variables are identical. */
static void compare_warm(const char *ser_bin, const char *mpi_bin, const char *name, const char *from,
                         const char *cfg)
{
    char cmd[4096];
    const char *mpirun = "mpirun --oversubscribe -x OMP_NUM_THREADS=1 -x OMP_WAIT_POLICY=passive";
    const char *root = geteuid() == 0 ? "--allow-run-as-root" : "";
    const char *runs[3] = {"serial", "np2", "np4"};
    for (int i = 0; i < (check_long() ? 3 : 2); i++) {
        snprintf(cmd, sizeof cmd, "rm -rf %s/%s-%s && mkdir -p %s/%s-%s && cp -r %s/%s/19990208T06Z %s/%s-%s/",
                 dir, name, runs[i], dir, name, runs[i], dir, from, dir, name, runs[i]);
        CHECK(run(cmd) == 0, "%s: the previous cycle copied for %s", name, runs[i]);
        if (i == 0)
            snprintf(cmd, sizeof cmd, "OMP_NUM_THREADS=1 %s", ser_bin);
        else
            snprintf(cmd, sizeof cmd, "%s %s -np %d %s", mpirun, root, i == 1 ? 2 : 4, mpi_bin);
        size_t used = strlen(cmd);
        snprintf(cmd + used, sizeof cmd - used, " run %s/%s --cycle 1999-02-08T12:00Z --hours 1 --out %s/%s-%s "
                 "--force >%s/%s-%s.log 2>&1", dir, cfg, dir, name, runs[i], dir, name, runs[i]);
        int rc = run(cmd);
        CHECK(rc == 0, "%s: %s warm-started run: rc %d (%s/%s-%s.log)", name, runs[i], rc, dir, name, runs[i]);
        snprintf(cmd, sizeof cmd, "grep -q 'warm start from .*%s/19990208T06Z/restart-19990208T12Z.nc' %s/%s-%s.log",
                 runs[i], dir, name, runs[i]);
        CHECK(run(cmd) == 0, "%s: %s: the run started warm from the previous cycle's restart", name, runs[i]);
        if (i == 0)
            continue;
        snprintf(cmd, sizeof cmd, "grep -q 'decomposition \"domain\" over %d ranks' %s/%s-%s.log", i == 1 ? 2 : 4,
                 dir, name, runs[i]);
        CHECK(run(cmd) == 0, "%s: %s: the run was decomposed", name, runs[i]);
        snprintf(cmd, sizeof cmd, "sh tools/same-products.sh %s/%s-serial/19990208T12Z %s/%s-%s/19990208T12Z", dir,
                 name, dir, name, runs[i]);
        CHECK(run(cmd) == 0, "%s: %s: every product and the restart equal the serial warm-started run's "
              "(same-products)", name, runs[i]);
        char a[1400], b[1400];
        snprintf(a, sizeof a, "%s/%s-serial/19990208T12Z/sphice_particles.nc", dir, name);
        snprintf(b, sizeof b, "%s/%s-%s/19990208T12Z/sphice_particles.nc", dir, name, runs[i]);
        int nv = 0;
        CHECK(same_particles_file(a, b, &nv), "%s: %s: the particles file's %d variables equal bit for bit", name,
              runs[i], nv);
        snprintf(a, sizeof a, "%s/%s-serial/19990208T12Z/restart-19990208T18Z.nc", dir, name);
        snprintf(b, sizeof b, "%s/%s-%s/19990208T12Z/restart-19990208T18Z.nc", dir, name, runs[i]);
        CHECK(same_particles_file(a, b, &nv), "%s: %s: the restart file's %d variables equal bit for bit", name,
              runs[i], nv);
    }
}

/* One refused combination (from -> to, and from2 -> to2 unless NULL):
 * exit 1 and one line naming key. */
static void refused2(const char *bin, const char *what, const char *from, const char *to, const char *from2,
                     const char *to2, const char *extra, const char *key)
{
    write_config("refuse.json", from, to, extra);
    if (from2)
        edit_config("refuse.json", from2, to2);
    char cmd[4096], log[1300];
    snprintf(log, sizeof log, "%s/refuse.log", dir);
    snprintf(cmd, sizeof cmd, "OMP_NUM_THREADS=1 %s run %s/refuse.json --cycle 1999-02-08T06:00Z --hours 1 --out "
             "%s/refused --force >%s 2>&1", bin, dir, dir, log);
    int rc = run(cmd);
    char line[2048] = "", all[8192] = "";
    FILE *f = fopen(log, "r");
    while (f && fgets(line, sizeof line, f))
        if (strstr(line, "sphice run:"))
            snprintf(all, sizeof all, "%s", line);
    if (f)
        fclose(f);
    CHECK(rc == 1 && strstr(all, key) && strstr(all, "parallel.decomposition"),
          "%s refused in one line naming %s (exit %d: %s)", what, key, rc, all);
    char out[1300];
    snprintf(out, sizeof out, "%s/refused/19990208T06Z", dir);
    CHECK(access(out, F_OK) != 0, "%s: nothing published", what);
}

static void refused(const char *bin, const char *what, const char *from, const char *to, const char *extra,
                    const char *key)
{
    refused2(bin, what, from, to, NULL, NULL, extra, key);
}

/* The serial run `name`'s ocean-fluxes file has `want` records. */
static void check_flux_records(const char *name, size_t want)
{
    char of[1300];
    snprintf(of, sizeof of, "%s/%s-serial/19990208T06Z/sphice_ocean_fluxes.nc", dir, name);
    int nc = -1, dim;
    size_t nt = 0;
    int ok = nc_open(of, NC_NOWRITE, &nc) == NC_NOERR && nc_inq_unlimdim(nc, &dim) == NC_NOERR && dim >= 0 &&
             nc_inq_dimlen(nc, dim, &nt) == NC_NOERR;
    if (nc >= 0)
        nc_close(nc);
    CHECK(ok && nt == want, "%s: the ocean-fluxes file has %zu hourly records (%zu), compared above", name, want, nt);
}

/* The season configuration: thermodynamics every 600 s, summation density,
 * a 2 m slab mixed layer, new particles from 2 mm of frazil and merging,
 * the cold air, initial ice from `ice`. */
static void write_season_config(const char *file, const char *ice, const char *dom)
{
    write_config(file, "\"thermo\": {\"dt\": 0}",
                 "\"thermo\": {\"dt\": 600}, \"summation_density\": true, \"ocean\": {\"mixed_layer\": true, "
                 "\"depth\": 2}, \"new_ice\": {\"create\": true, \"thickness\": 0.002, \"merge\": true, "
                 "\"merge_distance\": 1.05}", dom);
    edit_config(file, "ice1.nc", ice);
    edit_config(file, "[\"wind\"]", "[\"wind\", \"tair\"]");
}

int main(int argc, char **argv)
{
    (void)argc;
    ec_passive_openmp(argv);
    char mpi_bin[512], ser_bin[512];
    ec_sphice_bins(ser_bin, mpi_bin, sizeof ser_bin);
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    ec_write_inputs(dir);
    char p[1200];
    snprintf(p, sizeof p, "%s/ice1.nc", dir);
    ec_write_ice_at(p, 35, 21, 121.2, 40.1, 0.02, 0.02, 1.0, 1.0, -1); /* to 121.88 E, the coast at 121.9 */
    const char *dom = "\"parallel\": {\"decomposition\": \"domain\"},";

    /* the refusals (the plain build: fast, before any input is read) */
    refused(ser_bin, "the implicit solver", "\"physics\": \"full\"", "\"physics\": \"full\", \"solver\": \"implicit\"",
            dom, "model.solver");
    refused(ser_bin, "an ensemble", NULL, NULL, "\"parallel\": {\"decomposition\": \"domain\"}, \"ensemble\": {\"members\": 2},",
            "ensemble.members");
    refused(ser_bin, "Anderson acceleration", "\"evp\": {\"iterations\": 30}",
            "\"evp\": {\"iterations\": 30, \"anderson\": 3}", dom, "model.evp.anderson");

    if (run("command -v mpirun >/dev/null 2>&1") != 0 || access(mpi_bin, X_OK) != 0) {
        printf("test_mpi_run: skipped the MPI runs: needs mpirun and build-mpi/sphice (sh tools/install-deps.sh "
               "--mpi; make mpi-build)\n");
        if (!getenv("SPHICE_KEEP"))
            cycle_remove_tree(dir);
        return check_summary("test_mpi_run");
    }
    write_config("cfg.json", NULL, NULL, dom);
    char cmd[4096];
    const int hours = check_long() ? 2 : 1; /* make check: 12 steps, 2 output times, a few seconds */
    snprintf(cmd, sizeof cmd, "OMP_NUM_THREADS=1 %s run %s/cfg.json --cycle 1999-02-08T06:00Z --hours %d --out "
             "%s/serial --force >%s/serial.log 2>&1", ser_bin, dir, hours, dir, dir);
    CHECK(run(cmd) == 0, "serial canonical run (%s/serial.log)", dir);
    const char *mpirun = "mpirun --oversubscribe -x OMP_NUM_THREADS=1 -x OMP_WAIT_POLICY=passive";
    const char *root = geteuid() == 0 ? "--allow-run-as-root" : "";
    const int np[2] = {2, 4};
    for (int i = 0; i < (check_long() ? 2 : 1); i++) {
        snprintf(cmd, sizeof cmd, "%s %s -np %d %s run %s/cfg.json --cycle 1999-02-08T06:00Z --hours %d --out %s/np%d "
                 "--force >%s/np%d.log 2>&1", mpirun, root, np[i], mpi_bin, dir, hours, dir, np[i], dir, np[i]);
        int rc = run(cmd);
        CHECK(rc == 0, "mpirun -np %d: rc %d (%s/np%d.log)", np[i], rc, dir, np[i]);
        snprintf(cmd, sizeof cmd, "grep -q 'decomposition \"domain\" over %d ranks' %s/np%d.log", np[i], dir, np[i]);
        CHECK(run(cmd) == 0, "-np %d: the run was decomposed over %d ranks", np[i], np[i]);
        snprintf(cmd, sizeof cmd, "sh tools/same-products.sh %s/serial/19990208T06Z %s/np%d/19990208T06Z",
                 dir, dir, np[i]);
        CHECK(run(cmd) == 0, "-np %d: every product equals the serial canonical run's (same-products)", np[i]);
        char a[1400], b[1400];
        snprintf(a, sizeof a, "%s/serial/19990208T06Z/sphice_particles.nc", dir);
        snprintf(b, sizeof b, "%s/np%d/19990208T06Z/sphice_particles.nc", dir, np[i]);
        int nv = 0;
        CHECK(same_particles_file(a, b, &nv), "-np %d: the particles file's %d variables equal bit for bit", np[i],
              nv);
    }
    /* a warm start: the next cycle from the serial run's restart (make
     * check warm-starts the ocean-fluxes case below) */
    if (check_long())
        compare_warm(ser_bin, mpi_bin, "restart", "serial", "cfg.json");

    /* thermodynamics: warm air melts the thin columns out (particles
     * removed); with SPHICE_LONG also cold air growing the packed ice */
    if (check_long()) {
        write_config("cold.json", "\"thermo\": {\"dt\": 0}", "\"thermo\": {\"dt\": 600}", dom);
        edit_config("cold.json", "[\"wind\"]", "[\"wind\", \"tair\"]");
        compare_runs(ser_bin, mpi_bin, "cold", "cold.json", hours);
        double g = restart_budget("cold", "growth"), m0 = restart_budget("cold", "mass_initial");
        double m1 = restart_budget("cold", "mass");
        CHECK(g > 0.0 && m1 > m0 && cycle_number("cold", "particles_end") == cycle_number("cold", "particles_start"),
              "cold: the ice grew (growth %.4g kg, mass %.6g -> %.6g kg), no particle removed", g, m0, m1);
        compare_warm(ser_bin, mpi_bin, "restart-cold", "cold-serial", "cold.json"); /* with thermodynamics */
    }
    snprintf(p, sizeof p, "%s/atm_warm.nc", dir);
    ec_write_atm_at(p, 9.0, 120.5, 39.5, 9, 7, warm_atm);
    snprintf(p, sizeof p, "%s/ice_thin.nc", dir);
    ec_write_ice_at(p, 35, 8, 121.2, 40.1, 0.02, 0.02, 1.0, 1.0, -1); /* a strip: 40.1-40.24 N */
    {
        int nc, vt;
        double th[8 * 35];
        for (int k = 0; k < 8 * 35; k++)
            th[k] = (k % 35) % 2 ? 1.0 : 0.01;
        CHECK(nc_open(p, NC_WRITE, &nc) == NC_NOERR && nc_inq_varid(nc, "sithick", &vt) == NC_NOERR &&
              nc_put_var_double(nc, vt, th) == NC_NOERR && nc_close(nc) == NC_NOERR, "write %s", p);
    }
    write_config("warm.json", "\"thermo\": {\"dt\": 0}", "\"thermo\": {\"dt\": 600}", dom);
    edit_config("warm.json", "atm.nc", "atm_warm.nc");
    edit_config("warm.json", "ice1.nc", "ice_thin.nc");
    edit_config("warm.json", "[\"wind\"]", "[\"wind\", \"tair\"]");
    compare_runs(ser_bin, mpi_bin, "warm", "warm.json", 1);
    double n0 = cycle_number("warm", "particles_start"), n1 = cycle_number("warm", "particles_end");
    double mt = restart_budget("warm", "melt_top");
    CHECK(n1 < n0 && n1 > 0 && mt > 0.0, "warm: %.0f of %.0f particles melted out and were removed (surface melt %.4g kg)",
          n0 - n1, n0, mt);
    printf("  thermodynamics, warm: %.0f -> %.0f particles, surface melt %.4g kg, budget residual %.3g\n", n0, n1, mt,
           cycle_number("warm", "budget_residual"));

    /* the ocean-fluxes file (no mixed layer): the melt case for 2 h, two
     * hourly records of the particles' accumulators gathered on rank 0
     * (each rank's restart from zero after each record) */
    write_config("fluxes.json", "\"thermo\": {\"dt\": 0}", "\"thermo\": {\"dt\": 600}", dom);
    edit_config("fluxes.json", "atm.nc", "atm_warm.nc");
    edit_config("fluxes.json", "ice1.nc", "ice_thin.nc");
    edit_config("fluxes.json", "[\"wind\"]", "[\"wind\", \"tair\"]");
    edit_config("fluxes.json", "\"interval_hours\": 1", "\"interval_hours\": 1, \"ocean_fluxes\": true");
    compare_runs(ser_bin, mpi_bin, "fluxes", "fluxes.json", 2);
    check_flux_records("fluxes", 2);
    /* the next cycle warm-started from it: the restart carries the last
     * interval's accumulators, which the new file must not count */
    compare_warm(ser_bin, mpi_bin, "restart-fluxes", "fluxes-serial", "fluxes.json");

    /* the mixed layer with new ice in open water (issue 20): the thin
     * strip and open water elsewhere under the cold air (-10 C), a 2 m
     * slab at its freezing point, new particles from 2 mm of frazil,
     * merging on; 2 h with two hourly outputs, the ocean-fluxes file (the
     * particles', the cells' and the leaving particles' fluxes) and the
     * restart (its mixed layer among its variables). On -np 4 (SPHICE_LONG)
     * the new particles just outside the mask east of the land read mirror
     * ghosts whose sources lie beyond the 2-support halo (the coast zone,
     * docs/domain.md "Halo depth"): without it their stress in the fluxes
     * file differed. */
    write_season_config("season.json", "ice_thin.nc", dom);
    edit_config("season.json", "\"interval_hours\": 1", "\"interval_hours\": 1, \"ocean_fluxes\": true");
    compare_runs(ser_bin, mpi_bin, "season", "season.json", 2);
    check_flux_records("season", 2);
    {
        double s0 = cycle_number("season", "particles_start"), s1 = cycle_number("season", "particles_end");
        double er = cycle_number("season", "energy_budget_residual");
        double wr = cycle_number("season", "water_budget_residual");
        double sr = cycle_number("season", "salt_budget_residual");
        CHECK(s1 > s0, "season: new particles in open water (%.0f -> %.0f)", s0, s1);
        CHECK(er >= 0 && er < 1e-12 && wr >= 0 && wr < 1e-12 && sr >= 0 && sr < 1e-12,
              "season: the energy, water and salt budgets close (%.3g %.3g %.3g)", er, wr, sr);
        printf("  mixed layer and new ice: %.0f -> %.0f particles, residuals energy %.3g water %.3g salt %.3g\n", s0,
               s1, er, wr, sr);
    }
    compare_warm(ser_bin, mpi_bin, "restart-season", "season-serial", "season.json");
    /* the season case from open water (no particle at the start): while no
     * particle is active anywhere the serial step skips the stress solver,
     * and the decomposed one (every rank iterating, the exchange being
     * collective) must count its iterations as 0 too: the run statistics
     * (cycle.json, the fields file's attributes) compared above */
    snprintf(p, sizeof p, "%s/ice_none.nc", dir);
    ec_write_ice_at(p, 35, 8, 121.2, 40.1, 0.02, 0.02, 0.0, 0.0, -1);
    write_season_config("open.json", "ice_none.nc", dom);
    compare_runs(ser_bin, mpi_bin, "open", "open.json", 1);
    CHECK(cycle_number("open", "particles_start") == 0 && cycle_number("open", "particles_end") > 0,
          "open: from no particle to new ice (%.0f -> %.0f)", cycle_number("open", "particles_start"),
          cycle_number("open", "particles_end"));

    /* a failure fails every rank: forcing that ends at +9 h for a 12 h run
     * (every rank's coupling_open refuses it, after rank 0 sent the jobs) */
    snprintf(cmd, sizeof cmd, "timeout 120 %s %s -np 2 %s run %s/cfg.json --cycle 1999-02-08T06:00Z --hours 12 "
             "--out %s/short --force >%s/short.log 2>&1", mpirun, root, mpi_bin, dir, dir, dir);
    int rc = run(cmd);
    snprintf(cmd, sizeof cmd, "test $(grep -c '^sphice run: ' %s/short.log) -eq 1 && grep -q 'over 2 ranks' "
             "%s/short.log", dir, dir);
    CHECK(rc != 0 && rc != 124 && run(cmd) == 0, "-np 2, forcing too short: the run fails on every rank with one "
          "line (exit %d, %s/short.log)", rc, dir);
    snprintf(p, sizeof p, "%s/short/19990208T06Z", dir);
    CHECK(access(p, F_OK) != 0, "-np 2, forcing too short: nothing published");
    if (!getenv("SPHICE_KEEP") && !check_failed_)
        cycle_remove_tree(dir);
    return check_summary("test_mpi_run");
}
