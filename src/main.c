/* sphice: the program on top of the service layer.
 *
 *   sphice run CONFIG [--cycle TIME] [--hours N] [--out DIR] [--force]
 *   sphice serve CONFIG [--listen ADDR:PORT]
 *   sphice hindcast CONFIG --from TIME --to TIME [--out DIR] [--force]
 *   sphice status [--url URL]
 *   sphice check CONFIG [--cycle TIME] [--json]
 *   sphice config-doc
 *   sphice version
 *
 * Exit status: 0 success, 1 failure (one clear line on stderr), 2 usage. */
#include <gsl/gsl_errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "io/ncfile.h"
#include "io/quicklook.h"
#include "service/check.h"
#include "service/config.h"
#include "service/cycle.h"
#include "service/ensemble.h"
#include "service/daemon.h"
#include "service/history.h"
#include "service/schedule.h"
#include "service/status_client.h"
#include "util/fileio.h"
#include "util/log.h"
#include "util/timeutil.h"
#include "util/version.h"

static const char *usage_text =
    "usage: sphice COMMAND [ARGS]\n"
    "  run CONFIG [--cycle TIME] [--hours N] [--out DIR] [--force]\n"
    "                    run one forecast cycle and exit (cron, systemd timer)\n"
    "  serve CONFIG [--listen ADDR:PORT]\n"
    "                    the daemon: scheduled cycles, HTTP status, SIGHUP reload\n"
    "  hindcast CONFIG --from TIME --to TIME [--out DIR] [--force]\n"
    "                    replay past cycles over archived forcing\n"
    "  status [--url URL]  print the daemon's status (GET /status)\n"
    "  check CONFIG [--cycle TIME] [--json]\n"
    "                    validate the configuration and look for every source\n"
    "  config-doc        print the configuration key reference (markdown)\n"
    "  version           print the version\n"
    "TIME is ISO 8601 UTC, e.g. 2024-02-08T00:00Z. `sphice COMMAND --help` for details.\n";

static int usage(FILE *f, int code)
{
    fputs(usage_text, f);
    return code;
}

static int want_help(int argc, char **argv)
{
    for (int i = 2; i < argc; i++)
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h"))
            return 1;
    return 0;
}

/* Options of a subcommand: "--name value" pairs and flags. */
typedef struct opts {
    const char *config, *cycle, *hours, *out, *listen, *url, *from, *to;
    int force, json;
} opts;

static int parse_opts(int argc, char **argv, opts *o, const char *allowed)
{
    memset(o, 0, sizeof *o);
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i];
        const char **slot = NULL;
        if (!strcmp(a, "--cycle")) slot = &o->cycle;
        else if (!strcmp(a, "--hours")) slot = &o->hours;
        else if (!strcmp(a, "--out")) slot = &o->out;
        else if (!strcmp(a, "--listen")) slot = &o->listen;
        else if (!strcmp(a, "--url")) slot = &o->url;
        else if (!strcmp(a, "--from")) slot = &o->from;
        else if (!strcmp(a, "--to")) slot = &o->to;
        else if (!strcmp(a, "--force") && strstr(allowed, "force")) { o->force = 1; continue; }
        else if (!strcmp(a, "--json") && strstr(allowed, "json")) { o->json = 1; continue; }
        else if (a[0] != '-' && !o->config) { o->config = a; continue; }
        if (!slot || !strstr(allowed, a + 2)) {
            fprintf(stderr, "sphice %s: unknown argument \"%s\" (see --help)\n", argv[1], a);
            return -1;
        }
        if (i + 1 >= argc) {
            fprintf(stderr, "sphice %s: %s needs a value\n", argv[1], a);
            return -1;
        }
        *slot = argv[++i];
    }
    return 0;
}

/* What every command does first: --help prints its usage (exit 0), then
 * its options are parsed (exit 2 on a mistake). Returns -1 to go on, or
 * the exit status. */
static int command_setup(int argc, char **argv, const char *help, const char *allowed, opts *o)
{
    if (want_help(argc, argv)) {
        puts(help);
        return 0;
    }
    return parse_opts(argc, argv, o, allowed) ? 2 : -1;
}

static int parse_time_arg(const char *cmd, const char *what, const char *text, double *t)
{
    if (time_parse_iso(text, t)) {
        fprintf(stderr, "sphice %s: %s \"%s\": not an ISO 8601 time (e.g. 2024-02-08T00:00Z)\n", cmd, what, text);
        return -1;
    }
    return 0;
}

/* A usage error: CONFIG not given. Returns 1 (and says so) when missing. */
static int config_missing(const char *cmd, const char *path)
{
    if (path)
        return 0;
    fprintf(stderr, "sphice %s: CONFIG missing (see --help)\n", cmd);
    return 1;
}

