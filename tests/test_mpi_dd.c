/* Spatial domain decomposition within a member (issue 24, item 2;
 * service/domain_mpi.c, core/dd.h, docs/domain.md).
 *
 * The plain build's program runs the MPI build's copy of itself
 * (build-mpi/tests/test_mpi_dd, made by `make mpi-build`) under
 * `mpirun --oversubscribe -np 2` and `-np 4` (and `-np 1` with
 * SPHICE_LONG=1, which also runs 60 instead of 10 mEVP iterations per
 * step); skipped with one
 * line when mpirun or that build is absent. It also checks the exact
 * accumulator against sums known by hand.
 *
 * The plain program first runs the serial reference of each case: one
 * model in canonical mode, initialised and stepped 100 times, written to a
 * temporary directory (and the default, non-canonical path beside it, to
 * show that the canonical order changes the answer by round-off only). The decomposed run
 * starts from the same initialised state, scattered over the ranks along
 * the Hilbert curve, and steps 100 times with migration and halo; the
 * particles gathered to rank 0 and sorted by id must equal the serial
 * ones bit for bit in every field, and the global mass, momentum and
 * kinetic-energy budgets must equal the serial ones bit for bit (exact
 * sums). Cases:
 *  - free drift: a spatially varying wind carries the ice across rank
 *    boundaries (migrations counted and required on more than one rank);
 *  - packed ice against a coast: A = 1, full physics with mEVP, wind onto
 *    a straight coast, so mirror ghosts of halo particles take part;
 *  - migration with packed and loose ice: auto physics, a rotating drift
 *    across the boundaries;
 *  - packed ice on both sides of a land strip 500 m wide, narrower than
 *    the kernel support: particles read the mirror ghosts of the other
 *    side's particles, whose sources lie beyond the ghosts (the halo's
 *    coast zone, docs/domain.md "Halo depth"; without it -np 4 differs).
 * The dynamics never changes mass: the mass budget must stay the initial
 * one exactly. */
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
#include "lattice.h"
#ifdef SPHICE_MPI
#include <mpi.h>

#include "service/domain_mpi.h"
#endif

static inline void check_xsum(void)
{
    sph_xsum a, b;
    sph_xsum_clear(&a);
    sph_xsum_clear(&b);
    /* 1e16 + 1 - 1e16 = 1 exactly (a double sum in this order gives 0) */
    sph_xsum_add(&a, 1e16);
    sph_xsum_add(&a, 1.0);
    sph_xsum_add(&a, -1e16);
    CHECK(sph_xsum_value(&a) == 1.0, "xsum: 1e16 + 1 - 1e16 = %g (1)", sph_xsum_value(&a));
    /* 0.1 ten thousand times, forwards and with a split merge: the same
     * value, and the exact sum of the double 0.1 x 1e4 rounded */
    sph_xsum_clear(&a);
    for (int i = 0; i < 10000; i++)
        sph_xsum_add(i % 2 ? &a : &b, 0.1);
    sph_xsum_merge(&a, &b);
    double v = sph_xsum_value(&a);
    CHECK(fabs(v - 1000.0) < 1e-12, "xsum: 1e4 x 0.1 = %.17g (1000 + 5.55e-14)", v);
    sph_xsum c;
    sph_xsum_clear(&c);
    for (int i = 0; i < 10000; i++)
        sph_xsum_add(&c, 0.1);
    CHECK(sph_xsum_value(&c) == v, "xsum: order independent (%.17g vs %.17g)", sph_xsum_value(&c), v);
    /* subnormals, mixed signs and large values */
    sph_xsum_clear(&a);
    sph_xsum_add(&a, 4.9e-324);
    sph_xsum_add(&a, 1e300);
    sph_xsum_add(&a, -1e300);
    sph_xsum_add(&a, 4.9e-324);
    CHECK(sph_xsum_value(&a) == 2 * 4.9e-324, "xsum: subnormals survive 1e300 - 1e300");
    sph_xsum_clear(&a);
    sph_xsum_add(&a, -3.25);
    sph_xsum_add(&a, 1.0);
    CHECK(sph_xsum_value(&a) == -2.25, "xsum: negative total %g (-2.25)", sph_xsum_value(&a));
    sph_xsum_add(&a, NAN);
    CHECK(isnan(sph_xsum_value(&a)), "xsum: a NaN term gives NaN");
}

