/* Parallel bonds (Potyondy & Cundall 2004) and their breakage by the
 * seed's eq. 9. */
#include "dem_impl.h"

void dem_bond_update(dem *d, dem_bond *b, double dt, double zeta)
{
    for (int k = 0; k < 3; k++)
        b->f_i[k] = b->t_i[k] = b->t_j[k] = 0.0;
    if (b->broken)
        return;
    int i = b->i, j = b->j;
    double dx[3] = {d->x[j] - d->x[i], d->y[j] - d->y[i], d->z[j] - d->z[i]};
    double len = sqrt(v3dot(dx, dx));
    if (!(len > 0.0))
        return;
    double n[3] = {dx[0] / len, dx[1] / len, dx[2] / len};
    double ai = len * d->r[i] / (d->r[i] + d->r[j]), aj = len - ai;
    double wi[3] = {d->wx[i], d->wy[i], d->wz[i]}, wj[3] = {d->wx[j], d->wy[j], d->wz[j]};
    double ri[3] = {ai * n[0], ai * n[1], ai * n[2]}, rj[3] = {-aj * n[0], -aj * n[1], -aj * n[2]};
    double ci[3], cj[3];
    v3cross(wi, ri, ci);
    v3cross(wj, rj, cj);
    double vc[3] = {d->vx[j] + cj[0] - d->vx[i] - ci[0], d->vy[j] + cj[1] - d->vy[i] - ci[1],
                    d->vz[j] + cj[2] - d->vz[i] - ci[2]};
    double vn = v3dot(vc, n);
    double vt[3], th[3], ths[3];
    for (int k = 0; k < 3; k++) {
        vt[k] = vc[k] - vn * n[k];
        th[k] = (wj[k] - wi[k]) * dt;
    }
    double thn = v3dot(th, n);
    for (int k = 0; k < 3; k++)
        ths[k] = th[k] - thn * n[k];
    double R = b->radius, A = M_PI * R * R, I = 0.25 * M_PI * R * R * R * R, J = 2.0 * I;
    v3rotate_into_plane(b->fs, n);
    v3rotate_into_plane(b->ms, n);
    b->fn += b->kn * A * vn * dt;
    b->mn += b->ks * J * thn;
    for (int k = 0; k < 3; k++) {
        b->fs[k] += b->ks * A * vt[k] * dt;
        b->ms[k] += b->kn * I * ths[k];
    }
    /* Eq. 9 (tension positive here: the seed's -F_n is our fn). */
    double msm = sqrt(v3dot(b->ms, b->ms)), fsm = sqrt(v3dot(b->fs, b->fs));
    double sigma = b->fn / A + msm * R / I;
    double tau = fsm / A + fabs(b->mn) * R / J;
    if (sigma >= b->sigma_t) {
        b->broken = 1;
        return;
    }
    if (tau >= b->tau_c) {
        b->broken = 2;
        return;
    }
    /* Viscous damping of the bond's relative motion (same zeta as the
     * contacts); it does not enter the bond's stress. */
    double mi = d->m[i], mj = d->m[j];
    double me = (mi * mj) / (mi + mj);
    double cn = 2.0 * zeta * sqrt(me * b->kn * A), cs = 2.0 * zeta * sqrt(me * b->ks * A);
    double fsh[3];
    for (int k = 0; k < 3; k++) {
        fsh[k] = b->fs[k] + cs * vt[k];
        b->f_i[k] = (b->fn + cn * vn) * n[k] + fsh[k];
    }
    double tqi[3], tqj[3], nfs[3] = {n[0], n[1], n[2]};
    v3cross(nfs, fsh, tqi); /* n x F_s */
    for (int k = 0; k < 3; k++) {
        tqj[k] = aj * tqi[k];
        tqi[k] *= ai;
        b->t_i[k] = tqi[k] + b->mn * n[k] + b->ms[k];
        b->t_j[k] = tqj[k] - b->mn * n[k] - b->ms[k];
    }
}
