/* The ocean mixed layer and new ice in open water under spatial domain
 * decomposition (issue 20 on issue 24's decomposition; core/ocean/ocean_dd.c,
 * service/domain_mpi.c, docs/domain.md "The mixed layer").
 *
 * The plain build's program runs the serial reference: one model in
 * canonical mode with the slab mixed layer on a 6 x 4 grid of 10 km cells
 * (depths 5 to 30 m, a land corner, open edges elsewhere, restoring to
 * SST/SSS over 5 days), a patch of 16 ice particles and open water
 * elsewhere, free drift under a steady wind (ice leaves through the east
 * edge), the auto column: 3 cold days (frazil, new particles, merging of
 * the thin ones), a warm sunny day (melt-out: particles removed), 4 cold
 * days, hourly; 192 steps. (Continuity density, the core's default: the
 * service refuses it with new particles, docs/ocean.md; the identity does
 * not depend on it.) It writes the particles, every array of the
 * mixed layer and the budget to a temporary directory, and checks the
 * serial run itself: creation, merging, melt-out removal and outflow
 * happened, the energy, water and salt budgets of ice plus ocean and the
 * mass budget close (round-off), no particle on land. The ocean-fluxes
 * accumulators are on (thermo.ocean_fluxes, as output.ocean_fluxes sets
 * it): regridded the engine's way onto a 3 km plane grid, the integrals of
 * hfds, siflfwbot and siflsaltbot equal the particles' plus the cells'
 * totals within 1e-10 relative (the rule), the cells holding what
 * the particles that melted out or left gave.
 *
 * Then the MPI build's copy of this program (build-mpi/tests/test_mpi_season,
 * `make mpi-build`) runs under `mpirun --oversubscribe -np 2` and `-np 4`
 * (and `-np 1` with SPHICE_LONG=1): the same initial state, scattered over
 * the ranks along the Hilbert curve, stepped 192 times with migration and
 * halo; every rank steps its own mixed layer. Its particles gathered and
 * sorted by id must equal the serial ones bit for bit in every field; every
 * array of the mixed layer on every rank must equal the serial one bit for
 * bit (the seven flux accumulators of the cells among them: the particles
 * leaving through the east edge are booked by every rank in id order); the ocean's budget (energy, water, salt and their terms, the
 * created and merged counts) equal on every rank and equal to the serial
 * one; the global exact mass, momentum and energy diagnostics and the mass
 * budget's sources (growth, new ice, melt, outflow) equal the serial ones.
 * Skipped with one line when mpirun or that build is absent. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "mpi_launch.h"
#include "core/dd.h"
#include "core/model.h"
#include "core/ocean.h"
#include "lattice.h"
#include "ocean_column.h"
/* the fluxes file on 20 x 14 cells of 3 km over the 60 x 40 km plane */
#define NXG 20
#define NYG 14
#include "ofx_plane.h"
#ifdef SPHICE_MPI
#include <mpi.h>

#include "service/domain_mpi.h"
#endif

enum { NX = 6, NY = 4, NDAYS = 8, NSTEP = NDAYS * 24, CAP = 4000 };
static const double CELL = 1e4, DS = 2500.0;

/* land: 5 km mask cells, the south-west 10 x 5 km corner */
static unsigned char land[2 * NX * 2 * NY];

static void params(sph_params *p)
{
    oc_params(p, SPH_THERMO_AUTO);
    p->Ca = 1.2e-3;
    p->ocean.create = 1;
    p->ocean.merge = 1;
    p->ocean.merge_distance = 1.05;
    p->ocean.restore_days = 5.0;
    p->ocean.freezing = SPH_FREEZING_UNESCO;
    /* the ocean-fluxes accumulators (output.ocean_fluxes): the particles
     * leaving through the east edge hand theirs to the cells, which every
     * rank books in id order (ocean_dd.c) */
    p->thermo.ocean_fluxes = 1;
}

/* The model of the case (canonical mode on or off), its mixed layer set,
 * the ice patch in it when `patch`; not initialised. */
