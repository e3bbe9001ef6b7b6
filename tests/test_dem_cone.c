/* Ice on an upward-breaking cone (issue 25): Ralston's bending-failure
 * load (dem_ralston_cone) against the formula written out again with the
 * complete elliptic integrals taken from Abramowitz & Stegun's table, its
 * range refused outside IceFloe's input limits; then a bonded-particle
 * sheet driven into the DEM cone (angle, waterline diameter, neck): it
 * rides up, fails in bending (bonds broken in tension), and its mean
 * horizontal load is reported beside Ralston's for the same ice and cone.
 *
 * make check runs a small sheet for a short time and asserts what the
 * physics guarantees there: contact, ride-up above the waterline, tension
 * failure, the load pointing into the drift and down the cone, the ratio
 * of the load's components bounded by the face's friction factor; then a
 * small pre-shaped sheet with its sides confined (session 9: side bands
 * held laterally and carried along at the drift, DEM_FIX_X | DEM_FIX_Y,
 * free to heave): the same checks, and the held sides keep y exactly while
 * moving vertically.
 *
 * SPHICE_LONG (session 8's rebuild, docs/dem.md "The cone case rebuilt"):
 * the seed's 0.263 m ice as four close-packed layers of r = 0.0381 m
 * spheres (h/d = 3.45; NRL 2019 found DEM flexural strength unreliable
 * below h/d 4.5, and 3 is what the cost allowed), a 2.4 m by 3.0 m sheet
 * whose front is pre-shaped to the cone (the axis on the front edge, the
 * spheres inside the face at each layer's height left out: the edge a
 * first breaking cycle leaves, so contact spans the waterline's front half
 * instead of one sphere of a straight edge), the sides free, the rear edge
 * driven from rest to 0.5 m/s in 0.2 s, 1.2 s; the default bonds; the bond
 * modulus 0.1 GPa (Ralston's load does not depend on E; the step is 3x
 * longer). The PEAK (the largest 10 ms mean of H) is asserted within
 * [CONE_PEAK_LO, CONE_PEAK_HI] x Ralston's H, a range of this project's
 * making (no published DEM-against-Ralston numbers were found; its
 * provenance is in docs/dem.md). SPHICE_DEM_CONE="nx ny speed duration E_b
 * [nz r shaped ramp [sigma_t tau_c [sides rear]]]" overrides the case
 * (sides 1: held laterally, 2: also driven along x; rear 1: driven along x
 * only, floating); the shaped sheet's runs print the cycles' peaks and
 * period, and the sheet's and the broken pieces' positions (every 50 ms
 * with SPHICE_DEM_CONE_SERIES; docs/dem.md, "The cone with confined sides
 * (session 9)"). */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>

#include "check.h"
#include "core/dem.h"
#include "dem_pieces.h"

/* The range of the peak against Ralston's H that the long case asserts
 * (docs/dem.md, "The cone case rebuilt": its provenance): Croasdale et al.
 * (OTC-27385, 2016) found ISO 19906's sloping-structure algorithm 1.6 times
 * the measured peaks of 50 Confederation Bridge events, so a peak of
 * H / 1.6 is the lower bound (no published scatter to widen it by: an
 * earlier draft halved it, a choice made while the run was in progress,
 * and so dropped); the upper bound is the mean's range's 1.5 kept
 * (Ralston's is an upper bound for slow ice, model tests show steep cones
 * at speed above quasi-static methods). The rebuilt case's 0.330 fails
 * it: a known gap of issue 25 (docs/dem.md). */
#define CONE_PEAK_LO (1.0 / 1.6)
#define CONE_PEAK_HI 1.5

/* Ralston / IEC 61400-3 Annex E written out again, with K and E of
 * modulus sin 45 deg (parameter m = 0.5) from Abramowitz & Stegun, table
 * 17.1: K = 1.854074677301372, E = 1.350643881047676. */
