/* demo_summary: the numbers of the Liaodong Bay demo (make demo), from the
 * products of its runs.
 *
 *   build/tools/demo_summary [--config FILE] [--json OUT] LABEL DIR WALL_S [LABEL DIR WALL_S ...]
 *
 * DIR is a run's --out directory (or its cycle directory); WALL_S is the
 * run's wall time in seconds as measured by tools/demo.sh ("-" if not
 * known). rho_i (for area = mass / (rho_i h)) comes from the config's
 * model.momentum.rho_ice (900 without --config). Prints, per run, the thick
 * patch's ice area, mean thickness and concentration at 0, 24, 48, 72 and
 * 96 h, its area relative to the start, the net drift of its centre, the
 * spread of its particles' velocities, the tidal reversals and the mass
 * budget residual, then a comparison of the runs; --json writes the same
 * numbers. Definitions: tools/demo_analysis.h and docs/demo.md.
 */
#include <errno.h>
#include "demo_analysis.h"
#include "service/config.h"
#include "util/fileio.h"

#define MAX_RUNS 8

static const double report_hours[] = {0, 24, 48, 72, 96};
#define NREPORT (sizeof report_hours / sizeof report_hours[0])

static const char *compass(double deg)
{
    static const char *names[] = {"N", "NNE", "NE", "ENE", "E", "ESE", "SE", "SSE",
                                  "S", "SSW", "SW", "WSW", "W", "WNW", "NW", "NNW"};
    if (!isfinite(deg))
        return "?";
    return names[(int)floor(fmod(deg + 11.25, 360.0) / 22.5) % 16];
}

static cJSON *num_or_null(double v)
{
    return isfinite(v) ? cJSON_CreateNumber(v) : cJSON_CreateNull();
}

static void print_run(const char *label, const demo_run *r, double wall)
{
    const demo_time *t0 = &r->times[0], *tl = &r->times[r->ntimes - 1];
    printf("\n== %s  (%s)\n", label, r->particles_path);
    printf("   wall time %s%.1f s; %ld particles at t0, %ld in the thick patch (h > %.2f m)\n",
           isfinite(wall) ? "" : "unknown ", isfinite(wall) ? wall : 0.0, r->n_particles0, r->n_patch,
           DEMO_PATCH_THICK);
    printf("   %6s %6s %10s %8s %10s %8s %9s %9s %8s\n", "hour", "n", "area km2", "area/a0", "footpr km2",
           "h_mean", "conc", "|v| sd", "centre");
    for (size_t k = 0; k < NREPORT; k++) {
        const demo_time *d = demo_at_hours(r, report_hours[k]);
        if (!d)
            continue;
        printf("   %6.0f %6ld %10.2f %8.3f %10.2f %8.3f %9.3f %9.4f %.3fE %.3fN\n", d->hours, d->n, d->area_km2,
               d->area_km2 / t0->area_km2, d->footprint_km2, d->mean_thick, d->mean_conc, d->vel_spread, d->lon_c, d->lat_c);
    }
    if (!demo_at_hours(r, tl->hours) || tl->hours > report_hours[NREPORT - 1] ||
        fmod(tl->hours, 24.0) > 0.5)
        printf("   %6.0f %6ld %10.2f %8.3f %10.2f %8.3f %9.3f %9.4f %.3fE %.3fN\n", tl->hours, tl->n, tl->area_km2,
               tl->area_km2 / t0->area_km2, tl->footprint_km2, tl->mean_thick, tl->mean_conc, tl->vel_spread, tl->lon_c, tl->lat_c);
    printf("   ice area at %.0f h / start: %.3f (seed: about 1.5 at 96 h); footprint: %.3f\n", tl->hours,
           tl->area_km2 / t0->area_km2, tl->footprint_km2 / t0->footprint_km2);
    printf("   net drift of the patch centre: %.1f km towards %.0f deg (%s)\n", r->drift_km,
           r->drift_bearing_deg, compass(r->drift_bearing_deg));
    printf("   velocity spread of the patch particles: mean %.4f m/s over %d output times\n",
           r->vel_spread_mean, r->ntimes);
    printf("   along-bay (%.0f deg) velocity reversals of the patch centre: %d in %.0f h\n", DEMO_AXIS_DEG,
           r->reversals, tl->hours);
    if (isfinite(r->budget_residual))
        printf("   mass budget residual (relative): %.3g\n", r->budget_residual);
    else
        printf("   mass budget residual: not reported by the run\n");
}