static sph_model *make_model(int canonical, int patch, sph_landmask *mk)
{
    sph_params p;
    params(&p);
    for (int j = 0; j < 2 * NY; j++)
        for (int i = 0; i < 2 * NX; i++)
            land[j * 2 * NX + i] = (unsigned char)(j == 0 && i < 2);
    sph_landmask m0 = {2 * NX, 2 * NY, 0.0, 0.0, 5000.0, 5000.0, land, 0};
    *mk = m0;
    sph_model *m = sph_model_create(&p, CAP, mk);
    if (!m || sph_model_set_canonical(m, canonical)) {
        sph_model_free(m);
        return NULL;
    }
    sph_ocean_grid g = {NX, NY, 0.0, 0.0, CELL, CELL, DS / 2, DS / 2, DS};
    if (sph_model_ocean_create(m, &g) != SPH_STEP_OK) {
        sph_model_free(m);
        return NULL;
    }
    sph_ocean *o = sph_model_ocean(m);
    for (size_t c = 0; c < o->ncell; c++) {
        double depth = 5.0 + 2.5 * (double)(c % 11); /* 5 to 30 m */
        sph_ocean_set_cell(o, c, depth, 31.0, -1.2 + 0.1 * (double)(c % 3));
        o->sss_restore[c] = 31.5;
    }
    if (patch) { /* 4 x 4 particles, 0.3 m, A 0.9, in the north-west cells */
        sph_particles *P = sph_model_particles(m);
        lattice_fill(P, &p, 4, 4, DS / 2, 2 * CELL + DS / 2, DS, 0.3, 0.9, 40.0);
        for (size_t k = 0; k < P->n; k++)
            P->id[k] = 100 + 3 * (long)k; /* ids that are not slots */
    }
    return m;
}

/* The atmosphere of hour h over every particle and cell (and the
 * restoring target's temperature). */
static void forcing(sph_model *m, int h)
{
    int day = h / 24;
    int warm = day == 3;
    sph_ocean *o = sph_model_ocean(m);
    for (size_t c = 0; c < o->ncell; c++)
        o->sst_restore[c] = warm ? 1.0 : -1.5;
    if (warm)
        oc_fill_atm(m, 6.0, 5e-3, 5.0, 2.0, 400.0, 330.0, 40.0);
    else
        oc_fill_atm(m, -15.0, 6e-4, 5.0, 2.0, 0.0, 200.0, 40.0);
}

/* The mixed layer's arrays compared and written */
#define OCEAN_ARRAYS(o)                                                                                     \
    {(o)->temp, (o)->sal, (o)->depth, (o)->water, (o)->salt, (o)->frazil, (o)->frazil_enth, (o)->ow_heat, \
     (o)->ow_fresh, (o)->ow_salt, (o)->ofx_heat, (o)->ofx_water, (o)->ofx_salt, (o)->ofx_heat_ice,       \
     (o)->ofx_taux, (o)->ofx_tauy, (o)->ofx_swbase, (o)->cfoot}
enum { NOCEAN = 18 };

/* The ocean's budget (the fields the particles' exact sums do not give) */
static inline void ocean_budget(const sph_budget *b, double v[14])
{
    const double x[14] = {b->energy_initial, b->energy, b->energy_surface, b->energy_restoring,
                          b->energy_outflow, b->water_initial, b->water, b->water_outflow,
                          b->salt_initial, b->salt, b->salt_restoring, b->salt_outflow,
                          (double)b->created_particles, (double)b->merged_particles};
    memcpy(v, x, sizeof x);
}

static void ref_path(char *out, size_t n, const char *dir) { snprintf(out, n, "%s/season.ref", dir); }

#ifndef SPHICE_MPI

/* The serial run, canonical or not; NULL on failure. */
static sph_model *serial(int canonical, size_t *nmax_cold, size_t *nmin_warm, double worst[3])
{
    sph_landmask mk;
    sph_model *m = make_model(canonical, 1, &mk);
    CHECK(m != NULL, "serial model, canonical %d", canonical);
    if (!m)
        return NULL;
    sph_status st;
    forcing(m, 0);
    int rc = sph_model_init(m, &st);
    CHECK(rc == SPH_STEP_OK, "init: %s", st.what ? st.what : "");
    *nmax_cold = 0;
    *nmin_warm = CAP;
    worst[0] = worst[1] = worst[2] = 0.0;
    for (int h = 0; h < NSTEP && rc == SPH_STEP_OK; h++) {
        forcing(m, h);
        rc = sph_model_step(m, &st);
        CHECK(rc == SPH_STEP_OK, "canonical %d, step %d: %s %s (%g vs %g)", canonical, h,
              st.quantity ? st.quantity : "", st.what ? st.what : "", st.value, st.limit);
        size_t n = sph_model_particles(m)->n;
        int day = h / 24;
        if (day < 3)
            *nmax_cold = n > *nmax_cold ? n : *nmax_cold;
        if (day == 3)
            *nmin_warm = n < *nmin_warm ? n : *nmin_warm;
        const sph_budget *b = sph_model_budget(m);
        worst[0] = fmax(worst[0], sph_budget_energy_residual(b));
        worst[1] = fmax(worst[1], sph_budget_water_residual(b));
        worst[2] = fmax(worst[2], sph_budget_salt_residual(b));
    }
    if (rc != SPH_STEP_OK) {
        sph_model_free(m);
        return NULL;
    }
    return m;
}