static void test_ralston_formula(void)
{
    dem_cone_ice c = {0.6e6, 0.3, 0.3, 900.0, 0.15, 45.0, 4.0, 2.0};
    dem_cone_load L;
    const char *why = "";
    CHECK(dem_ralston_cone(&c, &L, &why) == 0, "in range: %s", why);
    double a = M_PI / 4, sa = sin(a), ca = cos(a), ta = tan(a), mu = c.friction;
    double Kt = 1.854074677301372, Et = 1.350643881047676;
    double g = (sa + a / ca) / (2 * mu * a * ca + M_PI / 2 * sa * sa);
    double G = 900.0 * 9.81 * 16.0 / (4 * 0.6e6 * 0.3), Y = 2.711;
    double x = 1 + 1 / sqrt(3 * G + Y / 2);
    double hb = 0.6e6 * 0.09 / 3 * ta / (1 - mu * g) *
                (G * (x - 1) * (x + 2) + (1 + Y * x * log(x)) / (x - 1));
    double W = 900.0 * 9.81 * 0.3 * (16.0 - 4.0) / (4 * ca);
    double hr = W * (ta + mu * (Et - (mu * Kt * ca + sa) * g * ca)) / (1 - mu * g);
    CHECK_CLOSE(L.h_break, hb, 1e-9, 0.0, "H_B");
    CHECK_CLOSE(L.h_rideup, hr, 1e-9, 0.0, "H_R (elliptic integrals against the table)");
    CHECK_CLOSE(L.h, hb + hr, 1e-12, 0.0, "H = H_B + H_R");
    double xi = (sa + mu * ca) / (ca - mu * sa);
    CHECK_CLOSE(L.v, (hb + hr) / xi, 1e-12, 0.0, "V = H / xi");
    printf("Ralston: a 45 deg, mu 0.15, D 4 m, D_T 2 m, h = h_r 0.3 m, sigma_f 0.6 MPa: "
           "H_B %.2f kN, H_R %.2f kN, H %.2f kN, V %.2f kN (g %.4f, xi %.4f)\n",
           hb / 1e3, hr / 1e3, L.h / 1e3, L.v / 1e3, g, xi);
    /* frictionless: the ride-up term is the weight's push up the slope, W tan a */
    c.friction = 0.0;
    CHECK(dem_ralston_cone(&c, &L, &why) == 0, "mu = 0 in range");
    CHECK_CLOSE(L.h_rideup, W * ta, 1e-12, 0.0, "H_R at mu = 0");
    /* the breaking load grows with the thickness (h^2 at small G) and the strength */
    c.friction = 0.15;
    dem_cone_load L2;
    c.flexural_strength = 1.2e6;
    dem_ralston_cone(&c, &L2, &why);
    CHECK(L2.h_break > 1.5 * hb && L2.h_break < 2.0 * hb + 1e-6, "H_B(2 sigma) %g vs %g",
          L2.h_break, hb);
    c.flexural_strength = 0.6e6;
    /* the range */
    const double bad_angle[] = {19.9, 70.1};
    for (int k = 0; k < 2; k++) {
        dem_cone_ice b = c;
        b.angle = bad_angle[k];
        CHECK(dem_ralston_cone(&b, &L, &why) == -1 && isnan(L.h), "angle %g refused",
              bad_angle[k]);
    }
    dem_cone_ice b = c;
    b.angle = 60.0;
    b.friction = 1.0 / tan(M_PI / 3.0); /* above cot a - 0.01 */
    CHECK(dem_ralston_cone(&b, &L, &why) == -1, "friction beyond cot a refused");
    printf("Ralston refusal: %s\n", why);
    b = c;
    b.top_diameter = b.diameter;
    CHECK(dem_ralston_cone(&b, &L, &why) == -1, "top diameter = waterline refused");
    b = c;
    b.thickness = 0.0;
    CHECK(dem_ralston_cone(&b, &L, &why) == -1, "no ice refused");
}

