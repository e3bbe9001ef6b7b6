/* Ridging's sail stage: a thin bonded sheet driven against a thick floe
 * breaks into rubble that piles up into a sail and a keel (issue 25; the
 * seed's section 3.2 after Hopkins 1998: once the sail has formed the
 * horizontal force follows F = beta h^1.5, beta = 95 400).
 *
 * A 2-D run in the vertical x-z plane (every centre at y = 0, so every
 * force stays in the plane): the thin ice is a chain of spheres of
 * diameter h (width b = h) bonded by the core's parallel bonds with their
 * default strengths (docs/dem.md: sigma_t = 0.334 MPa, tau_c = 0.558 MPa,
 * calibrated on the leg's 0.1 m spheres, E_b = 1 GPa), floating at Archimedes' level (draft found here by
 * bisection), with a random imperfection of 0.02 r; its first RUBBLE
 * spheres at the floe are loose (rubble blocks of size h already broken
 * off, Hopkins & Hibler 1991's blocks broken from the lead ice's leading
 * edge). Its last two spheres are driven at a prescribed speed U
 * toward the thick floe: a rigid L of fixed spheres (a vertical face of
 * the 2 m floe's draft and freeboard, its top and bottom surfaces 4 m
 * long), the "thick ice with sufficient strength" of the seed's
 * assumptions. Gravity, buoyancy (the submerged cap) and water drag come
 * from the core. The horizontal force F is the sum of the x forces on the
 * floe's spheres; per unit width F / b.
 *
 * Or (nl >= 2 layers) a close-packed 2-D sheet nl spheres thick (ridge()),
 * as a vertical section of the leg's hcp sheet: so that the sheet can bend
 * and fail locally instead of shattering along a one-sphere chain.
 *
 * make check (h = 0.5 m, a short push, one layer and two layers): the bonds break, rubble rises
 * above the sheet's freeboard (a sail) and sinks below its draft (a keel),
 * and the energy balance holds: the work of the pushing force (the
 * reaction on the driven spheres times U, summed per step) is at least the
 * gain of the pile's potential energy (gravity and buoyancy, computed
 * here from the cap volume's integral) plus its kinetic energy, the rest
 * being stored in the bonds or dissipated by contact damping, friction
 * and drag. The energy terms are computed in this file, not by the core.
 *
 * SPHICE_LONG=1: h = 0.25, 0.375 and 0.5 m (SPHICE_SAIL_LAYERS layers, 2
 * by default), each pushed for SPHICE_SAIL_PUSH (40) h of
 * sheet (geometrically similar runs), the force per width averaged over
 * the second half of the push; the exponent of F / b against h fitted by
 * least squares and printed beside the seed's 1.5 with beta = (F / b) /
 * h^1.5. SPHICE_SAIL_PUSH_M=L pushes every h the same L metres instead
 * (the seed's alpha h^1.5 L^0.5 takes h and L apart: with L = np h a
 * self-similar pile gives h^2, docs/dem.md). Each h also prints the share
 * of the potential energy gained in the sail (spheres ending with their
 * centre above the water) and below it, and alpha = (F / b) / (h^1.5
 * L^0.5). SPHICE_SAIL_PHASE=k: another pattern of the imperfection;
 * SPHICE_SAIL_PATTERNS=N runs N patterns (k, k + 1, ...) and reports the
 * exponents' mean and spread and the exponent of the patterns' mean force;
 * SPHICE_SAIL_HS="h1 h2 ..." sets the thicknesses (2 to 8). The exponent
 * is reported, not asserted to be 1.5: only that the force grows with h
 * (docs/dem.md: the run does not reproduce 1.5). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "check.h"
#include "core/dem.h"

#define FLOE_H 2.0   /* the seed's thick ice, m */
#ifndef PUSH_U
#define PUSH_U 0.5   /* driving speed, m s-1 (chosen for cost; not from the seed) */
#endif
#define RAMP_S 1.0   /* the driving speed's ramp, s */

/* A small imperfection of the sheet's level, IMPERFECTION r times the
 * golden-ratio sequence frac(i phi) - 1/2 (deterministic, evenly spread):
 * without it a straight chain against a flat face only compresses. */
#define IMPERFECTION 0.02
/* Loose spheres (rubble blocks of size h) between the intact sheet and the floe at the start */
#define RUBBLE 8
/* SPHICE_SAIL_PHASE=k (long case) shifts the sequence by frac(k sqrt 2):
 * another pattern of the same amplitude, to see how much of a result is
 * the pattern's (0: the pattern of every table before session 9). */