/* The rule for the ocean-fluxes file: regridded the way the engine
 * does it (ofx_add_particles for the live particles, ofx_add_cell_amounts
 * for the cells, each slab cell to the file cell of its centre: the
 * engine's ofx_add_ocean_cells), the file's
 * integrals of hfds, siflfwbot and siflsaltbot equal the particles' plus
 * the cells' totals over the run (the cells' holding what the particles
 * that melted out or left through the east edge gave) within 1e-10
 * relative. */
static void grid_sums(sph_model *m, const char *dir)
{
    const sph_ocean *o = sph_model_ocean(m);
    const sph_particles *P = sph_model_particles(m);
    static double rad[CAP], tx[CAP], ty[CAP], ia[CAP], iv[CAP];
    char path[1024];
    long to[3];
    sph_error err;
    ofx_writer *w = ofx_plane_open(dir, path, sizeof path, to, &err);
    CHECK(w != NULL, "fluxes file: open: %s", err.msg);
    if (!w)
        return;
    long cto[NX * NY];
    for (size_t c = 0; c < (size_t)(NX * NY); c++)
        cto[c] = ofx_locate(w, NAN, NAN, ((double)(c % NX) + 0.5) * CELL, ((double)(c / NX) + 0.5) * CELL,
                            hypot(CELL, CELL) + DXG);
    ofx_particles op = ofx_plane_particles(P, sph_model_params(m)->rho_i, rad, ia, iv, tx, ty);
    double pe = 0.0, pw = 0.0, ps = 0.0, ce = 0.0, cw = 0.0, cs = 0.0, lost[3] = {0, 0, 0}, hi = 0.0;
    for (size_t k = 0; k < P->n; k++) {
        pe += P->ofx_heat_ice[k] + P->ofx_heat_lead[k];
        pw += P->ofx_water[k];
        ps += P->ofx_salt[k];
    }
    for (size_t c = 0; c < o->ncell; c++) {
        ce += o->ofx_heat[c] + o->ofx_heat_ice[c]; /* the removed particles' under-ice heat is part of hfds */
        cw += o->ofx_water[c];
        cs += o->ofx_salt[c];
        hi += fabs(o->ofx_heat_ice[c]);
    }
    const double dt = NSTEP * 3600.0;
    CHECK(ofx_add_particles(w, &op, &err) == SPH_OK, "fluxes file: particles: %s", err.msg);
    double rot[2 * NX * NY];
    for (size_t c = 0; c < o->ncell; c++) {
        rot[c] = 1.0; /* the plane is the file's x/y */
        rot[o->ncell + c] = 0.0;
    }
    CHECK(ofx_add_ocean_cells(w, o->ncell, cto, rot, o->ofx_heat, o->ofx_water, o->ofx_salt, o->ofx_heat_ice,
                              o->ofx_taux, o->ofx_tauy, o->ofx_swbase, dt, lost, &err) == SPH_OK,
          "fluxes file: cells: %s", err.msg);
    CHECK(lost[0] == 0.0 && lost[1] == 0.0 && lost[2] == 0.0 && ofx_lost(w) == 0,
          "fluxes file: no cell or particle lost (%zu particles)", ofx_lost(w));
    CHECK(ofx_write_record(w, 1e9, 1e9 + dt, &err) == SPH_OK, "fluxes file: record: %s", err.msg);
    CHECK(ofx_close(w, &err) == SPH_OK, "fluxes file: close: %s", err.msg);
    CHECK(hi > 0.0, "the removed particles' under-ice heat reached the cells (%.3e J)", hi);
    const char *names[3] = {"hfds", "siflfwbot", "siflsaltbot"};
    const double tot[3] = {pe + ce, pw + cw, ps + cs};
    for (int f = 0; f < 3; f++) {
        double s = ofx_plane_integral(path, names[f], 0, NULL) * dt;
        printf("  fluxes file %s: grid %.12e, particles + cells %.12e\n", names[f], s, tot[f]);
        CHECK(fabs(s - tot[f]) <= 1e-10 * fabs(tot[f]) && tot[f] != 0.0,
              "fluxes file %s: the grid's integral equals the particles' plus the cells' within 1e-10", names[f]);
    }
    unlink(path);
}