static struct sph_config *load_config(const char *cmd, const char *path)
{
    if (config_missing(cmd, path))
        return NULL;
    struct sph_config *c = NULL;
    sph_error e;
    sph_error_clear(&e);
    if (sph_config_load(path, &c, &e)) {
        fprintf(stderr, "sphice %s: %s\n", cmd, e.msg);
        return NULL;
    }
    sph_log_level = config_log_level(c);
    return c;
}

/* ------------------------------------------------------------------ run */

static int cmd_run(int argc, char **argv)
{
    opts o;
    int setup = command_setup(argc, argv,
                              "usage: sphice run CONFIG [--cycle TIME] [--hours N] [--out DIR] [--force]\n"
                              "Runs one forecast cycle and exits: 0 published (or already published), 1 failed\n"
                              "(now, or in an earlier run the history records: --force runs it again), 2 usage.\n"
                              "  --cycle TIME  cycle time (default: the latest scheduled cycle)\n"
                              "  --hours N     forecast length (default: schedule.forecast_hours)\n"
                              "  --out DIR     write there instead of output.dir (not recorded in the history)\n"
                              "  --force       run even if the history says the cycle already ran",
                              "cycle hours out force", &o);
    if (setup >= 0)
        return setup;
    if (config_missing("run", o.config))
        return 2;
    struct sph_config *cfg = load_config("run", o.config);
    if (!cfg)
        return 1;
    if (ens_mpi_rank() > 0) { /* under mpirun: an ensemble worker (service/ensemble.h) */
        service_install_signals();
        int wc = ens_mpi_worker(cfg, &service_term);
        sph_config_free(cfg);
        return wc;
    }
    cycle_opts co;
    memset(&co, 0, sizeof co);
    co.cycle_time = schedule_prev(cfg, time_now());
    co.force = o.force;
    int code = 1;
    history *h = NULL;
    if (o.cycle && parse_time_arg("run", "--cycle", o.cycle, &co.cycle_time)) {
        code = 2;
        goto out;
    }
    if (o.hours) {
        char *end;
        co.hours = strtod(o.hours, &end);
        if (*end || end == o.hours || !(co.hours > 0) || co.hours > 2400) {
            fprintf(stderr, "sphice run: --hours \"%s\": expected a number in (0, 2400]\n", o.hours);
            code = 2;
            goto out;
        }
    }
    sph_error e;
    sph_error_clear(&e);
    if (o.out) {
        co.out_dir = o.out;
        co.force = 1;
    } else {
        char db[4200];
        snprintf(db, sizeof db, "%s/history.sqlite", cfg->paths.state_dir);
        if (mkdir_p(cfg->paths.state_dir, &e) || history_open(&h, db, &e)) {
            fprintf(stderr, "sphice run: %s\n", e.msg);
            goto out;
        }
        co.hist = h;
    }
    service_install_signals();
    cycle_report rep;
    int rc = cycle_run(cfg, &co, NULL, &service_term, &rep, &e);
    if (rc) {
        fprintf(stderr, "sphice run: %s\n", e.msg);
        code = 1;
    } else if (rep.result == CYCLE_SKIPPED && rep.skipped_failed) {
        /* not run again, but not a success either: cron and timers see it */
        fprintf(stderr, "sphice run: %s\n", rep.message);
        code = 1;
    } else {
        printf("%s\n", rep.message);
        code = 0;
    }
out:
    ens_mpi_stop_workers(); /* every path of rank 0 ends here: the workers leave too */
    history_close(h);
    sph_config_free(cfg);
    return code;
}

/* ---------------------------------------------------------------- serve */

static int cmd_serve(int argc, char **argv)
{
    opts o;
    int setup = command_setup(argc, argv,
                              "usage: sphice serve CONFIG [--listen ADDR:PORT]\n"
                              "The daemon: runs scheduled cycles, serves GET /status /config /runs /health /metrics,\n"
                              "reloads CONFIG on SIGHUP (an invalid file is refused and reported), stops on SIGTERM\n"
                              "(a running cycle is cancelled; published products are never touched).",
                              "listen", &o);
    if (setup >= 0)
        return setup;
    if (!o.config) {
        fprintf(stderr, "sphice serve: CONFIG missing (see --help)\n");
        return 2;
    }
    return service_serve(o.config, o.listen);
}

/* ------------------------------------------------------------- hindcast */

static int cmd_hindcast(int argc, char **argv)
{
    opts o;
    int setup = command_setup(argc, argv,
                              "usage: sphice hindcast CONFIG --from TIME --to TIME [--out DIR] [--force]\n"
                              "Replays every scheduled cycle in [from, to] over archived forcing (templates expanded\n"
                              "with each cycle time) into DIR (default paths.hindcast_dir or output.dir/hindcast),\n"
                              "scoring against observations.path where a raster exists. Same inputs, same fields.",
                              "from to out force", &o);
    if (setup >= 0)
        return setup;
    if (config_missing("hindcast", o.config))
        return 2;
    if (!o.from || !o.to) {
        fprintf(stderr, "sphice hindcast: --from and --to are required\n");
        return 2;
    }
    double from, to;
    if (parse_time_arg("hindcast", "--from", o.from, &from) || parse_time_arg("hindcast", "--to", o.to, &to))
        return 2;
    if (to < from) {
        fprintf(stderr, "sphice hindcast: --to is before --from\n");
        return 2;
    }
    struct sph_config *cfg = load_config("hindcast", o.config);
    if (!cfg)
        return 1;
    service_install_signals();
    sph_error e;
    sph_error_clear(&e);
    int failed = service_hindcast(cfg, from, to, o.out, o.force, &e);
    sph_config_free(cfg);
    if (failed < 0)
        fprintf(stderr, "sphice hindcast: %s\n", e.msg);
    else if (failed > 0)
        fprintf(stderr, "sphice hindcast: %d cycle(s) failed\n", failed);
    return failed ? 1 : 0;
}