typedef struct cone_case {
    int nx, ny, nz;
    double r, speed, duration, bond_modulus;
    double diameter, neck, angle;
    int compare; /* assert the peak against Ralston's range */
    int shaped;  /* the sheet's front pre-shaped to the cone's waterline, its sides free */
    double sigma_t, tau_c; /* bond strengths, Pa (0: the core's defaults) */
    double ramp; /* > 0: the sheet starts at rest, its rear edge reaches the speed in this time, s */
    int sides;   /* shaped sheet's side bands: 0 free, 1 held laterally (DEM_FIX_Y: free along
                  * the drift and vertically), 2 held laterally and driven along x at the ice
                  * speed (DEM_FIX_X | DEM_FIX_Y: free vertically) */
    int rear;    /* the driven rear band: 0 held in translation and rotation (a clamp), 1 driven
                  * along x and held laterally only (DEM_FIX_X | DEM_FIX_Y: it floats, free to
                  * heave and rotate, as the far-field ice) */
} cone_case;

/* Positions (docs/dem.md, "The cone with confined sides"): the intact
 * sheet is the largest set of spheres joined by intact bonds (union-find
 * over the bonds; it may have come off the driven rear, which then pushes
 * it through contacts); the rest are broken pieces. Prints, at time
 * t, the intact sheet's front on the cone's axis (the largest x within 2 r
 * of y0, as a distance to the axis: D/2 + r / sin a at the waterline when
 * it touches the face), and the pieces: how many,
 * how many ride above the sheet's top within 4 r of the face, how many
 * have cleared past the axis (x > x0) over the cone (|y - y0| < D/2) or
 * around it, and their largest lateral offset |y - y0|; with sizes, the
 * pieces' extents (the breaking length). Returns the front's distance to
 * the axis. */
static double print_positions(const dem *d, const unsigned char *isrear, double t, double ztop, double r,
                              int quiet, int sizes)
{
    int n = (int)d->n, *par = malloc((size_t)n * sizeof *par);
    dem_pieces(d, par);
    /* the intact sheet: the largest set of spheres joined by intact bonds */
    int *cnt = calloc((size_t)n, sizeof *cnt), rear = 0;
    for (int i = 0; i < n; i++)
        cnt[uf_find(par, i)]++;
    for (int i = 1; i < n; i++)
        if (cnt[i] > cnt[rear])
            rear = i;
    long nsheet = cnt[rear], ndriven = 0;
    for (int i = 0; i < n; i++)
        ndriven += isrear[i] && uf_find(par, i) == rear;
    /* the pieces' sizes: per piece of 10 spheres or more (a few spheres
     * across in the sheet's layers), its extent, the larger of its spans in
     * x and y (centres, plus a diameter) */
    double *bx = malloc(4 * (size_t)n * sizeof *bx);
    for (int i = 0; i < n; i++) {
        int q = uf_find(par, i);
        if (q == i) {
            bx[4 * q] = bx[4 * q + 2] = HUGE_VAL;
            bx[4 * q + 1] = bx[4 * q + 3] = -HUGE_VAL;
        }
    }
    for (int i = 0; i < n; i++) {
        int q = uf_find(par, i);
        bx[4 * q] = fmin(bx[4 * q], d->x[i]);
        bx[4 * q + 1] = fmax(bx[4 * q + 1], d->x[i]);
        bx[4 * q + 2] = fmin(bx[4 * q + 2], d->y[i]);
        bx[4 * q + 3] = fmax(bx[4 * q + 3], d->y[i]);
    }
    long nbig = 0, nsingle = 0, largest = 0;
    double ext_sum = 0.0, ext_max = 0.0;
    for (int q = 0; q < n; q++) {
        if (q == rear || uf_find(par, q) != q)
            continue;
        nsingle += cnt[q] == 1;
        if (cnt[q] >= 10) {
            double ext = fmax(bx[4 * q + 1] - bx[4 * q], bx[4 * q + 3] - bx[4 * q + 2]) + 2.0 * r;
            nbig++;
            ext_sum += ext;
            ext_max = fmax(ext_max, ext);
            largest = cnt[q] > largest ? cnt[q] : largest;
        }
    }
    free(bx);
    free(cnt);
    if (!quiet && sizes)
        printf("positions t %.2f s: pieces of 10 spheres or more %ld (mean extent %.3f m, largest %.3f m;"
               " the largest piece %ld spheres), single spheres %ld\n",
               t, nbig, nbig ? ext_sum / (double)nbig : NAN, ext_max, largest, nsingle);
    double x0 = d->s.x0, y0 = d->s.y0, rw = 0.5 * d->s.diameter, front = -HUGE_VAL, ymax = 0.0;
    long pieces = 0, ride = 0, over = 0, around = 0;
    double sx = 0.0, sz = 0.0, xrear = -HUGE_VAL;
    for (int i = 0; i < n; i++)
        if (isrear[i])
            xrear = fmax(xrear, d->x[i]);
    for (int i = 0; i < n; i++) {
        double dy = fabs(d->y[i] - y0);
        if (uf_find(par, i) == rear) {
            if (dy < 2.0 * r)
                front = fmax(front, d->x[i]);
            sx += d->x[i];
            sz += d->z[i];
            continue;
        }
        pieces++;
        ymax = fmax(ymax, dy);
        double rho = hypot(d->x[i] - x0, d->y[i] - y0);
        double a = d->s.cone_angle * M_PI / 180.0;
        if (d->z[i] + r > ztop + r && rho < rw - d->z[i] / tan(a) + 4.0 * r)
            ride++;
        if (d->x[i] > x0) {
            if (dy < rw)
                over++;
            else
                around++;
        }
    }
    free(par);
    if (!quiet)
        printf("positions t %.2f s: intact front on the axis %.3f m before it; pieces %ld: riding up at the"
               " face %ld, cleared past the axis over the cone %ld, around it %ld, largest |y - y0|"
               " %.3f m; the sheet %ld spheres (%s the driven rear), its centre %.3f m before the axis"
               " at z %.3f m, the driven rear's front %.3f m before it\n",
               t, x0 - front, pieces, ride, over, around, ymax, nsheet, ndriven ? "with" : "without",
               x0 - sx / (double)nsheet, sz / (double)nsheet, x0 - xrear);
    return x0 - front;
}