static void write_ref(const char *dir)
{
    size_t nmax[2], nmin[2];
    double worst[2][3];
    sph_model *mm[2] = {serial(0, &nmax[0], &nmin[0], worst[0]), serial(1, &nmax[1], &nmin[1], worst[1])};
    if (!mm[0] || !mm[1]) {
        sph_model_free(mm[0]);
        sph_model_free(mm[1]);
        return;
    }
    for (int c = 0; c < 2; c++) {
        const sph_budget *b = sph_model_budget(mm[c]);
        printf("  %s order, %d days: created %ld merged %ld outflow %ld particles, max %zu cold, min %zu in "
               "the thaw, now %zu; residuals energy %.2e water %.2e salt %.2e mass %.2e\n",
               c ? "canonical" : "default", NDAYS, b->created_particles, b->merged_particles,
               b->removed_particles, nmax[c], nmin[c], sph_model_particles(mm[c])->n, worst[c][0], worst[c][1],
               worst[c][2], sph_budget_residual(b));
        CHECK(b->created_particles > 0 && b->merged_particles > 0, "%s: creation and merging happened",
              c ? "canonical" : "default");
        CHECK(nmin[c] < nmax[c], "%s: the thaw removed melted particles (%zu < %zu)", c ? "canonical" : "default",
              nmin[c], nmax[c]);
        CHECK(b->removed_particles > 0 && b->outflow > 0.0, "%s: ice left through the open edge",
              c ? "canonical" : "default");
        CHECK(worst[c][0] < 1e-12 && worst[c][1] < 1e-12 && worst[c][2] < 1e-12,
              "%s: energy, water and salt budgets close (%.2e %.2e %.2e)", c ? "canonical" : "default",
              worst[c][0], worst[c][1], worst[c][2]);
        const sph_particles *P = sph_model_particles(mm[c]);
        int on_land = 0;
        for (size_t k = 0; k < P->n; k++)
            on_land += P->y[k] < 5000.0 && P->x[k] < 10000.0;
        CHECK(on_land == 0, "%s: no particle on land (%d)", c ? "canonical" : "default", on_land);
    }
    /* the canonical order is another order of the same sums, but a
     * round-off can flip a discrete choice (a cell's creation, a merge), so
     * the two runs are not compared beyond the print */
    grid_sums(mm[1], dir);
    const sph_budget *b0 = sph_model_budget(mm[0]), *b1 = sph_model_budget(mm[1]);
    printf("  canonical vs default order: ice plus ocean energy %.6e vs %.6e J (relative %.1e)\n", b1->energy,
           b0->energy, fabs(b1->energy - b0->energy) / fabs(b0->energy));
    char path[700];
    ref_path(path, sizeof path, dir);
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL, "%s", path);
    if (f) {
        const sph_particles *P = sph_model_particles(mm[1]);
        fwrite(&P->n, sizeof P->n, 1, f);
        for (int fi = 0; fi < SPH_PARTICLE_NFIELDS; fi++) {
            size_t sz = sph_particle_fields[fi].size * sph_particles_field_count(P, fi);
            fwrite(sph_particles_field(P, fi), sz, P->n, f);
        }
        sph_ocean *o = sph_model_ocean(mm[1]);
        double *arr[NOCEAN] = OCEAN_ARRAYS(o);
        for (int q = 0; q < NOCEAN; q++)
            fwrite(arr[q], sizeof(double), o->ncell, f);
        fwrite(sph_model_budget(mm[1]), sizeof(sph_budget), 1, f);
        fclose(f);
    }
    sph_model_free(mm[0]);
    sph_model_free(mm[1]);
}