static cJSON *run_json(const char *label, const char *dir, const demo_run *r, double wall)
{
    const demo_time *t0 = &r->times[0], *tl = &r->times[r->ntimes - 1];
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "label", label);
    cJSON_AddStringToObject(o, "dir", dir);
    cJSON_AddStringToObject(o, "particles_file", r->particles_path);
    cJSON_AddItemToObject(o, "wall_seconds", num_or_null(wall));
    cJSON_AddNumberToObject(o, "rho_i", r->rho_i);
    cJSON_AddNumberToObject(o, "particles_t0", (double)r->n_particles0);
    cJSON_AddNumberToObject(o, "patch_particles", (double)r->n_patch);
    cJSON_AddNumberToObject(o, "patch_thickness_threshold_m", DEMO_PATCH_THICK);
    cJSON *arr = cJSON_AddArrayToObject(o, "patch");
    for (size_t k = 0; k < NREPORT; k++) {
        const demo_time *d = demo_at_hours(r, report_hours[k]);
        if (!d)
            continue;
        cJSON *e = cJSON_CreateObject();
        cJSON_AddNumberToObject(e, "hours", d->hours);
        cJSON_AddNumberToObject(e, "particles", (double)d->n);
        cJSON_AddItemToObject(e, "area_km2", num_or_null(d->area_km2));
        cJSON_AddItemToObject(e, "area_ratio", num_or_null(d->area_km2 / t0->area_km2));
        cJSON_AddItemToObject(e, "footprint_km2", num_or_null(d->footprint_km2));
        cJSON_AddItemToObject(e, "radius_km", num_or_null(d->radius_km));
        cJSON_AddItemToObject(e, "mean_thickness_m", num_or_null(d->mean_thick));
        cJSON_AddItemToObject(e, "mean_concentration", num_or_null(d->mean_conc));
        cJSON_AddItemToObject(e, "centre_lon", num_or_null(d->lon_c));
        cJSON_AddItemToObject(e, "centre_lat", num_or_null(d->lat_c));
        cJSON_AddItemToObject(e, "velocity_spread_m_s", num_or_null(d->vel_spread));
        cJSON_AddItemToArray(arr, e);
    }
    cJSON_AddNumberToObject(o, "hours", tl->hours);
    cJSON_AddItemToObject(o, "area_ratio_end", num_or_null(tl->area_km2 / t0->area_km2));
    cJSON_AddItemToObject(o, "footprint_ratio_end", num_or_null(tl->footprint_km2 / t0->footprint_km2));
    cJSON_AddItemToObject(o, "mean_thickness_start_m", num_or_null(t0->mean_thick));
    cJSON_AddItemToObject(o, "mean_thickness_end_m", num_or_null(tl->mean_thick));
    cJSON_AddItemToObject(o, "drift_km", num_or_null(r->drift_km));
    cJSON_AddItemToObject(o, "drift_bearing_deg", num_or_null(r->drift_bearing_deg));
    cJSON_AddStringToObject(o, "drift_compass", compass(r->drift_bearing_deg));
    cJSON_AddItemToObject(o, "velocity_spread_mean_m_s", num_or_null(r->vel_spread_mean));
    cJSON_AddNumberToObject(o, "along_axis_reversals", r->reversals);
    cJSON_AddNumberToObject(o, "axis_bearing_deg", DEMO_AXIS_DEG);
    cJSON_AddItemToObject(o, "mass_budget_residual", num_or_null(r->budget_residual));
    return o;
}

static int usage(void)
{
    fprintf(stderr, "usage: demo_summary [--config FILE] [--json OUT] LABEL DIR WALL_S [LABEL DIR WALL_S ...]\n");
    return 2;
}