enum { NSTEP = 100 };

typedef struct dd_case {
    const char *name;
    int physics;   /* SPH_PHYSICS_* */
    int nx, ny;    /* lattice */
    double A;      /* concentration (case 3: loose half) */
    int coast;     /* 1: land beyond x = nx + 0.3 (km); 2: a land strip 500 m wide at x = 7-7.5 km */
    double dt;
    int wind;      /* 0: uniform + shear, 1: onto the coast, 2: rotating */
    int long_only; /* SPHICE_LONG only: above SPH_OMP_WORTH's 4096, so threads engage */
} dd_case;

static const double D = 1000.0;

static void forcing(const dd_case *c, sph_particles *P, size_t k)
{
    double x = P->x[k] / D, y = P->y[k] / D;
    if (c->wind == 0) {
        P->ua[k] = 12.0 + 0.3 * y;
        P->va[k] = 4.0 - 0.2 * x;
    } else if (c->wind == 1) {
        P->ua[k] = 15.0;
        P->va[k] = 3.0 * sin(y / 5.0);
    } else {
        double cx = x - 0.5 * c->nx, cy = y - 0.5 * c->ny;
        P->ua[k] = -1.5 * cy + 8.0;
        P->va[k] = 1.5 * cx;
    }
    P->uw[k] = 0.05;
    P->vw[k] = -0.02;
}

static unsigned char land[200 * 200];

/* The serial model of a case, initialised (canonical mode). */
static sph_model *make_model(const dd_case *c, size_t cap, sph_landmask *maskp)
{
    sph_params p;
    sph_params_default(&p);
    p.thermo_dt = 0;
    p.dt = c->dt;
    p.physics = c->physics;
    p.solver = SPH_SOLVER_MEVP;
    p.evp_iterations = check_long() ? 60 : 10; /* make check: 2 s */
    sph_landmask *mask = NULL;
    if (c->coast) {
        int mx = 2 * (c->nx + 20), my = 2 * (c->ny + 20); /* 0.5 km cells from -10 km */
        sph_landmask mk = {mx, my, -10 * D, -10 * D, D / 2, D / 2, land, 0};
        /* cell (0,0)'s corner at -10 km: shift the test's x by it */
        for (int j = 0; j < my; j++)
            for (int i = 0; i < mx; i++) {
                double x = -10 * D + (i + 0.5) * (D / 2);
                land[j * mx + i] = (unsigned char)(c->coast == 2 ? x > 7.0 * D && x < 7.5 * D
                                                                 : x > (c->nx + 0.3) * D);
            }
        *maskp = mk;
        mask = maskp;
    }
    sph_model *m = sph_model_create(&p, cap, mask);
    if (!m || sph_model_set_canonical(m, 1))
        return NULL;
    return m;
}

static void fill(const dd_case *c, sph_model *m)
{
    sph_particles *P = sph_model_particles(m);
    const sph_params *p = sph_model_params(m);
    for (int j = 0; j < c->ny; j++)
        for (int i = 0; i < c->nx; i++) {
            double A = c->wind == 2 && i < c->nx / 2 ? 0.5 : c->A;
            /* the strip: the lattice 250 m off its faces (the mirror
             * ghosts fall between the other side's particles) */
            double x = (i + (c->coast == 2 ? 0.75 : 0.5)) * D;
            size_t k = P->n;
            lattice_fill(P, p, 1, 1, x, (j + 0.5) * D, D, 1.0 + 0.01 * (i % 7), A, 75.0);
            P->id[k] = 1000 + 7L * (long)k; /* ids that are not slots */
            forcing(c, P, k);
        }
}

