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
#include <cjson/cJSON.h>
#include <gsl/gsl_errno.h>
#include <curl/curl.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "io/quicklook.h"
#include "service/config.h"
#include "service/forecast.h"
#include "service/cycle.h"
#include "service/daemon.h"
#include "service/history.h"
#include "service/schedule.h"
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

static int parse_time_arg(const char *cmd, const char *what, const char *text, double *t)
{
    if (time_parse_iso(text, t)) {
        fprintf(stderr, "sphice %s: %s \"%s\": not an ISO 8601 time (e.g. 2024-02-08T00:00Z)\n", cmd, what, text);
        return -1;
    }
    return 0;
}

static struct sph_config *load_config(const char *cmd, const char *path)
{
    if (!path) {
        fprintf(stderr, "sphice %s: CONFIG missing (see --help)\n", cmd);
        return NULL;
    }
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
    if (want_help(argc, argv)) {
        puts("usage: sphice run CONFIG [--cycle TIME] [--hours N] [--out DIR] [--force]\n"
             "Runs one forecast cycle and exits: 0 published (or already published), 1 failed.\n"
             "  --cycle TIME  cycle time (default: the latest scheduled cycle)\n"
             "  --hours N     forecast length (default: schedule.forecast_hours)\n"
             "  --out DIR     write there instead of output.dir (not recorded in the history)\n"
             "  --force       run even if the history says the cycle already ran");
        return 0;
    }
    opts o;
    if (parse_opts(argc, argv, &o, "cycle hours out force"))
        return 2;
    struct sph_config *cfg = load_config("run", o.config);
    if (!cfg)
        return 1;
    cycle_opts co;
    memset(&co, 0, sizeof co);
    co.cycle_time = schedule_prev(cfg, time_now());
    co.force = o.force;
    int code = 1;
    history *h = NULL;
    if (o.cycle && parse_time_arg("run", "--cycle", o.cycle, &co.cycle_time))
        goto out;
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
    } else {
        printf("%s\n", rep.message);
        code = 0;
    }
out:
    history_close(h);
    sph_config_free(cfg);
    return code;
}

/* ---------------------------------------------------------------- serve */

static int cmd_serve(int argc, char **argv)
{
    if (want_help(argc, argv)) {
        puts("usage: sphice serve CONFIG [--listen ADDR:PORT]\n"
             "The daemon: runs scheduled cycles, serves GET /status /runs /health /metrics,\n"
             "reloads CONFIG on SIGHUP (an invalid file is refused and reported), stops on SIGTERM\n"
             "(a running cycle is cancelled; published products are never touched).");
        return 0;
    }
    opts o;
    if (parse_opts(argc, argv, &o, "listen"))
        return 2;
    if (!o.config) {
        fprintf(stderr, "sphice serve: CONFIG missing (see --help)\n");
        return 2;
    }
    return service_serve(o.config, o.listen);
}

/* ------------------------------------------------------------- hindcast */