static double imperfection_phase = 0.0;
static double imperfection(int i)
{
    double q = 0.6180339887498949 * i + imperfection_phase;
    return q - floor(q) - 0.5;
}

/* Draft s of a floating sphere of radius r: its cap volume pi s^2 (3r - s) / 3
 * carries the sphere's weight (bisection). */
static double sphere_draft(double r, double rho_i, double rho_w)
{
    double want = rho_i / rho_w * 4.0 * r * r * r, a = 0.0, b = 2.0 * r;
    for (int it = 0; it < 100; it++) {
        double s = 0.5 * (a + b);
        if (s * s * (3.0 * r - s) < want)
            a = s;
        else
            b = s;
    }
    return 0.5 * (a + b);
}

/* Potential energy of a sphere of radius r, mass m with centre at z:
 * m g z plus the buoyancy's potential rho_w g Phi(s), s = r - z the
 * immersion and Phi' = V_sub(s) = pi s^2 (3r - s) / 3 on [0, 2r] (so
 * -dU/dz = rho_w g V_sub - m g, the core's vertical force). */
static double sphere_pe(double z, double r, double m, double rho_w, double g)
{
    double s = r - z, phi;
    if (s <= 0.0)
        phi = 0.0;
    else if (s <= 2.0 * r)
        phi = M_PI / 3.0 * (r * s * s * s - 0.25 * s * s * s * s);
    else
        phi = M_PI / 3.0 * (8.0 * r * r * r * r - 4.0 * r * r * r * r) +
              4.0 / 3.0 * M_PI * r * r * r * (s - 2.0 * r);
    return m * g * z + rho_w * g * phi;
}

typedef struct sail_run {
    double force_mean;   /* mean horizontal force on the floe over the window, N */
    double work;         /* work of the pushing force, J */
    double dpe, ke;      /* potential energy gained, kinetic energy at the end, J */
    double dpe_sail;     /* the part of dpe of the spheres ending with their centre above the water (the sail; the rest the keel and the sheet) */
    double sail, keel;   /* highest top / lowest bottom of the sheet's spheres, m */
    double freeboard, draft; /* the sheet's top and bottom when floating, m */
    double width;        /* b, m: one sphere */
    long broken, bonds;
    int ok;
} sail_run;

/* Draft of a close-packed 2-D sheet of nl layers (rows dz = sqrt(3) r
 * apart): the centre height zc of its bottom row at which the caps of one
 * column of nl spheres carry their weight (bisection). */
static double sheet_bottom_centre(double r, int nl, double rho_i, double rho_w)
{
    double want = nl * rho_i / rho_w * 4.0 / 3.0 * M_PI * r * r * r, dz = sqrt(3.0) * r;
    double a = -(nl - 1) * dz - r, b = r;
    for (int it = 0; it < 100; it++) {
        double zc = 0.5 * (a + b), v = 0.0;
        for (int k = 0; k < nl; k++) {
            double sub = fmin(fmax(r - (zc + k * dz), 0.0), 2.0 * r);
            v += M_PI * sub * sub * (3.0 * r - sub) / 3.0;
        }
        if (v > want)
            a = zc; /* too deep: raise it */
        else
            b = zc;
    }
    return 0.5 * (a + b);
}

/* Pushes a sheet of thickness h for `push` metres; the force is averaged
 * over the part of the push after `from` metres. nl = 1: a row of spheres
 * of diameter h; nl >= 2: nl close-packed rows (a 2-D triangular lattice,
 * as a vertical section of the leg's hcp sheet: rows sqrt(3) r apart, odd
 * rows shifted by r) of spheres of radius r = h / (2 + (nl - 1) sqrt(3)),
 * bonded to all their touching neighbours. The width is one sphere,
 * b = 2 r; the loose rubble and the 8 h left at the end are the same
 * lengths as for nl = 1. */