int main(int argc, char **argv)
{
    const char *config = NULL, *json = NULL;
    int a = 1;
    for (; a < argc && !strncmp(argv[a], "--", 2); a++) {
        if (!strcmp(argv[a], "--config") && a + 1 < argc)
            config = argv[++a];
        else if (!strcmp(argv[a], "--json") && a + 1 < argc)
            json = argv[++a];
        else
            return usage();
    }
    int nruns = (argc - a) / 3;
    if (nruns < 1 || (argc - a) % 3 || nruns > MAX_RUNS)
        return usage();
    double rho_i = 900;
    sph_error err;
    sph_error_clear(&err);
    if (config) {
        struct sph_config *cfg = NULL;
        if (sph_config_load(config, &cfg, &err)) {
            fprintf(stderr, "demo_summary: %s\n", err.msg);
            return 1;
        }
        rho_i = cfg->model.rho_i;
        sph_config_free(cfg);
    }
    demo_run runs[MAX_RUNS];
    double walls[MAX_RUNS];
    int code = 0, done = 0;
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "scene", "liaodong-1999 (synthetic forcing)");
    if (config)
        cJSON_AddStringToObject(root, "config", config);
    cJSON *jr = cJSON_AddObjectToObject(root, "runs");
    printf("Liaodong Bay 1999 demo: the thick patch (particles thicker than %.2f m at t0)\n", DEMO_PATCH_THICK);
    for (int k = 0; k < nruns; k++, done++) {
        const char *label = argv[a + 3 * k], *dir = argv[a + 3 * k + 1], *w = argv[a + 3 * k + 2];
        char *end;
        errno = 0;
        walls[k] = strcmp(w, "-") ? strtod(w, &end) : NAN;
        if (strcmp(w, "-") && (errno || end == w || *end)) {
            fprintf(stderr, "demo_summary: wall time \"%s\" of %s: expected seconds or -\n", w, label);
            code = 2;
            break;
        }
        if (demo_analyse(dir, rho_i, &runs[k], &err)) {
            fprintf(stderr, "demo_summary: %s: %s\n", label, err.msg);
            code = 1;
            break;
        }
        print_run(label, &runs[k], walls[k]);
        cJSON_AddItemToObject(jr, label, run_json(label, dir, &runs[k], walls[k]));
    }
    if (code == 0 && nruns >= 2) {
        const demo_run *s = &runs[0], *f = &runs[1];
        double gs = s->times[s->ntimes - 1].area_km2 / s->times[0].area_km2;
        double gf = f->times[f->ntimes - 1].area_km2 / f->times[0].area_km2;
        printf("\n== %s vs %s\n", argv[a + 3], argv[a]);
        double fs = s->times[s->ntimes - 1].footprint_km2 / s->times[0].footprint_km2;
        double ff = f->times[f->ntimes - 1].footprint_km2 / f->times[0].footprint_km2;
        printf("   ice area growth %.3f vs %.3f\n", gf, gs);
        printf("   spreading (footprint growth, leads included) %.3f vs %.3f: %s\n", ff, fs,
               ff > fs ? "free drift spreads more (seed)" : "free drift does NOT spread more");
        double rs = s->times[s->ntimes - 1].radius_km / s->times[0].radius_km;
        double rf = f->times[f->ntimes - 1].radius_km / f->times[0].radius_km;
        printf("   spreading (RMS radius about the centre) %.3f vs %.3f: %s\n", rf, rs,
               rf > rs ? "free drift spreads more (seed)" : "free drift does NOT spread more");
        printf("   velocity spread %.4f vs %.4f m/s: %s\n", f->vel_spread_mean, s->vel_spread_mean,
               f->vel_spread_mean > s->vel_spread_mean ? "free drift less uniform (seed)"
                                                        : "free drift NOT less uniform");
        cJSON *c = cJSON_AddObjectToObject(root, "comparison");
        cJSON_AddItemToObject(c, "area_ratio_second_over_first", num_or_null(gf / gs));
        cJSON_AddItemToObject(c, "radius_growth_second_over_first", num_or_null(rf / rs));
        cJSON_AddItemToObject(c, "velocity_spread_second_over_first",
                              num_or_null(f->vel_spread_mean / s->vel_spread_mean));
    }
    if (code == 0 && json) {
        char *text = cJSON_Print(root);
        if (!text || atomic_write_file(json, text, strlen(text), &err)) {
            fprintf(stderr, "demo_summary: %s: %s\n", json, text ? err.msg : "out of memory");
            code = 1;
        } else {
            printf("\nsummary: %s\n", json);
        }
        free(text);
    }
    cJSON_Delete(root);
    for (int k = 0; k < done; k++)
        demo_run_free(&runs[k]);
    return code;
}