static inline int same_particles(const char *name, const sph_particles *a, const sph_particles *b)
{
    if (a->n != b->n) {
        printf("  %s: %zu particles, serial %zu\n", name, a->n, b->n);
        return 0;
    }
    int ok = 1, shown = 0;
    for (int f = 0; f < SPH_PARTICLE_NFIELDS; f++) {
        size_t sz = sph_particle_fields[f].size * sph_particles_field_count(a, f);
        const unsigned char *x = sph_particles_field(a, f), *y = sph_particles_field(b, f);
        if (memcmp(x, y, a->n * sz) == 0)
            continue;
        ok = 0;
        if (shown++ >= 3)
            continue;
        double dmax = 0;
        if (sph_particle_fields[f].type == SPH_FIELD_DOUBLE)
            for (size_t q = 0; q < a->n * sz / 8; q++)
                dmax = fmax(dmax, fabs(((const double *)x)[q] - ((const double *)y)[q]));
        printf("  %s: field %s differs from the serial run (max |diff| %.3g)\n", name,
               sph_particle_fields[f].name, dmax);
    }
    return ok;
}


static const dd_case cases[] = {
    {"free drift", SPH_PHYSICS_FREE_DRIFT, 16, 16, 0.8, 0, 600.0, 0, 0},
    {"packed ice on a coast", SPH_PHYSICS_FULL, 14, 10, 1.0, 1, 60.0, 1, 0},
    {"migration, packed and loose", SPH_PHYSICS_AUTO, 14, 14, 1.0, 0, 60.0, 2, 0},
    {"packed ice on a coast, 4320 particles", SPH_PHYSICS_FULL, 72, 60, 1.0, 1, 60.0, 1, 1},
    {"packed ice on both sides of a land strip", SPH_PHYSICS_FULL, 15, 10, 1.0, 2, 60.0, 1, 0},
};
enum { NCASES = sizeof cases / sizeof cases[0] };

/* The initialised model of case c (canonical mode on or off). */
static sph_model *start_model(const dd_case *c, int canonical, sph_landmask *mk, sph_status *st)
{
    sph_model *m = make_model(c, (size_t)c->nx * c->ny, mk);
    if (!m || sph_model_set_canonical(m, canonical))
        return NULL;
    fill(c, m);
    if (sph_model_init(m, st) != SPH_STEP_OK) {
        sph_model_free(m);
        return NULL;
    }
    return m;
}

static void ref_path(char *out, size_t n, const char *dir, size_t c)
{
    snprintf(out, n, "%s/case%zu.ref", dir, c);
}
#ifndef SPHICE_MPI

/* The serial reference of each case (canonical mode, this plain build)
 * into dir, and how far the canonical order moves the default path. */
static void write_refs(const char *dir)
{
    for (size_t ci = 0; ci < NCASES; ci++) {
        const dd_case *c = &cases[ci];
        if (c->long_only && !check_long())
            continue;
        sph_model *mm[2];
        sph_landmask mk[2];
        sph_status st;
        for (int canon = 0; canon < 2; canon++) {
            mm[canon] = start_model(c, canon, &mk[canon], &st);
            CHECK(mm[canon] != NULL, "%s: serial model, canonical %d", c->name, canon);
            if (!mm[canon])
                return;
            int rc = SPH_STEP_OK;
            for (int s = 0; s < NSTEP && rc == SPH_STEP_OK; s++)
                rc = sph_model_step(mm[canon], &st);
            CHECK(rc == SPH_STEP_OK, "%s: serial steps (%s %s)", c->name, st.quantity ? st.quantity : "",
                  st.what ? st.what : "");
            sph_model_set_canonical(mm[canon], 0);
        }
        sph_particles *P0 = sph_model_particles(mm[0]), *P1 = sph_model_particles(mm[1]);
        /* same particles by id (both sorted below by the reference's order) */
        double dx = 0, du = 0;
        for (size_t k = 0; k < P1->n; k++)
            for (size_t q = 0; q < P0->n; q++)
                if (P0->id[q] == P1->id[k]) {
                    dx = fmax(dx, fmax(fabs(P0->x[q] - P1->x[k]), fabs(P0->y[q] - P1->y[k])));
                    du = fmax(du, fmax(fabs(P0->u[q] - P1->u[k]), fabs(P0->v[q] - P1->v[k])));
                }
        /* round-off of reordered sums, grown by 100 steps of plastic flow:
         * far below the ~1 km the ice moves and its ~0.2 m/s */
        CHECK(P0->n == P1->n && dx < 1.0 && du < 1e-3,
              "%s: the canonical order moves the default path by round-off only (%.3g m, %.3g m/s)", c->name,
              dx, du);
        printf("  %s: %zu particles; canonical vs default order after %d steps: max |dx| %.3g m, |du| %.3g m/s\n",
               c->name, P1->n, NSTEP, dx, du);
        char path[700];
        ref_path(path, sizeof path, dir, ci);
        FILE *f = fopen(path, "wb");
        CHECK(f != NULL, "%s", path);
        if (f) {
            fwrite(&P1->n, sizeof P1->n, 1, f);
            for (int fi = 0; fi < SPH_PARTICLE_NFIELDS; fi++) {
                size_t sz = sph_particle_fields[fi].size * sph_particles_field_count(P1, fi);
                /* in slot order (the MPI side sorts it by id) */
                fwrite(sph_particles_field(P1, fi), sz, P1->n, f);
            }
            fclose(f);
        }
        sph_model_free(mm[0]);
        sph_model_free(mm[1]);
    }
}

