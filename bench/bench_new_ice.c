/* The cost of the ocean mixed layer and of new ice (creation, merging) per
 * step, as a fraction of the step, at 1e4 and 1e5 particles (issue 20):
 * the same state stepped with the mixed layer off and on, in one run, so
 * the fraction is a ratio of two times measured on the same machine at the
 * same load: (t_on - t_off) / t_on. (The particle count over a 90-day
 * season with and without merging: bench/bench_season.c.)
 *
 * Case: a square of particles on a lattice (0.4 m ice, concentration 0.9,
 * leads freeze) over the west four fifths of a closed box, open water in
 * the east fifth where new particles are created; -15 C, dark, wind 6 m/s; mEVP
 * rheology, thermodynamics every step. Rows of bench/out/results.csv:
 * problem new_ice, method off/on, config the particle count; err = the
 * fraction. Usage: bench_new_ice [n ...] (default 10000 100000; BENCH_QUICK=1:
 * 10000 only). Run: BENCH_ONLY=new_ice sh bench/run.sh.
 * BENCH_NEW_ICE_PERF=S: only the mixed layer with creation and merging, S
 * steps after one warm-up, no rows: the run to profile with perf, whose
 * samples give the ocean's share of the step directly (docs/ocean.md,
 * Cost; the difference of step times above is within a loaded machine's
 * noise). */
#include "bench_common.h"
#include "new_ice_forcing.h"
#include "core/model.h"
#include "core/ocean.h"

#define DS 1000.0 /* lattice spacing, m */


/* n particles on the lattice, open water east of them. */
static sph_model *make(size_t n, int ocean, int create, int merge, double dt)
{
    sph_params p;
    sph_params_default(&p);
    p.dt = dt;
    p.thermo_dt = dt;
    p.ocean.mixed_layer = ocean;
    p.ocean.create = create;
    p.ocean.merge = merge;
    p.ocean.new_thickness = 0.001; /* particles are created from the first steps */
    /* a fixed amount of mEVP work per step, so that the runs differ only by the ocean */
    p.evp_tol = 0.0;
    p.evp_stall_window = 0;
    int side = (int)ceil(sqrt((double)n));
    int nx = side + (side + 3) / 4, ny = side; /* the east fifth open water */
    size_t cap = (size_t)nx * (size_t)ny + 16; /* every lattice point */
    static unsigned char *land;
    free(land);
    land = calloc((size_t)nx * ny, 1); /* all sea; closed box */
    sph_landmask mk = {nx, ny, 0.0, 0.0, DS, DS, land, 1}; /* a closed box */
    sph_model *m = sph_model_create(&p, cap, &mk);
    if (!m)
        return NULL;
    sph_ocean_grid g = {(nx + 3) / 4, (ny + 3) / 4, 0.0, 0.0, 4 * DS, 4 * DS, 0.5 * DS, 0.5 * DS, DS};
    if (ocean && sph_model_ocean_create(m, &g) != SPH_STEP_OK)
        return NULL;
    sph_particles *P = sph_model_particles(m);
    size_t k = 0;
    for (int j = 0; j < side; j++)
        for (int i = 0; i < side && k < n; i++, k++) {
            P->x[k] = (i + 0.5) * DS;
            P->y[k] = (j + 0.5) * DS;
            P->thick[k] = 0.4;
            P->conc[k] = 0.9;
            P->mass[k] = p.thermo.rho_i * 0.9 * 0.4 * DS * DS;
            P->sml[k] = DS;
            P->id[k] = (long)k;
        }
    P->n = k;
    new_ice_forcing(m);
    for (size_t q = 0; q < P->n; q++)
        sph_thermo_init_particle(&p.thermo, P, q, -15.0);
    sph_status st;
    if (sph_model_init(m, &st) != SPH_STEP_OK) {
        fprintf(stderr, "bench_new_ice: init: %s %s\n", st.quantity, st.what);
        sph_model_free(m);
        return NULL;
    }
    return m;
}

static double step_time(sph_model *m, int steps, int *ok)
{
    sph_status st;
    double t0 = bench_wall();
    for (int s = 0; s < steps && *ok; s++) {
        new_ice_forcing(m);
        if (sph_model_step(m, &st) != SPH_STEP_OK) {
            fprintf(stderr, "bench_new_ice: step: %s %s\n", st.quantity, st.what);
            *ok = 0;
        }
    }
    return (bench_wall() - t0) / steps;
}

int main(int argc, char **argv)
{
    size_t sizes[8] = {10000, 100000};
    int ns = getenv("BENCH_QUICK") ? 1 : 2;
    if (argc > 1) {
        ns = 0;
        for (int i = 1; i < argc && ns < 8; i++)
            sizes[ns++] = (size_t)atol(argv[i]);
    }
    const char *prof = getenv("BENCH_NEW_ICE_PERF"); /* steps of the mixed layer with new ice alone, for perf */
    for (int i = 0; i < ns && prof; i++) {
        int ok = 1, steps = atoi(prof) > 0 ? atoi(prof) : 10;
        sph_model *m = make(sizes[i], 1, 1, 1, 150.0);
        if (!m)
            return 1;
        step_time(m, 1, &ok);
        double t = step_time(m, steps, &ok);
        fprintf(stderr, "new_ice profile n=%zu: %d steps, %.3f s/step, %zu particles, %ld created%s\n", sizes[i], steps,
                t, sph_model_particles(m)->n, sph_model_budget(m)->created_particles, ok ? "" : " (a step failed)");
        sph_model_free(m);
        if (!ok)
            return 1;
    }
    for (int i = 0; i < ns && !prof; i++) {
        int ok = 1;
        /* off; mixed layer alone; mixed layer with creation and merging */
        double t[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, np[3];
        sph_model *m3[3];
        for (int c = 0; c < 3; c++) {
            m3[c] = make(sizes[i], c > 0, c == 2, c == 2, 150.0);
            if (!m3[c])
                return 1;
            step_time(m3[c], 1, &ok); /* warm-up (the first creation) */
        }
        /* alternate, keep the fastest of three: the machine's load moves */
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++)
                t[c] = fmin(t[c], step_time(m3[c], 2, &ok));
        for (int c = 0; c < 3; c++)
            np[c] = (double)sph_model_particles(m3[c])->n;
        long created = sph_model_budget(m3[2])->created_particles;
        for (int c = 0; c < 3; c++)
            sph_model_free(m3[c]);
        /* the mixed layer: same particles, a ratio of step times; creation
         * and merging: per particle-step, for the new particles also cost
         * the dynamics */
        double f_ml = (t[1] - t[0]) / t[1];
        double f_new = (t[2] / np[2] - t[1] / np[1]) / (t[2] / np[2]);
        static const char *const names[3] = {"off", "mixed_layer", "mixed_layer+new_ice"};
        for (int c = 0; c < 3; c++)
            printf("new_ice,%s,%zu,%.4f,%.4f,0,%s,mixed_layer_fraction,%.4f,new_ice_fraction_per_particle,%.4f,"
                   "particles,%.0f\n", names[c], sizes[i], t[c], t[c], ok ? "ok" : "fatal", f_ml, f_new, np[c]);
        fprintf(stderr, "new_ice n=%zu: step %.3f s off, %.3f s mixed layer, %.3f s with creation+merging (%ld created, "
                "%.0f particles): mixed layer %.1f %% of the step, creation+merging %.1f %% per particle-step\n",
                sizes[i], t[0], t[1], t[2], created, np[2], 100 * f_ml, 100 * f_new);
    }
    return 0;
}
