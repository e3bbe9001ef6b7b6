/* The particle contact law (the seed's Fig. 18): linear spring-dashpot in
 * the normal direction, incremental tangential spring with dashpot,
 * Mohr-Coulomb cap. */
#include "dem_impl.h"

void dem_contact_force(const dem_params *p, const double n[3], double delta, const double vc[3],
                       double m_eff, double dt, double fs[3], double f[3], double ft[3])
{
    double zeta = dem_zeta(p->restitution);
    double kn = p->kn, ks = p->kn * p->ks_ratio;
    double cn = 2.0 * zeta * sqrt(m_eff * kn), cs = 2.0 * zeta * sqrt(m_eff * ks);
    double vn = v3dot(vc, n); /* > 0: separating */
    /* Repulsive magnitude; not clipped at zero, so that the contact ends
     * where the overlap does (the analytic restitution's assumption). */
    double fnm = kn * delta - cn * vn;
    double vt[3];
    for (int k = 0; k < 3; k++)
        vt[k] = vc[k] - vn * n[k];
    v3rotate_into_plane(fs, n);
    for (int k = 0; k < 3; k++) {
        fs[k] += ks * vt[k] * dt;
        ft[k] = fs[k] + cs * vt[k];
    }
    double cap = p->friction * fabs(fnm);
    double ftm = sqrt(v3dot(ft, ft));
    if (ftm > cap) {
        /* Sliding: the spring is held at the Coulomb limit, no dashpot. */
        double fsm = sqrt(v3dot(fs, fs));
        double sc = fsm > 0.0 ? cap / fsm : 0.0;
        for (int k = 0; k < 3; k++) {
            fs[k] *= sc;
            ft[k] = fs[k];
        }
    }
    for (int k = 0; k < 3; k++)
        f[k] = -fnm * n[k] + ft[k];
}