static sail_run ridge(double h, double push, double from, int progress, int nl)
{
    sail_run out = {0};
    dem_params p;
    dem_params_default(&p);
    double rho_w = p.water_density, g = p.gravity;
    double r = nl == 1 ? 0.5 * h : h / (2.0 + (nl - 1) * sqrt(3.0)), dzl = sqrt(3.0) * r;
    double zc = nl == 1 ? r - sphere_draft(r, p.density, rho_w) : sheet_bottom_centre(r, nl, p.density, rho_w);
    out.width = 2.0 * r;
    out.freeboard = zc + (nl - 1) * dzl + r;
    out.draft = zc - r;
    int rubble = nl == 1 ? RUBBLE : (int)ceil(RUBBLE * h / (2.0 * r));
    int left = nl == 1 ? 8 : (int)ceil(8.0 * h / (2.0 * r));
    int ncol = rubble + (int)ceil(push / (2.0 * r)) + left + 2; /* rubble, the pushed length, 8 h left at the end, 2 driven */
    int nsheet = ncol * nl;
    /* floe spheres spaced r: face, top and bottom */
    double fdraft = FLOE_H * p.density / rho_w, ffree = FLOE_H - fdraft;
    int nface = (int)ceil((FLOE_H - 2.0 * r) / r) + 1, nlen = (int)ceil(4.0 / r);
    size_t cap = (size_t)nsheet + (size_t)nface + 2 * (size_t)nlen;
    dem *d = dem_create(cap, 3 * (size_t)nsheet, &p);
    if (!d)
        return out;
    double xw = 0.0; /* the floe's face (centres of its face spheres at xw + r) */
    for (int i = 0; i < ncol; i++)
        for (int k = 0; k < nl; k++) {
            /* column 0 nearest the floe, 1 mm clear of it; odd rows shifted back by r; the sheet at rest */
            double x = xw - 0.001 - r - 2.0 * r * i - ((k % 2) ? r : 0.0);
            dem_add_particle(d, x, 0.0, zc + k * dzl + IMPERFECTION * r * imperfection(i), r);
        }
    /* the first `rubble` columns loose (rubble already broken off), the rest bonded */
    if (nl == 1) {
        for (int i = RUBBLE; i + 1 < nsheet; i++)
            dem_add_bond(d, i, i + 1);
    } else {
        double lim = 2.0 * r * 1.02; /* the imperfection moves neighbours by under 1 % */
        for (long a = (long)rubble * nl; a < nsheet; a++)
            for (long c = a + 1; c < nsheet && c <= a + 2 * nl; c++) {
                double ddx = d->x[c] - d->x[a], ddz = d->z[c] - d->z[a];
                if (ddx * ddx + ddz * ddz <= lim * lim)
                    dem_add_bond(d, a, c);
            }
    }
    out.bonds = (long)d->nbonds;
    long first_floe = (long)d->n;
    for (int k = 0; k < nface; k++)
        dem_add_particle(d, xw + r, 0.0, -fdraft + r + fmin(k * r, FLOE_H - 2.0 * r), r);
    for (int k = 1; k <= nlen; k++) {
        dem_add_particle(d, xw + r + k * r, 0.0, ffree - r, r);
        dem_add_particle(d, xw + r + k * r, 0.0, -fdraft + r, r);
    }
    long n = (long)d->n;
    for (long i = first_floe; i < n; i++) {
        d->flags[i] = DEM_FIX_TRANSLATION | DEM_FIX_ROTATION;
        dem_set_velocity(d, i, 0, 0, 0);
    }
    long drv0 = nsheet - 2 * nl;
    for (long i = drv0; i < nsheet; i++)
        d->flags[i] = DEM_FIX_TRANSLATION | DEM_FIX_ROTATION;
    double pe0 = 0.0, *pe_start = malloc((size_t)drv0 * sizeof *pe_start);
    if (!pe_start) {
        dem_free(d);
        return out;
    }
    for (long i = 0; i < drv0; i++) {
        pe_start[i] = sphere_pe(d->z[i], r, d->m[i], rho_w, g);
        pe0 += pe_start[i];
    }
    double dt = 0.9 * p.dt_safety * dem_dt_critical(d);
    double t_end = push / PUSH_U + 0.5 * RAMP_S, t_from = from / PUSH_U;
    long steps = (long)(t_end / dt), nwin = 0;
    sph_status st;
    double fsum = 0.0;
    int bad = 0;
    for (long t = 0; t < steps && !bad; t++) {
        /* the driven spheres' speed ramped in over RAMP_S (no impact) */
        double u = PUSH_U * fmin(1.0, t * dt / RAMP_S);
        for (long i = drv0; i < nsheet; i++)
            dem_set_velocity(d, i, u, 0, 0);
        bad = dem_step(d, dt, &st) != SPH_STEP_OK;
        double fpush = 0.0, ffloe = 0.0;
        for (long i = drv0; i < nsheet; i++)
            fpush -= d->fx[i];
        for (long i = first_floe; i < n; i++)
            ffloe += d->fx[i];
        out.work += fpush * u * dt;
        if (t * dt >= t_from) {
            fsum += ffloe;
            nwin++;
        }
        if (progress && t % (steps / 10) == 0)
            fprintf(stderr, "    h %.3f m, %d layers: t %.1f / %.1f s, force on the floe %.4g kN/m, bonds broken %ld\n",
                    h, nl, t * dt, t_end, ffloe / out.width / 1e3, d->bonds_broken_tension + d->bonds_broken_shear);
    }
    if (bad)
        fprintf(stderr, "    h %.3f m: step refused: %s %s\n", h, st.quantity ? st.quantity : "?", st.what ? st.what : "?");
    double pe1 = 0.0;
    out.sail = -HUGE_VAL;
    out.keel = HUGE_VAL;
    for (long i = 0; i < drv0; i++) {
        double pe = sphere_pe(d->z[i], r, d->m[i], rho_w, g);
        pe1 += pe;
        if (d->z[i] > 0.0)
            out.dpe_sail += pe - pe_start[i];
        out.ke += 0.5 * d->m[i] * (d->vx[i] * d->vx[i] + d->vy[i] * d->vy[i] + d->vz[i] * d->vz[i]) +
                  0.5 * d->inertia[i] * (d->wx[i] * d->wx[i] + d->wy[i] * d->wy[i] + d->wz[i] * d->wz[i]);
        out.sail = fmax(out.sail, d->z[i] + r);
        out.keel = fmin(out.keel, d->z[i] - r);
    }
    free(pe_start);
    out.dpe = pe1 - pe0;
    out.broken = d->bonds_broken_tension + d->bonds_broken_shear;
    out.force_mean = nwin ? fsum / nwin : NAN;
    out.ok = !bad;
    dem_free(d);
    return out;
}