int main(void)
{
    char dir[] = "/tmp/sphice-mpiseason-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    write_ref(dir);
    const int np[] = {2, 4, 1}, nt[] = {1, 1, 1};
    mpi_launch("test_mpi_season", "SPHICE_MPISEASON_BIN", dir, np, nt, check_long() ? 3 : 2);
    char path[700];
    ref_path(path, sizeof path, dir);
    unlink(path);
    rmdir(dir);
    return check_summary("test_mpi_season");
}

#else
static int rank, size;

static int same_particles(const sph_particles *a, const sph_particles *b)
{
    if (a->n != b->n) {
        printf("  %zu particles, serial %zu\n", a->n, b->n);
        return 0;
    }
    int ok = 1;
    for (int f = 0; f < SPH_PARTICLE_NFIELDS; f++) {
        size_t sz = sph_particle_fields[f].size * sph_particles_field_count(a, f);
        if (memcmp(sph_particles_field(a, f), sph_particles_field(b, f), a->n * sz) != 0) {
            ok = 0;
            printf("  field %s differs from the serial run\n", sph_particle_fields[f].name);
        }
    }
    return ok;
}

int main(int argc, char **argv)
{
    MPI_Init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    if (argc < 2) {
        if (rank == 0)
            printf("usage: mpirun -np N test_mpi_season DIR (DIR: the serial reference the plain test writes)\n");
        MPI_Finalize();
        return 2;
    }
    sph_landmask mk0, mk;
    sph_status st;
    sph_model *ser = NULL;
    sph_particles *start = NULL, *got = NULL, *S = NULL;
    sph_model_clock clk;
    memset(&clk, 0, sizeof clk);
    double ref_ocean[NOCEAN][NX * NY];
    sph_budget ref_b;
    memset(&ref_b, 0, sizeof ref_b);
    if (rank == 0) {
        ser = make_model(1, 1, &mk0);
        forcing(ser, 0);
        CHECK(ser && sph_model_init(ser, &st) == SPH_STEP_OK, "initial state");
        if (!ser)
            MPI_Abort(MPI_COMM_WORLD, 1);
        sph_particles *P = sph_model_particles(ser);
        start = sph_particles_create(CAP, P->nlayers);
        got = sph_particles_create(CAP, P->nlayers);
        for (size_t k = 0; k < P->n; k++)
            sph_particles_copy_one(start, k, P, k);
        start->n = P->n;
        sph_model_get_clock(ser, &clk);
        char path[700];
        ref_path(path, sizeof path, argv[1]);
        FILE *f = fopen(path, "rb");
        size_t n = 0;
        int ok = f && fread(&n, sizeof n, 1, f) == 1 && n < CAP && (S = sph_particles_create(CAP, P->nlayers));
        if (ok) {
            S->n = n;
            for (int fi = 0; fi < SPH_PARTICLE_NFIELDS && ok; fi++) {
                size_t sz = sph_particle_fields[fi].size * sph_particles_field_count(S, fi);
                ok = fread(sph_particles_field(S, fi), sz, n, f) == n;
            }
            for (int q = 0; q < NOCEAN && ok; q++)
                ok = fread(ref_ocean[q], sizeof(double), NX * NY, f) == NX * NY;
            ok = ok && fread(&ref_b, sizeof ref_b, 1, f) == 1;
        }
        if (f)
            fclose(f);
        CHECK(ok, "serial reference %s", path);
        if (!ok)
            MPI_Abort(MPI_COMM_WORLD, 1);
        dd_sort_by_id(S);
    }
    sph_model *m = make_model(1, 0, &mk);
    dd_options o = {0.0, 0.0, NX * CELL, NY * CELL, 5000.0, 10};
    dd_ctx *d = m ? dd_create(MPI_COMM_WORLD, m, &o) : NULL;
    CHECK(d != NULL, "decomposition");
    if (!d)
        MPI_Abort(MPI_COMM_WORLD, 1);
    double t0 = MPI_Wtime();
    forcing(m, 0);
    int rc = dd_scatter(d, start, &clk, &st);
    CHECK(rc == SPH_STEP_OK, "scatter (%s %s)", st.quantity ? st.quantity : "", st.what ? st.what : "");
    for (int h = 0; h < NSTEP && rc == SPH_STEP_OK; h++) {
        forcing(m, h); /* every rank: its particles and its mixed layer */
        rc = dd_step(d, &st);
    }
    double tdd = MPI_Wtime() - t0;
    CHECK(rc == SPH_STEP_OK, "decomposed steps (%s %s)", st.quantity ? st.quantity : "", st.what ? st.what : "");
    dd_stats ds;
    dd_run_stats(d, &ds);
    dd_budget bd;
    dd_budget_global(d, &bd);
    sph_budget src;
    memset(&src, 0, sizeof src);
    dd_sources(d, &src);
    /* the mixed layer and the ocean's budget on every rank equal rank 0's */
    sph_ocean *oc = sph_model_ocean(m);
    double *arr[NOCEAN] = OCEAN_ARRAYS(oc);
    double ob[14], ob0[14];
    ocean_budget(sph_model_budget(m), ob);
    memcpy(ob0, ob, sizeof ob);
    MPI_Bcast(ob0, 14, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    int same_rank = memcmp(ob, ob0, sizeof ob) == 0;
    for (int q = 0; q < NOCEAN; q++) {
        double a0[NX * NY];
        memcpy(a0, arr[q], sizeof a0);
        MPI_Bcast(a0, NX * NY, MPI_DOUBLE, 0, MPI_COMM_WORLD);
        same_rank &= memcmp(a0, arr[q], sizeof a0) == 0;
    }
    int all_same = 0;
    MPI_Allreduce(&same_rank, &all_same, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    CHECK(all_same, "every rank's mixed layer and ocean budget equal rank 0's");
    CHECK(dd_gather(d, got) == 0, "gather");
    if (rank == 0) {
        CHECK(same_particles(got, S), "on %d ranks: every field of every particle equals the serial run after %d "
                                      "steps (%zu particles)", size, NSTEP, S->n);
        int same_ocean = 1;
        for (int q = 0; q < NOCEAN; q++)
            same_ocean &= memcmp(ref_ocean[q], arr[q], sizeof ref_ocean[q]) == 0;
        CHECK(same_ocean, "on %d ranks: every array of the mixed layer equals the serial one", size);
        double obs[14];
        ocean_budget(&ref_b, obs);
        CHECK(memcmp(ob, obs, sizeof ob) == 0,
              "on %d ranks: the ocean's budget equals the serial one (energy %.17g / %.17g, created %g / %g, "
              "merged %g / %g)", size, ob[1], obs[1], ob[12], obs[12], ob[13], obs[13]);
        dd_budget bs;
        dd_budget_of(S, S->n, sph_model_params(ser)->rho_i, &bs);
        CHECK(memcmp(&bd, &bs, sizeof bd) == 0, "on %d ranks: mass, area, volume, momentum and kinetic energy "
                                                "equal the serial ones (mass %.17g / %.17g)", size, bd.mass, bs.mass);
        const double sv[5] = {src.growth, src.new_ice, src.melt_bottom + src.melt_top + src.lateral_melt,
                              src.outflow, (double)src.removed_particles};
        const double rv[5] = {ref_b.growth, ref_b.new_ice, ref_b.melt_bottom + ref_b.melt_top + ref_b.lateral_melt,
                              ref_b.outflow, (double)ref_b.removed_particles};
        CHECK(memcmp(sv, rv, sizeof sv) == 0,
              "on %d ranks: the mass budget's sources equal the serial ones (new ice %.17g / %.17g, outflow "
              "%.17g / %.17g)", size, sv[1], rv[1], sv[3], rv[3]);
        printf("  %d ranks: %zu particles, %ld migrations, %.1f halo copies/step; %.2f s\n", size, S->n,
               ds.migrated, (double)ds.halo / NSTEP, tdd);
        if (size > 1)
            CHECK(ds.migrated > 0 && ds.halo > 0, "particles migrated (%ld) and halo exchanged", ds.migrated);
    }
    dd_free(d);
    sph_model_free(m);
    sph_model_free(ser);
    sph_particles_free(start);
    sph_particles_free(got);
    sph_particles_free(S);
    int fails = check_failed_;
    MPI_Allreduce(MPI_IN_PLACE, &fails, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
    if (rank == 0)
        printf("  %d ranks: %d checks true, %d false\n", size, check_passed_, fails);
    MPI_Finalize();
    return fails ? 1 : 0;
}
#endif
