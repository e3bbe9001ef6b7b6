/* The three-point-bending specimens shared by test_dem_bend (the
 * calibration of the bond strengths) and test_dem_compress (its joint
 * bending + compression calibration). Include after check.h and core/dem.h. */
#ifndef SPHICE_TESTS_DEM_SPECIMEN_H
#define SPHICE_TESTS_DEM_SPECIMEN_H

#include <math.h>
#include <stdlib.h>

/* The loading nose (the particles whose velocity is prescribed downward
 * on entry: DEM_FIX_TRANSLATION or DEM_FIX_Z with vz < 0) pushed down
 * until the specimen fails: the load falls below 0.3 of its peak after a
 * bond broke in tension (or, with `any`, in tension or shear). ramp > 0:
 * the nose's speed rises linearly from 0 to the prescribed one over ramp
 * seconds (a press starts from rest; a sudden start loads the nose's bonds
 * with their dashpots' C v at once). Returns the peak load; p_first, if
 * given, the load at the first tensile break. */
static double push_nose(dem *d, double dt, long steps, int any, double ramp, double *p_first,
                        const char *what)
{
    sph_status st;
    double pmax = 0.0;
    int bad = 0;
    size_t nn = 0, *nose = malloc(d->n * sizeof *nose);
    double *vz = malloc(d->n * sizeof *vz);
    for (size_t i = 0; i < d->n; i++)
        if ((d->flags[i] & (DEM_FIX_TRANSLATION | DEM_FIX_Z)) && d->vz[i] < 0.0) {
            vz[nn] = d->vz[i];
            nose[nn++] = i;
        }
    if (p_first)
        *p_first = -1.0;
    for (long k = 0; k < steps; k++) {
        if (ramp > 0.0) {
            double f = fmin(1.0, (double)(k + 1) * dt / ramp);
            for (size_t q = 0; q < nn; q++)
                d->vz[nose[q]] = f * vz[q];
        }
        bad |= dem_step(d, dt, &st) != SPH_STEP_OK;
        double P = 0.0;
        for (size_t q = 0; q < nn; q++)
            P += d->fz[nose[q]];
        pmax = fmax(pmax, P);
        if (p_first && *p_first < 0.0 && d->bonds_broken_tension > 0)
            *p_first = P;
        if (pmax > 0.0 && P < 0.3 * pmax && d->bonds_broken_tension + (any ? d->bonds_broken_shear : 0) > 0)
            break; /* failed */
    }
    CHECK(!bad && nn > 0, "%s: steps ok", what);
    free(nose);
    free(vz);
    return pmax;
}

/* The span of the calibration specimen: 16 times its depth, the minimum
 * support-span-to-thickness ratio of the three-point flexure standards
 * (ASTM D790's 16:1; TestResources, "Flexure test sample geometry",
 * testresources.net: 16:1 to 64:1 across the industry's standards, chosen
 * so that the beam fails in bending, not in shear). Session 7's specimen
 * spanned 1.10 m, 4.2 times its depth. nx: the spheres of a row for that span between the end spheres
 * of the bottom layer (spacing 2r). */
#define DEM_SPECIMEN_SPAN_DEPTH 16.0
static int hcp_nx_for_span(double r, int nz, double span_depth)
{
    double h = 2.0 * r + (nz - 1) * 2.0 * r * sqrt(2.0 / 3.0);
    return (int)ceil(span_depth * h / (2.0 * r) - 1e-9) + 2;
}