int main(void)
{
    check_xsum();
    char dir[] = "/tmp/sphice-mpidd-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    write_refs(dir);
    /* -np 1 (the driver on one rank) and 2 threads per rank only with
     * SPHICE_LONG: make check's budget */
    const int np[] = {2, 4, 1, 2}, nt[] = {1, 1, 1, 2};
    mpi_launch("test_mpi_dd", "SPHICE_MPIDD_BIN", dir, np, nt, check_long() ? 4 : 2);
    for (size_t ci = 0; ci < NCASES; ci++) {
        char path[700];
        ref_path(path, sizeof path, dir, ci);
        if (!cases[ci].long_only || check_long())
            unlink(path);
    }
    rmdir(dir);
    return check_summary("test_mpi_dd");
}

#else
static int rank, size;

static sph_particles *read_ref(const char *path, int nlayers)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    size_t n = 0;
    sph_particles *P = NULL;
    if (fread(&n, sizeof n, 1, f) == 1 && n < 10000000 && (P = sph_particles_create(n + 1, nlayers))) {
        P->n = n;
        for (int fi = 0; fi < SPH_PARTICLE_NFIELDS; fi++) {
            size_t sz = sph_particle_fields[fi].size * sph_particles_field_count(P, fi);
            if (fread(sph_particles_field(P, fi), sz, n, f) != n) {
                sph_particles_free(P);
                P = NULL;
                break;
            }
        }
    }
    fclose(f);
    return P;
}