static void quick_case(int nl)
{
    double h = 0.5;
    sail_run a = ridge(h, 1.6, 0.8, 0, nl);
    printf("  h %.3f m, %d layer(s) of %.4g m spheres (%ld bonds), pushed 1.6 m at %.2f m/s: bonds broken %ld; "
           "sail top %.3f m (sheet freeboard %.3f m), keel bottom %.3f m (sheet draft %.3f m); work of the push "
           "%.4g J, potential energy gained %.4g J, kinetic %.4g J; mean force on the floe (last 0.8 m) %.4g kN/m\n",
           h, nl, a.width, a.bonds, PUSH_U, a.broken, a.sail, a.freeboard, a.keel, a.draft, a.work, a.dpe, a.ke,
           a.force_mean / a.width / 1e3);
    CHECK(a.ok, "h 0.5 m, %d layer(s): every step accepted", nl);
    CHECK(a.broken > 0, "h 0.5 m, %d layer(s): the sheet broke into rubble (%ld bonds)", nl, a.broken);
    CHECK(a.sail > a.freeboard, "rubble above the sheet: top %.3f m above its freeboard %.3f m", a.sail, a.freeboard);
    CHECK(a.keel < a.draft - 0.5 * h, "a keel: bottom %.3f m below the draft %.3f m - h/2", a.keel, a.draft);
    CHECK(a.dpe > 0.0, "the pile gained potential energy (%.4g J)", a.dpe);
    CHECK(a.work >= a.dpe + a.ke - 0.01 * fabs(a.work),
          "energy balance: work %.5g J >= potential %.5g J + kinetic %.5g J", a.work, a.dpe, a.ke);
}

/* An environment value that is a whole integer (strtol, nothing after it). */
static int env_long(const char *s, long *out)
{
    char *end;
    long v = strtol(s, &end, 10);
    if (end == s || *end != '\0')
        return 0;
    *out = v;
    return 1;
}