/* The leg's sheet as a specimen (the calibration of Li, Long & Wang and
 * Song & Park 2022: the bonds' micro-strengths chosen so that a simulated
 * three-point bending specimen reaches the measured flexural strength).
 * A three-point rig: a pin line and a roller line under the bottom layer,
 * and a loading nose on the top layer at mid-span driven down at 0.01 m/s
 * and free to rotate (a roller, as a rig's loading nose is: session 7's
 * nose, fixed in rotation as well, clamped the mid-span section and
 * overstated the strength, docs/dem.md):
 * close-packed (hcp) layers of spheres of radius r as dem_add_sheet_hcp
 * builds the leg's and the station's sheet (nz = 3, r = 0.05 m: 0.263 m
 * deep, the seed's 0.26 m ice of 0.1 m spheres), nx = 12 spheres long,
 * ny rows wide, every bond of the same strengths (as the leg's sheet):
 * tensile sigma_t, shear tau_c. sigma_f = 3 P L / (2 b h^2) with b the
 * rows' share of the width, ny sqrt(3) r, h the sheet's outer depth. */
static double flexural_hcp(double r, int nx, int ny, int nz, double sigma_t, double tau_c,
                           long *broken_t, long *broken_s, double *span_out)
{
    dem_params p;
    dem_params_default(&p);
    p.water_density = p.gravity = 0.0;
    p.local_damping = 0.7;
    p.bond_tensile = sigma_t;
    p.bond_shear = tau_c;
    size_t np = (size_t)nx * ny * nz;
    dem *d = dem_create(np, 8 * np, &p);
    dem_add_sheet_hcp(d, 0.0, 0.0, nx, ny, nz, r, 0.0, 0.0);
    double zmin = HUGE_VAL, zmax = -HUGE_VAL, xlo = HUGE_VAL, xhi = -HUGE_VAL;
    for (size_t i = 0; i < d->n; i++) {
        zmin = fmin(zmin, d->z[i]);
        zmax = fmax(zmax, d->z[i]);
    }
    for (size_t i = 0; i < d->n; i++)
        if (d->z[i] < zmin + 0.5 * r) {
            xlo = fmin(xlo, d->x[i]);
            xhi = fmax(xhi, d->x[i]);
        }
    double xl = 0.0, xr = 0.0;
    int nl = 0, nr = 0;
    for (size_t i = 0; i < d->n; i++) {
        if (!(d->z[i] < zmin + 0.5 * r))
            continue;
        if (d->x[i] < xlo + 1.01 * r) {
            d->flags[i] = DEM_FIX_TRANSLATION; /* a pin line */
            xl += d->x[i];
            nl++;
        } else if (d->x[i] > xhi - 1.01 * r) {
            d->flags[i] = DEM_FIX_Z; /* a roller line */
            xr += d->x[i];
            nr++;
        }
    }
    xl /= nl;
    xr /= nr;
    double xmid = 0.5 * (xl + xr), span = xr - xl, v = 0.01;
    int nload = 0;
    for (size_t i = 0; i < d->n; i++)
        if (d->z[i] > zmax - 0.5 * r && fabs(d->x[i] - xmid) < 1.01 * r) {
            d->flags[i] = DEM_FIX_Z; /* the loading nose: a roller, free to rotate and slide */
            dem_set_velocity(d, (long)i, 0.0, 0.0, -v);
            nload++;
        }
    CHECK(nload >= 1 && nl >= 1 && nr >= 1, "hcp specimen: supports and nose");
    double b = ny * sqrt(3.0) * r, h = 2.0 * r + (nz - 1) * 2.0 * r * sqrt(2.0 / 3.0);
    double dt = p.dt_safety * dem_dt_critical(d);
    double dmax = 6.0 * sigma_t * span * span / (6.0 * p.bond_modulus * M_PI / 4.0 * h);
    /* the nose starts from rest and reaches v over the time it needs to bend
     * the extreme fibre to sigma_t (a third of the failure deflection or
     * less), long against the beam's first period (0.15 s at 16:1) */
    double ramp = dmax / 6.0 / v;
    long steps = (long)((dmax / v + 0.5 * ramp) / dt);
    double pmax = push_nose(d, dt, steps, 1, ramp, NULL, "hcp specimen");
    *broken_t = d->bonds_broken_tension;
    *broken_s = d->bonds_broken_shear;
    *span_out = span;
    dem_free(d);
    return 3.0 * pmax * span / (2.0 * b * h * h);
}

#endif