static int cmd_hindcast(int argc, char **argv)
{
    if (want_help(argc, argv)) {
        puts("usage: sphice hindcast CONFIG --from TIME --to TIME [--out DIR] [--force]\n"
             "Replays every scheduled cycle in [from, to] over archived forcing (templates expanded\n"
             "with each cycle time) into DIR (default paths.hindcast_dir or output.dir/hindcast),\n"
             "scoring against observations.path where a raster exists. Same inputs, same fields.");
        return 0;
    }
    opts o;
    if (parse_opts(argc, argv, &o, "from to out force"))
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

typedef struct membuf { char *p; size_t n; } membuf;

static size_t collect(void *data, size_t size, size_t nmemb, void *user)
{
    membuf *b = user;
    size_t add = size * nmemb;
    if (b->n + add > (16u << 20))
        return 0;
    char *g = realloc(b->p, b->n + add + 1);
    if (!g)
        return 0;
    memcpy(g + b->n, data, add);
    b->p = g;
    b->n += add;
    b->p[b->n] = 0;
    return add;
}

static int cmd_status(int argc, char **argv)
{
    if (want_help(argc, argv)) {
        puts("usage: sphice status [--url URL]\n"
             "Prints the daemon's GET /status, pretty-printed (default http://127.0.0.1:8642/status).\n"
             "Exit 0 when the daemon answered, 1 otherwise.");
        return 0;
    }
    opts o;
    if (parse_opts(argc, argv, &o, "url"))
        return 2;
    char url[2100];
    const char *base = o.url ? o.url : "http://127.0.0.1:8642";
    size_t bl = strlen(base);
    while (bl && base[bl - 1] == '/')
        bl--;
    /* "http://host:port", "http://host:port/" and ".../status" all mean /status */
    if (bl >= 7 && !strncmp(base + bl - 7, "/status", 7))
        snprintf(url, sizeof url, "%.*s", (int)bl, base);
    else
        snprintf(url, sizeof url, "%.*s/status", (int)bl, base);
    curl_global_init(CURL_GLOBAL_DEFAULT);
    CURL *c = curl_easy_init();
    membuf b = {0};
    char errbuf[CURL_ERROR_SIZE] = "";
    long http = 0;
    CURLcode rc = CURLE_FAILED_INIT;
    if (c) {
        curl_easy_setopt(c, CURLOPT_URL, url);
        curl_easy_setopt(c, CURLOPT_WRITEFUNCTION, collect);
        curl_easy_setopt(c, CURLOPT_WRITEDATA, &b);
        curl_easy_setopt(c, CURLOPT_TIMEOUT, 10L);
        curl_easy_setopt(c, CURLOPT_ERRORBUFFER, errbuf);
        curl_easy_setopt(c, CURLOPT_NOSIGNAL, 1L);
        rc = curl_easy_perform(c);
        curl_easy_getinfo(c, CURLINFO_RESPONSE_CODE, &http);
        curl_easy_cleanup(c);
    }
    curl_global_cleanup();
    int code = 1;
    if (rc != CURLE_OK) {
        fprintf(stderr, "sphice status: %s: %s\n", url, errbuf[0] ? errbuf : curl_easy_strerror(rc));
    } else if (http != 200) {
        fprintf(stderr, "sphice status: %s: HTTP %ld\n", url, http);
    } else {
        cJSON *j = cJSON_Parse(b.p ? b.p : "");
        char *pretty = j ? cJSON_Print(j) : NULL;
        if (!pretty) {
            fprintf(stderr, "sphice status: %s: the answer is not JSON\n", url);
        } else {
            printf("%s\n", pretty);
            code = 0;
        }
        free(pretty);
        cJSON_Delete(j);
    }
    free(b.p);
    return code;
}

/* ---------------------------------------------------------------- check */

static int cmd_check(int argc, char **argv)
{
    if (want_help(argc, argv)) {
        puts("usage: sphice check CONFIG [--cycle TIME] [--json]\n"
             "Validates CONFIG and looks for every configured file for the cycle (default: the\n"
             "latest scheduled): forcing sources, initial raster, land mask, observations.\n"
             "Exit 0 when every required source was found.");
        return 0;
    }
    opts o;
    if (parse_opts(argc, argv, &o, "cycle json"))
        return 2;
    struct sph_config *cfg = load_config("check", o.config);
    if (!cfg)
        return 1;
    double t = schedule_prev(cfg, time_now());
    if (o.cycle && parse_time_arg("check", "--cycle", o.cycle, &t)) {
        sph_config_free(cfg);
        return 2;
    }
    char iso[32];
    time_format_iso(t, iso, sizeof iso);
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "config", cfg->file);
    cJSON_AddStringToObject(root, "cycle", iso);
    cJSON *rows = cJSON_AddArrayToObject(root, "files");
    int missing_required = 0;
    /* forcing: each template of each source; then the other inputs */
    typedef struct { const char *what, *name, *tmpl; int required; double at; } check_item;
    check_item items[256];
    size_t n = 0;
    for (size_t s = 0; s < cfg->nforcing; s++)
        for (size_t i = 0; i < cfg->forcing[s].urls.n && n < 200; i++)
            items[n++] = (check_item){"forcing", cfg->forcing[s].name, cfg->forcing[s].urls.v[i],
                                            !cfg->forcing[s].optional_source, t};
    if (cfg->initial.path[0])
        items[n++] = (check_item){"initial", "initial", cfg->initial.path, 0, t};
    if (cfg->landmask.path[0])
        items[n++] = (check_item){"landmask", "landmask", cfg->landmask.path, 0, t};
    if (cfg->observations.path[0])
        items[n++] = (check_item){"observations", "observations", cfg->observations.path, 0,
                                        t + cfg->schedule.forecast_hours * 3600};
    for (size_t i = 0; i < n; i++) {
        char path[4096] = "", sha[65] = "";
        sph_error e;
        sph_error_clear(&e);
        int rc = cycle_expand_template(items[i].tmpl, items[i].at, path, sizeof path, &e);
        const char *p = !strncmp(path, "file://", 7) ? path + 7 : path;
        struct stat st;
        int found = 0;
        if (!rc) {
            if (strstr(p, "://"))
                sph_err_set(&e, SPH_ERR_DOWNLOAD, "%s: remote (checked when fetched)", p);
            else if (stat(p, &st) != 0)
                sph_err_set(&e, SPH_ERR_IO, "%s: %s", p, strerror(errno));
            else if (sha256_file(p, sha, &e) == 0)
                found = 1;
        }
        if (!found && items[i].required)
            missing_required++;
        cJSON *r = cJSON_CreateObject();
        cJSON_AddStringToObject(r, "kind", items[i].what);
        cJSON_AddStringToObject(r, "name", items[i].name);
        cJSON_AddStringToObject(r, "template", items[i].tmpl);
        cJSON_AddStringToObject(r, "path", p);
        cJSON_AddBoolToObject(r, "found", found);
        if (found) {
            cJSON_AddNumberToObject(r, "bytes", (double)st.st_size);
            cJSON_AddNumberToObject(r, "age_hours", (time_now() - (double)st.st_mtim.tv_sec) / 3600.0);
            cJSON_AddStringToObject(r, "sha256", sha);
        } else {
            cJSON_AddStringToObject(r, "problem", e.msg);
        }
        cJSON_AddItemToArray(rows, r);
        if (!o.json)
            printf("%-12s %-14s %-8s %s\n", items[i].what, items[i].name, found ? "found" : "MISSING",
                   found ? p : e.msg);
    }
    /* open every source whose files were found and describe what is in them */
    cJSON *vars = cJSON_AddArrayToObject(root, "variables");
    int problems = 0;
    for (size_t s = 0; s < cfg->nforcing; s++) {
        const char *files[201];
        char paths[8][4096];
        size_t nf = 0;
        for (size_t i = 0; i < cfg->forcing[s].urls.n && nf < 8; i++) {
            sph_error e;
            sph_error_clear(&e);
            if (cycle_expand_template(cfg->forcing[s].urls.v[i], t, paths[nf], sizeof paths[nf], &e))
                continue;
            const char *p = !strncmp(paths[nf], "file://", 7) ? paths[nf] + 7 : paths[nf];
            struct stat st;
            if (!strstr(p, "://") && stat(p, &st) == 0)
                files[nf++] = p;
        }
        files[nf] = NULL;
        if (nf == 0)
            continue;
        forcing_source_spec spec;
        forcing_name_map *map = NULL;
        forcing *f = NULL;
        sph_error e;
        sph_error_clear(&e);
        int rc = forecast_source_spec(cfg, s, files, &spec, &map, &e);
        if (!rc)
            rc = forcing_open(&f, &spec, 1, t, t + cfg->schedule.forecast_hours * 3600.0,
                              cfg->domain.lon_min, cfg->domain.lon_max, cfg->domain.lat_min,
                              cfg->domain.lat_max, &e);
        if (rc) {
            problems++;
            cJSON *r = cJSON_CreateObject();
            cJSON_AddStringToObject(r, "source", cfg->forcing[s].name);
            cJSON_AddStringToObject(r, "problem", e.msg);
            cJSON_AddItemToArray(vars, r);
            if (!o.json)
                printf("PROBLEM      %s\n", e.msg);
        } else {
            forcing_var_info info[32];
            size_t ni = forcing_describe(f, info, 32);
            for (size_t i = 0; i < ni && i < 32; i++) {
                char t0[32] = "harmonic", t1[32] = "any time";
                if (isfinite(info[i].t_first) && fabs(info[i].t_first) < 1e13) {
                    time_format_iso(info[i].t_first, t0, sizeof t0);
                    time_format_iso(info[i].t_last, t1, sizeof t1);
                }
                cJSON *r = cJSON_CreateObject();
                cJSON_AddStringToObject(r, "source", info[i].source);
                cJSON_AddStringToObject(r, "standard_name", info[i].standard_name);
                cJSON_AddStringToObject(r, "variable", info[i].variable);
                cJSON_AddStringToObject(r, "file", info[i].file);
                cJSON_AddStringToObject(r, "units", info[i].units);
                cJSON_AddStringToObject(r, "grid", info[i].grid);
                cJSON_AddStringToObject(r, "time_first", t0);
                cJSON_AddStringToObject(r, "time_last", t1);
                cJSON_AddNumberToObject(r, "fill_fraction", info[i].fill_fraction);
                cJSON_AddItemToArray(vars, r);
                if (!o.json)
                    printf("variable     %-10s %-44s %-8s %-12s %-30s %s..%s fill %.3f\n",
                           info[i].source, info[i].standard_name, info[i].variable, info[i].units,
                           info[i].grid, t0, t1, info[i].fill_fraction);
            }
        }
        forcing_close(f);
        free(map);
    }
    if (problems)
        missing_required++;
    cJSON_AddBoolToObject(root, "ok", missing_required == 0);
    if (o.json) {
        char *txt = cJSON_Print(root);
        printf("%s\n", txt);
        free(txt);
    } else {
        printf("cycle %s: %s\n", iso, missing_required ? "required forcing missing" : "all required forcing found");
    }
    cJSON_Delete(root);
    sph_config_free(cfg);
    return missing_required ? 1 : 0;
}

int main(int argc, char **argv)
{
    atexit(quicklook_release_caches);
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
    if (!strcmp(cmd, "run")) return cmd_run(argc, argv);
    if (!strcmp(cmd, "serve")) return cmd_serve(argc, argv);
    if (!strcmp(cmd, "hindcast")) return cmd_hindcast(argc, argv);
    if (!strcmp(cmd, "status")) return cmd_status(argc, argv);
    if (!strcmp(cmd, "check")) return cmd_check(argc, argv);
    fprintf(stderr, "sphice: unknown command \"%s\"\n", cmd);
    return usage(stderr, 2);
}