/* --------------------------------------------------------------- status */

static int cmd_status(int argc, char **argv)
{
    opts o;
    int setup = command_setup(argc, argv,
                              "usage: sphice status [--url URL]\n"
                              "Prints the daemon's GET /status, pretty-printed (default " STATUS_DEFAULT_URL "/status).\n"
                              "Exit 0 when the daemon answered, 1 otherwise.",
                              "url", &o);
    if (setup >= 0)
        return setup;
    char *text = NULL;
    sph_error e;
    sph_error_clear(&e);
    if (service_status_get(o.url, &text, &e)) {
        fprintf(stderr, "sphice status: %s\n", e.msg);
        return 1;
    }
    printf("%s\n", text);
    free(text);
    return 0;
}

/* ---------------------------------------------------------------- check */

static int cmd_check(int argc, char **argv)
{
    opts o;
    int setup = command_setup(argc, argv,
                              "usage: sphice check CONFIG [--cycle TIME] [--json]\n"
                              "Validates CONFIG and looks for every configured file for the cycle (default: the\n"
                              "latest scheduled): forcing sources, initial raster, land mask, observations.\n"
                              "Exit 0 when every required source was found.",
                              "cycle json", &o);
    if (setup >= 0)
        return setup;
    if (config_missing("check", o.config))
        return 2;
    struct sph_config *cfg = load_config("check", o.config);
    if (!cfg)
        return 1;
    double t = schedule_prev(cfg, time_now());
    int code = o.cycle && parse_time_arg("check", "--cycle", o.cycle, &t) ? 2 : service_check(cfg, t, o.json, stdout);
    sph_config_free(cfg);
    return code;
}

/* A NetCDF file that could not be closed (a full disk) would crash HDF5's
 * exit handler (io/ncfile.h): then leave without the exit handlers, with
 * this command's own status. */
static int leave(int code)
{
    if (ncfile_abandoned() > 0) {
        fflush(stdout);
        fflush(stderr);
        _exit(code);
    }
    return code;
}

int main(int argc, char **argv)
{
    if (ens_mpi_init(&argc, &argv)) {
        fprintf(stderr, "sphice: MPI_Init failed\n");
        return 1;
    }
    atexit(ens_mpi_finalize);
    atexit(quicklook_release_caches);
    /* GDAL's driver manager is left to the process's end: destroying it from
     * an exit handler after a failed run crashed in GDAL's thread-local data
     * (valgrind: GDALDestroyDriverManager after its TLS was freed), which
     * would replace the documented exit status by an abort */
    if (ens_mpi_size() > 1 && (argc < 2 || strcmp(argv[1], "run"))) {
        if (ens_mpi_rank() == 0)
            fprintf(stderr, "sphice: under mpirun only `sphice run` is supported (ensemble members over ranks)\n");
        return 2;
    }
    /* GSL's default handler aborts; every GSL call here checks its status */
    gsl_set_error_handler_off();
    if (argc < 2)
        return usage(stderr, 2);
    const char *cmd = argv[1];
    if (!strcmp(cmd, "--help") || !strcmp(cmd, "-h") || !strcmp(cmd, "help"))
        return usage(stdout, 0);
    if (!strcmp(cmd, "version") || !strcmp(cmd, "--version")) {
        printf("sphice %s (%s)\n", SPHICE_VERSION, SPHICE_GIT);
        return 0;
    }
    if (!strcmp(cmd, "config-doc")) {
        if (want_help(argc, argv)) {
            puts("usage: sphice config-doc\nPrints the configuration key reference (markdown).");
            return 0;
        }
        sph_config_doc(stdout);
        return 0;
    }
    if (!strcmp(cmd, "run")) return leave(cmd_run(argc, argv));
    if (!strcmp(cmd, "serve")) return leave(cmd_serve(argc, argv));
    if (!strcmp(cmd, "hindcast")) return leave(cmd_hindcast(argc, argv));
    if (!strcmp(cmd, "status")) return leave(cmd_status(argc, argv));
    if (!strcmp(cmd, "check")) return leave(cmd_check(argc, argv));
    fprintf(stderr, "sphice: unknown command \"%s\"\n", cmd);
    return usage(stderr, 2);
}