int main(void)
{
    int longrun = getenv("SPHICE_LONG") != NULL;
    const char *el = getenv("SPHICE_SAIL_LAYERS"); /* the long sweep's layers (default 2) */
    int nl = el ? atoi(el) : 2;
    quick_case(1);
    quick_case(2);
    if (!longrun) {
        printf("  (SPHICE_LONG=1: h = 0.25, 0.375, 0.5 m pushed SPHICE_SAIL_PUSH (40) h, SPHICE_SAIL_LAYERS (2) layers, the force's exponent and beta)\n");
        return check_summary("test_dem_sail");
    }
    CHECK(nl >= 1 && nl <= 4, "SPHICE_SAIL_LAYERS %d in [1, 4]", nl);
    if (nl < 1 || nl > 4)
        return check_summary("test_dem_sail");
    const char *ep = getenv("SPHICE_SAIL_PUSH"); /* the push, in sheet thicknesses (default 40) */
    double np = ep ? atof(ep) : 40.0;
    CHECK(np >= 4.0 && np <= 400.0, "SPHICE_SAIL_PUSH %g in [4, 400]", np);
    if (!(np >= 4.0 && np <= 400.0))
        return check_summary("test_dem_sail");
    /* SPHICE_SAIL_PUSH_M: every h pushed the same L metres (the seed's
     * alpha h^1.5 L^0.5 and beta h^1.5 take h and L apart; a push of np h
     * ties L to h: a self-similar pile then gives h^2 whichever of the two
     * holds, docs/dem.md) */
    const char *em = getenv("SPHICE_SAIL_PUSH_M");
    double push_m = em ? atof(em) : 0.0;
    CHECK(!em || (push_m >= 1.0 && push_m <= 100.0), "SPHICE_SAIL_PUSH_M %g in [1, 100] m", push_m);
    if (em && !(push_m >= 1.0 && push_m <= 100.0))
        return check_summary("test_dem_sail");
    /* SPHICE_SAIL_PHASE=k: the first pattern; SPHICE_SAIL_PATTERNS=N: N
     * patterns k, k + 1, ... (each h run once per pattern), and beside each
     * pattern's fit the mean and standard deviation of their exponents and
     * the exponent of the patterns' mean forces (session 12: how much of a
     * fit is the pattern's) */
    long phase0 = 0, npat = 1;
    const char *eph = getenv("SPHICE_SAIL_PHASE"), *epn = getenv("SPHICE_SAIL_PATTERNS");
    int good_p = (!eph || env_long(eph, &phase0)) && phase0 >= 0 && phase0 <= 1000;
    CHECK(good_p, "SPHICE_SAIL_PHASE \"%s\": an integer in [0, 1000]", eph ? eph : "");
    int good_n = (!epn || env_long(epn, &npat)) && npat >= 1 && npat <= 64;
    CHECK(good_n, "SPHICE_SAIL_PATTERNS \"%s\": an integer in [1, 64]", epn ? epn : "");
    if (!good_p || !good_n)
        return check_summary("test_dem_sail");
    /* SPHICE_SAIL_HS="h1 h2 ...": the thicknesses (default 0.25 0.375 0.5 m;
     * 2 to 8 of them, each in [0.1, 1] m) */
    double hs[8] = {0.25, 0.375, 0.5};
    int nh = 3;
    const char *ehs = getenv("SPHICE_SAIL_HS");
    if (ehs) {
        nh = 0;
        const char *q = ehs;
        char *end;
        int extra = 0;
        for (double v = strtod(q, &end); end != q; v = strtod(q, &end)) {
            if (nh < 8)
                hs[nh] = v;
            nh++;
            q = end;
        }
        while (*q == ' ' || *q == '\t')
            q++;
        extra = *q != '\0' || nh > 8; /* a token that is not a number, or a ninth */
        int good = nh >= 2 && !extra;
        if (nh > 8)
            nh = 8;
        for (int i = 0; i < nh; i++)
            good = good && hs[i] >= 0.1 && hs[i] <= 1.0 && (i == 0 || hs[i] > hs[i - 1]);
        CHECK(good, "SPHICE_SAIL_HS \"%s\": 2 to 8 increasing thicknesses in [0.1, 1] m", ehs);
        if (!good)
            return check_summary("test_dem_sail");
    }
    const char *eh = getenv("SPHICE_SAIL_H"); /* one thickness of the sweep only (no fit) */
    double honly = eh ? atof(eh) : 0.0;
    double fsum[8] = {0}, esum = 0.0, esq = 0.0;
    for (long pat = phase0; pat < phase0 + npat; pat++) {
        double kq = (double)pat * sqrt(2.0);
        imperfection_phase = kq - floor(kq);
        double sx = 0, sy = 0, sxx = 0, sxy = 0, fw[8];
        int nfit = 0;
        for (int i = 0; i < nh; i++) {
            if (honly > 0.0 && fabs(hs[i] - honly) > 1e-9) {
                fw[i] = NAN;
                continue;
            }
            double L = push_m > 0.0 ? push_m : np * hs[i];
            sail_run b = ridge(hs[i], L, 0.5 * L, 1, nl);
            fw[i] = b.force_mean / b.width;
            printf("  pattern %ld: h %.3f m, %d layer(s) of %.4g m spheres: pushed %.1f m, bonds broken %ld (of %ld), sail top %.2f m, "
                   "keel bottom %.2f m; mean force per width (second half) %.4g kN/m; beta = (F/b)/h^1.5 = %.4g N m^-2.5; "
                   "work %.4g J >= potential %.4g J + kinetic %.4g J (potential / work %.3f); "
                   "mean pushing force per width (work / push / b) %.4g kN/m; of the potential, %.3f in the sail (centres "
                   "above the water), %.3f below; alpha = (F/b)/(h^1.5 L^0.5) %.4g N m^-3\n",
                   pat, hs[i], nl, b.width, L, b.broken, b.bonds, b.sail, b.keel, fw[i] / 1e3,
                   fw[i] / pow(hs[i], 1.5), b.work, b.dpe, b.ke, b.dpe / b.work, b.work / L / b.width / 1e3,
                   b.dpe_sail / b.dpe, 1.0 - b.dpe_sail / b.dpe, fw[i] / pow(hs[i], 1.5) / sqrt(L));
            CHECK(b.ok && isfinite(fw[i]) && fw[i] > 0.0, "pattern %ld, h %.3f m: a finite positive force", pat, hs[i]);
            CHECK(b.work >= b.dpe + b.ke - 0.01 * fabs(b.work), "pattern %ld, h %.3f m: energy balance", pat, hs[i]);
            double x = log(hs[i]), y = log(fw[i]);
            sx += x;
            sy += y;
            sxx += x * x;
            sxy += x * y;
            fsum[i] += fw[i];
            nfit++;
        }
        if (honly > 0.0)
            continue;
        double slope = (nfit * sxy - sx * sy) / (nfit * sxx - sx * sx);
        esum += slope;
        esq += slope * slope;
        printf("  sail stage, %d layer(s), pattern %ld: force per width against thickness, fitted exponent %.3f (the seed's 1.5; "
               "Muchow & Polojarvi 2024's 3-D: 1, linear); beta at h = %.3f m %.4g N m^-2.5 beside the seed's 95 400\n",
               nl, pat, slope, hs[nh - 1], fw[nh - 1] / pow(hs[nh - 1], 1.5));
        CHECK(fw[nh - 1] > fw[0], "pattern %ld: the force grows with the thickness (%.4g > %.4g N/m)", pat, fw[nh - 1],
              fw[0]);
    }
    if (honly > 0.0 || npat < 2)
        return check_summary("test_dem_sail");
    /* across the patterns: the exponents' mean and standard deviation, and
     * the least-squares exponent of the mean force at each h with its
     * standard error (from the fit's residuals, nh - 2 degrees of freedom) */
    double mean = esum / npat, sd = sqrt(fmax(0.0, (esq - npat * mean * mean) / (npat - 1)));
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (int i = 0; i < nh; i++) {
        double x = log(hs[i]), y = log(fsum[i] / npat);
        sx += x;
        sy += y;
        sxx += x * x;
        sxy += x * y;
    }
    double sl = (nh * sxy - sx * sy) / (nh * sxx - sx * sx), ic = (sy - sl * sx) / nh, rss = 0.0;
    for (int i = 0; i < nh; i++) {
        double r = log(fsum[i] / npat) - ic - sl * log(hs[i]);
        rss += r * r;
    }
    double se = nh > 2 ? sqrt(rss / (nh - 2) / (sxx - sx * sx / nh)) : NAN;
    printf("  sail stage over %ld patterns (%ld to %ld), %d thicknesses: exponents' mean %.3f, s.d. %.3f (s.e. of the mean "
           "%.3f); the patterns' mean force per width:",
           npat, phase0, phase0 + npat - 1, nh, mean, sd, sd / sqrt((double)npat));
    for (int i = 0; i < nh; i++)
        printf(" %.4g", fsum[i] / npat / 1e3);
    printf(" kN/m at h =");
    for (int i = 0; i < nh; i++)
        printf(" %.3f", hs[i]);
    if (nh > 2)
        printf(" m, its exponent %.3f +- %.3f (s.e.)", sl, se);
    else
        printf(" m, its exponent %.3f (two thicknesses: no standard error)", sl);
    printf(", beta at h = %.3f m %.4g N m^-2.5 (the seed's 1.5 and 95 400)\n", hs[nh - 1],
           fsum[nh - 1] / npat / pow(hs[nh - 1], 1.5));
    CHECK(fsum[nh - 1] > fsum[0], "over the patterns: the mean force grows with the thickness");
    return check_summary("test_dem_sail");
}
