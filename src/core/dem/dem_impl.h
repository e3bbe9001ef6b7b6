/* Internals shared by the DEM core's files (src/core/dem/). */
#ifndef SPHICE_CORE_DEM_IMPL_H
#define SPHICE_CORE_DEM_IMPL_H

#include <math.h>
#include "core/dem.h"

static inline double v3dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static inline void v3cross(const double a[3], const double b[3], double c[3])
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

/* Removes the component along n of a history vector (it rotates with the
 * contact plane) and keeps its length. */
static inline void v3rotate_into_plane(double v[3], const double n[3])
{
    double len0 = sqrt(v3dot(v, v));
    if (len0 == 0.0)
        return;
    double vn = v3dot(v, n);
    for (int k = 0; k < 3; k++)
        v[k] -= vn * n[k];
    double len1 = sqrt(v3dot(v, v));
    if (len1 > 0.0)
        for (int k = 0; k < 3; k++)
            v[k] *= len0 / len1;
}

/* zeta of a linear spring-dashpot with restitution e. */
static inline double dem_zeta(double e)
{
    if (e >= 1.0)
        return 0.0;
    double l = log(e);
    return -l / sqrt(M_PI * M_PI + l * l);
}

/* Contact of particle i with a body j (particle or wall). n: unit vector
 * from i to j; delta > 0 the overlap; vc the velocity of j's surface
 * relative to i's at the contact point; m_eff the reduced mass. fs: the
 * tangential spring force on i (history, updated). Returns the force on i
 * in f and the tangential part in ft (for the torque). */
void dem_contact_force(const dem_params *p, const double n[3], double delta, const double vc[3],
                       double m_eff, double dt, double fs[3], double f[3], double ft[3]);

/* Updates bond b (forces, moments, breakage) from the particles' state;
 * fills its f_i, t_i, t_j. */
void dem_bond_update(dem *d, dem_bond *b, double dt, double zeta);

/* Contact of particle i with the structure: force on i (f, torque t);
 * fs the particle's structure tangential history. Returns 1 in contact. */
int dem_structure_contact(const dem *d, long i, double dt, double fs[3], double f[3],
                          double t[3]);

/* Advances the structure's oscillator by dt under its load (fx, fy). */
void dem_structure_advance(dem_structure *s, double dt);

/* Checks the structure's geometry and dynamics: 0 or -1 with st filled. */
int dem_structure_check(const dem_structure *s, sph_status *st);

#endif