/* The sheet of dem_add_sheet_hcp with the spheres inside the cone's face
 * (and a gap) left out: the cone's axis on the sheet's front edge, so that
 * the front is a half-circle notch following the face at every layer's
 * height -- the edge a first breaking cycle leaves, in contact over the
 * waterline's front half at once. Bonds: the touching pairs, as
 * dem_add_sheet_hcp bonds them. Returns the spheres kept. */
static long sheet_shaped(dem *d, const cone_case *c, double x0, double y0, double gap)
{
    size_t np = (size_t)c->nx * c->ny * c->nz;
    dem *t = dem_create(np, 8 * np, &d->p);
    if (!t || dem_add_sheet_hcp(t, 0.0, 0.0, c->nx, c->ny, c->nz, c->r, c->speed, 0.0) != 0) {
        dem_free(t);
        return -1;
    }
    double a = c->angle * M_PI / 180.0, ta = tan(a), rw = 0.5 * c->diameter;
    long kept = 0;
    for (size_t i = 0; i < t->n; i++) {
        double rho = hypot(t->x[i] - x0, t->y[i] - y0);
        /* a centre at height z touches the face at rho = rw - z / tan a + r / sin a */
        if (rho < rw - t->z[i] / ta + t->r[i] / sin(a) + gap)
            continue;
        long q = dem_add_particle(d, t->x[i], t->y[i], t->z[i], t->r[i]);
        if (q < 0)
            break;
        dem_set_velocity(d, q, c->ramp > 0.0 ? 0.0 : c->speed, 0.0, 0.0);
        kept++;
    }
    dem_free(t);
    dem_bond_touching(d, 1e-6);
    return kept;
}

