/* The rigid structure: a vertical cylinder or an upward-breaking cone with
 * a vertical neck, on a horizontal spring-dashpot (mass, stiffness,
 * damping ratio). */
#include "dem_impl.h"

/* Depth below the waterline to which the cone's surface extends, m. */
#define DEM_CONE_DEPTH 10.0

/* Closest point to (rho, z) on the segment (r1, z1)-(r2, z2). */
static double seg_closest(double rho, double z, double r1, double z1, double r2, double z2,
                          double *cr, double *cz)
{
    double er = r2 - r1, ez = z2 - z1;
    double l2 = er * er + ez * ez;
    double t = l2 > 0.0 ? ((rho - r1) * er + (z - z1) * ez) / l2 : 0.0;
    if (t < 0.0) t = 0.0;
    if (t > 1.0) t = 1.0;
    *cr = r1 + t * er;
    *cz = z1 + t * ez;
    double dr = rho - *cr, dz = z - *cz;
    return sqrt(dr * dr + dz * dz);
}

int dem_structure_contact(const dem *d, long i, double dt, double fs[3], double f[3], double t[3])
{
    const dem_structure *s = &d->s;
    double px = d->x[i] - (s->x0 + s->ux), py = d->y[i] - (s->y0 + s->uy), pz = d->z[i];
    double rho = sqrt(px * px + py * py), r = d->r[i];
    if (!(rho > 1e-12))
        return 0;
    double er[3] = {px / rho, py / rho, 0.0};
    double n[3], dist;
    if (s->kind == DEM_STRUCT_CYLINDER) {
        dist = rho - 0.5 * s->diameter;
        for (int k = 0; k < 3; k++)
            n[k] = -er[k];
    } else if (s->kind == DEM_STRUCT_CONE) {
        double ta = tan(s->cone_angle * M_PI / 180.0);
        double rw = 0.5 * s->diameter, rn = 0.5 * s->neck_diameter;
        double zb = s->z_waterline - DEM_CONE_DEPTH, rb = rw + DEM_CONE_DEPTH / ta;
        double zn = s->z_waterline + (rw - rn) * ta;
        double cr1, cz1, cr2, cz2;
        double d1 = seg_closest(rho, pz, rb, zb, rn, zn, &cr1, &cz1);
        double d2 = seg_closest(rho, pz, rn, zn, rn, zn + 1e6, &cr2, &cz2);
        double cr = d1 <= d2 ? cr1 : cr2, cz = d1 <= d2 ? cz1 : cz2;
        dist = d1 <= d2 ? d1 : d2;
        if (!(dist > 1e-12))
            return 0;
        double nr = (cr - rho) / dist, nz = (cz - pz) / dist;
        n[0] = nr * er[0];
        n[1] = nr * er[1];
        n[2] = nz;
        /* A centre inside the solid: the surface normal points the other way. */
        int inside = pz <= zn ? rho < rw + (s->z_waterline - pz) / ta : rho < rn;
        if (inside) {
            for (int k = 0; k < 3; k++)
                n[k] = -n[k];
            dist = -dist;
        }
    } else {
        return 0;
    }
    double delta = r - dist;
    if (!(delta > 0.0))
        return 0;
    double a = r - 0.5 * delta;
    double w[3] = {d->wx[i], d->wy[i], d->wz[i]}, ra[3] = {a * n[0], a * n[1], a * n[2]}, c[3];
    v3cross(w, ra, c);
    double vc[3] = {s->vx - d->vx[i] - c[0], s->vy - d->vy[i] - c[1], -d->vz[i] - c[2]};
    double ft[3];
    dem_contact_force(&d->p, n, delta, vc, d->m[i], dt, fs, f, ft);
    v3cross(ra, ft, t);
    return 1;
}

void dem_structure_advance(dem_structure *s, double dt)
{
    if (s->kind == DEM_STRUCT_NONE || !(s->mass > 0.0))
        return;
    double c = 2.0 * s->damping_ratio * sqrt(s->stiffness * s->mass);
    s->ax = (s->fx - c * s->vx - s->stiffness * s->ux) / s->mass;
    s->ay = (s->fy - c * s->vy - s->stiffness * s->uy) / s->mass;
    s->vx += s->ax * dt;
    s->vy += s->ay * dt;
    s->ux += s->vx * dt;
    s->uy += s->vy * dt;
}

static int bad(sph_status *st, const char *q, double v, const char *what)
{
    return sph_status_set(st, SPH_STEP_FATAL, SPH_FAULT_INVALID, -1, q, v, 0.0, what);
}

int dem_structure_check(const dem_structure *s, sph_status *st)
{
    if (s->kind == DEM_STRUCT_NONE)
        return 0;
    if (s->kind != DEM_STRUCT_CYLINDER && s->kind != DEM_STRUCT_CONE)
        return bad(st, "structure kind", s->kind, "is not a cylinder or a cone");
    if (!(s->diameter > 0.0) || !isfinite(s->diameter))
        return bad(st, "structure diameter", s->diameter, "must be positive");
    if (s->kind == DEM_STRUCT_CONE) {
        if (!(s->cone_angle > 0.0 && s->cone_angle < 90.0))
            return bad(st, "cone angle", s->cone_angle, "must lie in (0, 90) degrees");
        if (!(s->neck_diameter > 0.0 && s->neck_diameter < s->diameter))
            return bad(st, "cone neck diameter", s->neck_diameter,
                       "must be positive and below the waterline diameter");
    }
    if (!(s->mass >= 0.0) || !isfinite(s->mass))
        return bad(st, "structure mass", s->mass, "must be zero (fixed) or positive");
    if (s->mass > 0.0 && !(s->stiffness > 0.0 && isfinite(s->stiffness)))
        return bad(st, "structure stiffness", s->stiffness, "must be positive");
    if (!(s->damping_ratio >= 0.0 && s->damping_ratio < 1.0))
        return bad(st, "structure damping ratio", s->damping_ratio, "must lie in [0, 1)");
    return 0;
}
