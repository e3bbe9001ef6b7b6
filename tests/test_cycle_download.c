/* A forecast cycle whose forcing is an http:// URL template: the cycle
 * downloads it (io/fetch.h through the cycle's built-in fetcher) from a
 * server started here on 127.0.0.1, runs (test-double engine) and
 * publishes; a missing file (404) fails the cycle naming the URL. */
#include <microhttpd.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "service/config.h"
#include "service/cycle.h"
#include "util/err.h"
#include "util/fileio.h"

static char tmp[256];
static char *served;
static size_t served_len;
static int hits;

static enum MHD_Result answer(void *cls, struct MHD_Connection *c, const char *url, const char *method,
                              const char *version, const char *data, size_t *size, void **ptr)
{
    (void)cls; (void)method; (void)version; (void)data; (void)size; (void)ptr;
    hits++;
    struct MHD_Response *r;
    int code = MHD_HTTP_OK;
    if (!strcmp(url, "/atm_2024020800.nc")) {
        r = MHD_create_response_from_buffer(served_len, served, MHD_RESPMEM_PERSISTENT);
    } else {
        static char nf[] = "not found";
        r = MHD_create_response_from_buffer(strlen(nf), nf, MHD_RESPMEM_PERSISTENT);
        code = MHD_HTTP_NOT_FOUND;
    }
    enum MHD_Result ret = MHD_queue_response(c, (unsigned)code, r);
    MHD_destroy_response(r);
    return ret;
}

static struct sph_config *config_for(int port)
{
    char text[4096];
    snprintf(text, sizeof text,
             "{\"engine\": \"test-double\", \"test\": {\"engine_seconds\": 0.01},"
             " \"domain\": {\"lon_min\": 119, \"lon_max\": 122, \"lat_min\": 38, \"lat_max\": 41},"
             " \"forcing\": [{\"name\": \"atm\", \"kind\": \"atmosphere\","
             "   \"urls\": \"http://127.0.0.1:%d/atm_%%Y%%m%%d%%H.nc\", \"issue_hours\": 24}],"
             " \"output\": {\"dir\": \"%s/out\"},"
             " \"schedule\": {\"late_data\": {\"wait_minutes\": 0, \"policy\": \"fail\"}},"
             " \"paths\": {\"state_dir\": \"%s/state\", \"cache_dir\": \"%s/cache\"}}",
             port, tmp, tmp, tmp);
    struct sph_config *c = NULL;
    sph_error e;
    sph_error_clear(&e);
    if (sph_config_parse(text, "test", &c, &e))
        fprintf(stderr, "config: %s\n", e.msg);
    return c;
}

int main(void)
{
    snprintf(tmp, sizeof tmp, "/tmp/sphice-cycle-dl-XXXXXX");
    if (!mkdtemp(tmp))
        return 1;
    /* a small valid NetCDF file to serve */
    char nc[512];
    snprintf(nc, sizeof nc, "%s/atm.nc", tmp);
    int id, dim, var;
    nc_create(nc, NC_CLOBBER, &id);
    nc_def_dim(id, "time", 1, &dim);
    nc_def_var(id, "time", NC_DOUBLE, 1, &dim, &var);
    nc_enddef(id);
    double z = 0;
    nc_put_var_double(id, var, &z);
    nc_close(id);
    sph_error e;
    sph_error_clear(&e);
    CHECK(read_file(nc, &served, &served_len, &e) == 0, "read %s", e.msg);
    char want_sha[65];
    sha256_hex(served, served_len, want_sha);

    struct MHD_Daemon *d = MHD_start_daemon(MHD_USE_INTERNAL_POLLING_THREAD, 0, NULL, NULL, &answer,
                                            NULL, MHD_OPTION_END);
    CHECK(d != NULL, "server started");
    int port = d ? MHD_get_daemon_info(d, MHD_DAEMON_INFO_BIND_PORT)->port : 0;
    struct sph_config *c = config_for(port);
    CHECK(c != NULL, "config");
    if (d && c) {
        cycle_opts o;
        memset(&o, 0, sizeof o);
        o.cycle_time = 19761 * 86400.0; /* 2024-02-08T00:00Z */
        cycle_report rep;
        sph_error_clear(&e);
        int rc = cycle_run(c, &o, NULL, NULL, &rep, &e);
        CHECK(rc == 0, "cycle with downloaded forcing: %s", e.msg);
        CHECK(hits >= 1, "the server was asked (%d)", hits);
        char cycle_json[600];
        snprintf(cycle_json, sizeof cycle_json, "%s/out/20240208T00Z/cycle.json", tmp);
        char *txt = NULL;
        sph_error_clear(&e);
        CHECK(read_file(cycle_json, &txt, NULL, &e) == 0, "published cycle.json: %s", e.msg);
        CHECK(txt && strstr(txt, want_sha), "cycle.json records the downloaded file's sha256");
        free(txt);
        /* the next day's file does not exist: 404, the cycle fails naming the URL */
        o.cycle_time += 86400.0;
        sph_error_clear(&e);
        rc = cycle_run(c, &o, NULL, NULL, &rep, &e);
        CHECK(rc != 0 && strstr(e.msg, "atm_2024020900.nc") && strstr(e.msg, "404"),
              "missing remote file fails the cycle: %s", e.msg);
    }
    if (d)
        MHD_stop_daemon(d);
    sph_config_free(c);
    free(served);
    cycle_remove_tree(tmp);
    return check_summary("test_cycle_download");
}