static void run_cone(const cone_case *c)
{
    dem_params p;
    dem_params_default(&p);
    p.bond_modulus = c->bond_modulus;
    if (c->sigma_t > 0.0) {
        p.bond_tensile = c->sigma_t;
        p.bond_shear = c->tau_c;
    }
    size_t np = (size_t)c->nx * c->ny * c->nz;
    dem *d = dem_create(np, 8 * np, &p);
    CHECK(d != NULL, "created");
    double r = c->r;
    double a = c->angle * M_PI / 180.0, ta = tan(a);
    double ymax = sqrt(3.0) * r * (c->ny - 1) + r, ztop = -HUGE_VAL;
    long nside = 0;
    unsigned char *isrear = calloc(np, 1);
    if (c->shaped) {
        /* the axis on the front edge, mid-width */
        double xfront = 2.0 * r * (c->nx - 1) + r;
        d->s.x0 = xfront;
        d->s.y0 = 0.5 * sqrt(3.0) * r * (c->ny - 1);
        long kept = sheet_shaped(d, c, d->s.x0, d->s.y0, 0.01);
        CHECK(kept > 0 && (size_t)kept < np, "shaped sheet built: %ld of %zu spheres", kept, np);
    } else {
        long first = dem_add_sheet_hcp(d, 0.0, 0.0, c->nx, c->ny, c->nz, r, c->speed, 0.0);
        CHECK(first == 0, "sheet built");
    }
    for (size_t i = 0; i < d->n; i++) {
        ztop = fmax(ztop, d->z[i] + r);
        /* the rear edge (and, on the straight sheet, the two side edges) move
         * with the far-field ice */
        int side = d->y[i] < 2.0 * r || d->y[i] > ymax - 2.0 * r;
        isrear[i] = d->x[i] < 3.0 * r;
        if (d->x[i] < 3.0 * r || (!c->shaped && side)) {
            d->flags[i] = c->shaped && c->rear == 1 ? DEM_FIX_X | DEM_FIX_Y
                                                    : DEM_FIX_TRANSLATION | DEM_FIX_ROTATION;
            dem_set_velocity(d, (long)i, c->ramp > 0.0 ? 0.0 : c->speed, 0.0, 0.0);
        } else if (c->shaped && side && c->sides > 0) {
            /* confinement: the ice beside the sheet holds its sides laterally
             * (and, sides 2, carries them along at the drift) */
            d->flags[i] = DEM_FIX_Y | (c->sides == 2 ? DEM_FIX_X : 0);
            dem_set_velocity(d, (long)i, c->sides == 2 && c->ramp <= 0.0 ? c->speed : 0.0, 0.0, 0.0);
            nside++;
        }
    }
    CHECK(c->sides == 0 || nside > 0, "side bands held: %ld spheres", nside);
    if (c->shaped)
        printf("cone case: sides %s, rear %s\n",
               c->sides == 0 ? "free" : c->sides == 1 ? "held laterally (free along x and z)"
                                                   : "held laterally, driven along x (free in z)",
               c->rear == 1 ? "driven along x, held laterally, free to heave and rotate" : "held in translation and rotation");
    /* the held bands' lateral positions, to check the constraint at the end */
    double *yside = malloc(d->n * sizeof *yside);
    for (size_t i = 0; i < d->n; i++)
        yside[i] = d->y[i];
    double h = 2 * r + (c->nz - 1) * 2 * r * sqrt(2.0 / 3.0);
    d->s.kind = DEM_STRUCT_CONE;
    d->s.diameter = c->diameter;
    d->s.neck_diameter = c->neck;
    d->s.cone_angle = c->angle;
    d->s.z_waterline = 0.0;
    if (!c->shaped) {
        /* the sheet's nearest sphere on the axis 1 cm off the cone's face: a
         * centre at horizontal distance dx from the face touches at dx = r / sin a */
        d->s.y0 = 0.5 * sqrt(3.0) * r * (c->ny - 1);
        d->s.x0 = -HUGE_VAL;
        for (size_t i = 0; i < d->n; i++)
            if (fabs(d->y[i] - d->s.y0) < r)
                d->s.x0 = fmax(d->s.x0, d->x[i] + 0.5 * c->diameter - d->z[i] / ta + r / sin(a) + 0.01);
    }
    d->s.mass = 0.0; /* fixed: Ralston's load is on a rigid cone */
    double dt = 0.9 * p.dt_safety * dem_dt_critical(d);
    long steps = (long)(c->duration / dt);
    double t0 = omp_get_wtime();
    sph_status st;
    int bad = 0;
    long first_contact = -1;
    double sh = 0, sv = 0, hmax = 0, zmax = -HUGE_VAL;
    long ns = 0;
    /* SPHICE_DEM_CONE_SERIES: print the load every 10 ms (diagnosis) */
    int series = getenv("SPHICE_DEM_CONE_SERIES") != NULL;
    long every = (long)(0.01 / dt) + 1;
    double bh = 0, bv = 0;
    /* the load spectrum: 1 kHz block means of H from the first contact */
    long blk = (long)(1e-3 / dt) > 0 ? (long)(1e-3 / dt) : 1, nblk = 0, inblk = 0;
    double *blocks = malloc((size_t)(steps / blk + 1) * sizeof *blocks), bsum = 0.0;
    for (long s = 0; s < steps; s++) {
        if (c->ramp > 0.0 && (double)s * dt <= c->ramp + dt) {
            double u = c->speed * fmin(1.0, (double)(s + 1) * dt / c->ramp);
            for (size_t i = 0; i < d->n; i++)
                if (d->flags[i] & (DEM_FIX_TRANSLATION | DEM_FIX_X))
                    d->vx[i] = u;
        }
        if (dem_step(d, dt, &st) != SPH_STEP_OK) {
            bad = 1;
            break;
        }
        if (first_contact < 0 && d->s.fx != 0.0)
            first_contact = s;
        if (first_contact >= 0) {
            sh += d->s.fx;
            sv += -d->s.fz;
            ns++;
            hmax = fmax(hmax, d->s.fx);
            bsum += d->s.fx;
            if (++inblk == blk) {
                blocks[nblk++] = bsum / (double)blk;
                bsum = 0.0;
                inblk = 0;
            }
        }
        if (series) {
            bh += d->s.fx;
            bv += -d->s.fz;
            if ((s + 1) % every == 0) {
                long nc = 0;
                for (size_t i = 0; i < d->n; i++)
                    nc += d->s_f[3 * i] != 0.0;
                printf("series t %.3f s: H %.2f kN V %.2f kN, %ld spheres on the cone, broken %ld+%ld\n",
                       (s + 1) * dt, bh / every / 1e3, bv / every / 1e3, nc,
                       d->bonds_broken_tension, d->bonds_broken_shear);
                bh = bv = 0;
            }
        }
        if (c->shaped && (s + 1) % (5 * every) == 0)
            print_positions(d, isrear, (s + 1) * dt, ztop, r, !series, 0);
    }
    double wall = omp_get_wtime() - t0;
    CHECK(!bad, "steps ok (fault %d at particle %ld: %s)", st.kind, st.particle, st.what);
    CHECK(first_contact >= 0, "ice reached the cone");
    double xc = d->s.x0, yc = d->s.y0;
    for (size_t i = 0; i < d->n; i++) {
        double rho = hypot(d->x[i] - xc, d->y[i] - yc);
        if (rho < 0.5 * c->diameter + 4 * r)
            zmax = fmax(zmax, d->z[i] + r);
    }
    double mh = ns ? sh / ns : 0, mv = ns ? sv / ns : 0;
    /* sigma_f: the measured flexural strength of Bohai ice (Xiu et al. 2022), which the
     * default bonds are calibrated to give in test_dem_bend's specimen (docs/dem.md) */
    dem_cone_ice ice = {0.6e6, h, h, p.density, p.friction, c->angle, c->diameter,
                        c->neck};
    dem_cone_load L;
    const char *why = "";
    int ok = dem_ralston_cone(&ice, &L, &why);
    CHECK(ok == 0, "Ralston in range: %s", why);
    printf("cone case: %zu spheres (%d x %d x %d, r %.3f m), ice %.3f m at %.2f m/s, E_b %.3g Pa,"
           " cone %.0f deg, D %.2f m, neck %.2f m; %ld steps of %.3g s (%.3f s, %.1f s wall)\n",
           d->n, c->nx, c->ny, c->nz, r, h, c->speed, p.bond_modulus, c->angle, c->diameter,
           c->neck, steps, dt, c->duration, wall);
    printf("cone case: bonds intact %ld, broken in tension %ld, in shear %ld; ride-up: highest"
           " sphere top near the cone %.3f m (sheet top %.3f m)\n",
           d->bonds_intact, d->bonds_broken_tension, d->bonds_broken_shear, zmax, ztop);
    printf("cone case: from the first contact: mean H %.2f kN, max H %.2f kN, mean V %.2f kN;"
           " Ralston (sigma_f %.2f MPa measured; bonds sigma_t %.3g, tau_c %.3g MPa; h_r = h): H %.2f kN (H_B %.2f, H_R %.2f),"
           " V %.2f kN; DEM mean / Ralston %.3f\n",
           mh / 1e3, hmax / 1e3, mv / 1e3, ice.flexural_strength / 1e6, p.bond_tensile / 1e6, p.bond_shear / 1e6, L.h / 1e3, L.h_break / 1e3,
           L.h_rideup / 1e3, L.v / 1e3, mh / L.h);
    double bm = 0, bx = 0, bs = 0, freq = NAN;
    if (nblk > 1)
        dem_load_stats(blocks, (size_t)nblk, blk * dt, &bm, &bx, &bs, &freq);
    printf("cone case: load spectrum of H (%ld blocks of 1 ms): dominant frequency %.2f Hz, std %.2f kN;"
           " max / mean %.2f\n", nblk, freq, bs / 1e3, mh > 0 ? hmax / mh : NAN);
    /* the peak: the largest 10 ms mean of H (Ralston's is a quasi-static
     * peak; a single step's contact spike is not), and the breaking cycles:
     * the 10 ms means rising above half that peak after falling below a
     * fifth of it (a load build-up ended by a failure and a clearing) */
    long w10 = 10, cycles = 0, tpk = 0;
    double pk = 0.0;
    for (long k = 0; k + w10 <= nblk; k += w10) {
        double m = 0.0;
        for (long q = k; q < k + w10; q++)
            m += blocks[q] / (double)w10;
        if (m > pk) {
            pk = m;
            tpk = k;
        }
    }
    int high = 0;
    double cpk = 0.0, cpk_sum = 0.0, t_first = 0.0, t_last = 0.0;
    for (long k = 0; k + w10 <= nblk; k += w10) {
        double m = 0.0;
        for (long q = k; q < k + w10; q++)
            m += blocks[q] / (double)w10;
        if (!high && m > 0.5 * pk) {
            high = 1;
            cycles++;
            cpk = m;
            t_last = (double)k * blk * dt;
            if (cycles == 1)
                t_first = t_last;
        } else if (high && m < 0.2 * pk) {
            high = 0;
            printf("cone case: cycle %ld: starts %.3f s after the first contact, peak %.2f kN\n", cycles,
                   t_last, cpk / 1e3);
            cpk_sum += cpk;
        } else if (high)
            cpk = fmax(cpk, m);
    }
    if (high) {
        printf("cone case: cycle %ld: starts %.3f s after the first contact, peak %.2f kN (open at the end)\n",
               cycles, t_last, cpk / 1e3);
        cpk_sum += cpk;
    }
    double period = cycles > 1 ? (t_last - t_first) / (double)(cycles - 1) : NAN;
    printf("cone case: %ld cycles, mean of their peaks %.2f kN (%.3f of Ralston), mean period %.3f s"
           " (ice advance per cycle %.3f m = %.2f h)\n",
           cycles, cycles ? cpk_sum / cycles / 1e3 : NAN, cycles ? cpk_sum / cycles / L.h : NAN, period,
           period * c->speed, period * c->speed / h);
    printf("cone case: peak H (largest 10 ms mean) %.2f kN at %.3f s after the first contact (raw max %.2f kN);"
           " Ralston H %.2f kN: peak / Ralston %.3f, raw max / Ralston %.3f, mean / Ralston %.3f;"
           " load cycles (10 ms means above 0.5 peak after below 0.2 peak) %ld\n",
           pk / 1e3, tpk * blk * dt, hmax / 1e3, L.h / 1e3, pk / L.h, hmax / L.h, mh / L.h, cycles);
    free(blocks);
    if (c->shaped)
        print_positions(d, isrear, c->duration, ztop, r, 0, 1);
    if (c->sides > 0) {
        /* the held sides: y kept exactly, free to move vertically (and, held only
         * laterally, along the drift) */
        long moved_y = 0, moved_z = 0;
        for (size_t i = 0; i < d->n; i++)
            if (d->flags[i] & DEM_FIX_Y) {
                moved_y += d->y[i] != yside[i] || d->vy[i] != 0.0;
                moved_z += d->vz[i] != 0.0;
            }
        CHECK(moved_y == 0, "held sides: y unchanged (%ld moved)", moved_y);
        CHECK(moved_z > 0, "held sides: free vertically (%ld of %ld moving)", moved_z, nside);
    }
    free(yside);
    free(isrear);
    CHECK(mh > 0.0 && mv > 0.0, "the load pushes along the drift and down the cone");
    CHECK(d->bonds_broken_tension > 0, "the sheet failed in tension (bending)");
    CHECK(zmax > ztop + r, "ride-up: ice above the sheet's top at the cone (%.3f vs %.3f)",
          zmax, ztop);
    /* every contact on the face pushes along its normal plus friction up the
     * slope, and sliding ones at most at mu: H/V of the sum lies between the
     * frictionless tan a and the face's friction factor xi (contacts with the
     * vertical neck only add horizontal load: bounded below only) */
    CHECK(mh / mv > ta * 0.999, "H/V %.3f at least tan a %.3f", mh / mv, ta);
    if (c->compare)
        /* docs/dem.md: the range published comparisons report */
        CHECK(pk > CONE_PEAK_LO * L.h && pk < CONE_PEAK_HI * L.h,
              "peak %.2f kN within [%.2f, %.2f] x Ralston %.2f kN", pk / 1e3, CONE_PEAK_LO, CONE_PEAK_HI,
              L.h / 1e3);
    dem_free(d);
}