static void run_case(size_t ci, const char *dir)
{
    const dd_case *c = &cases[ci];
    size_t N = (size_t)c->nx * c->ny;
    sph_landmask mk, mk2;
    sph_status st;
    sph_model *ser = rank == 0 ? start_model(c, 1, &mk, &st) : NULL;
    sph_particles *start = NULL, *got = NULL, *S = NULL;
    sph_model_clock clk;
    memset(&clk, 0, sizeof clk);
    if (rank == 0) {
        CHECK(ser != NULL, "%s: initial state", c->name);
        if (!ser)
            MPI_Abort(MPI_COMM_WORLD, 1);
        sph_particles *P = sph_model_particles(ser);
        start = sph_particles_create(N, P->nlayers);
        got = sph_particles_create(N, P->nlayers);
        for (size_t k = 0; k < P->n; k++)
            sph_particles_copy_one(start, k, P, k);
        start->n = P->n;
        sph_model_get_clock(ser, &clk);
        char path[700];
        ref_path(path, sizeof path, dir, ci);
        S = read_ref(path, P->nlayers);
        CHECK(S != NULL, "%s: serial reference %s", c->name, path);
        if (!S)
            MPI_Abort(MPI_COMM_WORLD, 1);
        dd_sort_by_id(S);
    }
    sph_model *m = make_model(c, N, &mk2);
    dd_options o = {-10 * D, -10 * D, (c->nx + 10) * D, (c->ny + 10) * D, 3 * D, 10};
    dd_ctx *d = m ? dd_create(MPI_COMM_WORLD, m, &o) : NULL;
    CHECK(d != NULL, "%s: decomposition", c->name);
    if (!d)
        MPI_Abort(MPI_COMM_WORLD, 1);
    double t0 = MPI_Wtime();
    int rc = dd_scatter(d, start, &clk, &st);
    CHECK(rc == SPH_STEP_OK, "%s: scatter (%s %s)", c->name, st.quantity ? st.quantity : "", st.what ? st.what : "");
    for (int s = 0; s < NSTEP && rc == SPH_STEP_OK; s++)
        rc = dd_step(d, &st);
    double tdd = MPI_Wtime() - t0;
    dd_stats ds;
    dd_run_stats(d, &ds);
    long migrated = ds.migrated, halo = ds.halo, iters = ds.iterations, merging = ds.ghosts_merging;
    double hbytes = ds.halo_bytes;
    CHECK(rc == SPH_STEP_OK, "%s: decomposed steps (%s %s)", c->name, st.quantity ? st.quantity : "",
          st.what ? st.what : "");
    dd_budget bd, bs, b0;
    dd_budget_global(d, &bd);
    CHECK(dd_gather(d, got) == 0, "%s: gather", c->name);
    if (rank == 0) {
        const sph_params *p = sph_model_params(ser);
        dd_budget_of(S, S->n, p->rho_i, &bs);
        dd_budget_of(start, start->n, p->rho_i, &b0);
        CHECK(same_particles(c->name, got, S), "%s on %d ranks: every field of every particle equals the serial "
                                               "run after %d steps", c->name, size, NSTEP);
        CHECK(memcmp(&bd, &bs, sizeof bd) == 0,
              "%s: budgets equal the serial ones (mass %.17g / %.17g, px %.17g / %.17g, ke %.17g / %.17g)", c->name,
              bd.mass, bs.mass, bd.momentum_x, bs.momentum_x, bd.kinetic_energy, bs.kinetic_energy);
        CHECK(bd.mass == b0.mass, "%s: mass conserved exactly (%.17g, initial %.17g)", c->name, bd.mass, b0.mass);
        /* the exact sums against a plain sum */
        double msum = 0, kesum = 0;
        for (size_t k = 0; k < S->n; k++) {
            msum += S->mass[k];
            kesum += 0.5 * S->mass[k] * (S->u[k] * S->u[k] + S->v[k] * S->v[k]);
        }
        CHECK(fabs(bs.mass - msum) <= 1e-12 * msum && fabs(bs.kinetic_energy - kesum) <= 1e-10 * kesum,
              "%s: exact budgets agree with plain sums (mass %.17g / %.17g)", c->name, bs.mass, msum);
        CHECK(!merging, "%s: no coast ghosts merged (their order is not canonical)", c->name);
        double speed = sqrt(2.0 * bs.kinetic_energy / bs.mass);
        printf("  %s, %d ranks: %zu particles, rms speed %.3f m/s, %ld migrations, %.1f halo copies/step, "
               "%ld halo refreshes, %.1f kB halo/step; %.2f s\n",
               c->name, size, S->n, speed, migrated, (double)halo / NSTEP, iters, hbytes / NSTEP / 1e3, tdd);
        if (size > 1)
            CHECK(halo > 0, "%s: halo particles exchanged", c->name);
        if (size > 1 && c->wind != 1)
            CHECK(migrated > 0, "%s: particles migrated between ranks", c->name);
    }
    dd_free(d);
    sph_model_free(m);
    sph_model_free(ser);
    sph_particles_free(start);
    sph_particles_free(got);
    sph_particles_free(S);
}

int main(int argc, char **argv)
{
    MPI_Init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    if (argc < 2) {
        if (rank == 0)
            printf("usage: mpirun -np N test_mpi_dd DIR (DIR: the serial references the plain test_mpi_dd writes)\n");
        MPI_Finalize();
        return 2;
    }
    for (size_t ci = 0; ci < NCASES; ci++)
        if (!cases[ci].long_only || check_long())
            run_case(ci, argv[1]);
    int fails = check_failed_;
    MPI_Allreduce(MPI_IN_PLACE, &fails, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
    if (rank == 0)
        printf("  %d ranks: %d checks true, %d false\n", size, check_passed_, fails);
    MPI_Finalize();
    return fails ? 1 : 0;
}
#endif