int main(void)
{
    setvbuf(stdout, NULL, _IOLBF, 0);
    test_ralston_formula();
    /* the long case (docs/dem.md, "The cone case rebuilt"): four close-packed
     * layers of r = 0.0381 m spheres, 0.263 m (h/d 3.45), a 2.4 m by 3.0 m
     * sheet whose front is the cone's waterline notch, free sides, the rear
     * edge driven, started from rest; E_b 0.1 GPa (a 3x longer step, as
     * before), the default bonds */
    cone_case full = {32, 46, 4, 0.0381216, 0.5, 1.2, 1.0e8, 1.2, 0.6, 60.0, 1, 1, 0.0, 0.0, 0.2, 0, 0};
    cone_case quick = {6, 16, 2, 0.1, 0.5, 0.3, 1.0e9, 1.2, 0.6, 60.0, 0, 0, 0.0, 0.0, 0.0, 0, 0};
    cone_case *c = check_long() ? &full : &quick;
    /* "nx ny speed duration E_b [nz r shaped ramp [sigma_t tau_c (MPa, 0: defaults) [sides rear]]]" */
    const char *e = getenv("SPHICE_DEM_CONE");
    if (e) {
        double st = 0.0, tc = 0.0;
        sscanf(e, "%d %d %lf %lf %lf %d %lf %d %lf %lf %lf %d %d", &c->nx, &c->ny, &c->speed, &c->duration,
               &c->bond_modulus, &c->nz, &c->r, &c->shaped, &c->ramp, &st, &tc, &c->sides, &c->rear);
        c->sigma_t = st * 1e6;
        c->tau_c = tc * 1e6;
    }
    run_cone(c);
    if (!check_long() && !e) {
        /* make check's confined sheet (docs/dem.md, "The cone with confined
         * sides"): the pre-shaped front on 0.1 m spheres, two layers, the side
         * bands held laterally and carried along at the drift (DEM_FIX_X |
         * DEM_FIX_Y, free to heave), the rear clamped and ramped: the held
         * sides keep y exactly and move vertically, and the scene's physics
         * checks hold as on the straight sheet */
        cone_case held = {10, 16, 2, 0.1, 0.5, 0.3, 1.0e8, 1.2, 0.6, 60.0, 0, 1, 0.0, 0.0, 0.1, 2, 0};
        run_cone(&held);
    }
    return check_summary("test_dem_cone");
}
